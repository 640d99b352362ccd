//! Starting the services as child processes and stopping them.
//!
//! A child never outlives the `mimnav` process that started it (issue 23, item 9): each is started
//! with a parent-death signal (`prctl(PR_SET_PDEATHSIG, SIGTERM)`), so when `mimnav` ends in any
//! way — SIGKILL included — the kernel sends the child SIGTERM, and the service ends cleanly
//! (removing its shared memory). The kernel sends that signal when the *thread* that started
//! the child exits, not the process: start children only from the main thread, or from a thread
//! that lives as long as they should.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdout, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use std::os::unix::process::CommandExt;

use anyhow::{Context, Result, bail};

/// The signal a child receives when the thread that started it ends.
pub const PARENT_DEATH_SIGNAL: libc::c_int = libc::SIGTERM;

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

/// How a child is started.
#[derive(Debug, Clone, Copy, Default)]
pub struct Options {
    /// Put the child in a process group of its own, so that a Ctrl-C on the terminal (SIGINT to
    /// the foreground group) reaches only `mimnav`, which then stops its children in the order
    /// it chooses. Without it, the child gets the terminal's signals as `mimnav` does.
    pub own_process_group: bool,
    /// Read the child's stdout through [`Service::read_stdout`] instead of sharing ours.
    pub piped_stdout: bool,
}

/// A child process that is stopped (SIGTERM, then SIGKILL after a grace time) when dropped, and
/// that gets SIGTERM from the kernel should this process die first.
pub struct Service {
    name: String,
    child: Child,
    status: Option<ExitStatus>,
    stdout: Option<ChildStdout>,
}

/// The command that starts `binary` with `args` as `options` say, with the parent-death signal.
fn command(binary: &Path, args: &[String], options: Options) -> Command {
    let mut command = Command::new(binary);
    command.args(args).stdin(Stdio::null());
    if options.piped_stdout {
        command.stdout(Stdio::piped());
    }
    if options.own_process_group {
        command.process_group(0);
    }
    let parent = std::process::id() as libc::pid_t;
    // SAFETY: the closure runs in the forked child before exec and calls only prctl(2) and
    // getppid(2), which are async-signal-safe; it allocates nothing.
    unsafe {
        command.pre_exec(move || {
            if libc::prctl(libc::PR_SET_PDEATHSIG, PARENT_DEATH_SIGNAL as libc::c_ulong) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            // the parent may have died between fork and prctl: then no signal would come
            if libc::getppid() != parent {
                return Err(std::io::Error::from_raw_os_error(libc::ESRCH));
            }
            Ok(())
        });
    }
    command
}

impl Service {
    /// Starts `binary` with `args`; its stdout and stderr go to ours, and it shares our process
    /// group. Call it from the main thread (see the module's documentation).
    pub fn start(binary: &Path, args: &[String]) -> Result<Self> {
        Self::start_with(binary, args, Options::default())
    }

    /// Starts `binary` with `args` as `options` say. Call it from the main thread (see the
    /// module's documentation).
    pub fn start_with(binary: &Path, args: &[String], options: Options) -> Result<Self> {
        let name = binary
            .file_name()
            .map_or_else(|| "service".into(), |n| n.to_string_lossy().into_owned());
        let mut child = command(binary, args, options)
            .spawn()
            .with_context(|| format!("cannot start {}", binary.display()))?;
        let stdout = child.stdout.take();
        Ok(Service {
            name,
            child,
            status: None,
            stdout,
        })
    }

    /// The process id.
    pub fn id(&self) -> u32 {
        self.child.id()
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

    /// Everything the child wrote to its stdout (started with [`Options::piped_stdout`]), read
    /// until it closes it: call after the child has exited. Empty otherwise.
    pub fn read_stdout(&mut self) -> String {
        let mut out = String::new();
        if let Some(mut s) = self.stdout.take() {
            let _ = s.read_to_string(&mut out);
        }
        out
    }

    /// Sends SIGTERM, unless it has exited; does not wait.
    pub fn terminate(&mut self) {
        if self.exited().is_none() {
            // SAFETY: kill(2) on the pid of a child we started and have not reaped.
            unsafe { libc::kill(self.child.id() as libc::pid_t, libc::SIGTERM) };
        }
    }

    /// Waits up to `within` for it to exit.
    pub fn wait(&mut self, within: Duration) -> Option<ExitStatus> {
        let until = Instant::now() + within;
        loop {
            if self.exited().is_some() || Instant::now() >= until {
                return self.status;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    /// Asks it to stop (SIGTERM) and waits up to `grace`, then kills it.
    pub fn stop(&mut self, grace: Duration) -> Option<ExitStatus> {
        self.terminate();
        if self.wait(grace).is_some() {
            return self.status;
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

#[cfg(test)]
mod tests {
    use std::os::unix::process::ExitStatusExt;

    use super::*;

    /// Issue 23, item 9: a child gets SIGTERM from the kernel when what started it ends. Here
    /// the starter is a thread that ends at once (the kernel's trigger is the starting thread:
    /// the reason `mimnav` starts its children from its main thread), and the child a long sleep.
    #[test]
    fn demo_children_outlive_it_a_child_gets_sigterm_when_its_starter_ends() {
        let sh = Path::new("/bin/sh");
        if !sh.is_file() {
            println!("SKIP: no /bin/sh");
            return;
        }
        let mut child = std::thread::spawn(move || {
            command(
                sh,
                &["-c".into(), "exec sleep 30".into()],
                Options::default(),
            )
            .spawn()
        })
        .join()
        .expect("the starting thread")
        .expect("start sh");
        let until = Instant::now() + Duration::from_secs(5);
        let status = loop {
            if let Some(st) = child.try_wait().expect("try_wait") {
                break Some(st);
            }
            if Instant::now() > until {
                let _ = child.kill();
                let _ = child.wait();
                break None;
            }
            std::thread::sleep(Duration::from_millis(5));
        };
        let status = status.expect("the child still ran 5 s after its starting thread ended");
        assert_eq!(status.signal(), Some(PARENT_DEATH_SIGNAL), "{status:?}");
    }
}
