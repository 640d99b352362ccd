use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use mimnav_shared::ipc::{self, Listening, PointsSubscriber, PrivateDomain, Svc};
use mimnav_shared::topics::PointsHeader;

/// Folder of the workspace's binaries: beside the test executable's `deps/` folder, or
/// `MIMNAV_BIN_DIR`.
pub fn bin_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("MIMNAV_BIN_DIR") {
        return PathBuf::from(d);
    }
    let exe = std::env::current_exe().expect("test executable path");
    exe.parent()
        .and_then(|d| d.parent())
        .expect("target dir")
        .to_path_buf()
}

/// A workspace binary; panics with the build command when it is missing.
pub fn bin(name: &str) -> PathBuf {
    let p = bin_dir().join(name);
    assert!(
        p.is_file(),
        "{} is missing: run `cargo build --workspace` first",
        p.display()
    );
    p
}

/// `../shared/data/velodyne`, or None after printing a SKIP line.
pub fn velodyne_data(test: &str) -> Option<PathBuf> {
    let dir = match std::env::var_os("MIMNAV_SHARED_DATA") {
        Some(d) => PathBuf::from(d).join("velodyne"),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/velodyne"),
    };
    if dir.join("README.md").is_file() {
        Some(dir)
    } else {
        println!(
            "SKIP {test}: no shared VLP-16 captures at {}",
            dir.display()
        );
        None
    }
}

/// Point counts per frame from a reference `NAME.frames.csv`.
pub fn reference_counts(dir: &std::path::Path, name: &str) -> Vec<u32> {
    let text = std::fs::read_to_string(dir.join(format!("reference/{name}.frames.csv")))
        .expect("frames.csv");
    text.lines()
        .skip(1)
        .map(|l| {
            l.split(',')
                .nth(1)
                .expect("n_points")
                .parse()
                .expect("number")
        })
        .collect()
}

/// A child process killed when dropped.
pub struct Proc(pub Child);

impl Proc {
    pub fn start(cmd: &mut Command) -> Proc {
        Proc(cmd.stdin(Stdio::null()).spawn().expect("spawn"))
    }

    /// SIGTERM, then wait up to `within` for the exit status.
    pub fn terminate(&mut self, within: Duration) -> Option<std::process::ExitStatus> {
        // SAFETY: kill(2) on the pid of a child this test started and has not reaped.
        unsafe { libc::kill(self.0.id() as libc::pid_t, libc::SIGTERM) };
        self.wait(within)
    }

