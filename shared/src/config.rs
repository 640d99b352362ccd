//! The config loader: one TOML file configures the whole stack.
//!
//! ```toml
//! [robot]            # a profile from robots/NAME.toml beside this file, keys may be overridden
//! profile = "turtlebot2"
//!
//! [log]
//! level = "info"     # a tracing filter; the MIMNAV_LOG environment variable wins
//!
//! [iceoryx2.global]  # passed to iceoryx2's own Config (kebab-case keys)
//! root-path = "/tmp/mimnav/iceoryx2/"
//! prefix = "mimnav_"
//!
//! [velodyne]         # one section per process
//! input = "udp"
//! ```
//!
//! Every key has a documented default (see docs/configuration.md); unknown keys, wrong types
//! and out-of-range values are errors that name the file, the key and what is allowed.
//! `--set key.path=value` on a service's command line overrides one key (the value is TOML; a
//! bare word is taken as a string).

use std::fmt;
use std::net::IpAddr;
use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

/// Default location of the stack's config file when a service is started without `--config`.
pub const DEFAULT_CONFIG_PATH: &str = "/etc/mimnav/mimnav.toml";

/// Why the configuration cannot be used.
#[derive(Debug)]
pub struct ConfigError {
    /// The file (or `--set` option) at fault.
    pub source_name: String,
    /// What is wrong, naming the key.
    pub message: String,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.source_name, self.message)
    }
}

impl std::error::Error for ConfigError {}

fn err(source: impl fmt::Display, message: impl Into<String>) -> ConfigError {
    ConfigError {
        source_name: source.to_string(),
        message: message.into(),
    }
}

/// The whole stack's configuration.
#[derive(Debug, Clone)]
pub struct Config {
    /// The file it was read from (empty for the built-in defaults).
    pub path: PathBuf,
    /// The robot profile.
    pub robot: RobotProfile,
    /// Logging.
    pub log: LogConfig,
    /// iceoryx2's own settings, with the project's root path and prefix.
    pub iceoryx2: iceoryx2::config::Config,
    /// The VLP-16 driver.
    pub velodyne: VelodyneConfig,
    /// The robot-centred map grid.
    pub map: MapConfig,
    /// The simulator.
    pub sim: SimConfig,
    /// The map builder.
    pub mapper: MapperConfig,
    /// The planner.
    pub planner: PlannerConfig,
    /// The foliage classifier.
    pub foliage: FoliageConfig,
    /// The services' latency settings.
    pub latency: LatencyConfig,
}

/// The keys of the config file as written.
#[derive(Debug, Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct FileConfig {
    robot: toml::Table,
    log: LogConfig,
    iceoryx2: toml::Table,
    velodyne: VelodyneConfig,
    map: MapConfig,
    sim: SimConfig,
    mapper: MapperConfig,
    planner: PlannerConfig,
    foliage: FoliageConfig,
    latency: LatencyConfig,
}

/// The services' latency settings (`[latency]`); both default to 0.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LatencyConfig {
    /// The longest CPU wake-up the driver, mapper, foliage classifier and planner allow while
    /// they run, µs: a Linux PM QoS request through `/dev/cpu_dma_latency`, which keeps the CPUs
    /// out of idle states slower to leave (0: the CPUs poll when idle). −1 leaves the CPUs'
    /// power management alone.
    pub cpu_wakeup_us: i32,
    /// The SCHED_FIFO priority the driver, mapper, foliage classifier and planner run at (1–99;
    /// 0: the normal scheduler). Off by default: a real-time process that never sleeps starves
    /// the rest of its CPU, and a capture replayed at full speed never sleeps.
    pub realtime_priority: i32,
}

impl LatencyConfig {
    fn validate(&self, r: &mut Ranges) {
        r.check(
            "latency.cpu_wakeup_us",
            f64::from(self.cpu_wakeup_us),
            -1.0,
            1_000_000.0,
        );
        r.check(
            "latency.realtime_priority",
            f64::from(self.realtime_priority),
            0.0,
            99.0,
        );
    }
}

/// The foliage classifier (`[foliage]`): the parameters of
/// `foliage-discrimination-rotating-ladar.txt`, scaled for a VLP-16 (the paper's values in
/// docs/configuration.md).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FoliageConfig {
    /// K1: the threshold's constant part.
    pub k1: f64,
    /// δ: how much a new candidate raises its neighbouring windows' thresholds.
    pub delta: f64,
    /// K2: how much the last two scans' evidence widens RELAX-OBST's tolerance.
    pub k2: f64,
    /// K3: the evidence a window with a candidate gets.
    pub k3: f64,
    /// a: range error per metre of range.
    pub range_error_a: f64,
    /// b: range error at zero range, m.
    pub range_error_b_m: f64,
    /// d_min: nearer obstacles are cropped, m.
    pub d_min_m: f64,
    /// d_max: farther obstacles are cropped, m.
    pub d_max_m: f64,
    /// α: window of FIND-LOW-FREQ, degrees.
    pub window_deg: f64,
    /// Sector of R_s, degrees.
    pub sector_deg: f64,
    /// W_s: returns around a return that REMOVE-THIN-OBST counts.
    pub thin_window: usize,
    /// O_s: obstacle returns among them that keep it.
    pub thin_min: usize,
    /// Beyond the paper: a window that held a confirmed obstacle in the previous scan seeds a
    /// candidate when its maximum is within RELAX-OBST's tolerance of that range.
    pub hold_obstacles: bool,
    /// Beyond the paper: a window whose maximum is nearer than both neighbours' takes the nearer
    /// neighbour's maximum before FIND-LOW-FREQ's differences (blades in front of a surface).
    pub fill_notches: bool,
    /// Beyond the paper: earlier scans whose window maxima, moved with the odometry into the
    /// present scan's frame, join the max filter's smoothness test (0: the paper).
    pub carry_scans: usize,
    /// How far, m, the sensor must have moved from where an earlier scan was taken to carry it.
    pub carry_min_travel_m: f64,
    /// Odometry older than this when a scan arrives is not used to carry earlier scans, s.
    pub odom_max_age_s: f64,
}

