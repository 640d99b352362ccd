//! `mimnav-zenoh` between two network namespaces on one machine (issue 25 item 3): the stack and
//! the bridge in namespace A, PyPI's `eclipse-zenoh` (`tests/zenoh_peer.py`) in namespace B,
//! joined by a veth pair. B receives the points and the map plan and decodes them with the
//! documented layouts, sends a goal that must reach the planner and a stop after which
//! `cmd_vel` must stay zero. A second test: with `zenoh.accept_goals = false` nothing B sends
//! reaches `mimnav/goal`. A third: docs/zenoh-robot.json5's mutual TLS and access control let
//! only the operator's certificate steer.
//!
//! Needs root (namespaces) and a Python with `eclipse-zenoh` (`MIMNAV_ZENOH_PYTHON`, which
//! `.ci/run` sets, else `target/zenoh-venv`): a SKIP line otherwise. The namespaces' names are
//! unique per run and only the test's own are deleted, also when an assertion fails (a Drop
//! guard). iceoryx2's shared memory (`/dev/shm`) and its path-based sockets work across
//! network namespaces, so the test process taps the stack's topics from outside.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{ChildStdin, Command, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use mimnav_shared::ipc::{self, Listening, PrivateDomain};
use mimnav_shared::topics::{Goal, Odometry, command_status, goal_flags};
use serde_json::Value;

use crate::util::{Proc, TempFile, bin, lines_of, root, stack_args};

/// The zenoh peer's Python: `MIMNAV_ZENOH_PYTHON`, else `target/zenoh-venv`.
fn python_with_zenoh(test: &str) -> Option<PathBuf> {
    crate::util::python_with(
        test,
        "MIMNAV_ZENOH_PYTHON",
        "zenoh-venv",
        "zenoh",
        "eclipse-zenoh==1.10.2",
    )
}

/// Two network namespaces joined by a veth pair, A at 10.77.N.1 and B at 10.77.N.2 (/24), both
/// with loopback up; deleted (with the veth pair) when dropped.
struct NetnsPair {
    a: String,
    b: String,
    a_ip: String,
}

fn ip(args: &[&str]) -> Result<(), String> {
    let o = Command::new("ip")
        .args(args)
        .output()
        .map_err(|e| format!("ip {}: {e}", args.join(" ")))?;
    match o.status.success() {
        true => Ok(()),
        false => Err(format!(
            "ip {}: {}",
            args.join(" "),
            String::from_utf8_lossy(&o.stderr).trim()
        )),
    }
}

impl NetnsPair {
    /// None after a SKIP line when namespaces cannot be made here (not root, no `ip`).
    fn create(test: &str) -> Option<NetnsPair> {
        static N: AtomicU32 = AtomicU32::new(0);
        // SAFETY: geteuid has no preconditions
        if unsafe { libc::geteuid() } != 0 {
            println!("SKIP {test}: not root (network namespaces)");
            return None;
        }
        let n = N.fetch_add(1, Ordering::Relaxed);
        let tag = format!("{}{n}", std::process::id());
        let pair = NetnsPair {
            a: format!("mimnav-zA{tag}"),
            b: format!("mimnav-zB{tag}"),
            a_ip: format!("10.77.{}.1", n % 250),
        };
        let b_ip = format!("10.77.{}.2", n % 250);
        let (va, vb) = (format!("vzA{tag}"), format!("vzB{tag}"));
        if let Err(e) = ip(&["netns", "add", &pair.a]) {
            println!("SKIP {test}: cannot create a network namespace: {e}");
            return None;
        }
        // from here on, Drop deletes what was made
        let made = (|| {
            ip(&["netns", "add", &pair.b])?;
            ip(&[
                "link", "add", &va, "netns", &pair.a, "type", "veth", "peer", "name", &vb, "netns",
                &pair.b,
            ])?;
            for (ns, dev, addr) in [(&pair.a, &va, &pair.a_ip), (&pair.b, &vb, &b_ip)] {
                ip(&["-n", ns, "addr", "add", &format!("{addr}/24"), "dev", dev])?;
                ip(&["-n", ns, "link", "set", dev, "up"])?;
                ip(&["-n", ns, "link", "set", "lo", "up"])?;
            }
            Ok::<_, String>(())
        })();
        match made {
            Ok(()) => Some(pair),
            Err(e) => {
                println!("SKIP {test}: cannot set up the namespaces: {e}");
                None
            }
        }
    }

