//! `[mapper]`: the multi-layer intensity map, its classes and memories.

use serde::Deserialize;

use mimnav_shared::config::RobotProfile;
use mimnav_shared::config::{Checks, Invalid};

/// Unit of a map layer's height interval.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LayerUnit {
    /// Metres above the sensor (z in the sensor frame).
    M,
    /// Degrees of elevation from the sensor: a slab that follows the lasers outwards.
    Deg,
}

/// One layer of the multi-layer intensity map (`[[mapper.layer]]`): points with
/// `low <= z < high` (or elevation, for `unit = "deg"`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LayerConfig {
    /// Name; `below`, `above`, `zero` and `minus_eps` play the roles of the paper's
    /// [−h, 0), (0, h], z = 0 and z = −ε layers.
    pub name: String,
    /// Unit of `low` and `high`.
    pub unit: LayerUnit,
    /// Lower bound (inclusive).
    pub low: f64,
    /// Upper bound (exclusive).
    pub high: f64,
}

/// The map builder (`[mapper]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MapperConfig {
    /// The layers; empty: the paper's four, sized from the robot profile (see the README).
    #[serde(rename = "layer")]
    pub layers: Vec<LayerConfig>,
    /// Intensity full scale R: intensities are divided by it.
    pub full_scale: f64,
    /// Γ of equation 3, on the normalised scale: a cell whose layers' mean intensities all stay
    /// at or below it is passable.
    pub gamma: f64,
    /// A cell with a return brighter than this (normalised) is solid, whatever its mean.
    pub solid_max: f64,
    /// Single-echo and stopped returns count as evidence of an opaque surface from this
    /// brightness (normalised).
    pub opaque_min: f64,
    /// A cell with a return higher than this above the ground, that no beam passed through, is
    /// solid (taller than grass grows), m.
    pub tall_m: f64,
    /// Points lower than this above the ground are ground, m.
    pub ground_clearance_m: f64,
    /// A cell with at least this many returns, none of which a beam passed through, is solid
    /// whatever its intensity (an opaque surface seen at a grazing angle).
    pub min_returns_solid: u32,
    /// A cell with at least this many returns in one revolution, none of which a beam passed
    /// through, is solid whatever its intensity and height: a surface that stops every beam
    /// (a trunk seen through grass returns faintly, below Γ, but lets nothing past).
    pub stop_min_returns: u32,
    /// Surface along a ring: two downward last returns of one laser lie on the same surface when
    /// their ranges differ by less than this, m.
    pub surface_tolerance_m: f64,
    /// Surface along a ring: the firings on each side of a return that are compared with it.
    pub surface_window: u32,
    /// Surface along a ring: a return with at least this many of those neighbours on its surface
    /// is on a surface (foliage returns at scattered ranges).
    pub surface_neighbours: u32,
    /// Surface along a ring, in the shade of foliage: a return with at least this many
    /// neighbours on its surface (fewer than `surface_neighbours`) is on a surface when at most
    /// `surface_beyond_max` of the window's firings went farther than it. The others ended
    /// short of it, in the blades in front, and say nothing of what it is: a rock seen from
    /// high up through a metre or two of grass, which few beams reach at all, while a
    /// curtain's strands let every other beam through (0: off).
    pub surface_shaded_neighbours: u32,
    /// The firings of the window that may have gone farther than a shaded surface return, its
    /// rock's sides or a gap between blades (`surface_shaded_neighbours`).
    pub surface_beyond_max: u32,
    /// A cell with at least this many returns on a surface in one revolution is solid whatever
    /// its intensity (0: the cue is off).
    pub surface_min_returns: u32,
    /// Cells the surface cue made solid stay solid this long while the robot moves (0: not
    /// kept), s: an obstacle lower than the lowest beam's reach next to the robot is out of
    /// sight once the robot is beside it.
    pub surface_memory_s: f64,
    /// A kept surface cell is remembered `surface_memory_s` after it was last found and half
    /// that longer for each further revolution it was found in, up to this, s: a rock's face is
    /// found revolution after revolution, a curtain's strands now and then.
    pub surface_memory_longest_s: f64,
    /// Kept surface cells farther than this from the robot are forgotten, m.
    pub surface_memory_m: f64,
    /// A surface cell stands for the face of an object the beams met: the cells behind it,
    /// along the beam from the sensor, up to this far (or a glass cell), are solid too, m (0:
    /// only the face). A rock hidden in grass shows a few cells of its near face; its body lies
    /// behind them, under the grass.
    pub surface_depth_m: f64,
    /// Only a surface cell whose surface returns all lie at most this high above the ground is
    /// deepened (`surface_depth_m`): a rock hidden in grass is low, m.
    pub surface_depth_top_m: f64,
    /// A solid cell with no solid cell among its eight neighbours and at least this many
    /// passable ones, two of them on opposite sides of it, is passable unless it was solid at
    /// its place in the last revolution too (0: off): a string curtain or grass stops a beam here and
    /// there, and one revolution's few returns in a cell of it can look opaque, bright or tall;
    /// a trunk, a rock or a post seen at any range covers several cells.
    pub lone_solid_passable: u32,
    /// Tall cells (a return above `tall_m`, no beam through) found in two revolutions in a row
    /// are kept this long while the robot moves (0: not kept), s: close by, a bush behind
    /// grass returns too little light to tell from the grass, though its top stood out from
    /// farther away.
    pub tall_memory_s: f64,
    /// Kept tall cells farther than this from the robot are forgotten, m.
    pub tall_memory_m: f64,
    /// Glass: a spike's returns reach at least this intensity (the top of the diffuse range).
    pub glass_intensity: f64,
    /// Glass: the spike rises and falls by at least this much.
    pub glass_gradient: f64,
    /// Glass: the spike is at most this wide, degrees of azimuth.
    pub glass_width_deg: f64,
    /// Glass: the ranges of the spike's own returns agree within this (one surface), m. What lies
    /// beside the spike (behind the glass) is not compared.
    pub glass_range_tolerance_m: f64,
    /// Detected glass is kept this long, s.
    pub glass_memory_s: f64,
    /// Detected glass farther than this from the robot is forgotten, m.
    pub glass_memory_m: f64,
    /// Glass returns a spike within this angle of normal incidence: a beam this close to a
    /// pane's normal that crosses its line and returns from beyond without a spike shows an
    /// opening there, degrees.
    pub glass_normal_deg: f64,
    /// A pane is extended along its fitted line up to this far from its evidence, across gaps
    /// and beyond its ends, until an opening, a solid or a passable cell, m (0: never).
    pub glass_extend_m: f64,
    /// A solid stretch of a pane's line no longer than this, with the line going on beyond it,
    /// is a post between panes (a mullion): the extension goes on past it, m (0: every solid
    /// ends a pane).
    pub glass_mullion_m: f64,
    /// A stretch of a pane's line from what was seen open (beams crossed it squarely, no spike)
    /// to a solid or passable cell no longer than this is the rest of a passage beside a frame
    /// and is not drawn; a longer one may hide a pane never faced and is drawn as suspected
    /// glass, m (0: every such stretch drawn).
    pub glass_passage_m: f64,
    /// Planning cost of a passable cell, 0–1 (free 0, solid and glass 1).
    pub passable_cost: f64,
    /// Odometry older than this is stale: the glass memory is not moved, m.
    pub odom_max_age_s: f64,
    /// A revolution later than this is reported as stale input, s.
    pub points_deadline_s: f64,
}