impl Default for FoliageConfig {
    fn default() -> Self {
        FoliageConfig {
            k1: 0.02,
            delta: 0.03,
            k2: 0.05,
            k3: 25.0,
            range_error_a: 0.01,
            range_error_b_m: 0.03,
            d_min_m: 0.3,
            d_max_m: 3.0,
            window_deg: 0.4,
            sector_deg: 10.0,
            thin_window: 9,
            thin_min: 3,
            hold_obstacles: true,
            fill_notches: true,
            carry_scans: 2,
            carry_min_travel_m: 0.03,
            odom_max_age_s: 0.5,
        }
    }
}

impl FoliageConfig {
    fn validate(&self, r: &mut Ranges) {
        r.check("foliage.k1", self.k1, 0.0, 10.0);
        r.check("foliage.delta", self.delta, 0.0, 10.0);
        r.check("foliage.k2", self.k2, 0.0, 10.0);
        r.check("foliage.k3", self.k3, 0.0, 1000.0);
        r.check("foliage.range_error_a", self.range_error_a, 0.0, 1.0);
        r.check("foliage.range_error_b_m", self.range_error_b_m, 0.0, 1.0);
        r.check("foliage.d_min_m", self.d_min_m, 0.0, 100.0);
        r.check("foliage.d_max_m", self.d_max_m, 0.0, 200.0);
        r.require(
            self.d_min_m < self.d_max_m,
            format!(
                "foliage.d_min_m = {} must be below foliage.d_max_m = {}",
                self.d_min_m, self.d_max_m
            ),
        );
        r.check("foliage.window_deg", self.window_deg, 0.05, 45.0);
        r.check("foliage.sector_deg", self.sector_deg, 5.0, 180.0);
        r.check("foliage.thin_window", self.thin_window as f64, 1.0, 1001.0);
        r.check("foliage.carry_scans", self.carry_scans as f64, 0.0, 8.0);
        r.check(
            "foliage.carry_min_travel_m",
            self.carry_min_travel_m,
            0.0,
            1.0,
        );
        r.check("foliage.odom_max_age_s", self.odom_max_age_s, 0.01, 60.0);
        r.check(
            "foliage.thin_min",
            self.thin_min as f64,
            0.0,
            self.thin_window as f64,
        );
    }
}

/// How the planner inflates obstacles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum InflationConfig {
    /// The paper's adaptive kernel along the goal direction.
    Adaptive,
    /// An all-ones kernel (the ablation).
    Uniform,
    /// None.
    None,
}

/// The planner (`[planner]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlannerConfig {
    /// `adaptive`, `uniform` or `none`.
    pub inflation: InflationConfig,
    /// Side e of the inflation kernel, cells (odd).
    pub kernel_cells: usize,
    /// Thickness of the adaptive kernel's line either side, cells.
    pub padding_cells: usize,
    /// Goal directions the adaptive kernels are cached for, a half turn.
    pub kernel_angles: usize,
    /// Time the window's accelerations apply over, s.
    pub window_s: f64,
    /// Rollout step, s.
    pub dt_s: f64,
    /// Rollout horizon, s.
    pub horizon_s: f64,
    /// Speed samples.
    pub v_samples: usize,
    /// Turn-rate samples.
    pub omega_samples: usize,
    /// Weight of the remaining distance to the goal.
    pub goal_weight: f64,
    /// Weight of driving slower than the top speed.
    pub speed_weight: f64,
    /// Weight of the obstacle cost along a trajectory.
    pub obstacle_weight: f64,
    /// Distance kept from solid and glass cells beyond the robot's radius, m.
    pub margin_m: f64,
    /// Coarse cell of the route search around obstacles, m (0: straight-line goal progress, as
    /// in the paper).
    pub route_cell_m: f64,
    /// Extra route cost per unit of planning cost.
    pub route_cost_weight: f64,
    /// Obstacles the foliage classifier confirms are solid for the planner (false: ignore it).
    pub use_foliage: bool,
    /// A foliage verdict older than this is ignored, s.
    pub foliage_max_age_s: f64,
    /// A map older than this is stale: zero velocity, s.
    pub map_max_age_s: f64,
    /// Odometry older than this is stale: zero velocity, s.
    pub odom_max_age_s: f64,
    /// A goal older than this is dropped (0: never), s.
    pub goal_max_age_s: f64,
}

impl Default for PlannerConfig {
    fn default() -> Self {
        PlannerConfig {
            inflation: InflationConfig::Adaptive,
            kernel_cells: 13,
            padding_cells: 1,
            kernel_angles: 36,
            window_s: 0.5,
            dt_s: 0.1,
            horizon_s: 3.5,
            v_samples: 11,
            omega_samples: 21,
            goal_weight: 5.0,
            speed_weight: 0.1,
            obstacle_weight: 1.0,
            margin_m: 0.1,
            route_cell_m: 0.25,
            route_cost_weight: 1.0,
            use_foliage: true,
            foliage_max_age_s: 0.3,
            map_max_age_s: 0.15,
            odom_max_age_s: 0.5,
            goal_max_age_s: 0.0,
        }
    }
}