    /// `cmd` run inside namespace `ns` (`ip netns exec` execs it: the pid is the program's).
    fn exec(ns: &str, program: &Path) -> Command {
        let mut c = Command::new("ip");
        c.args(["netns", "exec", ns]).arg(program);
        c
    }
}

impl Drop for NetnsPair {
    fn drop(&mut self) {
        for ns in [&self.a, &self.b] {
            if let Err(e) = ip(&["netns", "del", ns]) {
                eprintln!("could not delete {ns}: {e}");
            }
        }
    }
}

/// Odometry number `seq` at `x` m, stamped now: the test standing in for the robot's base.
fn publish_odom(odom: &ipc::ValuePublisher<Odometry>, seq: u64, x: f64) {
    let o = Odometry {
        seq,
        rx_mono_ns: ipc::monotonic_ns(),
        x,
        ..Odometry::default()
    };
    odom.publish(o).expect("publish odom");
}

/// A Zenoh JSON5 config for the bridge: peer, listening on `endpoint` only, no scouting.
pub(crate) fn bridge_config(endpoint: &str) -> TempFile {
    static N: AtomicU32 = AtomicU32::new(0);
    let path = std::env::temp_dir().join(format!(
        "mimnav-zenoh-{}-{}.json5",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    ));
    let text = format!(
        "{{\n  mode: \"peer\",\n  listen: {{ endpoints: [\"{endpoint}\"] }},\n  \
         scouting: {{ multicast: {{ enabled: false }}, gossip: {{ enabled: false }} }},\n}}\n"
    );
    std::fs::write(&path, text).expect("write the Zenoh config");
    TempFile(path)
}

/// The bridge in namespace `ns`, its stderr lines on a channel, once it logged "topics open".
fn start_bridge(
    ns: &str,
    args: &[String],
    sets: &[String],
    all: &mut Vec<String>,
) -> (Proc, Receiver<String>) {
    let mut cmd = NetnsPair::exec(ns, &bin("mimnav-zenoh"));
    cmd.args(args);
    for s in sets {
        cmd.args(["--set", s]);
    }
    let mut p = Proc::start(
        cmd.env("MIMNAV_LOG", "info")
            .stdout(Stdio::null())
            .stderr(Stdio::piped()),
    );
    let rx = lines_of(p.0.stderr.take().expect("stderr"));
    assert!(
        crate::util::wait_until(
            &rx,
            |l| l.contains("topics open"),
            Duration::from_secs(30),
            all
        ),
        "the bridge opens its topics: {all:?}"
    );
    (p, rx)
}

/// The Python peer in namespace `ns`, connected to `endpoint`, subscribed to `topics`.
struct Peer {
    _proc: Proc,
    stdin: ChildStdin,
    lines: Receiver<String>,
    seen: Vec<Value>,
}

impl Peer {
    fn start(python: &Path, ns: &str, endpoint: &str, robot: &str, topics: &[&str]) -> Peer {
        Peer::start_tls(python, ns, endpoint, robot, topics, None)
    }

