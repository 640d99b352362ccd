//! The systemd deployment: the units as `mimnav install` places them, checked by
//! `systemd-analyze`, and the whole stack under a real systemd *user* manager.
//!
//! The manager is started the safe way (README, "Testing under systemd"): never as PID 1, in a
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

use mimnav_shared::config::Config;
use mimnav_shared::ipc::{self, PrivateDomain};
use mimnav_shared::topics::{Goal, Odometry, VelocityCommand, command_status};

use crate::util::{bin_dir, root};

const SERVICES: [&str; 4] = ["velodyne", "mapper", "foliage", "planner"];

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

#[test]
fn install_places_every_file_and_keeps_an_edited_config() {
    let t = TempDir::new("install");
    let o = install(&t.0);
    assert!(o.status.success(), "{}", text(&o));
    for s in SERVICES {
        let unit =
            t.0.join(format!("usr/lib/systemd/system/mimnav-{s}.service"));
        let repo = root().join(format!("systemd/system/mimnav-{s}.service"));
        assert_eq!(
            std::fs::read_to_string(&unit).expect("unit"),
            std::fs::read_to_string(&repo).expect("repo unit"),
            "{s}: the installed unit is the repository's"
        );
        let b = t.0.join(format!("usr/bin/mimnav-{s}"));
        let mode = std::fs::metadata(&b).expect("binary").permissions().mode();
        assert_eq!(mode & 0o777, 0o755, "{}", b.display());
    }
    for f in [
        "usr/bin/mimnav",
        "usr/lib/systemd/system/mimnav.target",
        "usr/lib/sysusers.d/mimnav.conf",
        "usr/lib/tmpfiles.d/mimnav.conf",
        "etc/mimnav/robots/spot.toml",
        "etc/mimnav/robots/turtlebot2.toml",
    ] {
        assert!(t.0.join(f).is_file(), "{f} installed");
    }
    // the deployed config parses, with iceoryx2's root under /run (tmpfiles.d makes it)
    let etc = t.0.join("etc/mimnav/mimnav.toml");
    let config = Config::resolve(Some(&etc), &[]).expect("the installed config parses");
    assert_eq!(
        config.iceoryx2.global.root_path().to_string(),
        "/run/mimnav/iceoryx2/"
    );
    let tmpfiles = std::fs::read_to_string(t.0.join("usr/lib/tmpfiles.d/mimnav.conf")).unwrap();
    assert!(
        tmpfiles
            .lines()
            .any(|l| l.starts_with("d")
                && l.split_whitespace().nth(1) == Some("/run/mimnav/iceoryx2")),
        "{tmpfiles}"
    );
    // a second install keeps the owner's edits and leaves the shipped config beside them
    std::fs::write(&etc, "# mine\n").expect("edit");
    let o = install(&t.0);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(std::fs::read_to_string(&etc).unwrap(), "# mine\n");
    assert!(t.0.join("etc/mimnav/mimnav.toml.dist").is_file());
    assert!(text(&o).contains("kept"), "{}", text(&o));
    // a missing binary is named, and nothing is half-installed from a wrong folder
    let o = Command::new(crate::util::bin("mimnav"))
        .args(["install", "--root"])
        .arg(t.0.join("other"))
        .arg("--bin-dir")
        .arg(&t.0)
        .output()
        .expect("run");
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).contains("mimnav-velodyne"), "{}", text(&o));
    assert!(!t.0.join("other").exists());
}

/// A root for `systemd-analyze verify --root`: the installed units, with the targets they name.
fn verify_root(tag: &str) -> Option<TempDir> {
    if which("systemd-analyze").is_none() {
        println!("SKIP {tag}: no systemd-analyze on this machine");
        return None;
    }
    let t = TempDir::new(tag);
    let o = install(&t.0);
    assert!(o.status.success(), "{}", text(&o));
    // verify resolves the units a unit pulls in; an empty unit file would count as masked
    for target in ["sysinit", "basic", "shutdown", "network", "multi-user"] {
        let p = t.0.join(format!("usr/lib/systemd/system/{target}.target"));
        std::fs::write(p, "[Unit]\nDescription=stub for verify\n").expect("stub");
    }
    Some(t)
}

fn verify(root_dir: &Path, unit: &str) -> Output {
    Command::new("systemd-analyze")
        .arg("verify")
        .arg(format!("--root={}", root_dir.display()))
        .arg("--man=no")
        .arg(unit)
        .output()
        .expect("run systemd-analyze verify")
}

#[test]
fn systemd_analyze_verify_passes_every_unit_without_a_warning() {
    let Some(t) = verify_root("verify") else {
        return;
    };
    for unit in SERVICES
        .iter()
        .map(|s| format!("mimnav-{s}.service"))
        .chain(["mimnav.target".to_string()])
    {
        let o = verify(&t.0, &unit);
        // verify exits 0 on warnings (an unknown key is "ignoring"): the output must be empty
        assert!(
            o.status.success() && text(&o).trim().is_empty(),
            "{unit}: {} {}",
            o.status,
            text(&o)
        );
    }
    // and it does see a broken unit: an unknown key and a bad value
    let mapper = t.0.join("usr/lib/systemd/system/mimnav-mapper.service");
    let good = std::fs::read_to_string(&mapper).unwrap();
    std::fs::write(
        &mapper,
        good.replace("WatchdogSec=2s", "WatchdogSecs=2s\nProtectHome=maybe"),
    )
    .unwrap();
    let out = text(&verify(&t.0, "mimnav-mapper.service"));
    assert!(out.contains("WatchdogSecs"), "{out}");
    assert!(out.contains("protect home"), "{out}");
}