impl PlannerConfig {
    fn validate(&self, r: &mut Ranges) {
        r.check("planner.kernel_cells", self.kernel_cells as f64, 1.0, 101.0);
        r.require(
            self.kernel_cells % 2 == 1,
            format!("planner.kernel_cells = {} must be odd", self.kernel_cells),
        );
        r.check(
            "planner.padding_cells",
            self.padding_cells as f64,
            0.0,
            20.0,
        );
        r.check(
            "planner.kernel_angles",
            self.kernel_angles as f64,
            1.0,
            3600.0,
        );
        r.check("planner.window_s", self.window_s, 0.01, 5.0);
        r.check("planner.dt_s", self.dt_s, 0.01, 1.0);
        r.check("planner.horizon_s", self.horizon_s, 0.1, 20.0);
        r.check("planner.v_samples", self.v_samples as f64, 1.0, 200.0);
        r.check(
            "planner.omega_samples",
            self.omega_samples as f64,
            1.0,
            400.0,
        );
        r.check("planner.goal_weight", self.goal_weight, 0.0, 1000.0);
        r.check("planner.speed_weight", self.speed_weight, 0.0, 1000.0);
        r.check("planner.obstacle_weight", self.obstacle_weight, 0.0, 1000.0);
        r.check("planner.margin_m", self.margin_m, 0.0, 2.0);
        r.check("planner.route_cell_m", self.route_cell_m, 0.0, 2.0);
        r.check(
            "planner.route_cost_weight",
            self.route_cost_weight,
            0.0,
            100.0,
        );
        r.check(
            "planner.foliage_max_age_s",
            self.foliage_max_age_s,
            0.01,
            60.0,
        );
        r.check("planner.map_max_age_s", self.map_max_age_s, 0.01, 60.0);
        r.check("planner.odom_max_age_s", self.odom_max_age_s, 0.01, 60.0);
        r.check("planner.goal_max_age_s", self.goal_max_age_s, 0.0, 86400.0);
    }
}

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
    /// The layers; empty: the paper's four, sized from the robot profile
    /// ([`MapperConfig::layers_for`]).
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
    /// A cell with at least this many returns on a surface in one revolution is solid whatever
    /// its intensity (0: the cue is off).
    pub surface_min_returns: u32,
    /// Cells the surface cue made solid stay solid this long while the robot moves (0: not
    /// kept), s: an obstacle lower than the lowest beam's reach next to the robot is out of
    /// sight once the robot is beside it.
    pub surface_memory_s: f64,
    /// Kept surface cells farther than this from the robot are forgotten, m.
    pub surface_memory_m: f64,
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
    /// Glass: the ranges at both edges of the spike agree within this, m.
    pub glass_range_tolerance_m: f64,
    /// Detected glass is kept this long, s.
    pub glass_memory_s: f64,
    /// Detected glass farther than this from the robot is forgotten, m.
    pub glass_memory_m: f64,
    /// Gaps up to this long between glass detections along a pane are filled, m.
    pub glass_gap_fill_m: f64,
    /// A pane is extended along its line through free cells to a solid cell within this, m
    /// (0: never).
    pub glass_extend_m: f64,
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
            surface_min_returns: 2,
            surface_memory_s: 3.0,
            surface_memory_m: 3.0,
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
            glass_gap_fill_m: 0.8,
            glass_extend_m: 3.0,
            passable_cost: 0.2,
            odom_max_age_s: 0.5,
            points_deadline_s: 0.5,
        }
    }
}

impl MapperConfig {
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

    fn validate(&self, r: &mut Ranges) {
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
            format!(
                "mapper.surface_neighbours = {} must be at most 2 × mapper.surface_window = {}",
                self.surface_neighbours,
                2 * self.surface_window
            ),
        );
        r.check(
            "mapper.surface_min_returns",
            f64::from(self.surface_min_returns),
            0.0,
            10000.0,
        );
        r.check("mapper.surface_memory_s", self.surface_memory_s, 0.0, 600.0);
        r.check("mapper.surface_memory_m", self.surface_memory_m, 0.0, 100.0);
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
        r.check("mapper.glass_gap_fill_m", self.glass_gap_fill_m, 0.0, 10.0);
        r.check("mapper.glass_extend_m", self.glass_extend_m, 0.0, 20.0);
        r.check("mapper.passable_cost", self.passable_cost, 0.0, 1.0);
        r.check("mapper.odom_max_age_s", self.odom_max_age_s, 0.01, 60.0);
        r.check(
            "mapper.points_deadline_s",
            self.points_deadline_s,
            0.01,
            60.0,
        );
        for (i, l) in self.layers.iter().enumerate() {
            r.require(
                l.low < l.high,
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
                    format!("mapper.layer: a layer named \"{role}\" is needed (equations 3 and 6 use it)"),
                );
            }
        }
    }
}

/// The robot-centred map grid (`[map]`), shared by the mapper, the planner and the simulator's
/// ground truth.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MapConfig {
    /// Cells per side (n).
    pub cells: usize,
    /// Cell size, metres (g).
    pub cell_m: f64,
}

impl Default for MapConfig {
    fn default() -> Self {
        MapConfig {
            cells: 200,
            cell_m: 0.05,
        }
    }
}

impl MapConfig {
    /// The grid.
    pub fn grid(&self) -> crate::grid::GridSpec {
        crate::grid::GridSpec {
            cells: self.cells,
            cell_m: self.cell_m as f32,
        }
    }

    fn validate(&self, r: &mut Ranges) {
        r.check("map.cells", self.cells as f64, 10.0, 2000.0);
        r.check("map.cell_m", self.cell_m, 0.01, 1.0);
    }
}

/// Return mode the simulated sensor is set to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SimReturnMode {
    /// Strongest return (0x37).
    Strongest,
    /// Last return (0x38).
    Last,
    /// Dual return (0x39).
    Dual,
}

