//! `mimnav-view` behind the driver replaying the bundled capture and the mapper, watched by a
//! Foxglove client nobody here wrote: PyPI's `websockets`, decoding with PyPI's `protobuf` from
//! the schemas the view advertises (`tests/foxglove_client.py`).

use std::collections::HashMap;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use mimnav_shared::ipc::{self, Listening, PrivateDomain};
use mimnav_shared::topics::{MapHeader, PlanCell};
use serde_json::Value;

use crate::util::{Proc, bin, config_args, free_tcp_port, lines_of, root, wait_until};

/// A Python with PyPI's `websockets` and `protobuf` (`MIMNAV_WS_PYTHON`, which `.ci/run` sets,
/// else `target/ws-venv`), or None after a SKIP line.
fn python_with_websockets(test: &str) -> Option<PathBuf> {
    crate::util::python_with(
        test,
        "MIMNAV_WS_PYTHON",
        "ws-venv",
        "websockets, google.protobuf",
        "websockets==15.0.1 protobuf==5.29.4",
    )
}

/// `mimnav-view` in `domain` on `port`, once it serves; its stderr lines go to the receiver.
fn start_view(
    domain: &PrivateDomain,
    port: u16,
    extra: &[&str],
) -> (Proc, std::sync::mpsc::Receiver<String>) {
    let mut p = Proc::start(
        Command::new(bin("mimnav-view"))
            .args(config_args(domain))
            .args(["--set", &format!("view.port={port}")])
            .args(extra)
            .env("MIMNAV_LOG", "info")
            .stderr(Stdio::piped()),
    );
    let rx = lines_of(p.0.stderr.take().expect("stderr"));
    let mut seen = Vec::new();
    assert!(
        wait_until(
            &rx,
            |l| l.contains("serving Foxglove on"),
            Duration::from_secs(10),
            &mut seen
        ),
        "the view serves: {seen:?}"
    );
    (p, rx)
}

fn mapper(domain: &PrivateDomain) -> Proc {
    Proc::start(
        Command::new(bin("mimnav-mapper"))
            .args(config_args(domain))
            .stderr(Stdio::null()),
    )
}

fn driver(domain: &PrivateDomain, extra: &[&str]) -> Proc {
    Proc::start(
        Command::new(bin("mimnav-velodyne"))
            .args(config_args(domain))
            .arg("--pcap")
            .arg(root().join("captures/scenario2_curtain_door.pcap"))
            .args(extra)
            .stderr(Stdio::null()),
    )
}

/// The Python client on `port` with `args`; its stdout lines on a receiver.
fn client(
    python: &PathBuf,
    port: u16,
    args: &[&str],
) -> (Child, std::sync::mpsc::Receiver<String>) {
    let mut c = Command::new(python)
        .arg("-u")
        .arg(root().join("tests/foxglove_client.py"))
        .args(["--url", &format!("ws://127.0.0.1:{port}")])
        .args(args)
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("run python");
    let rx = lines_of(c.stdout.take().expect("stdout"));
    (c, rx)
}

