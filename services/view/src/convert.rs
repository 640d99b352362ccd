//! The stack's topic samples as Foxglove's well-known schemas (`foxglove::messages`), and the few
//! that have none as JSON objects.
//!
//! Nothing here touches iceoryx2 or a socket: [`crate::bridge`] decides what to send and when,
//! this builds the messages. Every function takes the topic's own types (`mimnav_shared::topics`)
//! and checks what it cannot trust: a grid whose payload does not match its header is a
//! [`BadSample`], counted and skipped by the caller, never a panic.
//!
//! Frames (REP-103, as the stack's): `odom` is the fixed odometry frame the maps and poses are in;
//! `base_link` the robot (its pose from `odom`); `lidar` the sensor (the points, the scans), placed
//! on the robot by the config's `[robot.mount]` and `robot.sensor_height_m`.
//!
//! The grid layout (mimnav's row-major cell `(r along x, c along y)` at `r · cells + c`, transposed
//! into Foxglove's rows along x, the corner half a side back and right of the robot, turned with
//! it) is the same as `mimnav record`'s (`services/mimnav/src/record/convert.rs`, which writes
//! JSON for MCAP); it is written again here for the SDK's protobuf types. A later change can make
//! `record` use this crate's grids too.

use foxglove::bytes::Bytes;
use foxglove::messages::{
    Color, CylinderPrimitive, FrameTransform, FrameTransforms, Grid, PackedElementField,
    PointCloud, Pose, PoseInFrame, PosesInFrame, Quaternion, SceneEntity, SceneUpdate,
    TextPrimitive, Timestamp, Vector2, Vector3, packed_element_field::NumericType,
};
use serde_json::{Value, json};

use mimnav_shared::pose::LidarMount;
use mimnav_shared::topics::{
    BaseState, FoliageHeader, FoliageReturn, Goal, MapHeader, Odometry, PlanCell, Point,
    PointsHeader, VelocityCommand, command_flags,
};

/// The fixed odometry frame of the maps, the poses and the path.
pub const ODOM_FRAME: &str = "odom";
/// The robot's frame.
pub const BASE_FRAME: &str = "base_link";
/// The sensor's frame: the points and the scans.
pub const LIDAR_FRAME: &str = "lidar";

/// Bytes per point of `/lidar/points`: x, y, z, intensity as little-endian `f32`.
pub const POINT_STRIDE: usize = 16;
/// Bytes per point of `/foliage/scan`: x, y, z as `f32`, then the class as `u8` (3 bytes pad).
pub const SCAN_STRIDE: usize = 16;

/// `PlanCell::class` of a glass cell and of a suspected-glass cell (docs/topics.md).
const CLASS_GLASS: u8 = 3;
const CLASS_SUSPECTED_GLASS: u8 = 5;

/// Why a sample could not be converted: skipped and counted, the view goes on.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BadSample {
    /// A grid's payload does not hold `cells² × layers` values.
    #[error("payload of {len} values, the header says {cells} × {cells} cells × {layers}")]
    GridSize {
        /// Values in the payload.
        len: usize,
        /// `cells` of the header.
        cells: u32,
        /// Values per cell.
        layers: u32,
    },
    /// A pose or a grid's placement is not finite.
    #[error("a pose that is not finite: ({x}, {y}, {yaw})")]
    Pose {
        /// x, m.
        x: f64,
        /// y, m.
        y: f64,
        /// yaw, rad.
        yaw: f64,
    },
}

/// Foxglove's time from ns since the Unix epoch (the latest representable time past 2106).
pub fn stamp(ns: u64) -> Timestamp {
    match u32::try_from(ns / 1_000_000_000) {
        Ok(sec) => {
            Timestamp::new_checked(sec, (ns % 1_000_000_000) as u32).unwrap_or(Timestamp::MAX)
        }
        Err(_) => Timestamp::MAX,
    }
}

fn quat_yaw(yaw: f64) -> Quaternion {
    let (s, c) = (yaw * 0.5).sin_cos();
    Quaternion {
        x: 0.0,
        y: 0.0,
        z: s,
        w: c,
    }
}

/// A pose in the x-y plane: position (x, y, 0), turned by `yaw` about z.
pub fn planar_pose(x: f64, y: f64, yaw: f64) -> Pose {
    Pose {
        position: Some(Vector3 { x, y, z: 0.0 }),
        orientation: Some(quat_yaw(yaw)),
    }
}