#[test]
fn every_unit_is_exposed_at_most_3_of_10() {
    if which("systemd-analyze").is_none() {
        println!("SKIP security exposure: no systemd-analyze on this machine");
        return;
    }
    for s in SERVICES {
        let unit = root().join(format!("systemd/system/mimnav-{s}.service"));
        let o = Command::new("systemd-analyze")
            .args(["security", "--offline=yes", "--no-pager"])
            .arg(&unit)
            .output()
            .expect("run systemd-analyze security");
        let out = text(&o);
        let Some(level) = out
            .lines()
            .find_map(|l| l.split("Overall exposure level for ").nth(1))
            .and_then(|rest| rest.split(": ").nth(1))
            .and_then(|v| v.split_whitespace().next())
            .and_then(|v| v.parse::<f64>().ok())
        else {
            panic!("no exposure level for {s}: {out}");
        };
        println!("mimnav-{s}.service exposure {level}");
        assert!(level <= 3.0, "mimnav-{s}: {level}\n{out}");
    }
}

#[test]
fn sysusers_and_tmpfiles_entries_make_the_user_and_the_runtime_folder() {
    let (Some(_), Some(_)) = (which("systemd-sysusers"), which("systemd-tmpfiles")) else {
        println!("SKIP sysusers/tmpfiles: systemd-sysusers or systemd-tmpfiles missing");
        return;
    };
    let t = TempDir::new("sysusers");
    let o = install(&t.0);
    assert!(o.status.success(), "{}", text(&o));
    std::fs::create_dir_all(t.0.join("etc")).unwrap();
    let o = Command::new("systemd-sysusers")
        .arg(format!("--root={}", t.0.display()))
        .arg("mimnav.conf")
        .output()
        .expect("run systemd-sysusers");
    assert!(o.status.success(), "{}", text(&o));
    let passwd = std::fs::read_to_string(t.0.join("etc/passwd")).expect("passwd");
    let line = passwd
        .lines()
        .find(|l| l.starts_with("mimnav:"))
        .unwrap_or_else(|| panic!("no mimnav user: {passwd}"));
    let uid: u32 = line.split(':').nth(2).unwrap().parse().unwrap();
    assert!(uid < 1000, "a system user: {line}");
    // tmpfiles chowns to the new user, which needs root
    // SAFETY: geteuid has no preconditions
    if unsafe { libc::geteuid() } != 0 {
        println!("SKIP tmpfiles --create: not root");
        return;
    }
    // a stand-in for the PM QoS device, which the z line hands to the mimnav group
    std::fs::create_dir_all(t.0.join("dev")).unwrap();
    std::fs::write(t.0.join("dev/cpu_dma_latency"), b"").unwrap();
    let o = Command::new("systemd-tmpfiles")
        .arg(format!("--root={}", t.0.display()))
        .args(["--create", "mimnav.conf"])
        .output()
        .expect("run systemd-tmpfiles");
    assert!(o.status.success(), "{}", text(&o));
    let meta = std::fs::metadata(t.0.join("run/mimnav/iceoryx2")).expect("runtime folder");
    use std::os::unix::fs::MetadataExt;
    assert_eq!(meta.uid(), uid);
    assert_eq!(meta.mode() & 0o777, 0o750);
    let group = std::fs::read_to_string(t.0.join("etc/group")).expect("group");
    let gid: u32 = group
        .lines()
        .find(|l| l.starts_with("mimnav:"))
        .and_then(|l| l.split(':').nth(2))
        .and_then(|g| g.parse().ok())
        .unwrap_or_else(|| panic!("no mimnav group: {group}"));
    let dev = std::fs::metadata(t.0.join("dev/cpu_dma_latency")).expect("device stand-in");
    assert_eq!(dev.uid(), 0, "the device stays root's");
    assert_eq!(
        dev.gid(),
        gid,
        "the mimnav group may write the PM QoS device"
    );
    assert_eq!(dev.mode() & 0o777, 0o660);
}

// ---------------------------------------------------------------------------------------------
// Under a real systemd user manager

/// The user-mode variant of a system unit: no `User=`/`Group=` (a user manager cannot switch
/// identity), the installed binary and config with the test's iceoryx2 location, the test's
/// runtime folder in place of `/run/mimnav`, and the log in a file (there is no journal).
fn user_unit(
    system: &str,
    service: &str,
    exec: &str,
    run_dir: &Path,
    log: &Path,
    drop_protect_home: bool,
) -> String {
    let mut out = String::new();
    let (mut exec_done, mut rw_done) = (false, false);
    let exec_from = format!("ExecStart=/usr/bin/mimnav-{service} --config /etc/mimnav/mimnav.toml");
    for line in system.lines() {
        let key = line.split('=').next().unwrap_or("");
        match key {
            "User" | "Group" => continue,
            "ProtectHome" if drop_protect_home => continue,
            "ReadWritePaths" if line == "ReadWritePaths=/run/mimnav" => {
                out.push_str(&format!("ReadWritePaths={}\n", run_dir.display()));
                rw_done = true;
            }
            "ExecStart" if line == exec_from => {
                out.push_str(&format!("ExecStart={exec}\n"));
                out.push_str(&format!("StandardOutput=append:{}\n", log.display()));
                out.push_str("StandardError=inherit\nEnvironment=MIMNAV_LOG=info\n");
                exec_done = true;
            }
            _ => {
                out.push_str(line);
                out.push('\n');
            }
        }
    }
    assert!(exec_done, "{service}: no `{exec_from}` line to rewrite");
    assert!(
        rw_done,
        "{service}: no `ReadWritePaths=/run/mimnav` line to rewrite"
    );
    out
}

