//! `[iceoryx2]`: iceoryx2's own config, with the project's root path and prefix.

use serde::Deserialize;

use super::{ConfigError, err};

/// Root path of iceoryx2's files unless the config says otherwise. Not under iceoryx2's default
/// `/tmp/iceoryx2/`, so mimnav never meets another application's services; the systemd units
/// use a path under `/run` instead (a private `/tmp` would hide it).
pub const DEFAULT_IOX2_ROOT: &str = "/tmp/mimnav/iceoryx2/";
/// Prefix of iceoryx2's files unless the config says otherwise.
pub const DEFAULT_IOX2_PREFIX: &str = "mimnav_";

pub(crate) fn project_iceoryx2_defaults() -> iceoryx2::config::Config {
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
pub(crate) fn iceoryx2_config(
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
