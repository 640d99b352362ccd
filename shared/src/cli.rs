//! The command-line options every service shares, so they read the same way everywhere.

use std::path::PathBuf;

use crate::config::{ConfigError, Load};

/// `--config FILE` and `--set KEY=VALUE`, for `#[command(flatten)]` into a service's arguments;
/// they also give every service the closing paragraph of its `--help`.
#[derive(Debug, Clone, clap::Args)]
#[command(after_help = SERVICE_AFTER_HELP)]
pub struct ServiceArgs {
    /// The stack's config file [default: /etc/mimnav/mimnav.toml if it exists, else built-in
    /// defaults].
    #[arg(long, env = "MIMNAV_CONFIG")]
    pub config: Option<PathBuf>,
    /// Override one config key, e.g. --set velodyne.rpm=900 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

/// What every service's `--help` ends with: stopping and shared memory (issue 23, item 10).
pub const SERVICE_AFTER_HELP: &str = "\
SIGTERM or SIGINT ends the service cleanly (exit status 0), removing its shared memory.

Shared memory: on start, the service removes what dead nodes of its iceoryx2 domain (processes \
killed before they could clean up) left in /dev/shm and under the root path, and logs it at INFO; \
a service restarted after a SIGKILL thus frees what it left. Nothing it creates is writable by \
other users: iceoryx2's global management segment, which iceoryx2 creates with mode 0666 whatever \
the umask, is set to 0660 by the process that created it.";

impl ServiceArgs {
    /// The config these options name, with `extra` overrides applied after the `--set` ones.
    pub fn load<C: Load>(&self, extra: &[String]) -> Result<C, ConfigError> {
        let mut sets = self.set.clone();
        sets.extend_from_slice(extra);
        C::resolve(self.config.as_deref(), &sets)
    }
}

impl ServiceArgs {
    /// [`ServiceArgs::load`] for `service`'s `main`: a bad config is printed as
    /// `service: file: what` and becomes exit status 2.
    pub fn load_or_exit<C: Load>(
        &self,
        service: &str,
        extra: &[String],
    ) -> Result<C, std::process::ExitCode> {
        self.load(extra).map_err(|e| {
            stderr_line(format_args!("{service}: {e}"));
            std::process::ExitCode::from(2)
        })
    }
}

/// The exit status of a service's run: its own on success; on an error, the error chain is logged,
/// printed as `service: …` and the status is 1 (so systemd's `Restart=on-failure` acts on it).
pub fn finish<E: std::fmt::Display>(
    service: &str,
    result: Result<std::process::ExitCode, E>,
) -> std::process::ExitCode {
    match result {
        Ok(code) => code,
        Err(e) => {
            tracing::error!("{e:#}");
            stderr_line(format_args!("{service}: {e:#}"));
            std::process::ExitCode::from(1)
        }
    }
}

/// Writes a line to stdout, ignoring a failure: for a service's report of a run that is over,
/// whose exit status must not depend on whether anyone still reads it.
pub fn stdout_line(line: std::fmt::Arguments<'_>) {
    use std::io::Write;
    let _ = writeln!(std::io::stdout().lock(), "{line}");
}

/// Writes a line to stderr, ignoring a failure: a service whose stderr is closed exits with its
/// own status, not with eprintln!'s panic (101).
pub fn stderr_line(line: std::fmt::Arguments<'_>) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr().lock(), "{line}");
}

/// A clap value parser for a duration in seconds: above 0, at most a day.
pub fn seconds_arg(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v <= 86_400.0 => Ok(v),
        _ => Err(format!("{s} is out of range: allowed above 0 to 86400")),
    }
}