/// The simulator (`[sim]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimConfig {
    /// World file; a relative path is taken from the config file's folder.
    pub world: PathBuf,
    /// Seed of every random draw: the same seed gives the same bytes.
    pub seed: u64,
    /// The simulated sensor's return mode.
    pub return_mode: SimReturnMode,
    /// Where streamed packets go (data to `velodyne.data_port`, position packets to
    /// `velodyne.position_port`); loopback only unless you mean it.
    pub udp_target: IpAddr,
    /// Standard deviation of the range noise of solid surfaces, metres.
    pub range_noise_m: f64,
    /// Standard deviation of the intensity noise, reflectivity units.
    pub intensity_noise: f64,
    /// Glass returns only within this angle of normal incidence, degrees.
    pub glass_specular_deg: f64,
    /// Lock-step: send one revolution, then wait for the stack's command before the next.
    pub lockstep: bool,
    /// In lock-step, how long to wait for the stack's command before going on without one, s.
    pub lockstep_timeout_s: f64,
    /// The goal counts as reached within this distance, metres.
    pub goal_tolerance_m: f64,
    /// Grass as blades standing in the ground, which neighbouring beams meet alike (the
    /// VLP-16's spot is wider than its firing spacing), instead of blades drawn for each beam
    /// on its own (the default, which every published figure uses).
    pub grass_blades: bool,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            world: PathBuf::from("worlds/scenario1_glass_wall.toml"),
            seed: 1,
            return_mode: SimReturnMode::Dual,
            udp_target: IpAddr::from([127, 0, 0, 1]),
            range_noise_m: 0.015,
            intensity_noise: 1.5,
            glass_specular_deg: 3.0,
            lockstep: false,
            lockstep_timeout_s: 5.0,
            goal_tolerance_m: 0.3,
            grass_blades: false,
        }
    }
}

impl SimConfig {
    fn validate(&self, r: &mut Ranges) {
        r.check("sim.range_noise_m", self.range_noise_m, 0.0, 0.5);
        r.check("sim.intensity_noise", self.intensity_noise, 0.0, 50.0);
        r.check("sim.glass_specular_deg", self.glass_specular_deg, 0.1, 30.0);
        r.check(
            "sim.lockstep_timeout_s",
            self.lockstep_timeout_s,
            0.01,
            600.0,
        );
        r.check("sim.goal_tolerance_m", self.goal_tolerance_m, 0.01, 5.0);
    }

    /// The world file, relative paths taken from `config_dir`.
    pub fn world_path(&self, config_dir: &Path) -> PathBuf {
        if self.world.is_absolute() {
            self.world.clone()
        } else {
            config_dir.join(&self.world)
        }
    }
}

/// A robot: footprint, sensor mounting and motion limits (`config/robots/NAME.toml`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RobotProfile {
    /// Profile name.
    pub name: String,
    /// Radius of the circle that encloses the footprint, metres.
    pub radius_m: f64,
    /// Height of the lidar's optical centre above the ground, metres.
    pub sensor_height_m: f64,
    /// Height of the robot's top above the ground, metres.
    pub height_m: f64,
    /// Largest forward speed, m/s.
    pub max_linear_mps: f64,
    /// Largest turn rate, rad/s.
    pub max_angular_rps: f64,
    /// Largest linear acceleration, m/s².
    pub max_linear_accel: f64,
    /// Largest angular acceleration, rad/s².
    pub max_angular_accel: f64,
    /// How long a velocity command stays valid on the base, seconds.
    pub command_validity_s: f64,
    /// Where the lidar sits on the robot (`[robot.mount]`; its height is `sensor_height_m`).
    pub mount: crate::pose::LidarMount,
}

impl Default for RobotProfile {
    /// The Turtlebot 2 (DESIGN §4).
    fn default() -> Self {
        RobotProfile {
            name: "turtlebot2".into(),
            radius_m: 0.20,
            sensor_height_m: 0.5,
            height_m: 0.6,
            max_linear_mps: 0.5,
            max_angular_rps: 1.5,
            max_linear_accel: 0.6,
            max_angular_accel: 3.0,
            command_validity_s: 0.5,
            mount: crate::pose::LidarMount::default(),
        }
    }
}

/// Logging.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LogConfig {
    /// A `tracing` filter (`info`, `mimnav_velodyne=debug,info`, …); `MIMNAV_LOG` overrides it.
    pub level: String,
}

impl Default for LogConfig {
    fn default() -> Self {
        LogConfig {
            level: "info".into(),
        }
    }
}

/// Where the driver's datagrams come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum VelodyneInput {
    /// A UDP socket: a live sensor, or a simulator streaming.
    Udp,
    /// A pcap or pcapng capture (`velodyne.pcap`).
    Pcap,
}

/// Which return of a dual pair the planar scan takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ScanReturnConfig {
    /// The strongest return.
    Strongest,
    /// The last return.
    Last,
}

