//! Logging setup: `tracing` to stderr, filtered by the config's `log.level` or the `MIMNAV_LOG`
//! environment variable; iceoryx2's own messages arrive through `tracing` too (its `tracing`
//! feature), with its level set to match so it does not format what would be filtered out.

use tracing_subscriber::EnvFilter;
use tracing_subscriber::filter::LevelFilter;

/// Environment variable that overrides the configured filter.
pub const LOG_ENV: &str = "MIMNAV_LOG";

/// Installs the global subscriber. `level` is the configured filter (`log.level`); a bad filter
/// falls back to `info` with a warning. Calling it twice keeps the first subscriber.
pub fn init(level: &str) {
    let (filter, bad) = match std::env::var(LOG_ENV) {
        Ok(v) if !v.is_empty() => match EnvFilter::try_new(&v) {
            Ok(f) => (f, None),
            Err(e) => (EnvFilter::new("info"), Some(format!("{LOG_ENV}={v}: {e}"))),
        },
        _ => match EnvFilter::try_new(level) {
            Ok(f) => (f, None),
            Err(e) => (
                EnvFilter::new("info"),
                Some(format!("log.level = {level:?}: {e}")),
            ),
        },
    };
    let max = filter.max_level_hint().unwrap_or(LevelFilter::TRACE);
    let ansi = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let installed = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(ansi)
        .try_init()
        .is_ok();
    if installed {
        iceoryx2::prelude::set_log_level(iceoryx2_level(max));
    }
    if let Some(bad) = bad {
        tracing::warn!("invalid log filter, using `info`: {bad}");
    }
}

fn iceoryx2_level(max: LevelFilter) -> iceoryx2::prelude::LogLevel {
    use iceoryx2::prelude::LogLevel;
    match max {
        LevelFilter::TRACE => LogLevel::Trace,
        LevelFilter::DEBUG => LogLevel::Debug,
        LevelFilter::INFO => LogLevel::Info,
        LevelFilter::WARN => LogLevel::Warn,
        _ => LogLevel::Error,
    }
}