    /// With `tls` = (folder, name): mutual TLS with the folder's `ca.pem`, `NAME.pem` and
    /// `NAME-key.pem`.
    fn start_tls(
        python: &Path,
        ns: &str,
        endpoint: &str,
        robot: &str,
        topics: &[&str],
        tls: Option<(&Path, &str)>,
    ) -> Peer {
        let mut cmd = NetnsPair::exec(ns, python);
        if let Some((dir, name)) = tls {
            cmd.env("ZENOH_PEER_TLS", format!("{} {name}", dir.display()));
        }
        cmd.env("PYTHONPATH", root().join("clients/python"))
            .env("PYTHONDONTWRITEBYTECODE", "1")
            .arg("-u")
            .arg(root().join("tests/zenoh_peer.py"))
            .args([endpoint, robot])
            .args(topics)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit());
        let mut proc = Proc(cmd.stdin(Stdio::piped()).spawn().expect("spawn the peer"));
        let stdin = proc.0.stdin.take().expect("stdin");
        let lines = lines_of(proc.0.stdout.take().expect("stdout"));
        let mut peer = Peer {
            _proc: proc,
            stdin,
            lines,
            seen: Vec::new(),
        };
        assert!(
            peer.until(Duration::from_secs(20), |v| v["event"] == "open"),
            "the peer opens its session: {:?}",
            peer.seen
        );
        peer
    }

    /// Reads lines until `hit` or `within`; every line is kept in `seen`.
    fn until(&mut self, within: Duration, mut hit: impl FnMut(&Value) -> bool) -> bool {
        let end = Instant::now() + within;
        while let Some(left) = end.checked_duration_since(Instant::now()) {
            let Ok(line) = self.lines.recv_timeout(left) else {
                return false;
            };
            let v: Value = serde_json::from_str(&line)
                .unwrap_or_else(|e| panic!("the peer printed {line:?}: {e}"));
            let done = hit(&v);
            self.seen.push(v);
            if done {
                return true;
            }
        }
        false
    }

    fn send(&mut self, command: &str) {
        writeln!(self.stdin, "{command}").expect("write to the peer");
        let what = command.split_whitespace().next().unwrap_or("").to_string();
        assert!(
            self.until(Duration::from_secs(10), |v| v["event"] == "sent"
                && v["what"] == what.as_str()),
            "the peer sends {command}"
        );
    }

    fn samples(&self, topic: &str) -> Vec<&Value> {
        (self.seen.iter())
            .filter(|v| v["event"] == "sample" && v["topic"] == topic)
            .collect()
    }
}

/// Waits up to `within` for a goal on `sub` that `hit` accepts.
fn goal_within(
    sub: &ipc::ValueSubscriber<Goal>,
    within: Duration,
    hit: impl Fn(&Goal) -> bool,
) -> Option<(Goal, u64)> {
    let end = Instant::now() + within;
    while Instant::now() < end {
        sub.heard_within(Duration::from_millis(20));
        while let Some(g) = sub.receive().expect("receive a goal") {
            if hit(&g) {
                return Some((g, ipc::monotonic_ns()));
            }
        }
    }
    None
}