impl Default for MapperConfig {
    fn default() -> Self {
        MapperConfig {
            layers: Vec::new(),
            full_scale: 100.0,
            gamma: 0.3,
            solid_max: 0.35,
            opaque_min: 0.05,
            tall_m: 1.0,
            stop_min_returns: 16,
            surface_tolerance_m: 0.04,
            surface_window: 8,
            surface_neighbours: 8,
            surface_shaded_neighbours: 3,
            surface_beyond_max: 2,
            surface_min_returns: 2,
            surface_memory_s: 3.0,
            surface_memory_longest_s: 30.0,
            surface_memory_m: 3.0,
            surface_depth_m: 0.3,
            surface_depth_top_m: 0.3,
            lone_solid_passable: 3,
            tall_memory_s: 10.0,
            tall_memory_m: 5.0,
            ground_clearance_m: 0.08,
            min_returns_solid: 1,
            glass_intensity: 100.0,
            glass_gradient: 30.0,
            glass_width_deg: 8.0,
            glass_range_tolerance_m: 0.3,
            glass_memory_s: 120.0,
            glass_memory_m: 8.0,
            glass_normal_deg: 2.8,
            glass_extend_m: 3.0,
            glass_mullion_m: 0.2,
            glass_passage_m: 1.8,
            passable_cost: 0.2,
            odom_max_age_s: 0.5,
            points_deadline_s: 0.5,
        }
    }
}