/// The VLP-16 driver (`[velodyne]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VelodyneConfig {
    /// `udp` or `pcap`.
    pub input: VelodyneInput,
    /// Address the UDP sockets bind to.
    pub bind_address: IpAddr,
    /// UDP port of the data packets.
    pub data_port: u16,
    /// UDP port of the position packets; 0 does not listen for them.
    pub position_port: u16,
    /// Accept datagrams from this sender only (the sensor's address).
    pub allowed_source: Option<IpAddr>,
    /// UDP receive buffer asked of the kernel, bytes.
    pub recv_buffer_bytes: usize,
    /// Capture file replayed when `input = "pcap"`.
    pub pcap: Option<PathBuf>,
    /// Replay speed factor (1.0 is real time).
    pub replay_speed: f64,
    /// Replay as fast as possible instead of by the capture's timestamps.
    pub replay_fast: bool,
    /// Start the capture over when it ends.
    pub replay_loop: bool,
    /// Gaps in the capture longer than this are shortened to it, seconds.
    pub replay_max_gap_s: f64,
    /// After a capture ends, keep the topics open this long so subscribers can take the last
    /// samples, then exit; seconds.
    pub replay_linger_s: f64,
    /// Sensor rotation rate, revolutions per minute (the sensor's own setting, 300–1200).
    pub rpm: f64,
    /// Cut revolutions where the azimuth passes this angle (degrees, clockwise from forward);
    /// unset: wherever a full turn completes.
    pub cut_azimuth_deg: Option<f64>,
    /// Drop returns nearer than this, metres.
    pub min_range_m: f64,
    /// Drop returns farther than this, metres.
    pub max_range_m: f64,
    /// Decode product byte 0x21 (early VLP-16 firmware) as a VLP-16.
    pub accept_product_0x21: bool,
    /// Laser id (0–15, firing order) published as the planar scan; 14 is the −1° laser.
    pub scan_laser: u8,
    /// Return of a dual pair the planar scan takes: `last` (default: the foliage classifier sees
    /// an obstacle behind grass through the beams that reach it) or `strongest`.
    pub scan_return: ScanReturnConfig,
    /// Publish every raw datagram on `lidar/packets`.
    pub publish_packets: bool,
    /// Interval of the statistics log line, seconds.
    pub stats_interval_s: f64,
}

impl Default for VelodyneConfig {
    fn default() -> Self {
        VelodyneConfig {
            input: VelodyneInput::Udp,
            bind_address: IpAddr::from([0, 0, 0, 0]),
            data_port: 2368,
            position_port: 8308,
            allowed_source: None,
            recv_buffer_bytes: 4 << 20,
            pcap: None,
            replay_speed: 1.0,
            replay_fast: false,
            replay_loop: false,
            replay_max_gap_s: 1.0,
            replay_linger_s: 2.0,
            rpm: 600.0,
            cut_azimuth_deg: None,
            min_range_m: 0.1,
            max_range_m: 200.0,
            accept_product_0x21: false,
            scan_laser: 14,
            scan_return: ScanReturnConfig::Last,
            publish_packets: false,
            stats_interval_s: 10.0,
        }
    }
}

/// Collects range violations as "key = value is out of range: allowed …".
struct Ranges(Vec<String>);

impl Ranges {
    fn check(&mut self, key: &str, value: f64, lo: f64, hi: f64) {
        if !(value >= lo && value <= hi) {
            self.0.push(format!(
                "{key} = {value} is out of range: allowed {lo} to {hi}"
            ));
        }
    }
    fn require(&mut self, ok: bool, message: impl Into<String>) {
        if !ok {
            self.0.push(message.into());
        }
    }
}

impl VelodyneConfig {
    fn validate(&self, r: &mut Ranges) {
        r.check("velodyne.replay_speed", self.replay_speed, 0.01, 100.0);
        r.check(
            "velodyne.replay_max_gap_s",
            self.replay_max_gap_s,
            0.001,
            3600.0,
        );
        r.check("velodyne.replay_linger_s", self.replay_linger_s, 0.0, 60.0);
        r.check("velodyne.rpm", self.rpm, 300.0, 1200.0);
        if let Some(c) = self.cut_azimuth_deg {
            r.check("velodyne.cut_azimuth_deg", c, 0.0, 359.99);
        }
        r.check("velodyne.min_range_m", self.min_range_m, 0.0, 200.0);
        r.check("velodyne.max_range_m", self.max_range_m, 0.1, 200.0);
        r.require(
            self.min_range_m < self.max_range_m,
            format!(
                "velodyne.min_range_m = {} must be below velodyne.max_range_m = {}",
                self.min_range_m, self.max_range_m
            ),
        );
        r.check("velodyne.scan_laser", f64::from(self.scan_laser), 0.0, 15.0);
        r.check(
            "velodyne.stats_interval_s",
            self.stats_interval_s,
            0.1,
            3600.0,
        );
        r.check(
            "velodyne.data_port",
            f64::from(self.data_port),
            1.0,
            65535.0,
        );
        r.require(
            self.input != VelodyneInput::Pcap || self.pcap.is_some(),
            "velodyne.input = \"pcap\" needs velodyne.pcap = \"FILE\"",
        );
    }
}

impl RobotProfile {
    fn validate(&self, r: &mut Ranges) {
        r.check("robot.radius_m", self.radius_m, 0.05, 3.0);
        r.check("robot.sensor_height_m", self.sensor_height_m, 0.05, 3.0);
        r.check("robot.height_m", self.height_m, 0.05, 3.0);
        r.check("robot.max_linear_mps", self.max_linear_mps, 0.01, 5.0);
        r.check("robot.max_angular_rps", self.max_angular_rps, 0.01, 10.0);
        r.check("robot.max_linear_accel", self.max_linear_accel, 0.01, 20.0);
        r.check(
            "robot.max_angular_accel",
            self.max_angular_accel,
            0.01,
            50.0,
        );
        r.check(
            "robot.command_validity_s",
            self.command_validity_s,
            0.01,
            10.0,
        );
        if let Err(e) = self.mount.validate() {
            r.require(false, e.to_string());
        }
    }
}

impl Default for Config {
    fn default() -> Self {
        Config {
            path: PathBuf::new(),
            robot: RobotProfile::default(),
            log: LogConfig::default(),
            iceoryx2: project_iceoryx2_defaults(),
            velodyne: VelodyneConfig::default(),
            map: MapConfig::default(),
            sim: SimConfig::default(),
            mapper: MapperConfig::default(),
            planner: PlannerConfig::default(),
            foliage: FoliageConfig::default(),
            latency: LatencyConfig::default(),
        }
    }
}

