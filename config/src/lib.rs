//! The stack's config file: one TOML file configures every service.
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
//! [velodyne]         # one section per library
//! input = "udp"
//! ```
//!
//! This crate defines no parameter of its own: it composes. Each algorithm library owns its
//! section — the type, its documented defaults and its `validate()` returning typed errors that
//! name the key and its range — and the sections every process shares (robot, map, log,
//! latency, iceoryx2) are [`mimnav_shared::config::Common`]:
//!
//! | section | type |
//! |---|---|
//! | `[velodyne]` | [`mimnav_velodyne::config::VelodyneConfig`] |
//! | `[sim]` | [`mimnav_sim::config::SimConfig`] |
//! | `[mapper]` | [`mimnav_mapper::config::MapperConfig`] |
//! | `[planner]` | [`mimnav_planner::config::PlannerConfig`] |
//! | `[foliage]` | [`mimnav_foliage::FoliageParams`] |
//! | `[kobuki]` | [`mimnav_kobuki::config::KobukiConfig`] |
//! | `[sick]` | [`mimnav_sick::SickConfig`] |
//! | `[spot]` | [`SpotConfig`] |
//! | `[view]` | [`ViewConfig`] |
//! | `[zenoh]` | [`ZenohConfig`] |
//! | `[robot]`, `[map]`, `[log]`, `[latency]`, `[iceoryx2]` | [`Common`] |
//!
//! [`Config`] checks the file whole: unknown keys, wrong types and out-of-range values are errors
//! that name the file, the key and what is allowed, and the rules that tie sections together
//! ([`Config::validate`]) hold. `--set key.path=value` on a command line overrides one key (the
//! value is TOML; a bare word is taken as a string). Every service loads the whole file, so a
//! mistake anywhere stops the stack at start, not the one service that reads the key.
//!
//! The methods that build a library's parameters or step from several sections
//! ([`Config::mapper_params`], [`Config::map_step`], [`Config::pilot`], …) are the one place
//! a section is joined with the robot and the grid.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod spot;
mod view;
mod zenoh;

use std::ops::{Deref, DerefMut};
use std::path::{Path, PathBuf};

use serde::Deserialize;

use mimnav_shared::config::{
    Checks, Common, CommonTables, ConfigError, DEFAULT_CONFIG_PATH, Invalid, LatencyConfig, Load,
    LogConfig, MapConfig, apply_overrides, err, read_config_text, seconds_ns, section,
};

use mimnav_foliage::FoliageParams;
use mimnav_foliage::ScanSource;
use mimnav_foliage::step::{ScanStep, StepError};
use mimnav_kobuki::config::KobukiConfig;
use mimnav_mapper::MapperParams;
use mimnav_mapper::config::MapperConfig;
use mimnav_mapper::step::MapStep;
use mimnav_planner::PlannerParams;
use mimnav_planner::config::PlannerConfig;
use mimnav_planner::pilot::Pilot;
use mimnav_sick::SickConfig;
use mimnav_sim::SimSettings;
use mimnav_sim::config::SimConfig;
use mimnav_velodyne::config::VelodyneConfig;
pub use spot::SpotConfig;
pub use view::ViewConfig;
pub use zenoh::{BRIDGE_TOPICS, ZenohConfig, is_key_chunk};

/// The whole stack's configuration: the shared sections ([`Common`], reached through `Deref`:
/// `config.robot`, `config.map`, …) and every library's own.
#[derive(Debug, Clone, Default)]
pub struct Config {
    /// The sections every process shares: robot, map, log, latency, iceoryx2.
    pub common: Common,
    /// `[velodyne]`: the VLP-16 driver.
    pub velodyne: VelodyneConfig,
    /// `[sim]`: the simulator.
    pub sim: SimConfig,
    /// `[mapper]`: the map builder.
    pub mapper: MapperConfig,
    /// `[planner]`: the planner.
    pub planner: PlannerConfig,
    /// `[foliage]`: the foliage classifier.
    pub foliage: FoliageParams,
    /// `[kobuki]`: the Turtlebot 2's base.
    pub kobuki: KobukiConfig,
    /// `[sick]`: the SICK planar ladar (`foliage.source = "sick"`).
    pub sick: SickConfig,
    /// `[spot]`: the Spot bridge.
    pub spot: SpotConfig,
    /// `[view]`: the Foxglove live view.
    pub view: ViewConfig,
    /// `[zenoh]`: the Zenoh bridge.
    pub zenoh: ZenohConfig,
}

