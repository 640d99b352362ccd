//! The systemd deployment: the units as `mimnav install` places them, checked by
//! `systemd-analyze`, and the whole stack under a real systemd *user* manager.
//!
//! The manager is started the safe way (docs/testing.md, "The safe recipe"): never as PID 1, in a
//! private mount namespace with a private `/run`, in an empty cgroup of its own (a user manager
//! moves every process of the cgroup it starts in into its `init.scope`), and driven with
//! `systemctl --user` through its private socket. The user-mode units are generated from the
//! installed system units by [`user_unit`], line by line, so there is no second copy to keep.

use std::io::Write;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use mimnav_config::Config;
use mimnav_shared::ipc::{self, PrivateDomain};
use mimnav_shared::topics::{Goal, Odometry, VelocityCommand, command_status};

use crate::util::{bin_dir, root};

const SERVICES: [&str; 4] = ["velodyne", "mapper", "foliage", "planner"];
/// Every unit `mimnav install` installs: the stack's services and the bases' (enabled per robot).
const UNITS: [&str; 9] = [
    "velodyne", "mapper", "foliage", "planner", "kobuki", "spot", "view", "zenoh", "sick",
];

/// A temporary folder removed when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> TempDir {
        let d = std::env::temp_dir().join(format!("mimnav-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("temp dir");
        TempDir(d)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn which(cmd: &str) -> Option<PathBuf> {
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join(cmd))
            .find(|p| p.is_file())
    })
}

/// `mimnav install --root DIR` with the workspace's binaries: what a robot owner runs.
fn install(root_dir: &Path) -> Output {
    Command::new(crate::util::bin("mimnav"))
        .arg("install")
        .arg("--root")
        .arg(root_dir)
        .arg("--bin-dir")
        .arg(bin_dir())
        .output()
        .expect("run mimnav install")
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// A systemd user manager started the safe way, and the user-mode units.
mod manager;
/// The whole stack under the user manager: runs, restarts, stops; logs to the journal.
mod stack;
/// The test's subscribers on every topic, and a stand-in odometry and goal.
mod taps;
/// `mimnav install`, `systemd-analyze verify` and `security`, sysusers and tmpfiles.
mod units;
