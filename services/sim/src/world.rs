//! Scenario worlds: the TOML format and its compiled form, the [`Scene`].
//!
//! A world is flat ground (z = 0, z up) with objects on it. Positions are metres in the world
//! frame (x east/forward, y north/left), angles in degrees in the file.
//!
//! ```toml
//! name = "one wall"
//! description = "a concrete wall 5 m ahead"
//! start = [0.0, 0.0, 0.0]     # x, y, heading (degrees, counter-clockwise from x)
//! goal = [8.0, 0.0]
//! time_limit_s = 60.0
//!
//! [ground]
//! reflectivity = 12           # diffuse reflectivity, 0–100 (the VLP-16's calibrated scale)
//!
//! [[wall]]                    # a vertical opaque sheet
//! from = [5.0, -3.0]
//! to = [5.0, 3.0]
//! height = 2.5
//! reflectivity = 50
//! ```
//!
//! Objects (every key but the position has a default):
//!
//! | table | keys | class |
//! |---|---|---|
//! | `[[wall]]` | `from`, `to`, `height` 2.5, `reflectivity` 50 | solid |
//! | `[[pillar]]` | `center`, `size` [x, y] 0.4 × 0.4, `yaw_deg` 0, `height` 2.5, `reflectivity` 60 | solid |
//! | `[[glass]]` | `from`, `to`, `bottom` 0, `top` 2.2 | glass |
//! | `[[curtain]]` | `from`, `to`, `height` 2.0, `coverage` 0.5 (fraction of the sheet that is strands), `reflectivity` 25 | passable |
//! | `[[grass]]` | `center`, `size` [x, y], `yaw_deg` 0, `height` 0.8, `density` 6 (blade hits per metre of beam), `reflectivity` 20 | passable |
//! | `[[bush]]` | `center`, `radius`, `height` 1.0, `density` 40, `reflectivity` 45 | solid (dense foliage to avoid) |
//! | `[[trunk]]` | `center`, `radius` 0.15, `height` 5.0, `reflectivity` 45 | solid |
//! | `[[rock]]` | `center`, `radius` 0.25, `height` 0.3, `reflectivity` 35 | solid (may sit inside grass) |
//!
//! `survey = [[x, y], …]` (optional) is the route the map scorer drives; it defaults to the goal.
//!
//! Limits, checked on loading before anything is built (docs/configuration.md, "Limits of a
//! world"): every number finite; positions within [`WORLD_EXTENT_M`]; angles within
//! [`MAX_ANGLE_DEG`]; the grass patches' blade fields within [`crate::blades::MAX_FIELD_CELLS`]
//! and [`crate::blades::MAX_FIELD_BLADES`] in all; the file at most [`MAX_WORLD_FILE_BYTES`].
//! A `[generated]` table (`family`, `seed`, `index`) records where a world drawn by
//! [`crate::generate`] came from.

use std::path::Path;

use mimnav_shared::config::{Checks, Invalid};

use mimnav_shared::pose::{Pose2Ext, pose2};
use mimnav_shared::topics::cell_class;
use serde::{Deserialize, Serialize};

use crate::blades;

/// Why a world cannot be used.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct WorldError {
    /// The world file.
    pub path: String,
    /// What is wrong.
    pub message: String,
    /// The values refused, each naming its key and what is allowed, when that is what is wrong
    /// (not a file that cannot be read or parsed).
    pub invalid: Option<Invalid>,
}