fn finite_pose(x: f64, y: f64, yaw: f64) -> Result<(), BadSample> {
    if x.is_finite() && y.is_finite() && yaw.is_finite() {
        Ok(())
    } else {
        Err(BadSample::Pose { x, y, yaw })
    }
}

fn field(name: &str, offset: usize, kind: NumericType) -> PackedElementField {
    PackedElementField {
        name: name.to_string(),
        offset: offset as u32,
        r#type: kind as i32,
    }
}

/// `lidar/points` as a `PointCloud` in the `lidar` frame: x, y, z and intensity (the
/// reflectivity byte as a float) of every point, in firing order, stamped with the revolution's
/// sensor time.
pub fn points(h: &PointsHeader, pts: &[Point]) -> PointCloud {
    let mut data = Vec::with_capacity(pts.len() * POINT_STRIDE);
    for p in pts {
        data.extend_from_slice(&p.x.to_le_bytes());
        data.extend_from_slice(&p.y.to_le_bytes());
        data.extend_from_slice(&p.z.to_le_bytes());
        data.extend_from_slice(&f32::from(p.intensity).to_le_bytes());
    }
    PointCloud {
        timestamp: Some(stamp(h.stamp_ns)),
        frame_id: LIDAR_FRAME.into(),
        pose: Some(planar_pose(0.0, 0.0, 0.0)),
        point_stride: POINT_STRIDE as u32,
        fields: vec![
            field("x", 0, NumericType::Float32),
            field("y", 4, NumericType::Float32),
            field("z", 8, NumericType::Float32),
            field("intensity", 12, NumericType::Float32),
        ],
        data: Bytes::from(data),
    }
}

/// `foliage/alarm`'s classified scan as a `PointCloud` in the `lidar` frame: each return with a
/// range at its bearing on the sensor's plane (z 0), with its `class` (1 foliage, 2 obstacle, 3
/// held back) to colour by. Returns without a range are left out.
pub fn foliage_scan(h: &FoliageHeader, returns: &[FoliageReturn]) -> PointCloud {
    let mut data = Vec::with_capacity(returns.len() * SCAN_STRIDE);
    for r in returns {
        if !(r.range_m > 0.0 && r.range_m.is_finite() && r.angle_rad.is_finite()) {
            continue;
        }
        let (s, c) = r.angle_rad.sin_cos();
        data.extend_from_slice(&(r.range_m * c).to_le_bytes());
        data.extend_from_slice(&(r.range_m * s).to_le_bytes());
        data.extend_from_slice(&0f32.to_le_bytes());
        data.extend_from_slice(&[r.class, 0, 0, 0]);
    }
    PointCloud {
        timestamp: Some(stamp(h.stamp_ns)),
        frame_id: LIDAR_FRAME.into(),
        pose: Some(planar_pose(0.0, 0.0, 0.0)),
        point_stride: SCAN_STRIDE as u32,
        fields: vec![
            field("x", 0, NumericType::Float32),
            field("y", 4, NumericType::Float32),
            field("z", 8, NumericType::Float32),
            field("class", 12, NumericType::Uint8),
        ],
        data: Bytes::from(data),
    }
}

/// Checks a map before anything is made of it: its payload holds `cells² × per_cell` values
/// (and is not empty) and its pose is finite. Cheap (no cell is read), so the bridge checks
/// every map, watched or not.
pub fn check_map(h: &MapHeader, len: usize, per_cell: u32) -> Result<(), BadSample> {
    check_grid(len, h.cells, per_cell)?;
    finite_pose(h.x, h.y, h.yaw)
}

/// Checks that a grid's payload holds `cells² × layers` values (and is not empty).
pub fn check_grid(len: usize, cells: u32, layers: u32) -> Result<(), BadSample> {
    let want = (cells as usize)
        .checked_mul(cells as usize)
        .and_then(|n| n.checked_mul(layers as usize));
    if want == Some(len) && len > 0 {
        Ok(())
    } else {
        Err(BadSample::GridSize { len, cells, layers })
    }
}

/// The cells of a robot-centred `n × n` map in Foxglove's order: mimnav stores cell (r along x,
/// c along y) at `r · n + c`; Foxglove fills each row along x, so `put` is called with the
/// indices transposed and writes (r, c) at `c · n + r`, `cell_stride` bytes each. `mimnav
/// record`'s grids are laid out by this too.
pub fn grid_cells(
    n: usize,
    cell_stride: usize,
    mut put: impl FnMut(usize, &mut Vec<u8>),
) -> Vec<u8> {
    let mut data = Vec::with_capacity(n * n * cell_stride);
    for c in 0..n {
        for r in 0..n {
            put(r * n + c, &mut data);
        }
    }
    data
}

