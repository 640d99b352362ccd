//! Starting the services as child processes and stopping them.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};

/// Finds a service binary: beside this executable (a cargo build or an install), else on PATH.
pub fn service_binary(name: &str) -> Result<PathBuf> {
    let exe = std::env::current_exe().context("cannot find the mimnav executable's path")?;
    if let Some(dir) = exe.parent() {
        let beside = dir.join(name);
        if beside.is_file() {
            return Ok(beside);
        }
    }
    if let Some(paths) = std::env::var_os("PATH") {
        for dir in std::env::split_paths(&paths) {
            let p = dir.join(name);
            if p.is_file() {
                return Ok(p);
            }
        }
    }
    bail!(
        "`{name}` is neither beside {} nor on PATH; build every binary with \
         `cargo build --release --workspace`",
        exe.display()
    )
}

/// A child process that is stopped (SIGTERM, then SIGKILL after a grace time) when dropped.
pub struct Service {
    name: String,
    child: Child,
    status: Option<ExitStatus>,
}

impl Service {
    /// Starts `binary` with `args`; its stdout and stderr go to ours.
    pub fn start(binary: &Path, args: &[String]) -> Result<Self> {
        let name = binary
            .file_name()
            .map_or_else(|| "service".into(), |n| n.to_string_lossy().into_owned());
        let child = Command::new(binary)
            .args(args)
            .spawn()
            .with_context(|| format!("cannot start {}", binary.display()))?;
        Ok(Service {
            name,
            child,
            status: None,
        })
    }

    /// The binary's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The exit status, if it has exited.
    pub fn exited(&mut self) -> Option<ExitStatus> {
        if self.status.is_none() {
            self.status = self.child.try_wait().ok().flatten();
        }
        self.status
    }

    /// Asks it to stop (SIGTERM) and waits up to `grace`, then kills it.
    pub fn stop(&mut self, grace: Duration) -> Option<ExitStatus> {
        if self.exited().is_some() {
            return self.status;
        }
        // SAFETY: kill(2) on the pid of a child we started and have not reaped.
        unsafe { libc::kill(self.child.id() as libc::pid_t, libc::SIGTERM) };
        let until = Instant::now() + grace;
        while Instant::now() < until {
            if self.exited().is_some() {
                return self.status;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        let _ = self.child.kill();
        self.status = self.child.wait().ok();
        self.status
    }
}

impl Drop for Service {
    fn drop(&mut self) {
        self.stop(Duration::from_secs(2));
    }
}
