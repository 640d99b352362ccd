//! Topic samples as JSON messages with JSON schemas, the way Foxglove reads an MCAP file
//! (message encoding `json`, schema encoding `jsonschema`).
//!
//! The point cloud and the grids use Foxglove's well-known schemas (`foxglove.PointCloud`,
//! `foxglove.Grid`, `foxglove.PoseInFrame`), so Foxglove draws them; the rest are plain JSON
//! objects holding every field of the topic's type, under schemas named `mimnav.*`. Binary
//! fields (`data`) are base64, as Foxglove's JSON encoding of `bytes` fields wants; numbers are
//! little-endian inside them.
//!
//! Nothing here touches iceoryx2 or a file: [`super`] receives, this converts, the `mcap` crate
//! writes.

use serde_json::{Value, json};

use mimnav_shared::pose::LidarMount;
use mimnav_shared::topics::{
    self, BaseState, FoliageHeader, FoliageReturn, Goal, MapHeader, Odometry, PlanCell, Point,
    PointsHeader, ScanHeader, ScanReturn, TruthHeader, VelocityCommand,
};

/// Foxglove's `NumericType` values used here.
mod numeric {
    pub const UINT8: u8 = 1;
    pub const UINT16: u8 = 3;
    pub const UINT32: u8 = 5;
    pub const FLOAT32: u8 = 7;
}

/// Frame of the point cloud and the scans: the sensor's (REP-103, x forward).
pub const SENSOR_FRAME: &str = "lidar";
/// Frame of odometry and of the maps: the fixed odometry frame.
pub const ODOM_FRAME: &str = "odom";
/// The robot's frame: on the ground under its centre, x ahead (REP-105's `base_link`).
pub const BASE_FRAME: &str = "base_link";

/// The channel of the frames' transforms, written with every odometry sample.
pub const TF_CHANNEL: &str = "mimnav/tf";
/// Its schema's name.
pub const TF_SCHEMA: &str = "foxglove.FrameTransforms";

/// Bytes per point in a recorded `foxglove.PointCloud` ([`POINT_FIELDS`] and a padding byte).
pub const POINT_STRIDE: usize = 28;

/// The fields of a recorded point: name, byte offset, Foxglove `NumericType`.
pub const POINT_FIELDS: [(&str, usize, u8); 10] = [
    ("x", 0, numeric::FLOAT32),
    ("y", 4, numeric::FLOAT32),
    ("z", 8, numeric::FLOAT32),
    ("intensity", 12, numeric::FLOAT32),
    ("time_offset_ns", 16, numeric::UINT32),
    ("distance_raw", 20, numeric::UINT16),
    ("azimuth_cdeg", 22, numeric::UINT16),
    ("laser_id", 24, numeric::UINT8),
    ("ring", 25, numeric::UINT8),
    ("return_type", 26, numeric::UINT8),
];

/// A topic `mimnav record` can record.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Topic {
    Points,
    Scan2d,
    Odom,
    CmdVel,
    Goal,
    Plan,
    Layers,
    Foliage,
    BaseState,
    Truth,
}

/// Why a sample could not be converted: it is skipped and counted, the recording goes on (the
/// live view's reasons: a grid's payload that does not match its header).
pub use mimnav_view::convert::BadSample;
use mimnav_view::convert::{check_grid, grid_cells, grid_corner};

impl Topic {
    /// Every topic, in the order of `docs/topics.md`.
    pub const ALL: [Topic; 10] = [
        Topic::Points,
        Topic::Scan2d,
        Topic::CmdVel,
        Topic::Odom,
        Topic::Goal,
        Topic::BaseState,
        Topic::Truth,
        Topic::Layers,
        Topic::Plan,
        Topic::Foliage,
    ];