/// The corner of a robot-centred map of `cells` cells of `cell_m` at the pose (x, y, yaw): half
/// the side back and right of the robot, turned with it (a Foxglove grid's origin).
pub fn grid_corner((x, y, yaw): (f64, f64, f64), cells: u32, cell_m: f32) -> (f64, f64) {
    let half = f64::from(cells) * f64::from(cell_m) * 0.5;
    let (s, co) = yaw.sin_cos();
    (x - co * half + s * half, y - s * half - co * half)
}

/// A `Grid` of the robot-centred `cells × cells` map of `h`, placed at the robot's pose in the
/// odometry frame. mimnav stores cell (r along x, c along y) at `r · cells + c`; Foxglove fills
/// each row along x, so the cells are transposed: `data` holds (r, c) at `c · cells + r`,
/// `cell_stride` bytes each, written by `put` (the same layout as `mimnav record`'s grids).
fn grid(
    h: &MapHeader,
    fields: Vec<PackedElementField>,
    cell_stride: usize,
    put: impl FnMut(usize, &mut Vec<u8>),
) -> Result<Grid, BadSample> {
    finite_pose(h.x, h.y, h.yaw)?;
    let n = h.cells as usize;
    let data = grid_cells(n, cell_stride, put);
    let corner = grid_corner((h.x, h.y, h.yaw), h.cells, h.cell_m);
    Ok(Grid {
        timestamp: Some(stamp(h.stamp_ns)),
        frame_id: ODOM_FRAME.into(),
        pose: Some(planar_pose(corner.0, corner.1, h.yaw)),
        column_count: h.cells,
        cell_size: Some(Vector2 {
            x: f64::from(h.cell_m),
            y: f64::from(h.cell_m),
        }),
        row_stride: (n * cell_stride) as u32,
        cell_stride: cell_stride as u32,
        fields,
        data: Bytes::from(data),
    })
}

/// `map/plan` as a `Grid` with the fields `class` (0 free, 1 solid, 2 passable, 3 glass,
/// 4 unknown, 5 suspected glass) and `cost` (0–255), both `uint8`.
pub fn plan(h: &MapHeader, cells: &[PlanCell]) -> Result<Grid, BadSample> {
    check_grid(cells.len(), h.cells, 1)?;
    let fields = vec![
        field("class", 0, NumericType::Uint8),
        field("cost", 1, NumericType::Uint8),
    ];
    grid(h, fields, 2, |i, d| {
        d.extend_from_slice(&[cells[i].class, cells[i].cost])
    })
}

/// The glass memory as the map publishes it (`map/plan`'s classes 3, glass seen, and 5, a
/// pane's line drawn on where it was not seen) as a `Grid` with the field `glass` (`uint8`):
/// 0 none, 1 glass, 2 suspected glass. Also returns how many cells are glass and suspected.
pub fn glass(h: &MapHeader, cells: &[PlanCell]) -> Result<(Grid, usize, usize), BadSample> {
    check_grid(cells.len(), h.cells, 1)?;
    let (mut seen, mut suspected) = (0, 0);
    let g = grid(h, vec![field("glass", 0, NumericType::Uint8)], 1, |i, d| {
        d.push(match cells[i].class {
            CLASS_GLASS => {
                seen += 1;
                1
            }
            CLASS_SUSPECTED_GLASS => {
                suspected += 1;
                2
            }
            _ => 0,
        })
    })?;
    Ok((g, seen, suspected))
}

/// `map/layers` as a `Grid` with one `float32` field a layer, `layer0`, `layer1`, … (mimnav's
/// layers one after the other become the values of each cell side by side).
pub fn layers(h: &MapHeader, values: &[f32]) -> Result<Grid, BadSample> {
    check_grid(values.len(), h.cells, h.layers)?;
    let m = h.layers as usize;
    let n2 = (h.cells as usize).pow(2);
    let fields = (0..m)
        .map(|j| field(&format!("layer{j}"), 4 * j, NumericType::Float32))
        .collect();
    grid(h, fields, 4 * m, |i, d| {
        for j in 0..m {
            d.extend_from_slice(&values[j * n2 + i].to_le_bytes());
        }
    })
}