/// Why the systemd test cannot run here, if it cannot.
fn cannot_run() -> Result<(PathBuf, PathBuf), String> {
    // SAFETY: geteuid has no preconditions
    if unsafe { libc::geteuid() } != 0 {
        return Err("needs root (a mount namespace and a cgroup of its own)".into());
    }
    for cmd in ["unshare", "systemctl", "mount", "mknod", "mkfifo"] {
        if which(cmd).is_none() {
            return Err(format!("no `{cmd}` on this machine"));
        }
    }
    let systemd = ["/lib/systemd/systemd", "/usr/lib/systemd/systemd"]
        .iter()
        .map(PathBuf::from)
        .find(|p| p.is_file())
        .ok_or("no systemd binary (/lib/systemd/systemd)")?;
    let fs_type = |p: &str| {
        let c = std::ffi::CString::new(p).unwrap();
        let mut st = std::mem::MaybeUninit::<libc::statfs>::uninit();
        // SAFETY: statfs writes into the buffer it is given
        (unsafe { libc::statfs(c.as_ptr(), st.as_mut_ptr()) } == 0)
            // SAFETY: statfs succeeded
            .then(|| unsafe { st.assume_init() }.f_type)
    };
    const CGROUP2_MAGIC: libc::c_long = 0x6367_7270;
    let v2 = ["/sys/fs/cgroup", "/sys/fs/cgroup/unified"]
        .into_iter()
        .find(|p| fs_type(p) == Some(CGROUP2_MAGIC as _))
        .ok_or("no cgroup2 hierarchy")?;
    Ok((systemd, PathBuf::from(v2)))
}

/// A throwaway `systemd --user`, in its own cgroup and mount namespace; ended when dropped.
struct Manager {
    child: Child,
    t: PathBuf,
    cgroup: PathBuf,
    exited: bool,
}

