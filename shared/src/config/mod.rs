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
//! Every key has a documented default (see the README's config table); unknown keys, wrong types
//! and out-of-range values are errors that name the file, the key and what is allowed.
//! `--set key.path=value` on a service's command line overrides one key (the value is TOML; a
//! bare word is taken as a string).
//!
//! Each section is a module here ([`velodyne`], [`map`], [`mapper`], [`planner`], [`foliage`],
//! [`sim`], [`robot`], [`log`], [`latency`]) holding its type, its defaults and its `validate()`,
//! which returns an [`Invalid`]: every value refused as a [`ParamError`] naming the key and what
//! is allowed. These types are the algorithm libraries' parameters, defined once: the libraries
//! take them as they are (the foliage classifier's `FoliageParams` is [`foliage::FoliageParams`];
//! the mapper, planner, simulator and driver hold their sections beside the grid and the robot
//! profile) rather than copying them into types of their own. They live in `shared`, below every
//! service, because [`Config`] composes them: one file is checked whole, rules tie sections
//! together ([`Config::validate`]), and each service reads the sections it needs.

mod check;
pub mod foliage;
mod iceoryx2;
pub mod latency;
pub mod log;
pub mod map;
pub mod mapper;
pub mod planner;
pub mod robot;
pub mod sim;
pub mod velodyne;

use std::fmt;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use serde::de::DeserializeOwned;

pub use check::{Allowed, Checks, Invalid, ParamError};

/// A duration key in seconds as nanoseconds (truncated; `as` takes a negative or NaN value to 0,
/// which validation refuses anyway).
pub fn seconds_ns(seconds: f64) -> u64 {
    (seconds * 1e9) as u64
}
pub use foliage::FoliageParams;
pub use iceoryx2::{DEFAULT_IOX2_PREFIX, DEFAULT_IOX2_ROOT};
use iceoryx2::{iceoryx2_config, project_iceoryx2_defaults};
pub use latency::LatencyConfig;
pub use log::LogConfig;
pub use map::MapConfig;
pub use mapper::{LayerConfig, LayerUnit, MapperConfig};
pub use planner::{Inflation, PlannerConfig};
pub use robot::RobotProfile;
pub use sim::{SimConfig, SimReturnMode};
pub use velodyne::{ScanReturnSelect, VelodyneConfig, VelodyneInput};

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

pub(super) fn err(source: impl fmt::Display, message: impl Into<String>) -> ConfigError {
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
    pub iceoryx2: ::iceoryx2::config::Config,
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
    pub foliage: FoliageParams,
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
    foliage: FoliageParams,
    latency: LatencyConfig,
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
            foliage: FoliageParams::default(),
            latency: LatencyConfig::default(),
        }
    }
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
        config.validate().map_err(|e| err(&source, e.to_string()))?;
        Ok(config)
    }

    /// Checks every section and the rules between sections: every value refused, each naming
    /// its key and what is allowed.
    pub fn validate(&self) -> Result<(), Invalid> {
        let mut r = Checks::default();
        r.merge(self.robot.validate());
        r.merge(self.velodyne.validate());
        r.merge(self.map.validate());
        r.merge(self.sim.validate());
        r.merge(self.mapper.validate());
        r.merge(self.planner.validate());
        r.merge(self.foliage.validate());
        r.merge(self.latency.validate());
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
    fn a_section_checked_alone_gives_typed_errors() {
        let v = VelodyneConfig {
            rpm: 50.0,
            ..VelodyneConfig::default()
        };
        let e = v.validate().expect_err("rpm");
        assert_eq!(
            e.get("velodyne.rpm"),
            Some(&ParamError::OutOfRange {
                key: "velodyne.rpm".into(),
                value: 50.0,
                allowed: Allowed::closed(300.0, 1200.0),
            })
        );
        assert_eq!(Config::default().validate(), Ok(()));
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