/// Issue 25 item 3: the points and the map plan reach a host in another namespace over Zenoh and
/// decode there; its goal reaches the planner, and after its stop `cmd_vel` is zero.
#[test]
fn issue25_3_zenoh_peer_in_another_namespace_sees_the_map_and_steers() {
    let test = "zenoh across namespaces";
    let Some(python) = python_with_zenoh(test) else {
        return;
    };
    let Some(net) = NetnsPair::create(test) else {
        return;
    };
    let domain = PrivateDomain::new("zenoh");
    let args = stack_args(&domain, 2368, 8308);
    let robot = format!("t{}", std::process::id());
    let endpoint = format!("tcp/{}:7447", net.a_ip);
    let zconf = bridge_config(&endpoint);
    // the test's own taps, before anything publishes
    let node = ipc::node(&domain.config(), "zenoh-test").expect("node");
    let goals = ipc::goal_subscriber(&node).expect("goal");
    let cmds = ipc::cmd_vel_subscriber(&node).expect("cmd_vel");

    let world = root().join("config/worlds/open_field.toml");
    let service = |name: &str| {
        Proc::start(
            NetnsPair::exec(&net.a, &bin(name))
                .args(&args)
                .stdout(Stdio::null())
                .stderr(Stdio::null()),
        )
    };
    let _driver = service("mimnav-velodyne");
    let _mapper = service("mimnav-mapper");
    let _planner = service("mimnav-planner");
    let mut log = Vec::new();
    let (mut bridge, bridge_rx) = start_bridge(
        &net.a,
        &args,
        &[
            "zenoh.enabled=true".into(),
            format!("zenoh.robot=\"{robot}\""),
            "zenoh.accept_goals=true".into(),
            "zenoh.topics=[\"lidar/points\", \"map/plan\", \"cmd_vel\"]".into(),
            format!("zenoh.config_file=\"{}\"", zconf.0.display()),
        ],
        &mut log,
    );
    let _sim = Proc::start(
        NetnsPair::exec(&net.a, &bin("mimnav-sim"))
            .args(&args)
            .args(["--set", "sim.endless=true", "--seconds", "300", "--world"])
            .arg(&world)
            .stdout(Stdio::null())
            .stderr(Stdio::null()),
    );
    let mut peer = Peer::start(
        &python,
        &net.b,
        &endpoint,
        &robot,
        &["lidar/points", "map/plan", "cmd_vel"],
    );

    // the points and the plan arrive in B and decode with the documented layouts
    let enough =
        |p: &Peer| p.samples("lidar/points").len() >= 3 && p.samples("map/plan").len() >= 3;
    let end = Instant::now() + Duration::from_secs(90);
    while !enough(&peer) && Instant::now() < end {
        peer.until(Duration::from_millis(500), |_| false);
    }
    assert!(enough(&peer), "points and plans in B: {:?}", peer.seen);
    let bad: Vec<_> = peer.seen.iter().filter(|v| v["event"] == "bad").collect();
    assert!(bad.is_empty(), "every sample decodes: {bad:?}");
    for s in peer.samples("lidar/points") {
        assert_eq!(
            s["encoding"],
            "application/octet-stream;mimnav/PointsHeader/v1+[mimnav/Point/v1]"
        );
        assert_eq!(s["key"], format!("mimnav/{robot}/lidar/points"));
        assert_eq!(s["point_count"], s["items"], "{s}");
        assert!(s["items"].as_u64().is_some_and(|n| n > 1000), "{s}");
        // the open field: the downward lasers hit the ground, the upward ones see the sky
        assert!(
            s["rings"].as_u64().is_some_and(|r| (4..=16).contains(&r)),
            "{s}"
        );
    }
    let cells = 200u64; // the shipped [map] cells
    for s in peer.samples("map/plan") {
        assert_eq!(
            s["encoding"],
            "application/octet-stream;mimnav/MapHeader/v1+[mimnav/PlanCell/v2]"
        );
        assert_eq!(s["cells"], cells);
        assert_eq!(s["items"], cells * cells);
        let classes = s["classes"].as_object().expect("classes");
        let total: u64 = classes.values().filter_map(Value::as_u64).sum();
        assert_eq!(total, cells * cells);
        // the open field: free cells around the robot
        assert!(
            classes
                .get("0")
                .and_then(Value::as_u64)
                .is_some_and(|n| n > 100),
            "{s}"
        );
    }
    // at most max_rate_hz (2 Hz default) of the 10 Hz revolutions
    let points = peer.samples("lidar/points");
    let seqs: Vec<u64> = points.iter().filter_map(|s| s["seq"].as_u64()).collect();
    let span = seqs.last().unwrap_or(&0) - seqs.first().unwrap_or(&0);
    assert!(
        span >= 4 * (seqs.len() as u64 - 1) - 2,
        "points capped at 2 of 10 revolutions a second: seqs {seqs:?}"
    );

    // bad goals are refused, a good one reaches the planner
    peer.send("bad");
    let (x, y) = (3.0, 0.5);
    let mut goal = None;
    for _ in 0..3 {
        peer.send(&format!("goal {x} {y} 0.3"));
        goal = goal_within(&goals, Duration::from_secs(3), |g| g.flags == 0);
        if goal.is_some() {
            break;
        }
    }
    let (g, goal_at) = goal.expect("the goal from B on mimnav/goal");
    assert_eq!((g.x, g.y, g.tolerance_m), (x, y, 0.3), "{g:?}");
    // the planner takes it: a command that is not "no goal", computed after it
    let end = Instant::now() + Duration::from_secs(10);
    let mut steered = None;
    while steered.is_none() && Instant::now() < end {
        cmds.heard_within(Duration::from_millis(20));
        while let Some(c) = cmds.receive().expect("receive") {
            if c.stamp_mono_ns > goal_at && c.status != command_status::NO_GOAL {
                steered = Some(c);
            }
        }
    }
    let c = steered.expect("the planner commands towards B's goal");
    println!(
        "after B's goal: status {} v {} omega {}",
        c.status, c.v, c.omega
    );
    assert!(
        peer.until(Duration::from_secs(10), |v| v["event"] == "sample"
            && v["topic"] == "cmd_vel"
            && v["status"] != command_status::NO_GOAL),
        "B sees the planner's command on mimnav/{robot}/cmd_vel"
    );

    // the stop: zero velocity, status "no goal", until a new goal
    peer.send("stop");
    let (s, stop_at) = goal_within(&goals, Duration::from_secs(5), |g| g.flags != 0)
        .expect("the stop from B on mimnav/goal");
    assert_eq!(s.flags, goal_flags::STOP);
    let (from, until) = (
        stop_at + 300_000_000,
        Instant::now() + Duration::from_secs(2),
    );
    let mut after = Vec::new();
    while Instant::now() < until {
        cmds.heard_within(Duration::from_millis(20));
        while let Some(c) = cmds.receive().expect("receive") {
            if c.stamp_mono_ns > from {
                after.push(c);
            }
        }
    }
    assert!(after.len() >= 5, "commands after the stop: {after:?}");
    // every command zero; its status "no goal", or "stale input" where the stack's inputs lagged
    // on a loaded machine (held still either way, and never "driving"); the stop itself shows
    for c in &after {
        assert!(
            c.v == 0.0
                && c.omega == 0.0
                && matches!(
                    c.status,
                    command_status::NO_GOAL | command_status::STALE_INPUT
                ),
            "held still after the stop: {c:?}"
        );
    }
    assert!(
        after.iter().any(|c| c.status == command_status::NO_GOAL),
        "the planner has no goal after the stop: {after:?}"
    );
    println!("{} commands after the stop, every one zero", after.len());

    // the bridge counted the bad goals and forwarded one goal (of up to 3 sent) and one stop
    writeln!(peer.stdin, "quit").expect("write to the peer");
    assert!(
        bridge
            .terminate(Duration::from_secs(10))
            .is_some_and(|s| s.success()),
        "the bridge ends cleanly on SIGTERM"
    );
    log.extend(bridge_rx.iter());
    let last = (log.iter().rev())
        .find(|l| l.contains("bridged:"))
        .unwrap_or_else(|| panic!("the bridge's closing counters: {log:?}"));
    println!("{last}");
    for says in ["remote_malformed=1", "remote_out_of_range=1", "stops=1"] {
        assert!(last.contains(says), "{says}: {last}");
    }
    assert!(!log.iter().any(|l| l.contains("panicked")), "{log:?}");
}