fn d_wall_h() -> f64 {
    2.5
}
fn d_wall_r() -> f64 {
    50.0
}
fn d_pillar_size() -> [f64; 2] {
    [0.4, 0.4]
}
fn d_pillar_r() -> f64 {
    60.0
}
fn d_glass_top() -> f64 {
    2.2
}
fn d_curtain_h() -> f64 {
    2.0
}
fn d_coverage() -> f64 {
    0.5
}
fn d_25() -> f64 {
    25.0
}
fn d_bush_r() -> f64 {
    45.0
}
fn d_grass_h() -> f64 {
    0.8
}
fn d_grass_density() -> f64 {
    6.0
}
fn d_grass_r() -> f64 {
    20.0
}
fn d_bush_h() -> f64 {
    1.0
}
fn d_bush_density() -> f64 {
    40.0
}
fn d_trunk_radius() -> f64 {
    0.15
}
fn d_trunk_h() -> f64 {
    5.0
}
fn d_trunk_r() -> f64 {
    45.0
}
fn d_rock_radius() -> f64 {
    0.25
}
fn d_rock_h() -> f64 {
    0.3
}
fn d_rock_r() -> f64 {
    35.0
}
fn d_ground_r() -> f64 {
    12.0
}

/// The ground plane.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Ground {
    /// Diffuse reflectivity 0–100.
    #[serde(default = "d_ground_r")]
    pub reflectivity: f64,
}

impl Default for Ground {
    fn default() -> Self {
        Ground {
            reflectivity: d_ground_r(),
        }
    }
}

/// `[[wall]]`.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Wall {
    /// One end.
    pub from: [f64; 2],
    /// The other end.
    pub to: [f64; 2],
    /// Height, m.
    #[serde(default = "d_wall_h")]
    pub height: f64,
    /// Reflectivity 0–100.
    #[serde(default = "d_wall_r")]
    pub reflectivity: f64,
}

/// `[[pillar]]`: a box.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Pillar {
    /// Centre.
    pub center: [f64; 2],
    /// Extent along its own x and y, m.
    #[serde(default = "d_pillar_size")]
    pub size: [f64; 2],
    /// Rotation, degrees.
    #[serde(default)]
    pub yaw_deg: f64,
    /// Height, m.
    #[serde(default = "d_wall_h")]
    pub height: f64,
    /// Reflectivity 0–100.
    #[serde(default = "d_pillar_r")]
    pub reflectivity: f64,
}

/// `[[glass]]`: a pane.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Glass {
    /// One end.
    pub from: [f64; 2],
    /// The other end.
    pub to: [f64; 2],
    /// Lower edge above the ground, m.
    #[serde(default)]
    pub bottom: f64,
    /// Upper edge above the ground, m.
    #[serde(default = "d_glass_top")]
    pub top: f64,
}

/// `[[curtain]]`: a string or beaded curtain.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Curtain {
    /// One end.
    pub from: [f64; 2],
    /// The other end.
    pub to: [f64; 2],
    /// Height, m.
    #[serde(default = "d_curtain_h")]
    pub height: f64,
    /// Fraction of the sheet covered by strands, 0–1.
    #[serde(default = "d_coverage")]
    pub coverage: f64,
    /// Reflectivity of a strand 0–100.
    #[serde(default = "d_25")]
    pub reflectivity: f64,
}

/// `[[grass]]`: a patch of tall grass.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Grass {
    /// Centre.
    pub center: [f64; 2],
    /// Extent along its own x and y, m.
    pub size: [f64; 2],
    /// Rotation, degrees.
    #[serde(default)]
    pub yaw_deg: f64,
    /// Height, m.
    #[serde(default = "d_grass_h")]
    pub height: f64,
    /// Blade hits per metre of beam path.
    #[serde(default = "d_grass_density")]
    pub density: f64,
    /// Reflectivity of a blade 0–100.
    #[serde(default = "d_grass_r")]
    pub reflectivity: f64,
}

/// `[[bush]]`: dense foliage.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Bush {
    /// Centre.
    pub center: [f64; 2],
    /// Radius, m.
    pub radius: f64,
    /// Height, m.
    #[serde(default = "d_bush_h")]
    pub height: f64,
    /// Leaf hits per metre of beam path.
    #[serde(default = "d_bush_density")]
    pub density: f64,
    /// Reflectivity of a leaf 0–100 (leaves are bright in the near infrared).
    #[serde(default = "d_bush_r")]
    pub reflectivity: f64,
}