    pub fn wait(&mut self, within: Duration) -> Option<std::process::ExitStatus> {
        let until = Instant::now() + within;
        while Instant::now() < until {
            if let Ok(Some(s)) = self.0.try_wait() {
                return Some(s);
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        None
    }
}

impl Drop for Proc {
    /// SIGTERM first, so a service cleans up its shared memory; SIGKILL if it does not stop.
    fn drop(&mut self) {
        if self.0.try_wait().ok().flatten().is_none()
            && self.terminate(Duration::from_secs(2)).is_none()
        {
            let _ = self.0.kill();
        }
        let _ = self.0.wait();
    }
}

/// A test's view of `lidar/points` in its private domain.
pub struct PointsTap {
    pub sub: PointsSubscriber,
    _node: iceoryx2::prelude::Node<Svc>,
}

/// What a tap collected.
#[derive(Debug, Default)]
pub struct Collected {
    pub headers: Vec<PointsHeader>,
    /// Points per revolution, as received.
    pub counts: Vec<usize>,
    pub end_of_stream: bool,
}

impl PointsTap {
    pub fn open(domain: &PrivateDomain) -> PointsTap {
        let node = ipc::node(&domain.config(), "e2e-tap").expect("node");
        let sub = ipc::points_subscriber(&node).expect("subscriber");
        PointsTap { sub, _node: node }
    }

    /// Receives until end of stream, `stop(&collected)` says so, or `timeout`.
    pub fn collect(
        &self,
        timeout: Duration,
        mut stop: impl FnMut(&Collected) -> bool,
    ) -> Collected {
        let mut c = Collected::default();
        let until = Instant::now() + timeout;
        while Instant::now() < until {
            let heard = self.sub.heard_within(Duration::from_millis(50));
            while let Some(sample) = self.sub.receive().expect("receive") {
                let h = *sample.user_header();
                assert_eq!(
                    h.point_count as usize,
                    sample.payload().len(),
                    "header matches payload"
                );
                c.headers.push(h);
                c.counts.push(sample.payload().len());
            }
            if heard.end_of_stream {
                c.end_of_stream = true;
                // samples sent before the notification are already in the buffer
                while let Some(sample) = self.sub.receive().expect("receive") {
                    c.headers.push(*sample.user_header());
                    c.counts.push(sample.payload().len());
                }
                break;
            }
            if stop(&c) {
                break;
            }
        }
        c
    }
}

/// Removes a test's temporary file even when an assertion fails first.
pub struct TempFile(pub PathBuf);

impl Drop for TempFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// A loopback UDP port free right now (bound and released: another process could take it, which
/// on a test machine it does not).
pub fn free_udp_port() -> u16 {
    let s = std::net::UdpSocket::bind("127.0.0.1:0").expect("bind");
    s.local_addr().expect("addr").port()
}

/// A loopback TCP port free right now (bound and released, as [`free_udp_port`]).
pub fn free_tcp_port() -> u16 {
    let l = std::net::TcpListener::bind("127.0.0.1:0").expect("bind");
    l.local_addr().expect("addr").port()
}

/// The repository's top folder.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The shipped `config/mimnav.toml`.
pub fn shipped_config() -> PathBuf {
    root().join("config/mimnav.toml")
}

/// `mimnav demo` with the shipped config on the bundled world `world` (a file name under
/// `config/worlds/`) and `extra` options, writing its map to a temporary PNG: its stdout, after
/// asserting it reached the goal, and the PNG (removed when dropped).
pub fn demo_to_goal(world: &str, extra: &[&str]) -> (String, TempFile) {
    static RUN: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    let n = RUN.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let png =
        TempFile(std::env::temp_dir().join(format!("mimnav-demo-{}-{n}.png", std::process::id())));
    let out = Command::new(bin("mimnav"))
        .arg("--config")
        .arg(shipped_config())
        .arg("demo")
        .args(extra)
        .arg("--world")
        .arg(shipped_config().with_file_name(format!("worlds/{world}")))
        .arg("--out")
        .arg(&png.0)
        .output()
        .expect("run mimnav demo");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("goal_reached"), "{stdout}");
    (stdout, png)
}

/// `--config` with the shipped config and the `--set` options of a private domain.
pub fn config_args(domain: &mimnav_shared::ipc::PrivateDomain) -> Vec<String> {
    let mut a = vec!["--config".into(), shipped_config().display().to_string()];
    a.extend(domain.set_args());
    a
}

/// `--config` and `--set` arguments shared by the driver and the simulator of one test.
pub fn stack_args(domain: &PrivateDomain, data_port: u16, position_port: u16) -> Vec<String> {
    let mut a = config_args(domain);
    for s in [
        "velodyne.input=\"udp\"".to_string(),
        "velodyne.bind_address=\"127.0.0.1\"".into(),
        format!("velodyne.data_port={data_port}"),
        format!("velodyne.position_port={position_port}"),
        "sim.udp_target=\"127.0.0.1\"".into(),
    ] {
        a.extend(["--set".into(), s]);
    }
    a
}

/// The environment variable naming a Python that has iceoryx2's binding (`pip install
/// iceoryx2==0.10.0`); `.ci/run` sets it.
pub const PYTHON_ENV: &str = "MIMNAV_PYTHON";

/// A Python that imports `iceoryx2`: `MIMNAV_PYTHON`, else `target/iox2-venv/bin/python` (the venv
/// `.ci/run` makes). None after printing a SKIP line when there is neither; a `MIMNAV_PYTHON` that
/// cannot import iceoryx2 fails the test instead, so CI (which sets it) never skips.
pub fn python_with_iceoryx2(test: &str) -> Option<PathBuf> {
    python_with(
        test,
        PYTHON_ENV,
        "iox2-venv",
        "iceoryx2",
        "iceoryx2==0.10.0",
    )
}

/// A Python that imports `modules` (comma-separated, as `import` takes them): the one the
/// environment variable `env` names, else `target/VENV/bin/python` (a venv `.ci/run` makes and
/// names in `env`). None after printing a SKIP line when there is neither; a Python `env` names
/// that cannot import them fails the test (`pip install PACKAGES` into it), so CI never skips.
pub fn python_with(
    test: &str,
    env: &str,
    venv: &str,
    modules: &str,
    packages: &str,
) -> Option<PathBuf> {
    let (python, explicit) = match std::env::var_os(env) {
        Some(p) => (PathBuf::from(p), true),
        None => (root().join("target").join(venv).join("bin/python"), false),
    };
    let imports = Command::new(&python)
        .args(["-c", &format!("import {modules}")])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    match (imports, explicit) {
        (true, _) => Some(python),
        (false, true) => panic!(
            "{env}={} cannot import {modules}: `pip install {packages}` into it",
            python.display()
        ),
        (false, false) => {
            println!(
                "SKIP {test}: no Python with {modules} at {} (run .ci/run, or set {env})",
                python.display()
            );
            None
        }
    }
}

/// `python` with the Python client (`clients/python`) on its path and no `__pycache__` left in
/// the tree.
pub fn python_command(py: &std::path::Path) -> Command {
    let mut c = Command::new(py);
    c.env("PYTHONPATH", root().join("clients/python"))
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .arg("-u");
    c
}

/// The lines `r` gives, on a channel, read by a thread of their own.
pub fn lines_of(r: impl std::io::Read + Send + 'static) -> std::sync::mpsc::Receiver<String> {
    use std::io::BufRead;
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(r).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    rx
}

/// Lines until one satisfies `hit` (true) or `within` passes (false); all kept in `seen`.
pub fn wait_until(
    rx: &std::sync::mpsc::Receiver<String>,
    hit: impl Fn(&str) -> bool,
    within: Duration,
    seen: &mut Vec<String>,
) -> bool {
    let until = Instant::now() + within;
    while let Some(left) = until.checked_duration_since(Instant::now()) {
        match rx.recv_timeout(left) {
            Ok(l) => {
                let found = hit(&l);
                seen.push(l);
                if found {
                    return true;
                }
            }
            Err(_) => return false,
        }
    }
    false
}
