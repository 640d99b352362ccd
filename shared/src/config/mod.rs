//! The parts of the stack's configuration every process shares, and the file mechanics.
//!
//! One TOML file configures the whole stack (see `config/mimnav.toml`). Each algorithm library
//! owns its own section: its type, defaults and `validate()` live beside the algorithm
//! (`mimnav_velodyne::config`, `mimnav_sim::config`, `mimnav_mapper::config`,
//! `mimnav_planner::config`, `mimnav_foliage::config`), and the crate `mimnav-config`
//! (`config/src/`) composes them with the sections defined here into the file a service loads:
//!
//! - [`robot`]: the robot profile (`robots/NAME.toml` beside the config file, keys overridable),
//!   shared because every library needs the robot;
//! - [`map`]: the robot-centred grid, part of the topic contract;
//! - [`log`], [`latency`] and `[iceoryx2]`: the plumbing every service runs on.
//!
//! [`Common`] holds these; the service skeleton ([`crate::service`]) and the IPC layer take it.
//! Every value refused is a [`ParamError`] naming the key and what is allowed, collected in an
//! [`Invalid`]; a whole file's errors are a [`ConfigError`] naming the file (or `--set` option).

mod check;
mod iceoryx2;
pub mod latency;
pub mod log;
pub mod map;
pub mod robot;

use std::fmt;
use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;

pub use check::{Allowed, Checks, Invalid, ParamError};
pub use iceoryx2::{DEFAULT_IOX2_PREFIX, DEFAULT_IOX2_ROOT};
use iceoryx2::{iceoryx2_config, project_iceoryx2_defaults};
pub use latency::LatencyConfig;
pub use log::LogConfig;
pub use map::MapConfig;
pub use robot::{Body, Disc, RobotProfile, Side};

/// A duration key in seconds as nanoseconds (truncated; `as` takes a negative or NaN value to 0,
/// which validation refuses anyway).
pub fn seconds_ns(seconds: f64) -> u64 {
    (seconds * 1e9) as u64
}

/// The longest config file or robot profile read, bytes (the shipped config is under 10 kB).
pub const MAX_CONFIG_FILE_BYTES: u64 = 1024 * 1024;

/// Reads a config file or robot profile whole, refusing one longer than
/// [`MAX_CONFIG_FILE_BYTES`] (`--config /dev/zero` would otherwise never end): the error says
/// what went wrong, for the caller to name the file.
pub fn read_config_text(path: &Path) -> Result<String, String> {
    use std::io::Read;
    let mut text = String::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(MAX_CONFIG_FILE_BYTES + 1).read_to_string(&mut text))
        .map_err(|e| format!("cannot read: {e}"))?;
    if text.len() as u64 > MAX_CONFIG_FILE_BYTES {
        return Err(format!(
            "the file is longer than {MAX_CONFIG_FILE_BYTES} bytes, the most a config file may be"
        ));
    }
    Ok(text)
}

/// Default location of the stack's config file when a service is started without `--config`.
pub const DEFAULT_CONFIG_PATH: &str = "/etc/mimnav/mimnav.toml";

/// Why the configuration cannot be used.
#[derive(Debug)]
pub struct ConfigError {
    /// The file (or `--set` option) at fault.
    pub source_name: String,
    /// What is wrong, naming the key.
    pub message: String,
    /// The values refused, each a [`ParamError`] naming its key and what is allowed, when that
    /// is what is wrong (not a file that cannot be read or parsed).
    pub invalid: Option<Invalid>,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.source_name, self.message)
    }
}

impl ConfigError {
    /// The values of `source` that `invalid` refuses.
    pub fn invalid(source: impl fmt::Display, invalid: Invalid) -> ConfigError {
        ConfigError {
            source_name: source.to_string(),
            message: invalid.to_string(),
            invalid: Some(invalid),
        }
    }
}

impl std::error::Error for ConfigError {}

/// A [`ConfigError`] of `source` saying `message`.
pub fn err(source: impl fmt::Display, message: impl Into<String>) -> ConfigError {
    ConfigError {
        source_name: source.to_string(),
        message: message.into(),
        invalid: None,
    }
}