/// `[[trunk]]` and `[[rock]]`: vertical cylinders.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Trunk {
    /// Centre.
    pub center: [f64; 2],
    /// Radius, m.
    #[serde(default = "d_trunk_radius")]
    pub radius: f64,
    /// Height, m.
    #[serde(default = "d_trunk_h")]
    pub height: f64,
    /// Reflectivity 0–100.
    #[serde(default = "d_trunk_r")]
    pub reflectivity: f64,
}

/// `[[rock]]`.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Rock {
    /// Centre.
    pub center: [f64; 2],
    /// Radius, m.
    #[serde(default = "d_rock_radius")]
    pub radius: f64,
    /// Height, m.
    #[serde(default = "d_rock_h")]
    pub height: f64,
    /// Reflectivity 0–100.
    #[serde(default = "d_rock_r")]
    pub reflectivity: f64,
}

/// A world file as written.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct WorldFile {
    /// Short name.
    pub name: String,
    /// What the world is about.
    #[serde(default)]
    pub description: String,
    /// Robot start: x, y (m), heading (degrees).
    pub start: [f64; 3],
    /// Goal: x, y (m).
    pub goal: [f64; 2],
    /// Time allowed to reach the goal, s.
    pub time_limit_s: f64,
    /// Waypoints (x, y) the map scorer drives through, in order (default: the goal): a route
    /// that shows the mapper what the world is about.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub survey: Vec<[f64; 2]>,
    /// The ground.
    #[serde(default)]
    pub ground: Ground,
    /// Walls.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub wall: Vec<Wall>,
    /// Pillars.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub pillar: Vec<Pillar>,
    /// Glass panes.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub glass: Vec<Glass>,
    /// Curtains.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub curtain: Vec<Curtain>,
    /// Grass patches.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub grass: Vec<Grass>,
    /// Bushes.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub bush: Vec<Bush>,
    /// Tree trunks.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub trunk: Vec<Trunk>,
    /// Rocks.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub rock: Vec<Rock>,
    /// Where a generated world came from ([`crate::generate`]); absent in hand-made worlds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub generated: Option<Generated>,
}

/// `[generated]`: the family, set seed and index a generated world came from. The same three
/// give the same file, byte for byte.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Generated {
    /// The family ([`crate::generate::Family::name`]).
    pub family: String,
    /// The set's seed.
    pub seed: u64,
    /// The world's index in its set (0-based).
    pub index: u64,
}

/// What a beam meets at an object's surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Material {
    /// A diffuse, opaque surface.
    Opaque {
        /// Reflectivity 0–100.
        reflectivity: f64,
    },
    /// A glass pane.
    Glass,
    /// A sheet of strands (a curtain) crossed once.
    Strands {
        /// Fraction of the sheet that is strands.
        coverage: f64,
        /// Reflectivity of a strand.
        reflectivity: f64,
    },
    /// A volume of blades or leaves.
    Foliage {
        /// Hits per metre of beam path (for grass, 2 m from the sensor: see
        /// [`crate::blades::areal_density`]).
        density: f64,
        /// Reflectivity of a blade.
        reflectivity: f64,
        /// Grass: blades standing in the ground that neighbouring beams meet alike
        /// ([`crate::blades`]). Otherwise (bushes) each beam draws its own leaves.
        blades: bool,
    },
}

/// Geometry of an object.
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    /// A vertical sheet over a segment, between two heights.
    Sheet {
        /// One end.
        a: [f64; 2],
        /// The other end.
        b: [f64; 2],
        /// Lower edge.
        z0: f64,
        /// Upper edge.
        z1: f64,
    },
    /// A vertical prism over a convex polygon (counter-clockwise).
    Prism {
        /// Corners, counter-clockwise.
        poly: Vec<[f64; 2]>,
        /// Bottom.
        z0: f64,
        /// Top.
        z1: f64,
    },
    /// A vertical cylinder.
    Cylinder {
        /// Centre.
        c: [f64; 2],
        /// Radius.
        r: f64,
        /// Bottom.
        z0: f64,
        /// Top.
        z1: f64,
    },
}