/// The transform `odom → base_link` of an odometry message (the robot's pose).
pub fn robot_transform(o: &Odometry) -> Result<FrameTransform, BadSample> {
    finite_pose(o.x, o.y, o.yaw)?;
    Ok(FrameTransform {
        timestamp: Some(stamp(o.stamp_ns)),
        parent_frame_id: ODOM_FRAME.into(),
        child_frame_id: BASE_FRAME.into(),
        translation: Some(Vector3 {
            x: o.x,
            y: o.y,
            z: 0.0,
        }),
        rotation: Some(quat_yaw(o.yaw)),
    })
}

/// The transform `base_link → lidar`: the lidar's mount (`[robot.mount]`) at the sensor's height
/// (`robot.sensor_height_m`). Roll, pitch and yaw are applied in that order about the fixed axes,
/// as `LidarMount::isometry` does.
pub fn mount_transform(mount: &LidarMount, sensor_height_m: f64, stamp_ns: u64) -> FrameTransform {
    let iso = mount.isometry();
    let q = iso.rotation;
    FrameTransform {
        timestamp: Some(stamp(stamp_ns)),
        parent_frame_id: BASE_FRAME.into(),
        child_frame_id: LIDAR_FRAME.into(),
        translation: Some(Vector3 {
            x: iso.translation.x,
            y: iso.translation.y,
            z: iso.translation.z + sensor_height_m,
        }),
        rotation: Some(Quaternion {
            x: q.i,
            y: q.j,
            z: q.k,
            w: q.w,
        }),
    }
}

/// `/tf`: the robot's pose and the lidar on it, as one `FrameTransforms`.
pub fn transforms(
    o: &Odometry,
    mount: &LidarMount,
    sensor_height_m: f64,
) -> Result<FrameTransforms, BadSample> {
    Ok(FrameTransforms {
        transforms: vec![
            robot_transform(o)?,
            mount_transform(mount, sensor_height_m, o.stamp_ns),
        ],
    })
}

/// `odom` as a `PoseInFrame` in the odometry frame (the velocities are in `/base/state`'s
/// neighbour `/cmd_vel`; the odometry's own are not kept).
pub fn odom_pose(o: &Odometry) -> Result<PoseInFrame, BadSample> {
    finite_pose(o.x, o.y, o.yaw)?;
    Ok(PoseInFrame {
        timestamp: Some(stamp(o.stamp_ns)),
        frame_id: ODOM_FRAME.into(),
        pose: Some(planar_pose(o.x, o.y, o.yaw)),
    })
}

/// The driven path: a pose every `step_m` metres, at most `max` (the oldest go first).
#[derive(Debug, Clone)]
pub struct Path {
    step_m: f64,
    max: usize,
    poses: std::collections::VecDeque<(f64, f64, f64)>,
    stamp_ns: u64,
}

impl Path {
    /// An empty path.
    pub fn new(step_m: f64, max: usize) -> Path {
        Path {
            step_m,
            max: max.max(2),
            poses: std::collections::VecDeque::new(),
            stamp_ns: 0,
        }
    }

    /// Adds the pose of `o` if the robot moved `step_m` from the last kept one; whether it did.
    /// A pose that is not finite is refused.
    pub fn add(&mut self, o: &Odometry) -> Result<bool, BadSample> {
        finite_pose(o.x, o.y, o.yaw)?;
        self.stamp_ns = o.stamp_ns;
        let far = self
            .poses
            .back()
            .is_none_or(|&(x, y, _)| (o.x - x).hypot(o.y - y) >= self.step_m);
        if far {
            if self.poses.len() == self.max {
                self.poses.pop_front();
            }
            self.poses.push_back((o.x, o.y, o.yaw));
        }
        Ok(far)
    }

    /// Poses kept.
    pub fn len(&self) -> usize {
        self.poses.len()
    }

    /// Whether no pose is kept.
    pub fn is_empty(&self) -> bool {
        self.poses.is_empty()
    }

    /// The path as a `PosesInFrame` in the odometry frame, oldest first.
    pub fn message(&self) -> PosesInFrame {
        PosesInFrame {
            timestamp: Some(stamp(self.stamp_ns)),
            frame_id: ODOM_FRAME.into(),
            poses: (self.poses.iter())
                .map(|&(x, y, yaw)| planar_pose(x, y, yaw))
                .collect(),
        }
    }
}