    /// The stack's service name, used as the MCAP channel's topic.
    pub fn name(self) -> &'static str {
        match self {
            Topic::Points => topics::LIDAR_POINTS,
            Topic::Scan2d => topics::LIDAR_SCAN2D,
            Topic::Odom => topics::ODOM,
            Topic::CmdVel => topics::CMD_VEL,
            Topic::Goal => topics::GOAL,
            Topic::Plan => topics::MAP_PLAN,
            Topic::Layers => topics::MAP_LAYERS,
            Topic::Foliage => topics::FOLIAGE_ALARM,
            Topic::BaseState => topics::BASE_STATE,
            Topic::Truth => topics::SIM_TRUTH,
        }
    }

    /// The topic named `name`, with or without the `mimnav/` prefix (`lidar/points`).
    pub fn parse(name: &str) -> Option<Topic> {
        let full = if name.starts_with("mimnav/") {
            name.to_string()
        } else {
            format!("mimnav/{name}")
        };
        Topic::ALL.into_iter().find(|t| t.name() == full)
    }

    /// The MCAP schema's name.
    pub fn schema_name(self) -> &'static str {
        match self {
            Topic::Points => "foxglove.PointCloud",
            Topic::Odom => "foxglove.PoseInFrame",
            Topic::Plan | Topic::Layers | Topic::Truth => "foxglove.Grid",
            Topic::Scan2d => "mimnav.Scan2d",
            Topic::CmdVel => "mimnav.VelocityCommand",
            Topic::Goal => "mimnav.Goal",
            Topic::Foliage => "mimnav.FoliageAlarm",
            Topic::BaseState => "mimnav.BaseState",
        }
    }

    /// The JSON schema of the topic's messages.
    pub fn schema(self) -> Value {
        let title = self.schema_name();
        let mut s = match self {
            Topic::Points => point_cloud_schema(),
            Topic::Odom => pose_in_frame_schema(),
            Topic::Plan | Topic::Layers | Topic::Truth => grid_schema(),
            Topic::Scan2d => object(&[
                ("seq", INT),
                ("stamp_ns", INT),
                ("rx_mono_ns", INT),
                ("elevation_rad", NUM),
                ("laser_id", INT),
                ("return_select", INT),
                ("angle_rad", NUMS),
                ("range_m", NUMS),
                ("intensity", INTS),
                ("return_type", INTS),
            ]),
            Topic::CmdVel => object(&[
                ("seq", INT),
                ("stamp_mono_ns", INT),
                ("source_stamp_ns", INT),
                ("source_seq", INT),
                ("valid_until_mono_ns", INT),
                ("v", NUM),
                ("omega", NUM),
                ("status", INT),
                ("flags", INT),
            ]),
            Topic::Goal => object(&[
                ("seq", INT),
                ("stamp_mono_ns", INT),
                ("x", NUM),
                ("y", NUM),
                ("tolerance_m", NUM),
                ("flags", INT),
            ]),
            Topic::Foliage => object(&[
                ("seq", INT),
                ("source_seq", INT),
                ("stamp_ns", INT),
                ("rx_mono_ns", INT),
                ("sectors", INT),
                ("obstacles", INT),
                ("processing_us", INT),
                ("alarm", INT),
                ("laser_id", INT),
                // infinite ranges (no obstacle in the sector) are null: JSON has no infinity
                ("nearest_m", NUMS_OR_NULL),
                ("angle_rad", NUMS),
                ("range_m", NUMS),
                ("class", INTS),
            ]),
            Topic::BaseState => object(&[
                ("seq", INT),
                ("rx_mono_ns", INT),
                ("base_stamp_ms", INT),
                ("battery_v", NUM_OR_NULL),
                ("halted", INT),
                ("base", INT),
                ("link", INT),
                ("bumper", INT),
                ("cliff", INT),
                ("wheel_drop", INT),
                ("buttons", INT),
                ("charger", INT),
                ("over_current", INT),
                ("rejected", INT),
                ("link_losses", INT),
            ]),
        };
        s["title"] = json!(title);
        s["description"] = json!(format!("{} as recorded by `mimnav record`", self.name()));
        s
    }
}

const INT: &str = "integer";
const NUM: &str = "number";
const NUM_OR_NULL: &str = "number|null";
const INTS: &str = "integer[]";
const NUMS: &str = "number[]";
const NUMS_OR_NULL: &str = "(number|null)[]";

/// A JSON schema of an object whose every field is required, from (name, kind) pairs.
fn object(fields: &[(&str, &str)]) -> Value {
    let mut props = serde_json::Map::new();
    for (name, kind) in fields {
        let t = match *kind {
            NUM_OR_NULL => json!({"type": ["number", "null"]}),
            INTS => json!({"type": "array", "items": {"type": "integer"}}),
            NUMS => json!({"type": "array", "items": {"type": "number"}}),
            NUMS_OR_NULL => json!({"type": "array", "items": {"type": ["number", "null"]}}),
            k => json!({ "type": k }),
        };
        props.insert((*name).to_string(), t);
    }
    let required: Vec<&str> = fields.iter().map(|(n, _)| *n).collect();
    json!({"type": "object", "properties": props, "required": required})
}