/// Root path of iceoryx2's files unless the config says otherwise. Not under iceoryx2's default
/// `/tmp/iceoryx2/`, so mimnav never meets another application's services; the systemd units
/// use a path under `/run` instead (a private `/tmp` would hide it).
pub const DEFAULT_IOX2_ROOT: &str = "/tmp/mimnav/iceoryx2/";
/// Prefix of iceoryx2's files unless the config says otherwise.
pub const DEFAULT_IOX2_PREFIX: &str = "mimnav_";

fn project_iceoryx2_defaults() -> iceoryx2::config::Config {
    let mut table = toml::Table::new();
    let mut global = toml::Table::new();
    global.insert("root-path".into(), DEFAULT_IOX2_ROOT.into());
    global.insert("prefix".into(), DEFAULT_IOX2_PREFIX.into());
    table.insert("global".into(), global.into());
    // the two values above are valid by construction
    iceoryx2_config(&table, "built-in defaults").unwrap_or_default()
}

/// Builds iceoryx2's Config from a partial `[iceoryx2]` table: iceoryx2's defaults, then the
/// project's root path and prefix, then the table. Keys iceoryx2 does not know are errors.
fn iceoryx2_config(
    table: &toml::Table,
    source: &str,
) -> Result<iceoryx2::config::Config, ConfigError> {
    let defaults = toml::Table::try_from(iceoryx2::config::Config::default())
        .map_err(|e| err(source, format!("iceoryx2 defaults do not serialise: {e}")))?;
    let mut merged = defaults.clone();
    let mut project = toml::Table::new();
    let mut global = toml::Table::new();
    global.insert("root-path".into(), DEFAULT_IOX2_ROOT.into());
    global.insert("prefix".into(), DEFAULT_IOX2_PREFIX.into());
    project.insert("global".into(), global.into());
    merge(&mut merged, &project, &defaults, "iceoryx2", source)?;
    merge(&mut merged, table, &defaults, "iceoryx2", source)?;
    iceoryx2::config::Config::deserialize(toml::Value::Table(merged))
        .map_err(|e| err(source, format!("[iceoryx2]: {e}")))
}

/// Overlays `over` onto `base`, refusing keys that `known` does not have.
fn merge(
    base: &mut toml::Table,
    over: &toml::Table,
    known: &toml::Table,
    path: &str,
    source: &str,
) -> Result<(), ConfigError> {
    for (k, v) in over {
        let key = format!("{path}.{k}");
        let Some(known_v) = known.get(k) else {
            let mut keys: Vec<&str> = known.keys().map(String::as_str).collect();
            keys.sort_unstable();
            return Err(err(
                source,
                format!("unknown key `{key}`; expected one of: {}", keys.join(", ")),
            ));
        };
        match (v, known_v, base.get_mut(k)) {
            (toml::Value::Table(vt), toml::Value::Table(kt), Some(toml::Value::Table(bt))) => {
                merge(bt, vt, kt, &key, source)?
            }
            _ => {
                base.insert(k.clone(), v.clone());
            }
        }
    }
    Ok(())
}

/// `s` as a TOML basic string, quoted and escaped (for building `--set key=value` arguments).
pub fn toml_quote(s: &str) -> String {
    toml::Value::String(s.to_string()).to_string()
}

/// Sets `key.path = value` in `table`; `value` is TOML, a bare word is a string.
fn set_key(table: &mut toml::Table, assignment: &str) -> Result<(), ConfigError> {
    let source = format!("--set {assignment}");
    let (key, value) = assignment
        .split_once('=')
        .ok_or_else(|| err(&source, "expected KEY=VALUE, e.g. velodyne.rpm=600"))?;
    let key = key.trim();
    let value = value.trim();
    let parsed: toml::Value = match toml::from_str::<toml::Table>(&format!("v = {value}")) {
        Ok(mut t) => t.remove("v").unwrap_or_else(|| value.into()),
        Err(_) => toml::Value::String(value.to_string()),
    };
    let mut parts: Vec<&str> = key.split('.').collect();
    let last = parts
        .pop()
        .filter(|p| !p.is_empty())
        .ok_or_else(|| err(&source, "empty key"))?;
    let mut t = table;
    for p in parts {
        let entry = t
            .entry(p.to_string())
            .or_insert_with(|| toml::Table::new().into());
        t = entry
            .as_table_mut()
            .ok_or_else(|| err(&source, format!("`{p}` is not a table")))?;
    }
    t.insert(last.to_string(), parsed);
    Ok(())
}

fn section<T: DeserializeOwned>(
    v: toml::Value,
    name: &str,
    source: &str,
) -> Result<T, ConfigError> {
    T::deserialize(v).map_err(|e| err(source, format!("[{name}]: {}", e.message().trim())))
}

impl Config {
    /// Reads `path`, applies the `--set` overrides, loads the robot profile and checks every
    /// value.
    pub fn load(path: &Path, overrides: &[String]) -> Result<Config, ConfigError> {
        let shown = path.display().to_string();
        let text =
            std::fs::read_to_string(path).map_err(|e| err(&shown, format!("cannot read: {e}")))?;
        Self::from_toml(&text, path, overrides)
    }

    /// The config a service or tool starts with: the file given (`--config` or `MIMNAV_CONFIG`)
    /// must exist; without one, [`DEFAULT_CONFIG_PATH`] if it exists; else the built-in defaults.
    pub fn resolve(explicit: Option<&Path>, overrides: &[String]) -> Result<Config, ConfigError> {
        match explicit {
            Some(p) => Config::load(p, overrides),
            None if Path::new(DEFAULT_CONFIG_PATH).exists() => {
                Config::load(Path::new(DEFAULT_CONFIG_PATH), overrides)
            }
            None => Config::from_toml("", Path::new("built-in defaults"), overrides),
        }
    }