impl Manager {
    fn start(t: &Path, systemd: &Path, v2: &Path) -> Result<Manager, String> {
        let own = std::fs::read_to_string("/proc/self/cgroup")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find_map(|l| l.strip_prefix("0::").map(str::to_string))
            })
            .ok_or("no cgroup2 line in /proc/self/cgroup")?;
        let cgroup = v2
            .join(own.trim_start_matches('/'))
            .join(format!("mimnav-e2e-systemd-{}", std::process::id()));
        if let Err(e) = std::fs::create_dir(&cgroup) {
            return Err(format!("cannot make a cgroup {}: {e}", cgroup.display()));
        }
        let script = r#"
            echo $$ > "$CGDIR/cgroup.procs"
            mount -t tmpfs -o mode=0755 tmpfs /run
            mkdir -p /run/systemd/system /run/systemd/inaccessible
            cd /run/systemd/inaccessible
            mkdir -m 0 dir; : > reg; chmod 0 reg; mkfifo -m 0 fifo
            mknod -m 0 chr c 0 0; mknod -m 0 blk b 0 0
            cd /
            [ "$V2" = /sys/fs/cgroup ] || mount --bind "$V2" /sys/fs/cgroup
            [ ! -e /dev/console ] || mount --bind /dev/null /dev/console
            s=$SYSTEMD; unset CGDIR V2 SYSTEMD
            exec "$s" --user --log-target=null --unit=mimnav-test-idle.target
        "#;
        let out = std::fs::File::create(t.join("manager.out")).map_err(|e| e.to_string())?;
        let child = Command::new("unshare")
            .args([
                "--mount",
                "--propagation",
                "private",
                "--",
                "/bin/sh",
                "-ec",
                script,
            ])
            .env_clear()
            .env("PATH", "/usr/sbin:/usr/bin:/sbin:/bin")
            .env("HOME", t.join("home"))
            .env("XDG_RUNTIME_DIR", t.join("runtime"))
            .env("XDG_CONFIG_HOME", t.join("config"))
            .env("CGDIR", &cgroup)
            .env("V2", v2)
            .env("SYSTEMD", systemd)
            .stdin(Stdio::null())
            .stdout(out.try_clone().map_err(|e| e.to_string())?)
            .stderr(out)
            .spawn()
            .map_err(|e| {
                let _ = std::fs::remove_dir(&cgroup);
                format!("cannot run unshare: {e}")
            })?;
        let mut m = Manager {
            child,
            t: t.to_path_buf(),
            cgroup,
            exited: false,
        };
        let until = Instant::now() + Duration::from_secs(15);
        loop {
            if let Ok(Some(status)) = m.child.try_wait() {
                m.exited = true;
                return Err(format!(
                    "the user manager ended at once ({status}): {}",
                    std::fs::read_to_string(t.join("manager.out")).unwrap_or_default()
                ));
            }
            if t.join("runtime/systemd/private").exists() {
                let state = m.systemctl(&["show", "-p", "SystemState", "--value"]);
                let state = String::from_utf8_lossy(&state.stdout).trim().to_string();
                if state == "running" || state == "degraded" {
                    return Ok(m);
                }
            }
            if Instant::now() > until {
                return Err("the user manager did not come up within 15 s".into());
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    fn systemctl(&self, args: &[&str]) -> Output {
        Command::new("systemctl")
            .arg("--user")
            .args(args)
            .env("XDG_RUNTIME_DIR", self.t.join("runtime"))
            .env_remove("DBUS_SESSION_BUS_ADDRESS")
            .stdin(Stdio::null())
            .output()
            .expect("run systemctl")
    }

    fn prop(&self, unit: &str, name: &str) -> String {
        let o = self.systemctl(&["show", "-p", name, "--value", unit]);
        String::from_utf8_lossy(&o.stdout).trim().to_string()
    }

    fn main_pid(&self, unit: &str) -> i32 {
        self.prop(unit, "MainPID").parse().unwrap_or(0)
    }

    /// PIDs still in the manager's cgroup tree (the manager's own included).
    fn pids(&self) -> Vec<i32> {
        let mut pids = Vec::new();
        let mut dirs = vec![self.cgroup.clone()];
        while let Some(d) = dirs.pop() {
            if let Ok(s) = std::fs::read_to_string(d.join("cgroup.procs")) {
                pids.extend(s.lines().filter_map(|l| l.parse::<i32>().ok()));
            }
            if let Ok(rd) = std::fs::read_dir(&d) {
                dirs.extend(rd.flatten().map(|e| e.path()).filter(|p| p.is_dir()));
            }
        }
        pids
    }

    /// `systemctl --user exit`; true when the manager is gone within 5 s.
    fn exit(&mut self) -> bool {
        let _ = self.systemctl(&["exit"]);
        let until = Instant::now() + Duration::from_secs(5);
        while Instant::now() < until {
            if let Ok(Some(_)) = self.child.try_wait() {
                self.exited = true;
                return true;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        false
    }
}

impl Drop for Manager {
    fn drop(&mut self) {
        if !self.exited && !self.exit() {
            let pid = self.child.id() as libc::pid_t;
            // SAFETY: the manager is our child and not reaped yet
            unsafe { libc::kill(pid, libc::SIGTERM) };
            std::thread::sleep(Duration::from_millis(500));
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
        // whatever is still in our cgroup was started by our manager
        for pid in self.pids() {
            // SAFETY: kill(2) on a process in the cgroup this test made for its own manager
            unsafe { libc::kill(pid, libc::SIGKILL) };
        }
        for _ in 0..50 {
            let mut dirs = Vec::new();
            let mut stack = vec![self.cgroup.clone()];
            while let Some(d) = stack.pop() {
                if let Ok(rd) = std::fs::read_dir(&d) {
                    stack.extend(rd.flatten().map(|e| e.path()).filter(|p| p.is_dir()));
                }
                dirs.push(d);
            }
            for d in dirs.iter().rev() {
                let _ = std::fs::remove_dir(d);
            }
            if !self.cgroup.exists() {
                break;
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }
}

/// The test's view of every topic: the time and the count of what arrived.
struct Taps {
    _node: iceoryx2::prelude::Node<ipc::Svc>,
    points: ipc::PointsSubscriber,
    scan: ipc::ScanSubscriber,
    layers: ipc::LayersSubscriber,
    plan: ipc::PlanSubscriber,
    foliage: ipc::FoliageSubscriber,
    cmd: ipc::ValueSubscriber<VelocityCommand>,
    /// Topic name → (samples, time of the last one).
    seen: Vec<(&'static str, u64, Option<Instant>)>,
    /// Every command with its arrival time.
    cmds: Vec<(Instant, VelocityCommand)>,
}

const TOPICS: [&str; 6] = [
    "lidar/points",
    "lidar/scan2d",
    "map/layers",
    "map/plan",
    "foliage/alarm",
    "cmd_vel",
];

/// Which topic shows that a service is working again.
fn output_of(service: &str) -> &'static str {
    match service {
        "velodyne" => "lidar/points",
        "mapper" => "map/plan",
        "foliage" => "foliage/alarm",
        _ => "cmd_vel",
    }
}

impl Taps {
    fn open(config: &Config) -> Taps {
        let node = ipc::node(config, "e2e-systemd-tap").expect("node");
        Taps {
            points: ipc::points_subscriber(&node).expect("points"),
            scan: ipc::scan_subscriber(&node).expect("scan"),
            layers: ipc::layers_subscriber(&node).expect("layers"),
            plan: ipc::plan_subscriber(&node).expect("plan"),
            foliage: ipc::foliage_subscriber(&node).expect("foliage"),
            cmd: ipc::cmd_vel_subscriber(&node).expect("cmd_vel"),
            _node: node,
            seen: TOPICS.iter().map(|&t| (t, 0, None)).collect(),
            cmds: Vec::new(),
        }
    }

    fn mark(&mut self, i: usize, n: u64, now: Instant) {
        if n > 0 {
            self.seen[i].1 += n;
            self.seen[i].2 = Some(now);
        }
    }

    /// Drains every topic once.
    fn poll(&mut self) {
        fn drain<F: FnMut() -> bool>(mut f: F) -> u64 {
            let mut n = 0;
            while f() {
                n += 1;
            }
            n
        }
        let now = Instant::now();
        let n = drain(|| matches!(self.points.receive(), Ok(Some(_))));
        self.mark(0, n, now);
        let n = drain(|| matches!(self.scan.receive(), Ok(Some(_))));
        self.mark(1, n, now);
        let n = drain(|| matches!(self.layers.receive(), Ok(Some(_))));
        self.mark(2, n, now);
        let n = drain(|| matches!(self.plan.receive(), Ok(Some(_))));
        self.mark(3, n, now);
        let n = drain(|| matches!(self.foliage.receive(), Ok(Some(_))));
        self.mark(4, n, now);
        let mut n = 0;
        while let Ok(Some(c)) = self.cmd.receive() {
            self.cmds.push((now, c));
            n += 1;
        }
        self.mark(5, n, now);
    }

    fn count(&self, topic: &str) -> u64 {
        self.seen.iter().find(|s| s.0 == topic).map_or(0, |s| s.1)
    }

    /// Polls until `done(self)` or `timeout`; the time it took, or None.
    fn until(
        &mut self,
        timeout: Duration,
        mut done: impl FnMut(&Taps) -> bool,
    ) -> Option<Duration> {
        let t0 = Instant::now();
        while t0.elapsed() < timeout {
            self.poll();
            if done(self) {
                return Some(t0.elapsed());
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        None
    }
}

/// Publishes a standing robot's odometry (20 Hz) and a goal 5 m ahead (every 0.5 s, so a
/// restarted planner has it again), as a robot base and an operator would.
fn odom_and_goal(config: Config, stop: Arc<AtomicBool>) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        let node = ipc::node(&config, "e2e-systemd-base").expect("node");
        let odom = ipc::odom_publisher(&node).expect("odom");
        let goal = ipc::goal_publisher(&node).expect("goal");
        let mut k = 0u64;
        while !stop.load(Ordering::Relaxed) {
            let now = ipc::monotonic_ns();
            let _ = odom.publish(Odometry {
                seq: k,
                stamp_ns: ipc::realtime_ns(),
                rx_mono_ns: now,
                ..Odometry::default()
            });
            if k.is_multiple_of(10) {
                let _ = goal.publish(Goal {
                    seq: k / 10,
                    stamp_mono_ns: now,
                    x: 5.0,
                    y: 0.0,
                    tolerance_m: 0.3,
                });
            }
            k += 1;
            std::thread::sleep(Duration::from_millis(50));
        }
    })
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// True when `pid` is gone (or a zombie).
fn gone(pid: i32) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Err(_) => true,
        Ok(s) => {
            s.rsplit(')')
                .next()
                .and_then(|r| r.split_whitespace().next())
                == Some("Z")
        }
    }
}

#[test]
fn the_stack_runs_restarts_and_stops_under_a_real_systemd_user_manager() {
    // the services asked to run under SCHED_FIFO (the driver replays a capture, paced)
    const REALTIME: [&str; 2] = ["mapper", "planner"];
    let (systemd, v2) = match cannot_run() {
        Ok(x) => x,
        Err(why) => {
            println!("SKIP the stack under systemd: {why}");
            return;
        }
    };
    let t = TempDir::new("e2e-systemd");
    let run_dir = t.0.join("run");
    for d in [
        "home",
        "runtime",
        "config/systemd/user",
        "run/iceoryx2",
        "logs",
    ] {
        std::fs::create_dir_all(t.0.join(d)).expect("folder");
    }
    std::fs::set_permissions(t.0.join("runtime"), std::fs::Permissions::from_mode(0o700)).unwrap();
    // what a robot owner installs, under a root of our own
    let inst = t.0.join("install");
    let o = install(&inst);
    assert!(o.status.success(), "{}", text(&o));

    // the services' iceoryx2 location is ours too: the test subscribes beside them
    let domain = PrivateDomain {
        root: run_dir.join("iceoryx2"),
        prefix: format!("mtsd{}_", std::process::id()),
    };
    let config = domain
        .apply(Config::resolve(Some(&inst.join("etc/mimnav/mimnav.toml")), &[]).expect("config"));
    let home_like = |p: &Path| {
        ["/home", "/root", "/run/user"]
            .iter()
            .any(|h| p.starts_with(h))
    };
    let drop_protect_home = home_like(&t.0) || home_like(&root());
    let capture = root().join("captures/scenario2_curtain_door.pcap");
    let units = t.0.join("config/systemd/user");
    for s in SERVICES {
        let system = std::fs::read_to_string(
            inst.join(format!("usr/lib/systemd/system/mimnav-{s}.service")),
        )
        .expect("installed unit");
        let mut exec = format!(
            "{}/usr/bin/mimnav-{s} --config {}/etc/mimnav/mimnav.toml \
             '--set=iceoryx2.global.root-path=\"{}\"' '--set=iceoryx2.global.prefix=\"{}\"'",
            inst.display(),
            inst.display(),
            domain.root_str(),
            domain.prefix
        );
        if s == "velodyne" {
            exec.push_str(&format!(
                " '--set=velodyne.input=\"pcap\"' '--set=velodyne.pcap=\"{}\"' \
                 --set=velodyne.replay_loop=true",
                capture.display()
            ));
        }
        if REALTIME.contains(&s) {
            exec.push_str(" --set=latency.realtime_priority=5");
        }
        let log = t.0.join(format!("logs/{s}.log"));
        let unit = user_unit(&system, s, &exec, &run_dir, &log, drop_protect_home);
        std::fs::write(units.join(format!("mimnav-{s}.service")), unit).expect("unit");
    }
    std::fs::copy(
        inst.join("usr/lib/systemd/system/mimnav.target"),
        units.join("mimnav.target"),
    )
    .expect("target");
    // the manager boots into nothing, so the host's enabled user units stay off
    std::fs::write(
        units.join("mimnav-test-idle.target"),
        "[Unit]\nDescription=mimnav test: nothing\nDefaultDependencies=no\n",
    )
    .expect("idle target");
    // can a process without capabilities have SCHED_FIFO through LimitRTPRIO= here, as the
    // services do? (not where the manager may not raise RLIMIT_RTPRIO: no CAP_SYS_RESOURCE, as in
    // some containers; nor where RT group scheduling gives its cgroups no real-time runtime)
    let chrt = which("chrt");
    if let Some(chrt) = &chrt {
        std::fs::write(
            units.join("mimnav-test-rt.service"),
            format!(
                "[Unit]\nDescription=mimnav test: can a unit without capabilities run SCHED_FIFO\n\
                 [Service]\nType=oneshot\nPrivateUsers=yes\nLimitRTPRIO=99\n\
                 ExecStart={} -f 5 /bin/true\n",
                chrt.display()
            ),
        )
        .expect("probe unit");
    }

    let mut manager = match Manager::start(&t.0, &systemd, &v2) {
        Ok(m) => m,
        Err(why) => {
            println!("SKIP the stack under systemd: {why}");
            return;
        }
    };
    let logs = || {
        SERVICES
            .iter()
            .map(|s| {
                let l =
                    std::fs::read_to_string(t.0.join(format!("logs/{s}.log"))).unwrap_or_default();
                let tail: Vec<&str> = l.lines().rev().take(8).collect();
                format!(
                    "--- {s}:\n{}",
                    tail.into_iter().rev().collect::<Vec<_>>().join("\n")
                )
            })
            .collect::<Vec<_>>()
            .join("\n")
    };
    let mut report = std::io::stdout().lock();
    let mut taps = Taps::open(&config);
    let stop = Arc::new(AtomicBool::new(false));
    let base = odom_and_goal(config.clone(), stop.clone());

    // 1. start: systemctl waits for every READY=1 (Type=notify)
    let t0 = Instant::now();
    let o = manager.systemctl(&["start", "mimnav.target"]);
    assert!(o.status.success(), "{}\n{}", text(&o), logs());
    writeln!(report, "start mimnav.target: {:.0} ms", ms(t0.elapsed())).unwrap();
    for s in SERVICES {
        let u = format!("mimnav-{s}.service");
        assert_eq!(manager.prop(&u, "ActiveState"), "active", "{u}\n{}", logs());
        let exec: f64 = manager
            .prop(&u, "ExecMainStartTimestampMonotonic")
            .parse()
            .unwrap();
        let ready: f64 = manager
            .prop(&u, "ActiveEnterTimestampMonotonic")
            .parse()
            .unwrap();
        writeln!(
            report,
            "{u}: start → READY {:.0} ms, status \"{}\"",
            (ready - exec) / 1e3,
            manager.prop(&u, "StatusText")
        )
        .unwrap();
        assert!(ready >= exec, "{u}");
    }
    // real-time scheduling where the config asks for it: the unit lets an unprivileged process
    // have it (RestrictRealtime=no, LimitRTPRIO=, sched_setscheduler allowed)
    let rt_possible = chrt.is_some()
        && manager
            .systemctl(&["start", "mimnav-test-rt.service"])
            .status
            .success();
    for s in SERVICES {
        if !rt_possible {
            println!(
                "SKIP real-time scheduling under the units: `chrt -f 5` fails in a unit with \
                 PrivateUsers=yes and LimitRTPRIO=99 too (no CAP_SYS_RESOURCE to raise the \
                 limit, or RT group scheduling)"
            );
            break;
        }
        let u = format!("mimnav-{s}.service");
        let pid = manager.main_pid(&u);
        // SAFETY: sched_getscheduler has no preconditions; a wrong pid gives -1
        let policy = unsafe { libc::sched_getscheduler(pid) };
        let fifo = policy & !libc::SCHED_RESET_ON_FORK == libc::SCHED_FIFO;
        assert_eq!(
            fifo,
            REALTIME.contains(&s),
            "{u}: policy {policy}\n{}",
            logs()
        );
    }
    // data through every topic
    let flowing = taps.until(Duration::from_secs(10), |t| {
        TOPICS.iter().all(|topic| t.count(topic) >= 3)
    });
    assert!(
        flowing.is_some(),
        "data on every topic: {:?}\n{}",
        taps.seen,
        logs()
    );
    // the planner drives (or is blocked), it is not stale: there are a map, odometry and a goal
    let fresh = |c: &VelocityCommand| c.status != command_status::STALE_INPUT;
    assert!(
        taps.until(Duration::from_secs(3), |t| t
            .cmds
            .last()
            .is_some_and(|(_, c)| fresh(c)))
            .is_some(),
        "commands: {:?}",
        taps.cmds.iter().rev().take(3).collect::<Vec<_>>()
    );

    // a signal that only interrupts a wait (SIGCONT, as after a debugger) stops nothing
    let pids: Vec<i32> = SERVICES
        .iter()
        .map(|s| manager.main_pid(&format!("mimnav-{s}.service")))
        .collect();
    for &pid in &pids {
        // SAFETY: kill(2) on the main process of a unit of our own manager
        unsafe { libc::kill(pid, libc::SIGCONT) };
    }
    taps.poll();
    let counts: Vec<u64> = TOPICS.iter().map(|t| taps.count(t)).collect();
    let still = taps.until(Duration::from_secs(3), |t| {
        TOPICS
            .iter()
            .zip(&counts)
            .all(|(topic, &n)| t.count(topic) >= n + 3)
    });
    for (s, &pid) in SERVICES.iter().zip(&pids) {
        let u = format!("mimnav-{s}.service");
        assert_eq!(
            manager.main_pid(&u),
            pid,
            "{u} still runs after SIGCONT\n{}",
            logs()
        );
    }
    assert!(still.is_some(), "data after SIGCONT: {:?}", taps.seen);

    // 2. SIGKILL each service in turn: systemd restarts it and its output flows again
    for s in SERVICES {
        let u = format!("mimnav-{s}.service");
        let old = manager.main_pid(&u);
        let n0: u32 = manager.prop(&u, "NRestarts").parse().unwrap();
        assert!(old > 0, "{u} has a main PID");
        taps.poll();
        let topic = output_of(s);
        // SAFETY: kill(2) on the main process of a unit of our own manager
        let t_kill = Instant::now();
        unsafe { libc::kill(old, libc::SIGKILL) };
        while !gone(old) && t_kill.elapsed() < Duration::from_secs(1) {
            std::thread::sleep(Duration::from_millis(1));
        }
        taps.poll(); // what was sent before the kill
        let before = taps.count(topic);
        let cmds_before = taps.cmds.len();
        let mut stale_after = None;
        let back = taps.until(Duration::from_secs(5), |t| {
            if s == "mapper" && stale_after.is_none() {
                stale_after = t.cmds[cmds_before..]
                    .iter()
                    .find(|(_, c)| c.status == command_status::STALE_INPUT)
                    .map(|(at, _)| at.duration_since(t_kill));
            }
            t.count(topic) > before
        });
        let new = manager.main_pid(&u);
        let n1: u32 = manager.prop(&u, "NRestarts").parse().unwrap();
        let Some(_) = back else {
            panic!(
                "{u}: no {topic} within 5 s of SIGKILL (NRestarts {n0}→{n1})\n{}",
                logs()
            );
        };
        let took = t_kill.elapsed();
        writeln!(
            report,
            "SIGKILL {u}: restarted (pid {old} → {new}), {topic} again after {:.0} ms",
            ms(took)
        )
        .unwrap();
        assert_eq!(n1, n0 + 1, "{u}: one restart");
        assert!(new != old && new > 0, "{u}: a new process");
        assert!(
            took <= Duration::from_secs(1),
            "{u}: data again after {took:?}"
        );
        if s == "mapper" {
            let stale = stale_after.expect("a stale-input command while the mapper was down");
            writeln!(
                report,
                "  while the mapper was down: zero velocity, stale input, {:.0} ms after the kill",
                ms(stale)
            )
            .unwrap();
            assert!(stale <= Duration::from_millis(200), "stale after {stale:?}");
            let c = taps.cmds[cmds_before..]
                .iter()
                .find(|(_, c)| c.status == command_status::STALE_INPUT)
                .map(|(_, c)| *c)
                .unwrap();
            assert_eq!((c.v, c.omega), (0.0, 0.0));
        }
    }
    // the planner's status names the stale input while it lasts: stop the mapper for a moment
    let o = manager.systemctl(&["stop", "mimnav-mapper.service"]);
    assert!(o.status.success(), "{}", text(&o));
    let stale_status = (0..100).find_map(|_| {
        let st = manager.prop("mimnav-planner.service", "StatusText");
        if st.starts_with("stale input") {
            Some(st)
        } else {
            std::thread::sleep(Duration::from_millis(10));
            None
        }
    });
    writeln!(
        report,
        "planner status with the mapper stopped: {stale_status:?}"
    )
    .unwrap();
    assert!(stale_status.is_some_and(|s| s.contains("no map")));
    let o = manager.systemctl(&["start", "mimnav-mapper.service"]);
    assert!(o.status.success(), "{}", text(&o));

    // 3. a hung loop (SIGSTOP): the watchdog kills it, systemd restarts it
    let u = "mimnav-mapper.service";
    let old = manager.main_pid(u);
    let n0: u32 = manager.prop(u, "NRestarts").parse().unwrap();
    let t_stop = Instant::now();
    // SAFETY: kill(2) on the main process of a unit of our own manager
    unsafe { libc::kill(old, libc::SIGSTOP) };
    let mut result = String::new();
    while !gone(old) && t_stop.elapsed() < Duration::from_secs(6) {
        std::thread::sleep(Duration::from_millis(10));
    }
    let killed_after = t_stop.elapsed();
    for _ in 0..30 {
        let r = manager.prop(u, "Result");
        if r != "success" {
            result = r;
            break;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    taps.poll();
    let before = taps.count("map/plan");
    let back = taps.until(Duration::from_secs(5), |t| t.count("map/plan") > before);
    let n1: u32 = manager.prop(u, "NRestarts").parse().unwrap();
    writeln!(
        report,
        "SIGSTOP {u}: killed by the watchdog after {:.0} ms (Result={}), map/plan again after {:.0} ms",
        ms(killed_after),
        if result.is_empty() { "not caught" } else { &result },
        ms(t_stop.elapsed())
    )
    .unwrap();
    // WatchdogSec=2s counts from the last ping (every 0.5 s), not from SIGSTOP
    assert!(
        (1.4..4.0).contains(&killed_after.as_secs_f64()),
        "killed after {killed_after:?}\n{}",
        logs()
    );
    assert!(result.is_empty() || result == "watchdog", "Result={result}");
    assert!(
        back.is_some(),
        "map/plan after the watchdog restart\n{}",
        logs()
    );
    assert_eq!(n1, n0 + 1);

    // 4. stop: SIGTERM ends every service cleanly within a second
    let pids: Vec<i32> = SERVICES
        .iter()
        .map(|s| manager.main_pid(&format!("mimnav-{s}.service")))
        .collect();
    let t_stop = Instant::now();
    let o = manager.systemctl(&["stop", "mimnav.target"]);
    assert!(o.status.success(), "{}", text(&o));
    let all_gone = (0..200).any(|_| {
        if pids.iter().all(|&p| gone(p)) {
            return true;
        }
        std::thread::sleep(Duration::from_millis(5));
        false
    });
    let stopped_after = t_stop.elapsed();
    writeln!(
        report,
        "stop mimnav.target: every service gone after {:.0} ms",
        ms(stopped_after)
    )
    .unwrap();
    assert!(
        all_gone && stopped_after <= Duration::from_secs(1),
        "{stopped_after:?}"
    );
    for s in SERVICES {
        let u = format!("mimnav-{s}.service");
        let until = Instant::now() + Duration::from_secs(2);
        while manager.prop(&u, "ActiveState") != "inactive" && Instant::now() < until {
            std::thread::sleep(Duration::from_millis(10));
        }
        assert_eq!(manager.prop(&u, "ActiveState"), "inactive", "{u}");
        // a clean exit (status 0 on SIGTERM), not a kill after TimeoutStopSec=
        assert_eq!(manager.prop(&u, "Result"), "success", "{u}\n{}", logs());
        assert_eq!(manager.prop(&u, "ExecMainStatus"), "0", "{u}");
    }
    stop.store(true, Ordering::Relaxed);
    base.join().expect("odometry thread");
    drop(taps);

    // 5. nothing left: no service process, no iceoryx2 node, no shared memory but the one
    // global management segment iceoryx2 keeps per prefix by design (removed with the domain)
    let manager_pid = manager.child.id() as i32;
    let left: Vec<i32> = manager
        .pids()
        .into_iter()
        .filter(|&p| p != manager_pid)
        .collect();
    assert!(left.is_empty(), "processes left: {left:?}");
    let mut nodes = Vec::new();
    let _ = iceoryx2::prelude::Node::<ipc::Svc>::list(&config.iceoryx2, |state| {
        nodes.push(format!("{state:?}"));
        iceoryx2::prelude::CallbackProgression::Continue
    });
    assert!(nodes.is_empty(), "nodes left: {nodes:?}");
    let shm: Vec<String> = std::fs::read_dir("/dev/shm")
        .map(|rd| {
            rd.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.starts_with(&domain.prefix) && !n.ends_with("global_mgmt"))
                .collect()
        })
        .unwrap_or_default();
    assert!(shm.is_empty(), "shared memory left: {shm:?}");
    assert!(manager.exit(), "the user manager exits");
    drop(manager);
    drop(domain);
}

#[test]
fn with_stderr_on_the_journal_a_service_logs_to_the_journal_or_says_why_not() {
    use std::os::unix::fs::MetadataExt;
    let t = TempDir::new("journal");
    let err_path = t.0.join("stderr");
    let err = std::fs::File::create(&err_path).expect("stderr file");
    let meta = std::fs::metadata(&err_path).expect("meta");
    let domain = PrivateDomain::new("e2ejournal");
    let mut p = crate::util::Proc::start(
        Command::new(crate::util::bin("mimnav-foliage"))
            .args(crate::util::config_args(&domain))
            .env("JOURNAL_STREAM", format!("{}:{}", meta.dev(), meta.ino()))
            .env_remove("MIMNAV_LOG")
            .stderr(err),
    );
    std::thread::sleep(Duration::from_millis(500));
    let status = p
        .terminate(Duration::from_secs(2))
        .expect("stops on SIGTERM");
    assert!(status.success(), "{status}");
    let out = std::fs::read_to_string(&err_path).expect("read");
    if Path::new("/run/systemd/journal/socket").exists() {
        // the events went to the journal, not to the stream
        assert!(!out.contains("topics open"), "{out}");
    } else {
        assert!(out.contains("cannot open the journal's socket"), "{out}");
        assert!(out.contains("topics open"), "{out}");
        // the journal stamps lines itself: no timestamps, no colours
        for line in out.lines() {
            assert!(!line.starts_with(|c: char| c.is_ascii_digit()), "{line}");
            assert!(!line.contains('\u{1b}'), "{line}");
        }
    }
}