impl Deref for Config {
    type Target = Common;
    fn deref(&self) -> &Common {
        &self.common
    }
}

impl DerefMut for Config {
    fn deref_mut(&mut self) -> &mut Common {
        &mut self.common
    }
}

impl AsMut<Common> for Config {
    fn as_mut(&mut self) -> &mut Common {
        &mut self.common
    }
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
    foliage: FoliageParams,
    kobuki: KobukiConfig,
    sick: SickConfig,
    spot: SpotConfig,
    view: ViewConfig,
    zenoh: ZenohConfig,
    latency: LatencyConfig,
}

impl Load for Config {
    fn resolve(explicit: Option<&Path>, overrides: &[String]) -> Result<Config, ConfigError> {
        Config::resolve(explicit, overrides)
    }
}

impl Config {
    /// Reads `path`, applies the `--set` overrides, loads the robot profile and checks every
    /// value.
    pub fn load(path: &Path, overrides: &[String]) -> Result<Config, ConfigError> {
        let shown = path.display().to_string();
        let text = read_config_text(path).map_err(|e| err(&shown, e))?;
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

    /// The file the `mimnav` front end reads, which it also hands to the processes it starts:
    /// the one given (`--config` or `MIMNAV_CONFIG`); else [`DEFAULT_CONFIG_PATH`] if it exists;
    /// else `config/mimnav.toml` in the current folder if it exists (a checkout); else none, the
    /// built-in defaults.
    pub fn front_end_path(explicit: Option<&Path>) -> Option<PathBuf> {
        let etc = Path::new(DEFAULT_CONFIG_PATH);
        let local = Path::new("config/mimnav.toml");
        match explicit {
            Some(p) => Some(p.to_path_buf()),
            None if etc.exists() => Some(etc.to_path_buf()),
            None if local.exists() => Some(local.to_path_buf()),
            None => None,
        }
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
        apply_overrides(&mut table, overrides)?;
        // TOML reads nan and inf: refused wherever they are, before any section sees them
        let mut finite = Checks::default();
        finite.finite_table("", &table);
        finite
            .finish()
            .map_err(|e| ConfigError::invalid(&source, e))?;
        let file: FileConfig =
            section(toml::Value::Table(table), "config", &source).map_err(|mut e| {
                e.message = e.message.replacen("[config]: ", "", 1);
                e
            })?;
        let common = Common::from_tables(
            CommonTables {
                robot: file.robot,
                log: file.log,
                iceoryx2: file.iceoryx2,
                map: file.map,
                latency: file.latency,
            },
            path,
            &source,
        )?;
        let config = Config {
            common,
            velodyne: file.velodyne,
            sim: file.sim,
            mapper: file.mapper,
            planner: file.planner,
            foliage: file.foliage,
            kobuki: file.kobuki,
            sick: file.sick,
            spot: file.spot,
            view: file.view,
            zenoh: file.zenoh,
        };
        config
            .validate()
            .map_err(|e| ConfigError::invalid(&source, e))?;
        Ok(config)
    }

    /// Checks every section and the rules between sections: every value refused, each naming
    /// its key and what is allowed.
    pub fn validate(&self) -> Result<(), Invalid> {
        let mut r = Checks::default();
        r.merge(self.common.validate());
        r.merge(self.velodyne.validate());
        r.merge(self.sim.validate());
        r.merge(self.mapper.validate());
        r.merge(self.planner.validate());
        r.merge(self.foliage.validate());
        r.merge(self.kobuki.validate());
        r.merge(self.sick.validate());
        r.merge(self.spot.validate());
        r.merge(self.view.validate());
        r.merge(self.zenoh.validate());
        // a map comes once per revolution: a shorter limit would call every map stale
        let revolution_s = 60.0 / self.velodyne.rpm;
        r.require(
            !(300.0..=1200.0).contains(&self.velodyne.rpm)
                || self.planner.map_max_age_s >= 1.2 * revolution_s,
            "planner.map_max_age_s",
            format!(
                "planner.map_max_age_s = {} is shorter than 1.2 revolutions at velodyne.rpm = {} \
                 ({:.3} s): every map would be stale",
                self.planner.map_max_age_s,
                self.velodyne.rpm,
                1.2 * revolution_s
            ),
        );
        r.finish()
    }

    /// The simulator's settings: `[sim]`, the robot of `[robot]` (and its lidar mount), the
    /// sensor spinning at `velodyne.rpm`.
    pub fn sim_settings(&self) -> SimSettings {
        SimSettings {
            sim: self.sim.clone(),
            robot: self.robot.clone(),
            rpm: self.velodyne.rpm,
        }
    }

    /// The mapper's parameters: the grid of `[map]`, the robot of `[robot]` and `[mapper]`.
    pub fn mapper_params(&self) -> MapperParams {
        MapperParams {
            grid: self.map.grid(),
            robot: self.robot.clone(),
            mapper: self.mapper.clone(),
        }
    }

    /// The mapper's step: [`Config::mapper_params`], `mapper.odom_max_age_s` and `robot.mount`.
    pub fn map_step(&self) -> MapStep {
        MapStep::new(self.mapper_params(), seconds_ns(self.mapper.odom_max_age_s))
            .with_mount(&self.robot.mount)
    }

    /// The planner's parameters: `[planner]`, the robot of `[robot]` and the passable cost of
    /// `[mapper]`.
    pub fn planner_params(&self) -> PlannerParams {
        PlannerParams {
            planner: self.planner.clone(),
            robot: self.robot.clone(),
            passable_cost: self.mapper.passable_cell_cost(),
        }
    }

    /// The planner's step on [`Config::planner_params`].
    pub fn pilot(&self) -> Pilot {
        Pilot::new(self.planner_params())
    }

    /// The foliage classifier's parameters for the configured source: `[foliage]` as written
    /// for the VLP-16; for a SICK, the window `α` (DESIGN §8, `FIND-LOW-FREQ`'s window; the
    /// paper's figure uses `α ≈ 2θ`) is at least the scan's angular step (the
    /// `[sick]` mode's): a window narrower than the step leaves empty windows between the
    /// returns, and the classifier's runs of smooth windows break (issue 26: on generated
    /// grass worlds a TiM5xx at 1° detected 23 % of the visible obstacle-scans with 0.4°
    /// windows and 80 % with 1°; an LMS1xx at 0.25° keeps the 0.4° window, its figures being no
    /// better with 0.5°).
    pub fn foliage_params(&self) -> FoliageParams {
        let mut p = self.foliage;
        if p.source == ScanSource::Sick
            && let Ok((_, step_deg)) = self.sick.mode()
        {
            p.window_rad = p.window_rad.max((step_deg as f32).to_radians());
        }
        p
    }

    /// The foliage classifier's step: [`Config::foliage_params`] with `robot.mount` for the
    /// VLP-16's scan; a SICK's scan comes with its own mount (`sick.mount`) applied by its
    /// driver.
    pub fn scan_step(&self) -> Result<ScanStep, StepError> {
        let params = self.foliage_params();
        let step = ScanStep::new(params, seconds_ns(params.odom_max_age_s))?;
        Ok(match params.source {
            ScanSource::Velodyne => step.with_mount(&self.robot.mount),
            ScanSource::Sick => step,
        })
    }

    /// The most returns a `lidar/scan2d` sample (and so a `foliage/alarm` one) holds: the
    /// VLP-16's longest scan, or the SICK model's field at its finest step.
    pub fn scan_capacity(&self) -> usize {
        match self.foliage.source {
            ScanSource::Velodyne => {
                let asm = mimnav_velodyne::revolution::AssemblerConfig::from_config(&self.velodyne);
                mimnav_velodyne::revolution::max_scan_len(
                    self.velodyne.rpm,
                    asm.max_duration_ns as f64 * 1e-9,
                )
            }
            ScanSource::Sick => self.sick.max_returns(),
        }
    }
}

#[cfg(test)]
mod tests;