    /// The folder relative paths in the config are taken from: the config file's, or the
    /// current folder for the built-in defaults.
    pub fn dir(&self) -> PathBuf {
        match self.path.parent() {
            Some(p) if self.from_file() && !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        }
    }

    /// True when this config came from a file (not the built-in defaults).
    pub fn from_file(&self) -> bool {
        self.path.is_file()
    }

    /// Parses config text as if read from `path` (robot profiles are looked up beside it).
    pub fn from_toml(text: &str, path: &Path, overrides: &[String]) -> Result<Config, ConfigError> {
        let shown = path.display().to_string();
        // A strict parse of the file as written gives line and column for its own mistakes.
        toml::from_str::<FileConfig>(text).map_err(|e| err(&shown, e.to_string().trim_end()))?;
        let mut table: toml::Table =
            toml::from_str(text).map_err(|e| err(&shown, e.to_string()))?;
        let source = if overrides.is_empty() {
            shown.clone()
        } else {
            format!("{shown} with --set")
        };
        for o in overrides {
            set_key(&mut table, o)?;
        }
        let file: FileConfig =
            section(toml::Value::Table(table), "config", &source).map_err(|mut e| {
                e.message = e.message.replacen("[config]: ", "", 1);
                e
            })?;
        let robot = Self::robot(file.robot, path, &source)?;
        let iceoryx2 = iceoryx2_config(&file.iceoryx2, &source)?;
        let config = Config {
            path: path.to_path_buf(),
            robot,
            log: file.log,
            iceoryx2,
            velodyne: file.velodyne,
            map: file.map,
            sim: file.sim,
            mapper: file.mapper,
            planner: file.planner,
            foliage: file.foliage,
            latency: file.latency,
        };
        let mut r = Ranges(Vec::new());
        config.robot.validate(&mut r);
        config.velodyne.validate(&mut r);
        config.map.validate(&mut r);
        config.sim.validate(&mut r);
        config.mapper.validate(&mut r);
        config.planner.validate(&mut r);
        config.foliage.validate(&mut r);
        config.latency.validate(&mut r);
        // a map comes once per revolution: a shorter limit would call every map stale
        let revolution_s = 60.0 / config.velodyne.rpm;
        r.require(
            !(300.0..=1200.0).contains(&config.velodyne.rpm)
                || config.planner.map_max_age_s >= 1.2 * revolution_s,
            format!(
                "planner.map_max_age_s = {} is shorter than 1.2 revolutions at velodyne.rpm = {} \
                 ({:.3} s): every map would be stale",
                config.planner.map_max_age_s,
                config.velodyne.rpm,
                1.2 * revolution_s
            ),
        );
        if !r.0.is_empty() {
            return Err(err(&source, r.0.join("; ")));
        }
        Ok(config)
    }

    /// `[robot]`: `profile = NAME` loads `robots/NAME.toml` beside the config file; the other
    /// keys override the profile's.
    fn robot(
        mut section_table: toml::Table,
        path: &Path,
        source: &str,
    ) -> Result<RobotProfile, ConfigError> {
        let mut base = toml::Table::try_from(RobotProfile::default())
            .map_err(|e| err(source, format!("robot defaults: {e}")))?;
        if let Some(profile) = section_table.remove("profile") {
            let name = profile
                .as_str()
                .filter(|n| {
                    !n.is_empty()
                        && n.chars()
                            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
                })
                .ok_or_else(|| {
                    err(
                        source,
                        format!("robot.profile = {profile} must be a name like \"spot\""),
                    )
                })?;
            let dir = path.parent().unwrap_or(Path::new("."));
            let file = dir.join("robots").join(format!("{name}.toml"));
            let shown = file.display().to_string();
            let text = std::fs::read_to_string(&file).map_err(|e| {
                err(
                    source,
                    format!("robot.profile = \"{name}\": cannot read {shown}: {e}"),
                )
            })?;
            let parsed: RobotProfile =
                toml::from_str(&text).map_err(|e| err(&shown, e.to_string().trim_end()))?;
            base = toml::Table::try_from(parsed).map_err(|e| err(&shown, e.to_string()))?;
        }
        for (k, v) in section_table {
            base.insert(k, v);
        }
        section(toml::Value::Table(base), "robot", source)
    }