/// One object of a compiled world.
#[derive(Debug, Clone, PartialEq)]
pub struct Object {
    /// Geometry.
    pub shape: Shape,
    /// Material.
    pub material: Material,
    /// Ground-truth class ([`cell_class`]).
    pub class: u8,
    /// Whether the robot touching it is a collision.
    pub blocks: bool,
    /// How far around its footprint the object reaches in the ground truth, m: a curtain's
    /// strands sway a few centimetres either side of its line.
    pub truth_margin_m: f64,
    /// 2-D bounding circle: centre and radius.
    pub bound: ([f64; 2], f64),
}

/// A compiled world: objects ready for ray casting, collision checks and ground truth.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// The file's name.
    pub name: String,
    /// Start pose: x, y, heading (rad).
    pub start: [f64; 3],
    /// Goal.
    pub goal: [f64; 2],
    /// Time limit, s.
    pub time_limit_s: f64,
    /// The map scorer's route (at least the goal).
    pub survey: Vec<[f64; 2]>,
    /// Ground reflectivity.
    pub ground_reflectivity: f64,
    /// The objects.
    pub objects: Vec<Object>,
}

/// Every position in a world file (start, goal, survey, ends and centres of objects) lies
/// within this many metres of the origin along x and along y: finite, and small enough that what
/// is sized by the world's extent (the reachability grid of `mimnav worlds`) stays bounded.
pub const WORLD_EXTENT_M: f64 = 1000.0;
/// The longest world file read, bytes (the bundled ones are under 3 kB).
pub const MAX_WORLD_FILE_BYTES: u64 = 4 * 1024 * 1024;
/// Angles in a world file (the start's heading, `yaw_deg`) lie within ± this, degrees.
pub const MAX_ANGLE_DEG: f64 = 3600.0;

/// How far a curtain's strands sway either side of its line, m (the physics jitters strand
/// ranges by 3 cm, one standard deviation).
pub const CURTAIN_SWAY_M: f64 = 0.06;

/// The corners of a `size` box centred at `center` and turned by `yaw_deg`, counter-clockwise.
fn rect(center: [f64; 2], size: [f64; 2], yaw_deg: f64) -> Vec<[f64; 2]> {
    let pose = pose2(center[0], center[1], yaw_deg.to_radians());
    let (hx, hy) = (size[0] / 2.0, size[1] / 2.0);
    [[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]]
        .iter()
        .map(|p| pose.to_fixed(p[0], p[1]).into())
        .collect()
}

fn bound_of(shape: &Shape) -> ([f64; 2], f64) {
    match shape {
        Shape::Sheet { a, b, .. } => {
            let c = [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0];
            (c, ((a[0] - b[0]).hypot(a[1] - b[1])) / 2.0)
        }
        Shape::Prism { poly, .. } => {
            let n = poly.len() as f64;
            let c = [
                poly.iter().map(|p| p[0]).sum::<f64>() / n,
                poly.iter().map(|p| p[1]).sum::<f64>() / n,
            ];
            let r = poly
                .iter()
                .map(|p| (p[0] - c[0]).hypot(p[1] - c[1]))
                .fold(0.0, f64::max);
            (c, r)
        }
        Shape::Cylinder { c, r, .. } => (*c, *r),
    }
}