fn time_schema() -> Value {
    json!({"type": "object", "title": "time", "properties": {
        "sec": {"type": "integer", "minimum": 0},
        "nsec": {"type": "integer", "minimum": 0, "maximum": 999_999_999}}})
}

fn xyz_schema(names: &[&str], title: &str) -> Value {
    let props: serde_json::Map<String, Value> = names
        .iter()
        .map(|n| ((*n).to_string(), json!({"type": "number"})))
        .collect();
    json!({"type": "object", "title": title, "properties": props, "required": names})
}

fn pose_schema() -> Value {
    json!({"type": "object", "title": "foxglove.Pose", "properties": {
        "position": xyz_schema(&["x", "y", "z"], "foxglove.Vector3"),
        "orientation": xyz_schema(&["x", "y", "z", "w"], "foxglove.Quaternion")}})
}

fn fields_schema() -> Value {
    json!({"type": "array", "items": {"type": "object", "title": "foxglove.PackedElementField",
        "properties": {
            "name": {"type": "string"},
            "offset": {"type": "integer", "minimum": 0},
            "type": {"type": "integer", "title": "foxglove.NumericType"}}}})
}

fn bytes_schema() -> Value {
    json!({"type": "string", "contentEncoding": "base64"})
}

fn point_cloud_schema() -> Value {
    json!({"type": "object", "properties": {
        "timestamp": time_schema(),
        "frame_id": {"type": "string"},
        "pose": pose_schema(),
        "point_stride": {"type": "integer", "minimum": 0},
        "fields": fields_schema(),
        "data": bytes_schema(),
        "mimnav": extra_schema()},
        "required": ["timestamp", "frame_id", "pose", "point_stride", "fields", "data"]})
}

fn grid_schema() -> Value {
    json!({"type": "object", "properties": {
        "timestamp": time_schema(),
        "frame_id": {"type": "string"},
        "pose": pose_schema(),
        "column_count": {"type": "integer", "minimum": 0},
        "cell_size": xyz_schema(&["x", "y"], "foxglove.Vector2"),
        "row_stride": {"type": "integer", "minimum": 0},
        "cell_stride": {"type": "integer", "minimum": 0},
        "fields": fields_schema(),
        "data": bytes_schema()}})
}

/// The `mimnav` object beside a Foxglove schema's fields: the sample's fields the schema has no
/// place for (Foxglove ignores it; `mimnav replay` reads it).
fn extra_schema() -> Value {
    json!({"type": "object", "description":
        "the sample's own fields, as in docs/topics.md, for `mimnav replay`"})
}

fn pose_in_frame_schema() -> Value {
    json!({"type": "object", "properties": {
        "timestamp": time_schema(),
        "frame_id": {"type": "string"},
        "pose": pose_schema(),
        "mimnav": extra_schema()},
        "required": ["timestamp", "frame_id", "pose"]})
}

/// Foxglove's `time`: ns since the epoch as seconds and nanoseconds.
pub fn time(ns: u64) -> Value {
    json!({"sec": ns / 1_000_000_000, "nsec": ns % 1_000_000_000})
}

/// A pose in the x-y plane: position (x, y, 0), turned by `yaw` about z.
fn planar_pose(x: f64, y: f64, yaw: f64) -> Value {
    let (s, c) = (yaw * 0.5).sin_cos();
    json!({"position": {"x": x, "y": y, "z": 0.0},
           "orientation": {"x": 0.0, "y": 0.0, "z": s, "w": c}})
}

fn field(name: &str, offset: usize, kind: u8) -> Value {
    json!({"name": name, "offset": offset, "type": kind})
}