impl MapperConfig {
    /// The planning cost of a passable cell on `map/plan`'s 0–255 scale: `passable_cost` × 255,
    /// rounded (the mapper writes it, the planner inflates with it).
    pub fn passable_cell_cost(&self) -> u8 {
        (self.passable_cost * 255.0).round() as u8
    }

    /// The layers in force: the configured ones, or the paper's four for `robot`:
    /// below = [−(sensor height − ground clearance), 0) m, above = [0, robot top − sensor + 1) m,
    /// zero = [−1.5°, 1.5°) (the ±1° lasers), minus_eps = [−4°, −2°) (the −3° laser).
    pub fn layers_for(&self, robot: &RobotProfile) -> Vec<LayerConfig> {
        if !self.layers.is_empty() {
            return self.layers.clone();
        }
        let below = -(robot.sensor_height_m - self.ground_clearance_m);
        let above = (robot.height_m - robot.sensor_height_m).max(0.0) + 1.0;
        let l = |name: &str, unit, low, high| LayerConfig {
            name: name.into(),
            unit,
            low,
            high,
        };
        vec![
            l("below", LayerUnit::M, below, 0.0),
            l("above", LayerUnit::M, 0.0, above),
            l("zero", LayerUnit::Deg, -1.5, 1.5),
            l("minus_eps", LayerUnit::Deg, -4.0, -2.0),
        ]
    }