impl Scene {
    /// Solid objects hidden in grass: standing inside a grass patch and no taller than it. A lidar
    /// inside or above the grass sees them only through it; the foliage classifier, not the
    /// intensity map, is meant to find them (issue 6).
    pub fn hidden_in_grass(&self) -> Vec<usize> {
        let top = |shape: &Shape| match shape {
            Shape::Sheet { z1, .. } | Shape::Prism { z1, .. } | Shape::Cylinder { z1, .. } => *z1,
        };
        self.objects
            .iter()
            .enumerate()
            .filter(|(_, o)| {
                o.class == cell_class::SOLID && matches!(o.material, Material::Opaque { .. })
            })
            .filter(|(_, o)| {
                self.objects.iter().any(|g| {
                    g.class == cell_class::PASSABLE
                        && matches!(g.material, Material::Foliage { .. })
                        && crate::geometry::footprint_distance(&g.shape, o.bound.0) == 0.0
                        && top(&g.shape) >= top(&o.shape)
                })
            })
            .map(|(i, _)| i)
            .collect()
    }

    /// A scene with only the objects `keep` (for masks of chosen objects).
    pub fn only(&self, keep: &[usize]) -> Scene {
        Scene {
            objects: keep
                .iter()
                .filter_map(|&i| self.objects.get(i).cloned())
                .collect(),
            ..self.clone()
        }
    }
}

impl WorldFile {
    /// Reads and checks a world file.
    pub fn load(path: &Path) -> Result<WorldFile, WorldError> {
        use std::io::Read;
        let shown = path.display().to_string();
        let cannot = |e: std::io::Error| WorldError {
            path: shown.clone(),
            message: format!("cannot read: {e}"),
            invalid: None,
        };
        // bounded before reading: a world file is a few kB; the largest accepted is read whole
        let mut text = String::new();
        std::fs::File::open(path)
            .map_err(cannot)?
            .take(MAX_WORLD_FILE_BYTES + 1)
            .read_to_string(&mut text)
            .map_err(cannot)?;
        if text.len() as u64 > MAX_WORLD_FILE_BYTES {
            return Err(WorldError {
                path: shown,
                message: format!(
                    "the file is longer than {MAX_WORLD_FILE_BYTES} bytes, the most a world file may be"
                ),
                invalid: None,
            });
        }
        Self::parse(&text, &shown)
    }

    /// Parses and checks world text (`source` names it in errors).
    pub fn parse(text: &str, source: &str) -> Result<WorldFile, WorldError> {
        let w: WorldFile = toml::from_str(text).map_err(|e| WorldError {
            path: source.into(),
            message: e.to_string().trim_end().into(),
            invalid: None,
        })?;
        w.validate().map_err(|e| WorldError {
            path: source.into(),
            message: e.to_string(),
            invalid: Some(e),
        })?;
        Ok(w)
    }