/// Standard base64 with padding (RFC 4648 §4), what Foxglove's JSON `bytes` fields hold.
pub fn base64(bytes: &[u8]) -> String {
    use base64::Engine as _;
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

fn to_bytes(v: &Value) -> Vec<u8> {
    // serialising a Value cannot fail: its map keys are strings
    serde_json::to_vec(v).unwrap_or_default()
}

/// `lidar/points` as a `foxglove.PointCloud` in the sensor frame, stamped with the revolution's
/// sensor time: every field of every [`Point`], in firing order ([`POINT_FIELDS`]: x, y, z and
/// intensity — the reflectivity byte as a float, which Foxglove colours by — then the firing's
/// time offset, raw distance, azimuth, laser, ring and return type), and the revolution's header
/// under `mimnav` (ignored by Foxglove). Nothing is lost: `mimnav replay` publishes the same
/// revolution from it ([`parse_points`]).
pub fn points(h: &PointsHeader, pts: &[Point]) -> Vec<u8> {
    let mut data = Vec::with_capacity(pts.len() * POINT_STRIDE);
    for p in pts {
        for v in [p.x, p.y, p.z, f32::from(p.intensity)] {
            data.extend_from_slice(&v.to_le_bytes());
        }
        data.extend_from_slice(&p.time_offset_ns.to_le_bytes());
        data.extend_from_slice(&p.distance_raw.to_le_bytes());
        data.extend_from_slice(&p.azimuth_cdeg.to_le_bytes());
        data.extend_from_slice(&[p.laser_id, p.ring, p.return_type, 0]);
    }
    let fields: Vec<Value> = POINT_FIELDS
        .iter()
        .map(|&(name, offset, kind)| field(name, offset, kind))
        .collect();
    to_bytes(&json!({
        "timestamp": time(h.stamp_ns),
        "frame_id": SENSOR_FRAME,
        "pose": planar_pose(0.0, 0.0, 0.0),
        "point_stride": POINT_STRIDE,
        "fields": fields,
        "data": base64(&data),
        "mimnav": {
            "seq": h.seq,
            "stamp_ns": h.stamp_ns,
            "rx_mono_ns": h.rx_mono_ns,
            "first_packet_seq": h.first_packet_seq,
            "packet_count": h.packet_count,
            "strongest_count": h.strongest_count,
            "last_count": h.last_count,
            "both_count": h.both_count,
            "return_mode": h.return_mode,
            "product": h.product,
            "cut_reason": h.cut_reason,
        },
    }))
}

/// `lidar/scan2d`: the header's fields and the returns as parallel arrays.
pub fn scan(h: &ScanHeader, returns: &[ScanReturn]) -> Vec<u8> {
    to_bytes(&json!({
        "seq": h.seq,
        "stamp_ns": h.stamp_ns,
        "rx_mono_ns": h.rx_mono_ns,
        "elevation_rad": h.elevation_rad,
        "laser_id": h.laser_id,
        "return_select": h.return_select,
        "angle_rad": returns.iter().map(|r| r.angle_rad).collect::<Vec<_>>(),
        "range_m": returns.iter().map(|r| r.range_m).collect::<Vec<_>>(),
        "intensity": returns.iter().map(|r| r.intensity).collect::<Vec<_>>(),
        "return_type": returns.iter().map(|r| r.return_type).collect::<Vec<_>>(),
    }))
}

/// `odom` as a `foxglove.PoseInFrame` in the odometry frame, with every field of the sample under
/// `mimnav` (the pose exactly, and the velocities, which a pose has no place for).
pub fn odom(o: &Odometry) -> Vec<u8> {
    to_bytes(&json!({
        "timestamp": time(o.stamp_ns),
        "frame_id": ODOM_FRAME,
        "pose": planar_pose(o.x, o.y, o.yaw),
        "mimnav": {
            "seq": o.seq,
            "stamp_ns": o.stamp_ns,
            "rx_mono_ns": o.rx_mono_ns,
            "x": o.x,
            "y": o.y,
            "yaw": o.yaw,
            "v": o.v,
            "omega": o.omega,
        },
    }))
}

/// The transforms that place the sensor's points in the odometry frame, Foxglove's
/// `foxglove.FrameTransforms`: `odom` → `base_link` at the odometry pose, and `base_link` →
/// `lidar` by the profile's mount (`robot.mount`, at `robot.sensor_height_m` above the ground),
/// both stamped with the odometry's time.
pub fn transforms(o: &Odometry, mount: &LidarMount, sensor_height_m: f64) -> Vec<u8> {
    let iso = mount.isometry();
    let q = iso.rotation.coords;
    let base = planar_pose(o.x, o.y, o.yaw);
    to_bytes(&json!({"transforms": [
        {
            "timestamp": time(o.stamp_ns),
            "parent_frame_id": ODOM_FRAME,
            "child_frame_id": BASE_FRAME,
            "translation": base["position"],
            "rotation": base["orientation"],
        },
        {
            "timestamp": time(o.stamp_ns),
            "parent_frame_id": BASE_FRAME,
            "child_frame_id": SENSOR_FRAME,
            "translation": {"x": mount.x_m, "y": mount.y_m, "z": sensor_height_m},
            "rotation": {"x": q.x, "y": q.y, "z": q.z, "w": q.w},
        },
    ]}))
}

/// The JSON schema of [`transforms`]' messages.
pub fn transforms_schema() -> Value {
    let transform = json!({"type": "object", "title": "foxglove.FrameTransform", "properties": {
        "timestamp": time_schema(),
        "parent_frame_id": {"type": "string"},
        "child_frame_id": {"type": "string"},
        "translation": xyz_schema(&["x", "y", "z"], "foxglove.Vector3"),
        "rotation": xyz_schema(&["x", "y", "z", "w"], "foxglove.Quaternion")}});
    json!({"type": "object", "title": TF_SCHEMA,
        "description": "the frames odom → base_link → lidar, as recorded by `mimnav record`",
        "properties": {"transforms": {"type": "array", "items": transform}},
        "required": ["transforms"]})
}

/// `cmd_vel`: every field of the command.
pub fn cmd_vel(c: &VelocityCommand) -> Vec<u8> {
    to_bytes(&json!({
        "seq": c.seq,
        "stamp_mono_ns": c.stamp_mono_ns,
        "source_stamp_ns": c.source_stamp_ns,
        "source_seq": c.source_seq,
        "valid_until_mono_ns": c.valid_until_mono_ns,
        "v": c.v,
        "omega": c.omega,
        "status": c.status,
        "flags": c.flags,
    }))
}

/// `goal`: every field but the reserved bytes (`flags` 1: a stop request).
pub fn goal(g: &Goal) -> Vec<u8> {
    to_bytes(&json!({
        "seq": g.seq,
        "stamp_mono_ns": g.stamp_mono_ns,
        "x": g.x,
        "y": g.y,
        "tolerance_m": g.tolerance_m,
        "flags": g.flags,
    }))
}

/// `base/state`: every field but the reserved bytes (an unknown battery voltage is null).
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

/// `foliage/alarm`: the header's fields (the `sectors` used of `nearest_m`, null where no
/// obstacle is) and the returns as parallel arrays.
pub fn foliage(h: &FoliageHeader, returns: &[FoliageReturn]) -> Vec<u8> {
    let sectors = (h.sectors as usize).min(h.nearest_m.len());
    to_bytes(&json!({
        "seq": h.seq,
        "source_seq": h.source_seq,
        "stamp_ns": h.stamp_ns,
        "rx_mono_ns": h.rx_mono_ns,
        "sectors": h.sectors,
        "obstacles": h.obstacles,
        "processing_us": h.processing_us,
        "alarm": h.alarm,
        "laser_id": h.laser_id,
        "nearest_m": &h.nearest_m[..sectors],
        "angle_rad": returns.iter().map(|r| r.angle_rad).collect::<Vec<_>>(),
        "range_m": returns.iter().map(|r| r.range_m).collect::<Vec<_>>(),
        "class": returns.iter().map(|r| r.class).collect::<Vec<_>>(),
    }))
}

/// A `foxglove.Grid` of a robot-centred `cells × cells` map placed at the robot's pose in the
/// odometry frame. mimnav stores cell (r along x, c along y) at `r · cells + c`; Foxglove fills
/// each row along x, so the cells are transposed: Foxglove's `data` holds (r, c) at
/// `c · cells + r`, `values_per_cell` values of `value_size` bytes each, written by `put`.
fn grid(
    stamp_ns: u64,
    (x, y, yaw): (f64, f64, f64),
    cells: u32,
    cell_m: f32,
    fields: Vec<Value>,
    cell_stride: usize,
    put: impl FnMut(usize, &mut Vec<u8>),
) -> Vec<u8> {
    let n = cells as usize;
    let data = grid_cells(n, cell_stride, put);
    let corner = grid_corner((x, y, yaw), cells, cell_m);
    to_bytes(&json!({
        "timestamp": time(stamp_ns),
        "frame_id": ODOM_FRAME,
        "pose": planar_pose(corner.0, corner.1, yaw),
        "column_count": cells,
        "cell_size": {"x": cell_m, "y": cell_m},
        "row_stride": n * cell_stride,
        "cell_stride": cell_stride,
        "fields": fields,
        "data": base64(&data),
    }))
}

/// `map/plan` as a `foxglove.Grid` with the fields `class` and `cost` (`uint8`).
pub fn plan(h: &MapHeader, cells: &[PlanCell]) -> Result<Vec<u8>, BadSample> {
    check_grid(cells.len(), h.cells, 1)?;
    let fields = vec![
        field("class", 0, numeric::UINT8),
        field("cost", 1, numeric::UINT8),
    ];
    Ok(grid(
        h.stamp_ns,
        (h.x, h.y, h.yaw),
        h.cells,
        h.cell_m,
        fields,
        2,
        |i, d| d.extend_from_slice(&[cells[i].class, cells[i].cost]),
    ))
}

/// `map/layers` as a `foxglove.Grid` with one `float32` field a layer, `layer0`, `layer1`, …
/// (mimnav's layers one after the other become the values of each cell side by side).
pub fn layers(h: &MapHeader, values: &[f32]) -> Result<Vec<u8>, BadSample> {
    check_grid(values.len(), h.cells, h.layers)?;
    let m = h.layers as usize;
    let n2 = (h.cells as usize).pow(2);
    let fields = (0..m)
        .map(|j| field(&format!("layer{j}"), 4 * j, numeric::FLOAT32))
        .collect();
    Ok(grid(
        h.stamp_ns,
        (h.x, h.y, h.yaw),
        h.cells,
        h.cell_m,
        fields,
        4 * m,
        |i, d| {
            for j in 0..m {
                d.extend_from_slice(&values[j * n2 + i].to_le_bytes());
            }
        },
    ))
}

/// `sim/truth` as a `foxglove.Grid` with the field `class` (`uint8`), placed at the simulated
/// robot's pose in the world.
pub fn truth(h: &TruthHeader, classes: &[u8]) -> Result<Vec<u8>, BadSample> {
    check_grid(classes.len(), h.cells, 1)?;
    let fields = vec![field("class", 0, numeric::UINT8)];
    Ok(grid(
        h.stamp_ns,
        (h.x, h.y, h.yaw),
        h.cells,
        h.cell_m,
        fields,
        1,
        |i, d| d.push(classes[i]),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(bytes: &[u8]) -> Value {
        serde_json::from_slice(bytes).expect("valid JSON")
    }

    fn unbase64(s: &str) -> Vec<u8> {
        use base64::Engine as _;
        base64::engine::general_purpose::STANDARD
            .decode(s)
            .expect("base64")
    }

    #[test]
    fn base64_follows_rfc_4648() {
        // RFC 4648 §10's test vectors
        for (plain, enc) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(plain.as_bytes()), enc);
            assert_eq!(unbase64(enc), plain.as_bytes());
        }
        let all: Vec<u8> = (0..=255).collect();
        assert_eq!(unbase64(&base64(&all)), all);
    }

    #[test]
    fn topic_names_parse_with_or_without_the_prefix() {
        assert_eq!(Topic::parse("lidar/points"), Some(Topic::Points));
        assert_eq!(Topic::parse("mimnav/map/plan"), Some(Topic::Plan));
        assert_eq!(Topic::parse("lidar/packets"), None);
        for t in Topic::ALL {
            assert_eq!(Topic::parse(t.name()), Some(t));
            let s = t.schema();
            assert_eq!(s["title"], t.schema_name());
            assert_eq!(s["type"], "object");
        }
    }

    #[test]
    fn a_point_cloud_packs_every_field_little_endian() {
        let h = PointsHeader {
            seq: 7,
            stamp_ns: 1_700_000_000_123_456_789,
            point_count: 2,
            packet_count: 3,
            ..Default::default()
        };
        let pts = [
            Point {
                x: 1.5,
                y: -2.25,
                z: 0.125,
                intensity: 7,
                time_offset_ns: 0x0102_0304,
                distance_raw: 0x0506,
                azimuth_cdeg: 35_999,
                laser_id: 14,
                ring: 15,
                return_type: 3,
            },
            Point {
                x: -3.0,
                y: 4.0,
                z: -0.5,
                intensity: 255,
                ..Default::default()
            },
        ];
        let m = parse(&points(&h, &pts));
        assert_eq!(
            m["timestamp"],
            json!({"sec": 1_700_000_000u64, "nsec": 123_456_789})
        );
        assert_eq!(m["frame_id"], SENSOR_FRAME);
        assert_eq!(m["point_stride"], 28);
        let names: Vec<&str> = (0..10)
            .map(|k| m["fields"][k]["name"].as_str().unwrap())
            .collect();
        assert_eq!(
            names,
            [
                "x",
                "y",
                "z",
                "intensity",
                "time_offset_ns",
                "distance_raw",
                "azimuth_cdeg",
                "laser_id",
                "ring",
                "return_type"
            ]
        );
        // Foxglove's NumericType: FLOAT32 7, UINT32 5, UINT16 3, UINT8 1
        let types: Vec<u64> = (0..10)
            .map(|k| m["fields"][k]["type"].as_u64().unwrap())
            .collect();
        assert_eq!(types, [7, 7, 7, 7, 5, 3, 3, 1, 1, 1]);
        let data = unbase64(m["data"].as_str().unwrap());
        assert_eq!(data.len(), 56);
        let floats: Vec<f32> = data[..16]
            .chunks(4)
            .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
            .collect();
        assert_eq!(floats, [1.5, -2.25, 0.125, 7.0]);
        assert_eq!(
            data[16..28],
            [4, 3, 2, 1, 6, 5, 0x9f, 0x8c, 14, 15, 3, 0],
            "time, distance, azimuth 35999 = 0x8c9f, laser, ring, return type, padding"
        );
        assert_eq!(f32::from_le_bytes(data[40..44].try_into().unwrap()), 255.0);
        assert_eq!(m["pose"]["orientation"]["w"], 1.0);
        assert_eq!(m["mimnav"]["seq"], 7);
        assert_eq!(m["mimnav"]["packet_count"], 3);
    }

    #[test]
    fn transforms_chain_odom_base_and_lidar_by_the_mount() {
        let o = Odometry {
            stamp_ns: 2_000_000_001,
            x: 1.0,
            y: 2.0,
            yaw: std::f64::consts::FRAC_PI_2,
            ..Default::default()
        };
        let mount = LidarMount {
            x_m: 0.2,
            yaw_deg: 180.0,
            ..Default::default()
        };
        let m = parse(&transforms(&o, &mount, 0.7));
        let t = &m["transforms"];
        assert_eq!(t[0]["parent_frame_id"], ODOM_FRAME);
        assert_eq!(t[0]["child_frame_id"], BASE_FRAME);
        assert_eq!(t[0]["translation"], json!({"x": 1.0, "y": 2.0, "z": 0.0}));
        let w = t[0]["rotation"]["w"].as_f64().unwrap();
        assert!((w - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-12);
        assert_eq!(t[0]["timestamp"], json!({"sec": 2, "nsec": 1}));
        assert_eq!(t[1]["parent_frame_id"], BASE_FRAME);
        assert_eq!(t[1]["child_frame_id"], SENSOR_FRAME);
        assert_eq!(t[1]["translation"], json!({"x": 0.2, "y": 0.0, "z": 0.7}));
        // turned half a turn about z
        assert!((t[1]["rotation"]["z"].as_f64().unwrap().abs() - 1.0).abs() < 1e-12);
        assert_eq!(transforms_schema()["title"], TF_SCHEMA);
    }

    #[test]
    fn a_plan_grid_is_transposed_into_foxgloves_rows_along_x() {
        let h = MapHeader {
            cells: 2,
            cell_m: 0.5,
            stamp_ns: 5,
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
        let m = parse(&plan(&h, &cells).unwrap());
        assert_eq!(m["column_count"], 2);
        assert_eq!(m["cell_stride"], 2);
        assert_eq!(m["row_stride"], 4);
        assert_eq!(m["cell_size"], json!({"x": 0.5, "y": 0.5}));
        // Foxglove: row along y (c), column along x (r)
        assert_eq!(
            unbase64(m["data"].as_str().unwrap()),
            [0, 100, 10, 110, 1, 101, 11, 111]
        );
        // the corner half the side (0.5 m) back and right of the robot at the origin
        assert_eq!(
            m["pose"]["position"],
            json!({"x": -0.5, "y": -0.5, "z": 0.0})
        );
        assert_eq!(m["frame_id"], ODOM_FRAME);
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
        let m = parse(
            &truth(
                &TruthHeader {
                    cells: 2,
                    cell_m: 1.0,
                    x: h.x,
                    y: h.y,
                    yaw: h.yaw,
                    ..Default::default()
                },
                &[0; 4],
            )
            .unwrap(),
        );
        // facing +y: the corner (-1, -1) in the robot frame is (+1, -1) from the robot
        let p = &m["pose"]["position"];
        assert!((p["x"].as_f64().unwrap() - 11.0).abs() < 1e-9, "{p}");
        assert!((p["y"].as_f64().unwrap() - 19.0).abs() < 1e-9, "{p}");
        let q = &m["pose"]["orientation"];
        assert!((q["z"].as_f64().unwrap() - (0.5f64).sqrt()).abs() < 1e-9);
    }

    #[test]
    fn layers_sit_side_by_side_in_each_cell() {
        let h = MapHeader {
            cells: 1,
            cell_m: 0.1,
            layers: 3,
            ..Default::default()
        };
        let m = parse(&layers(&h, &[1.0, 2.0, 3.0]).unwrap());
        assert_eq!(m["cell_stride"], 12);
        assert_eq!(
            m["fields"][2],
            json!({"name": "layer2", "offset": 8, "type": 7})
        );
        let data = unbase64(m["data"].as_str().unwrap());
        assert_eq!(data[8..12], 3.0f32.to_le_bytes());
    }

    #[test]
    fn a_grid_whose_payload_does_not_match_its_header_is_a_bad_sample() {
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
        assert!(truth(&TruthHeader::default(), &[]).is_err());
    }

    #[test]
    fn foliage_keeps_the_used_sectors_with_null_for_none() {
        let mut h = FoliageHeader {
            sectors: 3,
            alarm: 1,
            ..Default::default()
        };
        h.nearest_m[1] = 1.5;
        let r = [FoliageReturn {
            angle_rad: 0.5,
            range_m: 2.0,
            class: 2,
            reserved: [0; 3],
        }];
        let m = parse(&foliage(&h, &r));
        assert_eq!(m["nearest_m"], json!([null, 1.5, null]));
        assert_eq!(m["class"], json!([2]));
        assert_eq!(m["alarm"], 1);
    }

    #[test]
    fn odometry_is_a_pose_in_the_odometry_frame() {
        let o = Odometry {
            stamp_ns: 2_000_000_001,
            x: 1.0,
            y: 2.0,
            yaw: std::f64::consts::PI,
            ..Default::default()
        };
        let m = parse(&odom(&o));
        assert_eq!(m["timestamp"], json!({"sec": 2, "nsec": 1}));
        assert_eq!(m["pose"]["position"], json!({"x": 1.0, "y": 2.0, "z": 0.0}));
        assert!((m["pose"]["orientation"]["z"].as_f64().unwrap() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn value_topics_keep_every_field() {
        let c = VelocityCommand {
            seq: 3,
            v: 0.25,
            omega: -0.5,
            status: 2,
            flags: 4,
            ..Default::default()
        };
        let m = parse(&cmd_vel(&c));
        let keys: Vec<&String> = m.as_object().unwrap().keys().collect();
        let schema = Topic::CmdVel.schema();
        let want: Vec<&str> = schema["required"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap())
            .collect();
        assert_eq!(keys.len(), want.len());
        assert!(want.iter().all(|k| m.get(*k).is_some()));
        assert_eq!(m["omega"], -0.5);
        let b = parse(&base_state(&BaseState {
            battery_v: f32::NAN,
            ..Default::default()
        }));
        assert_eq!(b["battery_v"], Value::Null);
        assert_eq!(
            parse(&goal(&Goal {
                tolerance_m: 0.2,
                ..Default::default()
            }))["tolerance_m"],
            0.2
        );
    }
}