    /// Sets iceoryx2's root path and prefix (tests give every run its own pair).
    pub fn set_iceoryx2_location(
        &mut self,
        root_path: &str,
        prefix: &str,
    ) -> Result<(), ConfigError> {
        let mut t = toml::Table::new();
        let mut g = toml::Table::new();
        g.insert("root-path".into(), root_path.into());
        g.insert("prefix".into(), prefix.into());
        t.insert("global".into(), g.into());
        let located = iceoryx2_config(&t, "iceoryx2 location")?;
        self.iceoryx2.global.prefix = located.global.prefix;
        self.iceoryx2
            .global
            .set_root_path(located.global.root_path());
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Config, ConfigError> {
        Config::from_toml(text, Path::new("test.toml"), &[])
    }

    #[test]
    fn empty_file_gives_the_documented_defaults() {
        let c = parse("").expect("defaults");
        assert_eq!(c.velodyne, VelodyneConfig::default());
        assert_eq!(c.robot, RobotProfile::default());
        assert_eq!(c.iceoryx2.global.prefix.to_string(), DEFAULT_IOX2_PREFIX);
        assert_eq!(c.iceoryx2.global.root_path().to_string(), DEFAULT_IOX2_ROOT);
    }

    #[test]
    fn map_age_limit_must_cover_a_revolution() {
        let e = parse("[velodyne]\nrpm = 300\n").expect_err("0.15 s < 1.2 × 0.2 s");
        let s = e.to_string();
        assert!(s.contains("planner.map_max_age_s = 0.15"), "{s}");
        assert!(s.contains("velodyne.rpm = 300"), "{s}");
        parse("[velodyne]\nrpm = 300\n[planner]\nmap_max_age_s = 0.25\n").expect("long enough");
    }

    #[test]
    fn unknown_key_names_file_line_and_key() {
        let e = parse("[velodyne]\nrmp = 600\n").expect_err("unknown key");
        let s = e.to_string();
        assert!(s.starts_with("test.toml: "), "{s}");
        assert!(s.contains("rmp"), "{s}");
        assert!(s.contains("line 2"), "{s}");
    }

    #[test]
    fn out_of_range_names_key_and_range() {
        let e = parse("[velodyne]\nrpm = 50\n").expect_err("range");
        assert_eq!(
            e.to_string(),
            "test.toml: velodyne.rpm = 50 is out of range: allowed 300 to 1200"
        );
        let e = parse("[velodyne]\ninput = \"pcap\"\n").expect_err("pcap without file");
        assert!(e.to_string().contains("velodyne.pcap"), "{e}");
    }

    #[test]
    fn surface_cue_needs_no_more_neighbours_than_its_window_holds() {
        let e =
            parse("[mapper]\nsurface_window = 3\nsurface_neighbours = 7\n").expect_err("7 of 6");
        assert_eq!(
            e.to_string(),
            "test.toml: mapper.surface_neighbours = 7 must be at most 2 × mapper.surface_window = 6"
        );
        assert!(parse("[mapper]\nsurface_window = 3\nsurface_neighbours = 6\n").is_ok());
        assert!(parse("[mapper]\nsurface_min_returns = 0\nsurface_memory_s = 0\n").is_ok());
    }

    #[test]
    fn wrong_type_is_refused() {
        let e = parse("[velodyne]\ndata_port = \"x\"\n").expect_err("type");
        assert!(
            e.to_string().contains("data_port") || e.to_string().contains("line 2"),
            "{e}"
        );
        let e = parse("[velodyne]\ndata_port = 70000\n").expect_err("u16");
        assert!(e.to_string().contains("line 2"), "{e}");
    }

    #[test]
    fn iceoryx2_table_is_passed_and_checked() {
        let c = parse("[iceoryx2.global]\nprefix = \"abc_\"\n[iceoryx2.defaults.publish-subscribe]\nmax-subscribers = 3\n")
            .expect("iceoryx2 table");
        assert_eq!(c.iceoryx2.global.prefix.to_string(), "abc_");
        assert_eq!(c.iceoryx2.defaults.publish_subscribe.max_subscribers, 3);
        let e = parse("[iceoryx2.global]\nprefx = \"abc_\"\n").expect_err("unknown iceoryx2 key");
        assert!(e.to_string().contains("iceoryx2.global.prefx"), "{e}");
    }

    #[test]
    fn set_overrides_a_key() {
        let c = Config::from_toml(
            "[velodyne]\nrpm = 600\n",
            Path::new("t.toml"),
            &[
                "velodyne.rpm=900".into(),
                "velodyne.pcap=/data/x.pcap".into(),
            ],
        )
        .expect("override");
        assert_eq!(c.velodyne.rpm, 900.0);
        assert_eq!(c.velodyne.pcap, Some(PathBuf::from("/data/x.pcap")));
        let e =
            Config::from_toml("", Path::new("t.toml"), &["velodyne.rpm".into()]).expect_err("no =");
        assert!(e.to_string().contains("KEY=VALUE"), "{e}");
        let e = Config::from_toml("", Path::new("t.toml"), &["velodyne.nope=1".into()])
            .expect_err("unknown");
        assert!(e.to_string().contains("nope"), "{e}");
    }

    #[test]
    fn robot_profile_is_loaded_and_overridden() {
        let dir = std::env::temp_dir().join(format!("mimnav-config-test-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("robots")).expect("dir");
        std::fs::write(
            dir.join("robots/bigbot.toml"),
            "name = \"bigbot\"\nradius_m = 0.6\nsensor_height_m = 0.7\n",
        )
        .expect("write");
        let path = dir.join("mimnav.toml");
        let c = Config::from_toml(
            "[robot]\nprofile = \"bigbot\"\nmax_linear_mps = 0.3\n",
            &path,
            &[],
        )
        .expect("profile");
        assert_eq!(c.robot.name, "bigbot");
        assert_eq!(c.robot.radius_m, 0.6);
        assert_eq!(c.robot.max_linear_mps, 0.3);
        let e = Config::from_toml("[robot]\nprofile = \"nobot\"\n", &path, &[])
            .expect_err("missing profile");
        assert!(e.to_string().contains("nobot.toml"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}

#[cfg(test)]
mod shipped {
    use super::*;

    /// `config/mimnav.toml` documents every key at its default: keep it true.
    #[test]
    fn shipped_config_holds_the_defaults() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/mimnav.toml");
        let c = Config::load(&path, &[]).expect("shipped config loads");
        let d = Config::default();
        assert_eq!(c.velodyne, d.velodyne);
        assert_eq!(c.robot, d.robot);
        assert_eq!(c.log, d.log);
        assert_eq!(c.iceoryx2, d.iceoryx2);
        assert_eq!(c.map, d.map);
        assert_eq!(c.sim, d.sim);
        assert_eq!(c.mapper, d.mapper);
        assert_eq!(c.planner, d.planner);
        assert_eq!(c.foliage, d.foliage);
        assert_eq!(c.latency, d.latency);
        for profile in ["spot", "turtlebot2"] {
            let c =
                Config::load(&path, &[format!("robot.profile=\"{profile}\"")]).expect("profile");
            assert_eq!(c.robot.name, profile);
        }
    }
}