/// A whole configuration a service can start from: the stack's composed config
/// (`mimnav_config::Config`) implements it, and the service skeleton loads it.
pub trait Load: Sized + std::ops::Deref<Target = Common> {
    /// The config a service or tool starts with: the file given (`--config` or
    /// `MIMNAV_CONFIG`) must exist; without one, [`DEFAULT_CONFIG_PATH`] if it exists; else the
    /// built-in defaults. `overrides` are `KEY=VALUE` as `--set` gives them.
    fn resolve(explicit: Option<&Path>, overrides: &[String]) -> Result<Self, ConfigError>;
}

/// The sections every process shares.
#[derive(Debug, Clone)]
pub struct Common {
    /// The file it was read from (empty for the built-in defaults).
    pub path: PathBuf,
    /// The robot profile.
    pub robot: RobotProfile,
    /// Logging.
    pub log: LogConfig,
    /// iceoryx2's own settings, with the project's root path and prefix.
    pub iceoryx2: ::iceoryx2::config::Config,
    /// The robot-centred map grid.
    pub map: MapConfig,
    /// The services' latency settings.
    pub latency: LatencyConfig,
}

impl Default for Common {
    fn default() -> Self {
        Common {
            path: PathBuf::new(),
            robot: RobotProfile::default(),
            log: LogConfig::default(),
            iceoryx2: project_iceoryx2_defaults(),
            map: MapConfig::default(),
            latency: LatencyConfig::default(),
        }
    }
}

impl AsMut<Common> for Common {
    fn as_mut(&mut self) -> &mut Common {
        self
    }
}

/// The shared sections as a file gives them, before the robot profile is resolved and the
/// `[iceoryx2]` table is checked against iceoryx2's own config.
#[derive(Debug, Default)]
pub struct CommonTables {
    /// `[robot]` as written (`profile` and overrides).
    pub robot: toml::Table,
    /// `[log]`.
    pub log: LogConfig,
    /// `[iceoryx2]` as written.
    pub iceoryx2: toml::Table,
    /// `[map]`.
    pub map: MapConfig,
    /// `[latency]`.
    pub latency: LatencyConfig,
}

/// `s` as a TOML basic string, quoted and escaped (for building `--set key=value` arguments).
pub fn toml_quote(s: &str) -> String {
    toml::Value::String(s.to_string()).to_string()
}

/// Applies `--set key.path=value` overrides to a file's table; a value is TOML, a bare word is a
/// string.
pub fn apply_overrides(table: &mut toml::Table, overrides: &[String]) -> Result<(), ConfigError> {
    for o in overrides {
        set_key(table, o)?;
    }
    Ok(())
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

/// Deserialises the section `name` of a file from `v`, naming `source` in the error.
pub fn section<T: DeserializeOwned>(
    v: toml::Value,
    name: &str,
    source: &str,
) -> Result<T, ConfigError> {
    T::deserialize(v).map_err(|e| err(source, format!("[{name}]: {}", e.message().trim())))
}

impl Common {
    /// The shared sections of the file at `path` (robot profiles are looked up beside it);
    /// `source` names the file (and `--set`) in errors. Values are not checked here: see
    /// [`Common::validate`].
    pub fn from_tables(
        tables: CommonTables,
        path: &Path,
        source: &str,
    ) -> Result<Common, ConfigError> {
        Ok(Common {
            path: path.to_path_buf(),
            robot: Self::robot(tables.robot, path, source)?,
            log: tables.log,
            iceoryx2: iceoryx2_config(&tables.iceoryx2, source)?,
            map: tables.map,
            latency: tables.latency,
        })
    }

    /// Checks the shared sections: every value refused, each naming its key and what is allowed.
    pub fn validate(&self) -> Result<(), Invalid> {
        let mut r = Checks::default();
        r.merge(self.robot.validate());
        r.merge(self.map.validate());
        r.merge(self.latency.validate());
        r.finish()
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
            let text = read_config_text(&file)
                .map_err(|e| err(source, format!("robot.profile = \"{name}\": {shown}: {e}")))?;
            let parsed: RobotProfile =
                toml::from_str(&text).map_err(|e| err(&shown, e.to_string().trim_end()))?;
            // TOML reads nan and inf: named in the profile file, where they were written
            let mut finite = Checks::default();
            if let Ok(t) = toml::from_str::<toml::Table>(&text) {
                finite.finite_table("robot", &t);
            }
            finite
                .finish()
                .map_err(|e| ConfigError::invalid(&shown, e))?;
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