/// Issue 25 item 3: with `zenoh.accept_goals = false` (the default), goals and stops from the
/// network never reach `mimnav/goal` — while the bridge is demonstrably connected to the peer.
#[test]
fn issue25_3_remote_goals_are_ignored_unless_accepted() {
    let test = "zenoh goals not accepted";
    let Some(python) = python_with_zenoh(test) else {
        return;
    };
    let Some(net) = NetnsPair::create(test) else {
        return;
    };
    let domain = PrivateDomain::new("zenohoff");
    let args = crate::util::config_args(&domain);
    let robot = format!("t{}", std::process::id());
    let endpoint = format!("tcp/{}:7447", net.a_ip);
    let zconf = bridge_config(&endpoint);
    let node = ipc::node(&domain.config(), "zenoh-test").expect("node");
    let goals = ipc::goal_subscriber(&node).expect("goal");
    let odom = ipc::odom_publisher(&node).expect("odom");
    let mut log = Vec::new();
    let (mut bridge, _rx) = start_bridge(
        &net.a,
        &args,
        &[
            "zenoh.enabled=true".into(),
            format!("zenoh.robot=\"{robot}\""),
            "zenoh.topics=[\"odom\"]".into(),
            format!("zenoh.config_file=\"{}\"", zconf.0.display()),
        ],
        &mut log,
    );
    let mut peer = Peer::start(&python, &net.b, &endpoint, &robot, &["odom"]);
    // the test stands in for the robot's odometry until B hears it: the link is up
    let end = Instant::now() + Duration::from_secs(30);
    let mut seq = 0;
    while peer.samples("odom").is_empty() && Instant::now() < end {
        seq += 1;
        publish_odom(&odom, seq, 1.25);
        peer.until(Duration::from_millis(100), |_| false);
    }
    let heard = peer.samples("odom");
    assert!(!heard.is_empty(), "B hears the odometry: {:?}", peer.seen);
    assert_eq!(heard[0]["x"], 1.25);
    for _ in 0..3 {
        peer.send("goal 2 0 0.3");
        peer.send("stop");
    }
    let got = goal_within(&goals, Duration::from_secs(2), |_| true);
    assert!(got.is_none(), "nothing from B reaches mimnav/goal: {got:?}");
    // B stops reading (SIGSTOP keeps its connection open) while odometry goes on: the bridge
    // must still end on SIGTERM well inside the unit's TimeoutStopSec=5s
    let pid = peer._proc.0.id() as libc::pid_t;
    // SAFETY: kill(2) on the pid of a child this test started and has not reaped.
    unsafe { libc::kill(pid, libc::SIGSTOP) };
    let until = Instant::now() + Duration::from_secs(2);
    while Instant::now() < until {
        seq += 1;
        publish_odom(&odom, seq, 0.0);
        std::thread::sleep(Duration::from_millis(10));
    }
    let t0 = Instant::now();
    let status = bridge.terminate(Duration::from_secs(15));
    let took = t0.elapsed();
    // SAFETY: as above; the peer goes on so that dropping it can end it
    unsafe { libc::kill(pid, libc::SIGCONT) };
    println!(
        "SIGTERM with the peer stopped: the bridge ended after {:.3} s: {status:?}",
        took.as_secs_f64()
    );
    assert!(status.is_some_and(|s| s.success()), "{status:?}");
    assert!(took < Duration::from_secs(3), "{took:?}");
    drop(peer);
}