fn json_lines(lines: &[String]) -> Vec<Value> {
    lines
        .iter()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

/// Waits for the client to exit (killing it after `within`), with every line it printed.
fn finish(mut c: Child, rx: &std::sync::mpsc::Receiver<String>, within: Duration) -> Vec<Value> {
    let until = Instant::now() + within;
    let mut lines = Vec::new();
    loop {
        while let Ok(l) = rx.try_recv() {
            lines.push(l);
        }
        if let Ok(Some(_)) = c.try_wait() {
            break;
        }
        if Instant::now() > until {
            let _ = c.kill();
            let _ = c.wait();
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    while let Ok(l) = rx.recv_timeout(Duration::from_millis(200)) {
        lines.push(l);
    }
    json_lines(&lines)
}

/// Every map/plan sample, by its sensor stamp (the Grid's timestamp).
type Plans = HashMap<u64, (MapHeader, Vec<PlanCell>)>;

#[test]
fn a_foxglove_client_receives_the_points_and_the_map_the_stack_published() {
    let Some(python) = python_with_websockets("a_foxglove_client_receives") else {
        return;
    };
    let domain = PrivateDomain::new("e2e-view");
    let port = free_tcp_port();
    // every revolution and every map, so each one the stack published can be matched
    let (_view, _log) = start_view(
        &domain,
        port,
        &["--set", "view.points_hz=0", "--set", "view.grids_hz=0"],
    );
    let node = ipc::node(&domain.config(), "e2e-view-tap").expect("node");
    let points = ipc::points_subscriber(&node).expect("lidar/points");
    let plan = ipc::plan_subscriber(&node).expect("map/plan");
    let _mapper = mapper(&domain);
    let topics = ["/lidar/points", "/map/plan", "/view/stats"];
    let mut args = vec!["--count", "5", "--seconds", "40"];
    for t in &topics {
        args.extend(["--topic", t]);
    }
    let (py, rx) = client(&python, port, &args);
    // subscribed before the capture starts: no history on either side
    let mut early = Vec::new();
    assert!(
        wait_until(
            &rx,
            |l| l.contains("subscribed"),
            Duration::from_secs(20),
            &mut early
        ),
        "the client subscribes: {early:?}"
    );
    std::thread::sleep(Duration::from_millis(300));
    let mut drv = driver(&domain, &["--set", "velodyne.replay_linger_s=1"]);
    let (mut counts, mut plans): (HashMap<u64, usize>, Plans) = Default::default();
    let until = Instant::now() + Duration::from_secs(20);
    // until both are in: the mapper maps a revolution from its slices and may publish its map
    // before the driver has published the whole revolution on lidar/points
    while (plans.len() < 5 || counts.len() < 5) && Instant::now() < until {
        plan.heard_within(Duration::from_millis(20));
        while let Some(s) = points.receive().expect("receive") {
            counts.insert(s.user_header().stamp_ns, s.payload().len());
        }
        while let Some(s) = plan.receive().expect("receive") {
            let h = *s.user_header();
            plans.insert(h.stamp_ns, (h, s.payload().to_vec()));
        }
    }
    assert_eq!(
        (counts.len(), plans.len()),
        (5, 5),
        "the capture's 5 revolutions and maps"
    );
    let _ = drv.wait(Duration::from_secs(5));
    let mut got = json_lines(&early);
    got.extend(finish(py, &rx, Duration::from_secs(30)));

    // the handshake and the advertisement
    let sub = got
        .iter()
        .find_map(|v| v.get("subprotocol"))
        .expect("subprotocol");
    assert_eq!(
        sub, "foxglove.sdk.v1",
        "the SDK's name for foxglove.websocket.v1"
    );
    let adv = got
        .iter()
        .find_map(|v| v.get("advertise"))
        .expect("advertise");
    for (t, schema) in [
        ("/lidar/points", "foxglove.PointCloud"),
        ("/map/plan", "foxglove.Grid"),
        ("/map/layers", "foxglove.Grid"),
        ("/map/glass", "foxglove.Grid"),
        ("/tf", "foxglove.FrameTransforms"),
        ("/path", "foxglove.PosesInFrame"),
        ("/goal", "foxglove.SceneUpdate"),
        ("/foliage/scan", "foxglove.PointCloud"),
    ] {
        assert_eq!(adv[t]["schemaName"], schema, "{t}");
        assert_eq!(adv[t]["encoding"], "protobuf", "{t}");
    }
    for t in [
        "/cmd_vel",
        "/foliage/alarm",
        "/base/state",
        "/latency",
        "/view/stats",
    ] {
        assert_eq!(adv[t]["encoding"], "json", "{t}");
    }

    // every revolution: as many points as the driver published, in the lidar frame
    let clouds: Vec<&Value> = got
        .iter()
        .filter(|v| v["topic"] == "/lidar/points")
        .collect();
    assert_eq!(clouds.len(), 5, "every revolution reached the client");
    for c in &clouds {
        let stamp = c["stamp_ns"].as_u64().expect("stamp");
        let want = counts
            .get(&stamp)
            .unwrap_or_else(|| panic!("no revolution at {stamp}"));
        assert_eq!(
            c["points"].as_u64(),
            Some(*want as u64),
            "points at {stamp}"
        );
        assert!(*want > 10_000, "a real revolution: {want}");
        assert_eq!(c["frame_id"], "lidar");
        assert_eq!(c["point_stride"], 16);
    }
    // every map: the grid's size, resolution and cells are the mapper's
    let grids: Vec<&Value> = got.iter().filter(|v| v["topic"] == "/map/plan").collect();
    assert_eq!(grids.len(), 5, "every map reached the client");
    for g in &grids {
        let stamp = g["stamp_ns"].as_u64().expect("stamp");
        let (h, cells) = plans
            .get(&stamp)
            .unwrap_or_else(|| panic!("no map at {stamp}"));
        assert_eq!(g["column_count"].as_u64(), Some(u64::from(h.cells)));
        assert_eq!(g["rows"].as_u64(), Some(u64::from(h.cells)));
        let size = g["cell_size"][0].as_f64().expect("cell size");
        assert!(
            (size - f64::from(h.cell_m)).abs() < 1e-6,
            "{size} vs {}",
            h.cell_m
        );
        assert_eq!(g["frame_id"], "odom");
        let mut hist: HashMap<String, u64> = HashMap::new();
        for c in cells {
            *hist.entry(c.class.to_string()).or_default() += 1;
        }
        let got_hist: HashMap<String, u64> =
            serde_json::from_value(g["first_byte_hist"].clone()).expect("histogram");
        assert_eq!(got_hist, hist, "the classes of the map at {stamp}");
        assert!(hist.len() > 1, "a map with more than one class");
        // the first 32 cells of Foxglove's first row (along x): mimnav's column 0
        let n = h.cells as usize;
        let head: String = (0..32)
            .map(|r| cells[r * n])
            .map(|c| format!("{:02x}{:02x}", c.class, c.cost))
            .collect();
        assert_eq!(g["head"], head, "transposed into rows along x");
    }
    // the counters, asked by another client once the replay is over: every revolution
    // received, none missed
    let (py2, rx2) = client(&python, port, &["--count", "1", "--topic", "/view/stats"]);
    let later = finish(py2, &rx2, Duration::from_secs(20));
    let stats = later
        .iter()
        .rfind(|v| v["topic"] == "/view/stats")
        .expect("view stats")["json"]
        .clone();
    assert_eq!(
        stats["topics"]["mimnav/lidar/points"]["received"], 5,
        "{stats}"
    );
    assert_eq!(
        stats["topics"]["mimnav/lidar/points"]["missed"], 0,
        "{stats}"
    );
    assert_eq!(stats["channels"]["/lidar/points"]["sent"], 5, "{stats}");
    // nobody asked for the layers: never converted
    assert_eq!(stats["channels"]["/map/layers"]["sent"], 0, "{stats}");
    assert_eq!(stats["channels"]["/map/layers"]["unwatched"], 5, "{stats}");
}

#[test]
fn a_client_offering_only_the_old_subprotocol_name_is_refused() {
    let Some(python) = python_with_websockets("a_client_offering_only_the_old_name") else {
        return;
    };
    let domain = PrivateDomain::new("e2e-view-old");
    let port = free_tcp_port();
    let (_view, _log) = start_view(&domain, port, &[]);
    let args = [
        "--subprotocol",
        "foxglove.websocket.v1",
        "--topic",
        "/map/plan",
    ];
    let (py, rx) = client(&python, port, &args);
    let got = finish(py, &rx, Duration::from_secs(20));
    let refused = got.iter().find_map(|v| v.get("refused")).expect("refused");
    assert!(refused.to_string().contains("400"), "{refused}");
}

#[test]
fn a_client_that_never_reads_stalls_neither_the_view_nor_the_other_client() {
    let Some(python) = python_with_websockets("a_client_that_never_reads") else {
        return;
    };
    let domain = PrivateDomain::new("e2e-view-stall");
    let port = free_tcp_port();
    // every revolution, a short queue per client and the counters at 5 Hz (a short test)
    let (mut view, log) = start_view(
        &domain,
        port,
        &[
            "--set",
            "view.points_hz=0",
            "--set",
            "view.client_backlog=8",
            "--set",
            "view.slow_hz=5",
        ],
    );
    let _drv = driver(&domain, &["--set", "velodyne.replay_loop=true"]);
    // subscribes to the points (about 4.5 MB/s) with a 4 KiB socket buffer and never reads again
    let stall_args = [
        "--stall",
        "--seconds",
        "15",
        "--rcvbuf",
        "4096",
        "--topic",
        "/lidar/points",
    ];
    let (stalled, stalled_rx) = client(&python, port, &stall_args);
    let mut seen = Vec::new();
    assert!(
        wait_until(
            &stalled_rx,
            |l| l.contains("subscribed"),
            Duration::from_secs(20),
            &mut seen
        ),
        "the stalled client subscribes: {seen:?}"
    );
    // long enough for its socket buffers and its queue in the view (8 revolutions) to fill
    std::thread::sleep(Duration::from_secs(2));
    let args = [
        "--count",
        "20",
        "--seconds",
        "12",
        "--topic",
        "/lidar/points",
        "--topic",
        "/view/stats",
    ];
    let (reader, rx) = client(&python, port, &args);
    let got = finish(reader, &rx, Duration::from_secs(30));
    let clouds: Vec<u64> = (got.iter())
        .filter(|v| v["topic"] == "/lidar/points")
        .map(|v| v["stamp_ns"].as_u64().expect("stamp"))
        .collect();
    // at least 30 revolutions (10 Hz: 3 s; the client goes on until 30 counters came, 15 s),
    // one after the other (the looped capture's 5 stamps in turn)
    assert!(
        clouds.len() >= 30,
        "the other client keeps receiving: {clouds:?}"
    );
    assert!(
        clouds.windows(2).all(|w| w[0] != w[1]),
        "each revolution once: {clouds:?}"
    );
    let stats = got
        .iter()
        .rfind(|v| v["topic"] == "/view/stats")
        .expect("view stats")["json"]
        .clone();
    assert_eq!(stats["clients"], 2, "both clients connected: {stats}");
    let received = stats["topics"]["mimnav/lidar/points"]["received"]
        .as_u64()
        .unwrap_or(0);
    let missed = stats["topics"]["mimnav/lidar/points"]["missed"]
        .as_u64()
        .unwrap_or(u64::MAX);
    // the view kept up with the driver while one client read nothing (a view held up by that
    // client would miss nearly every revolution; a loaded machine may make it miss a few)
    assert!(received >= 40, "{stats}");
    assert!(
        missed.saturating_mul(4) <= received,
        "missed {missed} of {received}: {stats}"
    );
    let sent = stats["channels"]["/lidar/points"]["sent"]
        .as_u64()
        .unwrap_or(0);
    assert!(sent + 5 >= received, "sent {sent} of {received}: {stats}");
    println!("with a stalled client: the view received {received}, missed {missed}, sent {sent}");
    // the view stops on SIGTERM with the stalled client still connected and its queue full:
    // the server's shutdown waits for its client tasks, and a client that reads nothing must
    // not hold it past the unit's stop timeout
    let t0 = std::time::Instant::now();
    let status = view.terminate(Duration::from_secs(10));
    let took = t0.elapsed();
    println!(
        "SIGTERM with a stalled client: the view ended after {:.3} s: {status:?}",
        took.as_secs_f64()
    );
    assert!(
        status.is_some_and(|s| s.success()),
        "the view ends cleanly within 10 s of SIGTERM with a stalled client: {status:?}"
    );
    // the server waits 0.5 s for its clients, its runtime 1 s at most for its tasks: well
    // inside the unit's 5 s (unbounded, it ended only when the stalled client went, 9 s)
    assert!(took < Duration::from_secs(3), "{took:?}");
    let lines: Vec<String> = log.try_iter().collect();
    assert!(
        lines.iter().any(|l| l.contains("did not close within")),
        "the view says it dropped the stalled client: {lines:?}"
    );
    let mut stalled = stalled;
    let _ = stalled.kill();
    let _ = stalled.wait();
    // the SDK dropped the stalled client's oldest messages, and said so
    assert!(
        lines
            .iter()
            .any(|l| l.contains("outbox for client") && l.contains("full")),
        "the SDK reports the stalled client's full queue: {lines:?}"
    );
}