    /// Every value refused, each naming its key and what is allowed.
    pub(crate) fn validate(&self) -> Result<(), Invalid> {
        let mut bad = Checks::default();
        self.check_positions(&mut bad);
        self.check_grass_fields(&mut bad);
        let mut pos = |what: String, v: f64, lo: f64, hi: f64| bad.check(what, v, lo, hi);
        pos("time_limit_s".into(), self.time_limit_s, 1.0, 3600.0);
        pos(
            "ground.reflectivity".into(),
            self.ground.reflectivity,
            0.0,
            255.0,
        );
        for (i, w) in self.wall.iter().enumerate() {
            pos(format!("wall[{i}].height"), w.height, 0.01, 50.0);
            pos(
                format!("wall[{i}].reflectivity"),
                w.reflectivity,
                0.0,
                255.0,
            );
        }
        for (i, p) in self.pillar.iter().enumerate() {
            pos(format!("pillar[{i}].size[0]"), p.size[0], 0.01, 50.0);
            pos(format!("pillar[{i}].size[1]"), p.size[1], 0.01, 50.0);
            pos(format!("pillar[{i}].height"), p.height, 0.01, 50.0);
            pos(
                format!("pillar[{i}].reflectivity"),
                p.reflectivity,
                0.0,
                255.0,
            );
        }
        for (i, g) in self.glass.iter().enumerate() {
            pos(format!("glass[{i}].bottom"), g.bottom, 0.0, 50.0);
            pos(format!("glass[{i}].top"), g.top, g.bottom + 0.01, 50.0);
        }
        for (i, c) in self.curtain.iter().enumerate() {
            pos(format!("curtain[{i}].height"), c.height, 0.01, 50.0);
            pos(format!("curtain[{i}].coverage"), c.coverage, 0.0, 1.0);
            pos(
                format!("curtain[{i}].reflectivity"),
                c.reflectivity,
                0.0,
                255.0,
            );
        }
        for (i, g) in self.grass.iter().enumerate() {
            pos(format!("grass[{i}].size[0]"), g.size[0], 0.01, 500.0);
            pos(format!("grass[{i}].size[1]"), g.size[1], 0.01, 500.0);
            pos(format!("grass[{i}].height"), g.height, 0.01, 5.0);
            pos(format!("grass[{i}].density"), g.density, 0.0, 500.0);
            pos(
                format!("grass[{i}].reflectivity"),
                g.reflectivity,
                0.0,
                255.0,
            );
        }
        for (i, b) in self.bush.iter().enumerate() {
            pos(format!("bush[{i}].radius"), b.radius, 0.01, 20.0);
            pos(format!("bush[{i}].height"), b.height, 0.01, 10.0);
            pos(format!("bush[{i}].density"), b.density, 0.0, 500.0);
            pos(
                format!("bush[{i}].reflectivity"),
                b.reflectivity,
                0.0,
                255.0,
            );
        }
        for (i, t) in self.trunk.iter().enumerate() {
            pos(format!("trunk[{i}].radius"), t.radius, 0.01, 5.0);
            pos(format!("trunk[{i}].height"), t.height, 0.01, 50.0);
            pos(
                format!("trunk[{i}].reflectivity"),
                t.reflectivity,
                0.0,
                255.0,
            );
        }
        for (i, r) in self.rock.iter().enumerate() {
            pos(format!("rock[{i}].radius"), r.radius, 0.01, 5.0);
            pos(format!("rock[{i}].height"), r.height, 0.01, 10.0);
            pos(
                format!("rock[{i}].reflectivity"),
                r.reflectivity,
                0.0,
                255.0,
            );
        }
        let sheets = self
            .wall
            .iter()
            .map(|w| (w.from, w.to))
            .chain(self.glass.iter().map(|g| (g.from, g.to)));
        for (i, (a, b)) in sheets
            .chain(self.curtain.iter().map(|c| (c.from, c.to)))
            .enumerate()
        {
            let too_short = (a[0] - b[0]).hypot(a[1] - b[1]) < 0.01;
            bad.require(
                !too_short,
                format!("sheet {i}"),
                format!("sheet {i} (wall, glass or curtain) is shorter than 1 cm: from = to"),
            );
        }
        bad.finish()
    }