/// `goal` as a `SceneUpdate`: one entity `goal`, a flat green disc of the goal's tolerance at the
/// goal in the odometry frame, with its coordinates as text above it (a new goal replaces it).
pub fn goal_scene(g: &Goal, stamp_ns: u64) -> Result<SceneUpdate, BadSample> {
    finite_pose(g.x, g.y, 0.0)?;
    let r = if g.tolerance_m.is_finite() && g.tolerance_m > 0.0 {
        g.tolerance_m
    } else {
        0.1
    };
    let green = Color {
        r: 0.1,
        g: 0.8,
        b: 0.2,
        a: 0.6,
    };
    let text_pose = Pose {
        position: Some(Vector3 {
            x: g.x,
            y: g.y,
            z: 0.5,
        }),
        orientation: Some(quat_yaw(0.0)),
    };
    Ok(SceneUpdate {
        deletions: Vec::new(),
        entities: vec![SceneEntity {
            timestamp: Some(stamp(stamp_ns)),
            frame_id: ODOM_FRAME.into(),
            id: "goal".into(),
            frame_locked: false,
            cylinders: vec![CylinderPrimitive {
                pose: Some(planar_pose(g.x, g.y, 0.0)),
                size: Some(Vector3 {
                    x: 2.0 * r,
                    y: 2.0 * r,
                    z: 0.05,
                }),
                bottom_scale: 1.0,
                top_scale: 1.0,
                color: Some(green),
            }],
            texts: vec![TextPrimitive {
                pose: Some(text_pose),
                billboard: true,
                font_size: 14.0,
                scale_invariant: true,
                color: Some(Color {
                    r: 1.0,
                    g: 1.0,
                    b: 1.0,
                    a: 1.0,
                }),
                text: format!("goal {} ({:.2}, {:.2})", g.seq, g.x, g.y),
            }],
            ..Default::default()
        }],
    })
}

/// The name of a `VelocityCommand::status`.
pub fn status_name(status: u8) -> &'static str {
    match status {
        0 => "driving",
        1 => "goal reached",
        2 => "blocked",
        3 => "stale input",
        4 => "no goal",
        _ => "unknown",
    }
}

fn to_bytes(v: &Value) -> Vec<u8> {
    // serialising a Value cannot fail: its map keys are strings
    serde_json::to_vec(v).unwrap_or_default()
}

/// `/cmd_vel`: every field of the command, its status by name and its flags spelled out, and the
/// time from the revolution's last packet to the command (`rev_to_cmd_us`, when the view saw
/// that revolution's map; else null).
pub fn cmd_vel(c: &VelocityCommand, rev_to_cmd_us: Option<f64>) -> Vec<u8> {
    to_bytes(&json!({
        "seq": c.seq,
        "stamp_mono_ns": c.stamp_mono_ns,
        "source_stamp_ns": c.source_stamp_ns,
        "source_seq": c.source_seq,
        "valid_until_mono_ns": c.valid_until_mono_ns,
        "v": c.v,
        "omega": c.omega,
        "status": c.status,
        "status_name": status_name(c.status),
        "flags": c.flags,
        "foliage_alarm": c.flags & command_flags::FOLIAGE_ALARM != 0,
        "no_route": c.flags & command_flags::NO_ROUTE != 0,
        "backing_out": c.flags & command_flags::BACKING_OUT != 0,
        "looking": c.flags & command_flags::LOOKING != 0,
        "tight": c.flags & command_flags::TIGHT != 0,
        "maneuvering": c.flags & command_flags::MANEUVERING != 0,
        "rev_to_cmd_us": rev_to_cmd_us,
    }))
}

/// `/goal/raw`: the goal's fields.
pub fn goal(g: &Goal) -> Vec<u8> {
    to_bytes(&json!({
        "seq": g.seq,
        "stamp_mono_ns": g.stamp_mono_ns,
        "x": g.x,
        "y": g.y,
        "tolerance_m": g.tolerance_m,
    }))
}

/// `/base/state`: every field but the reserved bytes (an unknown battery voltage is null).
pub fn base_state(b: &BaseState) -> Vec<u8> {
    to_bytes(&json!({
        "seq": b.seq,
        "rx_mono_ns": b.rx_mono_ns,
        "base_stamp_ms": b.base_stamp_ms,
        "battery_v": b.battery_v,
        "halted": b.halted,
        "base": b.base,
        "link": b.link,
        "bumper": b.bumper,
        "cliff": b.cliff,
        "wheel_drop": b.wheel_drop,
        "buttons": b.buttons,
        "charger": b.charger,
        "over_current": b.over_current,
        "rejected": b.rejected,
        "link_losses": b.link_losses,
    }))
}