/// Off by default: with `zenoh.enabled = false` the bridge says so and exits successfully at
/// once, opening nothing.
#[test]
fn issue25_3_the_bridge_is_off_unless_enabled() {
    let domain = PrivateDomain::new("zenohdisabled");
    let o = Command::new(bin("mimnav-zenoh"))
        .args(crate::util::config_args(&domain))
        .env("MIMNAV_LOG", "info")
        .output()
        .expect("run mimnav-zenoh");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("zenoh.enabled = false"), "{err}");
    assert!(
        !domain.root.join("nodes").exists(),
        "no iceoryx2 node was made"
    );
}

/// A temporary folder removed when dropped.
struct TempDir(PathBuf);

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A CA and certificates signed by it in `dir`: `robot` (for `robot_ip`) and each of `clients`
/// (their common names), as `NAME.pem` and `NAME-key.pem`. None when openssl fails.
fn certificates(dir: &Path, robot_ip: &str, clients: &[&str]) -> Option<()> {
    let run = |args: &[&str]| {
        Command::new("openssl")
            .args(args)
            .current_dir(dir)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    let ec = [
        "-newkey",
        "ec",
        "-pkeyopt",
        "ec_paramgen_curve:prime256v1",
        "-nodes",
    ];
    let ok = run(&[
        &["req", "-x509"][..],
        &ec,
        &[
            "-keyout",
            "ca-key.pem",
            "-out",
            "ca.pem",
            "-days",
            "1",
            "-subj",
            "/CN=mimnav-test-ca",
        ],
    ]
    .concat());
    if !ok {
        return None;
    }
    for (name, san) in std::iter::once(("robot", format!("IP:{robot_ip}")))
        .chain(clients.iter().map(|c| (*c, format!("DNS:{c}"))))
    {
        let ext = format!("{name}.ext");
        std::fs::write(
            dir.join(&ext),
            format!(
                "basicConstraints=CA:FALSE\nkeyUsage=digitalSignature\n\
                 extendedKeyUsage=serverAuth,clientAuth\nsubjectAltName={san}\n"
            ),
        )
        .ok()?;
        let (key, csr, pem) = (
            format!("{name}-key.pem"),
            format!("{name}.csr"),
            format!("{name}.pem"),
        );
        let subj = format!("/CN={name}");
        let ok = run(&[
            &["req"][..],
            &ec,
            &["-keyout", &key, "-out", &csr, "-subj", &subj],
        ]
        .concat())
            && run(&[
                "x509",
                "-req",
                "-in",
                &csr,
                "-CA",
                "ca.pem",
                "-CAkey",
                "ca-key.pem",
                "-CAcreateserial",
                "-out",
                &pem,
                "-days",
                "1",
                "-extfile",
                &ext,
            ]);
        if !ok {
            return None;
        }
    }
    Some(())
}

/// docs/zenoh-robot.json5 itself (TLS with client certificates, access control) for a robot in
/// namespace A: the operator's goal reaches `mimnav/goal`, a fleet station's does not, though
/// both watch the robot.
#[test]
fn issue25_3_the_documented_access_control_lets_only_the_operator_steer() {
    let test = "zenoh access control";
    let Some(python) = python_with_zenoh(test) else {
        return;
    };
    let Some(net) = NetnsPair::create(test) else {
        return;
    };
    let dir =
        TempDir(std::env::temp_dir().join(format!("mimnav-zenoh-tls-{}", std::process::id())));
    std::fs::create_dir_all(&dir.0).expect("temporary folder");
    if certificates(&dir.0, &net.a_ip, &["operator-laptop", "fleet-station"]).is_none() {
        println!("SKIP {test}: openssl could not make the certificates");
        return;
    }
    let robot = format!("t{}", std::process::id());
    let doc = std::fs::read_to_string(root().join("docs/zenoh-robot.json5")).expect("the example");
    let conf = doc
        .replace("mimnav/spot1/", &format!("mimnav/{robot}/"))
        .replace(
            "/etc/mimnav/zenoh/spot1-key.pem",
            &dir.0.join("robot-key.pem").display().to_string(),
        )
        .replace(
            "/etc/mimnav/zenoh/spot1.pem",
            &dir.0.join("robot.pem").display().to_string(),
        )
        .replace(
            "/etc/mimnav/zenoh/ca.pem",
            &dir.0.join("ca.pem").display().to_string(),
        );
    assert!(!conf.contains("/etc/mimnav"), "every path replaced: {conf}");
    let zconf = dir.0.join("robot.json5");
    std::fs::write(&zconf, conf).expect("write the robot's config");

    let domain = PrivateDomain::new("zenohacl");
    let args = crate::util::config_args(&domain);
    let node = ipc::node(&domain.config(), "zenoh-test").expect("node");
    let goals = ipc::goal_subscriber(&node).expect("goal");
    let odom = ipc::odom_publisher(&node).expect("odom");
    let mut log = Vec::new();
    let (mut bridge, _rx) = start_bridge(
        &net.a,
        &args,
        &[
            "zenoh.enabled=true".into(),
            format!("zenoh.robot=\"{robot}\""),
            "zenoh.accept_goals=true".into(),
            "zenoh.topics=[\"odom\"]".into(),
            format!("zenoh.config_file=\"{}\"", zconf.display()),
        ],
        &mut log,
    );
    let endpoint = format!("tls/{}:7447", net.a_ip);
    let mut peers: Vec<Peer> = ["fleet-station", "operator-laptop"]
        .iter()
        .map(|name| {
            Peer::start_tls(
                &python,
                &net.b,
                &endpoint,
                &robot,
                &["odom"],
                Some((&dir.0, name)),
            )
        })
        .collect();
    // both watch: each hears the odometry over TLS
    let end = Instant::now() + Duration::from_secs(30);
    let mut seq = 0;
    while peers.iter().any(|p| p.samples("odom").is_empty()) && Instant::now() < end {
        seq += 1;
        publish_odom(&odom, seq, 0.0);
        for p in &mut peers {
            p.until(Duration::from_millis(50), |_| false);
        }
    }
    for p in &peers {
        assert!(
            !p.samples("odom").is_empty(),
            "every viewer hears the robot: {:?}",
            p.seen
        );
    }
    // the fleet station may not steer
    for _ in 0..3 {
        peers[0].send("goal 2 0 0.3");
        peers[0].send("stop");
    }
    let got = goal_within(&goals, Duration::from_secs(2), |_| true);
    assert!(
        got.is_none(),
        "the fleet station's goal is refused: {got:?}"
    );
    // the operator may
    let mut goal = None;
    for _ in 0..3 {
        peers[1].send("goal 4 1 0.5");
        goal = goal_within(&goals, Duration::from_secs(3), |_| true);
        if goal.is_some() {
            break;
        }
    }
    let (g, _) = goal.expect("the operator's goal reaches mimnav/goal");
    assert_eq!((g.x, g.y, g.tolerance_m, g.flags), (4.0, 1.0, 0.5, 0));
    assert!(
        bridge
            .terminate(Duration::from_secs(10))
            .is_some_and(|s| s.success())
    );
}