    /// Positions and angles: finite, and within [`WORLD_EXTENT_M`] of the origin (angles within
    /// [`MAX_ANGLE_DEG`]). A NaN start or goal would otherwise load and steer the robot.
    fn check_positions(&self, bad: &mut Checks) {
        let e = WORLD_EXTENT_M;
        let mut point = |key: String, p: &[f64]| {
            for (k, v) in p.iter().enumerate() {
                bad.check(format!("{key}[{k}]"), *v, -e, e);
            }
        };
        point("start".into(), &self.start[..2]);
        point("goal".into(), &self.goal);
        for (i, p) in self.survey.iter().enumerate() {
            point(format!("survey[{i}]"), p);
        }
        for (i, w) in self.wall.iter().enumerate() {
            point(format!("wall[{i}].from"), &w.from);
            point(format!("wall[{i}].to"), &w.to);
        }
        for (i, g) in self.glass.iter().enumerate() {
            point(format!("glass[{i}].from"), &g.from);
            point(format!("glass[{i}].to"), &g.to);
        }
        for (i, c) in self.curtain.iter().enumerate() {
            point(format!("curtain[{i}].from"), &c.from);
            point(format!("curtain[{i}].to"), &c.to);
        }
        for (i, p) in self.pillar.iter().enumerate() {
            point(format!("pillar[{i}].center"), &p.center);
        }
        for (i, g) in self.grass.iter().enumerate() {
            point(format!("grass[{i}].center"), &g.center);
        }
        for (i, b) in self.bush.iter().enumerate() {
            point(format!("bush[{i}].center"), &b.center);
        }
        for (i, t) in self.trunk.iter().enumerate() {
            point(format!("trunk[{i}].center"), &t.center);
        }
        for (i, r) in self.rock.iter().enumerate() {
            point(format!("rock[{i}].center"), &r.center);
        }
        let a = MAX_ANGLE_DEG;
        bad.check("start[2]", self.start[2], -a, a);
        for (i, p) in self.pillar.iter().enumerate() {
            bad.check(format!("pillar[{i}].yaw_deg"), p.yaw_deg, -a, a);
        }
        for (i, g) in self.grass.iter().enumerate() {
            bad.check(format!("grass[{i}].yaw_deg"), g.yaw_deg, -a, a);
        }
    }