/// `/foliage/alarm`: the verdict's header (the `sectors` used of `nearest_m`, null where no
/// obstacle is); the returns themselves go to `/foliage/scan`.
pub fn foliage_alarm(h: &FoliageHeader) -> Vec<u8> {
    let sectors = (h.sectors as usize).min(h.nearest_m.len());
    to_bytes(&json!({
        "seq": h.seq,
        "source_seq": h.source_seq,
        "stamp_ns": h.stamp_ns,
        "rx_mono_ns": h.rx_mono_ns,
        "count": h.count,
        "sectors": h.sectors,
        "obstacles": h.obstacles,
        "processing_us": h.processing_us,
        "alarm": h.alarm != 0,
        "laser_id": h.laser_id,
        "nearest_m": &h.nearest_m[..sectors],
    }))
}

/// The JSON schemas of the channels that have no well-known schema.
pub mod schemas {
    use serde_json::{Value, json};

    fn object(title: &str, fields: &[(&str, &str)]) -> Value {
        let mut props = serde_json::Map::new();
        for (name, kind) in fields {
            let t = match *kind {
                "number|null" => json!({"type": ["number", "null"]}),
                "number[]|null" => json!({"type": "array", "items": {"type": ["number", "null"]}}),
                k => json!({ "type": k }),
            };
            props.insert((*name).to_string(), t);
        }
        json!({"title": title, "type": "object", "properties": props})
    }

    /// `mimnav.VelocityCommand`.
    pub fn cmd_vel() -> Value {
        object(
            "mimnav.VelocityCommand",
            &[
                ("seq", "integer"),
                ("stamp_mono_ns", "integer"),
                ("source_stamp_ns", "integer"),
                ("source_seq", "integer"),
                ("valid_until_mono_ns", "integer"),
                ("v", "number"),
                ("omega", "number"),
                ("status", "integer"),
                ("status_name", "string"),
                ("flags", "integer"),
                ("foliage_alarm", "boolean"),
                ("no_route", "boolean"),
                ("backing_out", "boolean"),
                ("looking", "boolean"),
                ("tight", "boolean"),
                ("maneuvering", "boolean"),
                ("rev_to_cmd_us", "number|null"),
            ],
        )
    }

    /// `mimnav.Goal`.
    pub fn goal() -> Value {
        object(
            "mimnav.Goal",
            &[
                ("seq", "integer"),
                ("stamp_mono_ns", "integer"),
                ("x", "number"),
                ("y", "number"),
                ("tolerance_m", "number"),
            ],
        )
    }

    /// `mimnav.BaseState`.
    pub fn base_state() -> Value {
        let ints = [
            "seq",
            "rx_mono_ns",
            "base_stamp_ms",
            "halted",
            "base",
            "link",
            "bumper",
            "cliff",
            "wheel_drop",
            "buttons",
            "charger",
            "over_current",
            "rejected",
            "link_losses",
        ];
        let mut f: Vec<(&str, &str)> = ints.iter().map(|n| (*n, "integer")).collect();
        f.push(("battery_v", "number|null"));
        object("mimnav.BaseState", &f)
    }

    /// `mimnav.FoliageAlarm`.
    pub fn foliage_alarm() -> Value {
        object(
            "mimnav.FoliageAlarm",
            &[
                ("seq", "integer"),
                ("source_seq", "integer"),
                ("stamp_ns", "integer"),
                ("rx_mono_ns", "integer"),
                ("count", "integer"),
                ("sectors", "integer"),
                ("obstacles", "integer"),
                ("processing_us", "integer"),
                ("alarm", "boolean"),
                ("laser_id", "integer"),
                ("nearest_m", "number[]|null"),
            ],
        )
    }

    /// `mimnav.Latency`: one revolution's times per hop, µs.
    pub fn latency() -> Value {
        object(
            "mimnav.Latency",
            &[
                ("source_seq", "integer"),
                ("mapper_us", "number"),
                ("rev_to_map_view_us", "number"),
                ("rev_to_cmd_us", "number"),
                ("cmd_to_view_us", "number"),
                ("foliage_us", "number|null"),
            ],
        )
    }