    /// Checks every key of `[mapper]`: each value refused names its key and what is allowed.
    pub fn validate(&self) -> Result<(), Invalid> {
        let mut r = Checks::default();
        r.check("mapper.full_scale", self.full_scale, 1.0, 255.0);
        r.check("mapper.gamma", self.gamma, 0.0, 1.0);
        r.check("mapper.solid_max", self.solid_max, 0.0, 2.55);
        r.check("mapper.opaque_min", self.opaque_min, 0.0, 2.55);
        r.check("mapper.tall_m", self.tall_m, 0.1, 10.0);
        r.check(
            "mapper.stop_min_returns",
            f64::from(self.stop_min_returns),
            1.0,
            10000.0,
        );
        r.check(
            "mapper.surface_tolerance_m",
            self.surface_tolerance_m,
            0.001,
            1.0,
        );
        r.check(
            "mapper.surface_window",
            f64::from(self.surface_window),
            1.0,
            64.0,
        );
        r.check(
            "mapper.surface_neighbours",
            f64::from(self.surface_neighbours),
            1.0,
            128.0,
        );
        r.require(
            self.surface_neighbours <= 2 * self.surface_window,
            "mapper.surface_neighbours",
            format!(
                "mapper.surface_neighbours = {} must be at most 2 × mapper.surface_window = {}",
                self.surface_neighbours,
                2 * self.surface_window
            ),
        );
        r.require(
            self.surface_shaded_neighbours <= self.surface_neighbours,
            "mapper.surface_shaded_neighbours",
            format!(
                "mapper.surface_shaded_neighbours = {} must be at most mapper.surface_neighbours = {}",
                self.surface_shaded_neighbours, self.surface_neighbours
            ),
        );
        r.check(
            "mapper.surface_beyond_max",
            f64::from(self.surface_beyond_max),
            0.0,
            128.0,
        );
        r.check(
            "mapper.surface_min_returns",
            f64::from(self.surface_min_returns),
            0.0,
            10000.0,
        );
        r.check("mapper.surface_memory_s", self.surface_memory_s, 0.0, 600.0);
        r.check(
            "mapper.surface_memory_longest_s",
            self.surface_memory_longest_s,
            0.0,
            600.0,
        );
        r.check("mapper.surface_memory_m", self.surface_memory_m, 0.0, 100.0);
        r.check("mapper.surface_depth_m", self.surface_depth_m, 0.0, 5.0);
        r.check(
            "mapper.surface_depth_top_m",
            self.surface_depth_top_m,
            0.0,
            10.0,
        );
        r.check(
            "mapper.lone_solid_passable",
            f64::from(self.lone_solid_passable),
            0.0,
            8.0,
        );
        r.check("mapper.tall_memory_s", self.tall_memory_s, 0.0, 600.0);
        r.check("mapper.tall_memory_m", self.tall_memory_m, 0.0, 100.0);
        r.check(
            "mapper.ground_clearance_m",
            self.ground_clearance_m,
            0.0,
            1.0,
        );
        r.check(
            "mapper.min_returns_solid",
            f64::from(self.min_returns_solid),
            1.0,
            1000.0,
        );
        r.check("mapper.glass_intensity", self.glass_intensity, 0.0, 255.0);
        r.check("mapper.glass_gradient", self.glass_gradient, 0.0, 255.0);
        r.check("mapper.glass_width_deg", self.glass_width_deg, 0.1, 90.0);
        r.check(
            "mapper.glass_range_tolerance_m",
            self.glass_range_tolerance_m,
            0.0,
            10.0,
        );
        r.check("mapper.glass_memory_s", self.glass_memory_s, 0.0, 86400.0);
        r.check("mapper.glass_memory_m", self.glass_memory_m, 0.0, 1000.0);
        r.check("mapper.glass_normal_deg", self.glass_normal_deg, 0.1, 30.0);
        r.check("mapper.glass_extend_m", self.glass_extend_m, 0.0, 20.0);
        r.check("mapper.glass_mullion_m", self.glass_mullion_m, 0.0, 2.0);
        r.check("mapper.glass_passage_m", self.glass_passage_m, 0.0, 20.0);
        r.check("mapper.passable_cost", self.passable_cost, 0.0, 1.0);
        r.check("mapper.odom_max_age_s", self.odom_max_age_s, 0.01, 60.0);
        r.check(
            "mapper.points_deadline_s",
            self.points_deadline_s,
            0.01,
            60.0,
        );
        for (i, l) in self.layers.iter().enumerate() {
            r.finite(format!("mapper.layer[{i}].low"), l.low);
            r.finite(format!("mapper.layer[{i}].high"), l.high);
            r.require(
                l.low < l.high,
                format!("mapper.layer[{i}]"),
                format!(
                    "mapper.layer[{i}] ({}): low = {} must be below high = {}",
                    l.name, l.low, l.high
                ),
            );
        }
        if !self.layers.is_empty() {
            for role in ["below", "above", "zero", "minus_eps"] {
                r.require(
                    self.layers.iter().any(|l| l.name == role),
                    "mapper.layer",
                    format!("mapper.layer: a layer named \"{role}\" is needed (equations 3 and 6 use it)"),
                );
            }
        }
        r.finish()
    }
}