    /// The blade fields the simulator builds over the grass patches (with `sim.grass_blades`;
    /// refused either way, so a world runs with both settings): their cells and blades in all
    /// within [`blades::MAX_FIELD_CELLS`] and [`blades::MAX_FIELD_BLADES`], checked before
    /// anything is allocated. A patch with a value already refused is left out.
    fn check_grass_fields(&self, bad: &mut Checks) {
        let mut sizes = Vec::new();
        for (i, g) in self.grass.iter().enumerate() {
            let ok = g.center.iter().chain(&g.size).all(|v| v.is_finite())
                && g.yaw_deg.is_finite()
                && g.density.is_finite();
            if !ok {
                continue;
            }
            let poly = rect(g.center, g.size, g.yaw_deg);
            let lo = [0, 1].map(|k| poly.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min));
            let hi = [0, 1].map(|k| poly.iter().map(|p| p[k]).fold(f64::NEG_INFINITY, f64::max));
            let (cells, blades) = blades::field_size(lo, hi, g.density);
            sizes.push((i, cells, blades));
        }
        let cells: f64 = sizes.iter().map(|s| s.1).sum();
        let blades: f64 = sizes.iter().map(|s| s.2).sum();
        let each = |k: usize| {
            sizes
                .iter()
                .map(|s| format!("grass[{}]: {:.0}", s.0, if k == 1 { s.1 } else { s.2 }))
                .collect::<Vec<_>>()
                .join(", ")
        };
        bad.require(
            cells <= blades::MAX_FIELD_CELLS,
            "grass",
            format!(
                "grass: the patches' bounding boxes make {cells:.0} cells of 10 × 10 cm ({}), \
                 more than the limit of {:.0} (40 000 m² of boxes in all): make the patches smaller",
                each(1),
                blades::MAX_FIELD_CELLS
            ),
        );
        bad.require(
            blades <= blades::MAX_FIELD_BLADES,
            "grass",
            format!(
                "grass: the patches hold {blades:.0} blades ({}; about {:.0} per m² of bounding box \
                 per unit of density), more than the limit of {:.0}: make the patches smaller or \
                 sparser",
                each(2),
                blades::areal_density(1.0),
                blades::MAX_FIELD_BLADES
            ),
        );
    }

    /// Compiles the world into a [`Scene`].
    pub fn compile(&self) -> Scene {
        let mut objects = Vec::new();
        let mut push = |shape: Shape, material: Material, class: u8, blocks: bool| {
            let bound = bound_of(&shape);
            let truth_margin_m = if matches!(material, Material::Strands { .. }) {
                CURTAIN_SWAY_M
            } else {
                0.0
            };
            objects.push(Object {
                shape,
                material,
                class,
                blocks,
                bound,
                truth_margin_m,
            });
        };
        for w in &self.wall {
            push(
                Shape::Sheet {
                    a: w.from,
                    b: w.to,
                    z0: 0.0,
                    z1: w.height,
                },
                Material::Opaque {
                    reflectivity: w.reflectivity,
                },
                cell_class::SOLID,
                true,
            );
        }
        for p in &self.pillar {
            push(
                Shape::Prism {
                    poly: rect(p.center, p.size, p.yaw_deg),
                    z0: 0.0,
                    z1: p.height,
                },
                Material::Opaque {
                    reflectivity: p.reflectivity,
                },
                cell_class::SOLID,
                true,
            );
        }
        for g in &self.glass {
            push(
                Shape::Sheet {
                    a: g.from,
                    b: g.to,
                    z0: g.bottom,
                    z1: g.top,
                },
                Material::Glass,
                cell_class::GLASS,
                true,
            );
        }
        for c in &self.curtain {
            push(
                Shape::Sheet {
                    a: c.from,
                    b: c.to,
                    z0: 0.0,
                    z1: c.height,
                },
                Material::Strands {
                    coverage: c.coverage,
                    reflectivity: c.reflectivity,
                },
                cell_class::PASSABLE,
                false,
            );
        }
        for g in &self.grass {
            push(
                Shape::Prism {
                    poly: rect(g.center, g.size, g.yaw_deg),
                    z0: 0.0,
                    z1: g.height,
                },
                Material::Foliage {
                    density: g.density,
                    reflectivity: g.reflectivity,
                    blades: true,
                },
                cell_class::PASSABLE,
                false,
            );
        }
        for b in &self.bush {
            push(
                Shape::Cylinder {
                    c: b.center,
                    r: b.radius,
                    z0: 0.0,
                    z1: b.height,
                },
                Material::Foliage {
                    density: b.density,
                    reflectivity: b.reflectivity,
                    blades: false,
                },
                cell_class::SOLID,
                true,
            );
        }
        for t in &self.trunk {
            push(
                Shape::Cylinder {
                    c: t.center,
                    r: t.radius,
                    z0: 0.0,
                    z1: t.height,
                },
                Material::Opaque {
                    reflectivity: t.reflectivity,
                },
                cell_class::SOLID,
                true,
            );
        }
        for r in &self.rock {
            push(
                Shape::Cylinder {
                    c: r.center,
                    r: r.radius,
                    z0: 0.0,
                    z1: r.height,
                },
                Material::Opaque {
                    reflectivity: r.reflectivity,
                },
                cell_class::SOLID,
                true,
            );
        }
        Scene {
            name: self.name.clone(),
            start: [self.start[0], self.start[1], self.start[2].to_radians()],
            goal: self.goal,
            time_limit_s: self.time_limit_s,
            survey: if self.survey.is_empty() {
                vec![self.goal]
            } else {
                self.survey.clone()
            },
            ground_reflectivity: self.ground.reflectivity,
            objects,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ROOM: &str =
        "name = \"r\"\nstart = [0.0, 0.0, 0.0]\ngoal = [3.0, 0.0]\ntime_limit_s = 10.0\n";

    #[test]
    fn a_refused_value_is_named_and_kept_typed() {
        let e = WorldFile::parse(
            &format!("{ROOM}[[wall]]\nfrom = [1.0, 0.0]\nto = [1.0, 2.0]\nreflectivity = 900\n"),
            "w",
        )
        .expect_err("reflectivity out of range");
        assert_eq!(e.path, "w");
        let invalid = e.invalid.expect("typed");
        assert!(
            invalid.0.iter().any(|p| p.key().contains("reflectivity")),
            "{invalid}"
        );
        let e = WorldFile::parse("name = \"r\"\n", "w").expect_err("no start");
        assert!(e.invalid.is_none() && e.message.contains("start"), "{e}");
    }
}