    /// `mimnav.ViewStats`: the view's counters (see `crate::counters`).
    pub fn stats() -> Value {
        json!({"title": "mimnav.ViewStats", "type": "object", "properties": {
            "uptime_s": {"type": "number"},
            "clients": {"type": "integer"},
            "missed": {"type": "integer"},
            "thinned": {"type": "integer"},
            "sent": {"type": "integer"},
            "bad": {"type": "integer"},
            "topics": {"type": "object"},
            "channels": {"type": "object"}}})
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn floats(b: &[u8]) -> Vec<f32> {
        b.chunks(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    }

    #[test]
    fn stamps_split_seconds_and_nanoseconds_and_saturate() {
        let t = stamp(1_700_000_000_123_456_789);
        assert_eq!((t.sec(), t.nsec()), (1_700_000_000, 123_456_789));
        assert_eq!(stamp(u64::MAX), Timestamp::MAX);
    }

    #[test]
    fn a_point_cloud_packs_x_y_z_and_intensity_as_little_endian_floats() {
        let h = PointsHeader {
            stamp_ns: 5_000_000_001,
            point_count: 2,
            ..Default::default()
        };
        let pts = [
            Point {
                x: 1.5,
                y: -2.25,
                z: 0.125,
                intensity: 7,
                ..Default::default()
            },
            Point {
                x: -3.0,
                y: 4.0,
                z: -0.5,
                intensity: 255,
                ..Default::default()
            },
        ];
        let m = points(&h, &pts);
        assert_eq!(m.frame_id, LIDAR_FRAME);
        assert_eq!(m.point_stride, 16);
        let names: Vec<&str> = m.fields.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["x", "y", "z", "intensity"]);
        assert_eq!(
            floats(&m.data),
            [1.5, -2.25, 0.125, 7.0, -3.0, 4.0, -0.5, 255.0]
        );
        assert_eq!(m.timestamp.map(|t| (t.sec(), t.nsec())), Some((5, 1)));
    }

    #[test]
    fn a_plan_grid_is_transposed_into_foxgloves_rows_along_x() {
        let h = MapHeader {
            cells: 2,
            cell_m: 0.5,
            ..Default::default()
        };
        // mimnav: (r, c) at r·2 + c; class = 10 r + c
        let cells: Vec<PlanCell> = [(0, 0), (0, 1), (1, 0), (1, 1)]
            .iter()
            .map(|&(r, c)| PlanCell {
                class: 10 * r + c,
                cost: 100 + 10 * r + c,
            })
            .collect();
        let g = plan(&h, &cells).unwrap();
        assert_eq!((g.column_count, g.cell_stride, g.row_stride), (2, 2, 4));
        assert_eq!(&g.data[..], [0, 100, 10, 110, 1, 101, 11, 111]);
        let p = g.pose.unwrap().position.unwrap();
        assert_eq!((p.x, p.y), (-0.5, -0.5));
        assert_eq!(g.frame_id, ODOM_FRAME);
    }

    #[test]
    fn a_grid_turns_with_the_robot() {
        let h = MapHeader {
            cells: 2,
            cell_m: 1.0,
            x: 10.0,
            y: 20.0,
            yaw: std::f64::consts::FRAC_PI_2,
            ..Default::default()
        };
        let g = plan(&h, &[PlanCell::default(); 4]).unwrap();
        // facing +y: the corner (-1, -1) in the robot frame is (+1, -1) from the robot
        let p = g.pose.unwrap().position.unwrap();
        assert!(
            (p.x - 11.0).abs() < 1e-9 && (p.y - 19.0).abs() < 1e-9,
            "{p:?}"
        );
    }

    #[test]
    fn the_glass_grid_marks_glass_and_suspected_glass_only() {
        let h = MapHeader {
            cells: 2,
            cell_m: 0.1,
            ..Default::default()
        };
        let cells = [3u8, 5, 1, 2].map(|class| PlanCell { class, cost: 255 });
        let (g, seen, suspected) = glass(&h, &cells).unwrap();
        assert_eq!((seen, suspected), (1, 1));
        // transposed: (0,0)=3→1, (1,0)=1→0, (0,1)=5→2, (1,1)=2→0
        assert_eq!(&g.data[..], [1, 0, 2, 0]);
    }

    #[test]
    fn layers_sit_side_by_side_in_each_cell() {
        let h = MapHeader {
            cells: 1,
            cell_m: 0.1,
            layers: 3,
            ..Default::default()
        };
        let g = layers(&h, &[1.0, 2.0, 3.0]).unwrap();
        assert_eq!(g.cell_stride, 12);
        assert_eq!(g.fields[2].name, "layer2");
        assert_eq!(g.fields[2].offset, 8);
        assert_eq!(floats(&g.data), [1.0, 2.0, 3.0]);
    }

    #[test]
    fn bad_grids_and_poses_are_refused_not_panics() {
        let h = MapHeader {
            cells: 3,
            cell_m: 0.1,
            layers: 2,
            ..Default::default()
        };
        assert_eq!(
            layers(&h, &[0.0; 9]),
            Err(BadSample::GridSize {
                len: 9,
                cells: 3,
                layers: 2
            })
        );
        let huge = MapHeader {
            cells: u32::MAX,
            ..h
        };
        assert!(plan(&huge, &[PlanCell::default(); 4]).is_err());
        let nan = MapHeader {
            cells: 1,
            x: f64::NAN,
            ..h
        };
        assert!(plan(&nan, &[PlanCell::default()]).is_err());
        let o = Odometry {
            yaw: f64::INFINITY,
            ..Default::default()
        };
        assert!(robot_transform(&o).is_err() && Path::new(0.1, 10).add(&o).is_err());
    }

    #[test]
    fn the_lidar_sits_on_the_robot_by_its_mount() {
        let mount = LidarMount {
            x_m: 0.2,
            yaw_deg: 90.0,
            ..Default::default()
        };
        let t = mount_transform(&mount, 0.5, 0);
        let v = t.translation.unwrap();
        assert!(
            (v.x - 0.2).abs() < 1e-9 && (v.z - 0.5).abs() < 1e-9,
            "{v:?}"
        );
        let q = t.rotation.unwrap();
        assert!((q.z - 0.5f64.sqrt()).abs() < 1e-9, "{q:?}");
        assert_eq!(
            (t.parent_frame_id.as_str(), t.child_frame_id.as_str()),
            ("base_link", "lidar")
        );
    }

    #[test]
    fn the_path_keeps_a_pose_every_step_and_at_most_max() {
        let mut p = Path::new(0.1, 3);
        for i in 0..10 {
            let o = Odometry {
                x: f64::from(i) * 0.06,
                ..Default::default()
            };
            p.add(&o).unwrap();
        }
        // kept at 0, 0.12, 0.24, 0.36, 0.48 (every second): the last 3
        assert_eq!(p.len(), 3);
        let xs: Vec<f64> = (p.message().poses.iter())
            .map(|q| q.position.as_ref().map_or(f64::NAN, |v| v.x))
            .collect();
        assert!((xs[2] - 0.48).abs() < 1e-9, "{xs:?}");
    }

    #[test]
    fn the_classified_scan_leaves_out_returns_without_a_range() {
        let h = FoliageHeader::default();
        let r = [
            FoliageReturn {
                angle_rad: std::f32::consts::FRAC_PI_2,
                range_m: 2.0,
                class: 2,
                reserved: [0; 3],
            },
            FoliageReturn {
                angle_rad: 0.0,
                range_m: 0.0,
                class: 0,
                reserved: [0; 3],
            },
        ];
        let m = foliage_scan(&h, &r);
        assert_eq!(m.data.len(), SCAN_STRIDE);
        let f = floats(&m.data[..12]);
        assert!(f[0].abs() < 1e-6 && (f[1] - 2.0).abs() < 1e-6);
        assert_eq!(m.data[12], 2);
    }

    #[test]
    fn json_messages_name_the_status_and_keep_every_field() {
        let c = VelocityCommand {
            status: 2,
            flags: command_flags::FOLIAGE_ALARM | command_flags::BACKING_OUT | command_flags::TIGHT,
            v: 0.25,
            ..Default::default()
        };
        let m: Value = serde_json::from_slice(&cmd_vel(&c, Some(1200.0))).unwrap();
        assert_eq!(m["status_name"], "blocked");
        assert_eq!(
            (m["foliage_alarm"].clone(), m["backing_out"].clone()),
            (json!(true), json!(true))
        );
        assert_eq!(
            (
                m["no_route"].clone(),
                m["looking"].clone(),
                m["tight"].clone()
            ),
            (json!(false), json!(false), json!(true))
        );
        assert_eq!(m["rev_to_cmd_us"], 1200.0);
        let props = schemas::cmd_vel()["properties"].as_object().unwrap().len();
        assert_eq!(m.as_object().unwrap().len(), props);
        let b: Value = serde_json::from_slice(&base_state(&BaseState {
            battery_v: f32::NAN,
            ..Default::default()
        }))
        .unwrap();
        assert_eq!(b["battery_v"], Value::Null);
        let mut fh = FoliageHeader {
            sectors: 2,
            ..Default::default()
        };
        fh.nearest_m[1] = 1.5;
        let f: Value = serde_json::from_slice(&foliage_alarm(&fh)).unwrap();
        // no obstacle in sector 0: infinite, null in JSON
        assert_eq!(f["nearest_m"], json!([null, 1.5]));
    }
}
