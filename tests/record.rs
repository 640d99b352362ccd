//! `mimnav record` behind the driver replaying the bundled capture, the file read back with
//! PyPI's `mcap` package (`tests/mcap_read.py`): after a clean end and after a SIGKILL.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use mimnav_shared::ipc::{self, Listening, PrivateDomain};
use mimnav_shared::topics::{MapHeader, Odometry, PlanCell, Point, PointsHeader, VelocityCommand};
use serde_json::Value;

use crate::util::{Proc, TempFile, bin, config_args, lines_of, root, wait_until};

/// A Python with PyPI's `mcap` (`MIMNAV_MCAP_PYTHON`, which `.ci/run` sets, else
/// `target/mcap-venv`), or None after a SKIP line.
fn python_with_mcap(test: &str) -> Option<PathBuf> {
    crate::util::python_with(
        test,
        "MIMNAV_MCAP_PYTHON",
        "mcap-venv",
        "mcap, lz4",
        "mcap==1.6.0",
    )
}

/// `tests/mcap_read.py FILE`'s JSON.
fn read_mcap(python: &Path, file: &Path) -> Value {
    let out = Command::new(python)
        .arg(root().join("tests/mcap_read.py"))
        .arg(file)
        .output()
        .expect("run python");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("JSON from mcap_read.py")
}

fn temp_mcap(tag: &str) -> TempFile {
    TempFile(std::env::temp_dir().join(format!("mimnav-{tag}-{}.mcap", std::process::id())))
}

/// `mimnav record` in `domain`, once it has subscribed (its INFO line).
fn start_recorder(domain: &PrivateDomain, out: &Path, extra: &[&str]) -> Proc {
    let mut p = Proc::start(
        Command::new(bin("mimnav"))
            .args(config_args(domain))
            .arg("record")
            .arg("--out")
            .arg(out)
            .args(extra)
            .env("MIMNAV_LOG", "info")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped()),
    );
    let rx = lines_of(p.0.stderr.take().expect("stderr"));
    let mut seen = Vec::new();
    assert!(
        wait_until(
            &rx,
            |l| l.contains("recording"),
            Duration::from_secs(10),
            &mut seen
        ),
        "the recorder subscribes: {seen:?}"
    );
    // keep draining its stderr so it never blocks on a full pipe
    std::thread::spawn(move || for _ in rx {});
    p
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

/// Every revolution the test's own subscriber got, with the points of the first.
struct Tapped {
    seqs: Vec<u64>,
    counts: Vec<usize>,
    first: Vec<Point>,
}

fn tap_until(
    sub: &ipc::PointsSubscriber,
    within: Duration,
    stop: impl Fn(&Tapped) -> bool,
) -> (Tapped, bool) {
    let mut t = Tapped {
        seqs: Vec::new(),
        counts: Vec::new(),
        first: Vec::new(),
    };
    let until = Instant::now() + within;
    let mut ended = false;
    while Instant::now() < until && !ended && !stop(&t) {
        ended = sub.heard_within(Duration::from_millis(20)).end_of_stream;
        while let Some(s) = sub.receive().expect("receive") {
            if t.seqs.is_empty() {
                t.first = s.payload().to_vec();
            }
            t.seqs.push(s.user_header().seq);
            t.counts.push(s.payload().len());
        }
    }
    (t, ended)
}

fn u64s(v: &Value) -> Vec<u64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_u64().expect("integer"))
        .collect()
}

#[test]
fn records_the_bundled_capture_into_an_mcap_file_pypi_reads() {
    let Some(python) = python_with_mcap("records_the_bundled_capture") else {
        return;
    };
    let domain = PrivateDomain::new("e2e-record");
    let file = temp_mcap("record");
    let mut recorder = start_recorder(&domain, &file.0, &["--seconds", "30"]);
    let node = ipc::node(&domain.config(), "e2e-record-tap").expect("node");
    let sub = ipc::points_subscriber(&node).expect("lidar/points");
    let mut drv = driver(&domain, &["--set", "velodyne.replay_linger_s=1"]);
    let (tapped, ended) = tap_until(&sub, Duration::from_secs(20), |_| false);
    assert!(ended, "the replay ends");
    // 0.5 s of a 600 rpm sensor
    assert_eq!(tapped.seqs, [0, 1, 2, 3, 4], "the capture's revolutions");
    let _ = drv.wait(Duration::from_secs(5));
    // SIGTERM ends the recording cleanly, with its summary
    std::thread::sleep(Duration::from_millis(300));
    let status = recorder
        .terminate(Duration::from_secs(5))
        .expect("the recorder ends within 5 s of SIGTERM");
    assert!(status.success(), "{status}");
    let mut stdout = String::new();
    std::io::Read::read_to_string(&mut recorder.0.stdout.take().unwrap(), &mut stdout).unwrap();
    assert!(stdout.contains("ended by a signal"), "{stdout}");
    assert!(
        stdout.contains("mimnav/lidar/points: 5 written, 0 dropped (not kept up with), 0 bad"),
        "{stdout}"
    );

    let got = read_mcap(&python, &file.0);
    assert_eq!(got["truncated"], Value::Null, "{got}");
    assert_eq!(got["summary"], true);
    let topics = got["topics"].as_object().expect("topics");
    assert_eq!(
        topics.len(),
        11,
        "a channel for every topic, and the transforms: {topics:?}"
    );
    assert_eq!(topics["mimnav/tf"]["schema"], "foxglove.FrameTransforms");
    let points = &got["topics"]["mimnav/lidar/points"];
    assert_eq!(points["schema"], "foxglove.PointCloud");
    assert_eq!(points["schema_title"], "foxglove.PointCloud");
    assert_eq!(points["schema_encoding"], "jsonschema");
    assert_eq!(points["message_encoding"], "json");
    assert_eq!(
        u64s(&points["seqs"]),
        tapped.seqs,
        "every revolution recorded"
    );
    let counts: Vec<usize> = u64s(&points["points"])
        .iter()
        .map(|&n| n as usize)
        .collect();
    assert_eq!(counts, tapped.counts, "with every point");
    // the driver's scan of each revolution too, and no other stack service ran
    let scans = &got["topics"]["mimnav/lidar/scan2d"];
    assert_eq!(u64s(&scans["seqs"]), tapped.seqs);
    assert_eq!(got["topics"]["mimnav/map/plan"]["count"], 0);
    assert_eq!(got["topics"]["mimnav/map/plan"]["schema"], "foxglove.Grid");
    assert_eq!(
        got["stats"]["mimnav/lidar/points"], 5,
        "the summary's statistics"
    );
    assert_eq!(got["stats"]["mimnav/lidar/scan2d"], 5);

    // the first revolution decodes to the values the driver sent
    let cloud = &got["first_cloud"];
    assert_eq!(cloud["seq"], 0);
    let values: Vec<f32> = cloud["values"]
        .as_array()
        .expect("values")
        .iter()
        .map(|v| v.as_f64().expect("number") as f32)
        .collect();
    let sent: Vec<f32> = tapped
        .first
        .iter()
        .flat_map(|p| [p.x, p.y, p.z, f32::from(p.intensity)])
        .collect();
    assert!(!sent.is_empty());
    assert_eq!(values.len(), sent.len());
    let differ = values
        .iter()
        .zip(&sent)
        .filter(|(a, b)| a.to_bits() != b.to_bits())
        .count();
    assert_eq!(differ, 0, "bit for bit");
}

#[test]
fn a_killed_recorder_leaves_its_complete_chunks_readable() {
    let Some(python) = python_with_mcap("a_killed_recorder_leaves") else {
        return;
    };
    let domain = PrivateDomain::new("e2e-record-kill");
    let file = temp_mcap("record-kill");
    let mut recorder = start_recorder(&domain, &file.0, &["--topic", "lidar/points"]);
    let node = ipc::node(&domain.config(), "e2e-record-kill-tap").expect("node");
    let sub = ipc::points_subscriber(&node).expect("lidar/points");
    let _drv = driver(&domain, &["--set", "velodyne.replay_loop=true"]);
    // about 3.5 s of revolutions: more than one chunk, and more than one once-a-second flush
    let (tapped, _) = tap_until(&sub, Duration::from_secs(20), |t| t.seqs.len() >= 35);
    assert!(tapped.seqs.len() >= 35, "{} revolutions", tapped.seqs.len());
    recorder.0.kill().expect("SIGKILL");
    let _ = recorder.0.wait();

    let got = read_mcap(&python, &file.0);
    assert_eq!(
        got["summary"], false,
        "no summary after a SIGKILL: {}",
        got["truncated"]
    );
    let points = &got["topics"]["mimnav/lidar/points"];
    let seqs = u64s(&points["seqs"]);
    assert!(
        seqs.len() >= 20,
        "the complete chunks hold most revolutions: {} of {} ({})",
        seqs.len(),
        tapped.seqs.len(),
        got["truncated"]
    );
    // what was read is a run of revolutions the stack sent, each with every point
    let counts = u64s(&points["points"]);
    for (seq, n) in seqs.iter().zip(&counts) {
        let k = tapped
            .seqs
            .iter()
            .position(|s| s == seq)
            .unwrap_or_else(|| panic!("revolution {seq} was sent"));
        assert_eq!(*n as usize, tapped.counts[k], "revolution {seq}");
    }
    assert!(seqs.windows(2).all(|w| w[1] == w[0] + 1), "{seqs:?}");
}

#[test]
fn records_the_mappers_grids_and_the_foliage_verdicts_as_they_were_sent() {
    let Some(python) = python_with_mcap("records_the_mappers_grids") else {
        return;
    };
    let domain = PrivateDomain::new("e2e-record-maps");
    let file = temp_mcap("record-maps");
    let args = config_args(&domain);
    let mut recorder = start_recorder(&domain, &file.0, &[]);
    let node = ipc::node(&domain.config(), "e2e-record-maps-tap").expect("node");
    let plan = ipc::plan_subscriber(&node).expect("map/plan");
    let mut mapper = Proc::start(
        Command::new(bin("mimnav-mapper"))
            .args(&args)
            .stderr(Stdio::null()),
    );
    let mut foliage = Proc::start(
        Command::new(bin("mimnav-foliage"))
            .args(&args)
            .stderr(Stdio::null()),
    );
    std::thread::sleep(Duration::from_millis(300));
    let _drv = driver(&domain, &["--set", "velodyne.replay_linger_s=1"]);
    let mut maps = Vec::new();
    let until = Instant::now() + Duration::from_secs(20);
    while maps.len() < 5 && Instant::now() < until {
        plan.heard_within(Duration::from_millis(20));
        while let Some(s) = plan.receive().expect("receive") {
            maps.push((*s.user_header(), s.payload().to_vec()));
        }
    }
    assert_eq!(maps.len(), 5, "a map a revolution");
    // let the last verdicts and maps reach the recorder, then end it
    std::thread::sleep(Duration::from_millis(500));
    let _ = mapper.terminate(Duration::from_secs(2));
    let _ = foliage.terminate(Duration::from_secs(2));
    let status = recorder
        .terminate(Duration::from_secs(5))
        .expect("the recorder ends within 5 s of SIGTERM");
    assert!(status.success(), "{status}");

    let got = read_mcap(&python, &file.0);
    assert_eq!(got["summary"], true, "{}", got["truncated"]);
    let seqs: Vec<u64> = maps.iter().map(|(h, _)| h.seq).collect();
    for topic in ["mimnav/map/plan", "mimnav/map/layers"] {
        assert_eq!(got["topics"][topic]["schema"], "foxglove.Grid");
        assert_eq!(u64s(&got["topics"][topic]["seqs"]), seqs, "{topic}");
    }
    let verdicts = &got["topics"]["mimnav/foliage/alarm"];
    assert_eq!(verdicts["schema"], "mimnav.FoliageAlarm");
    assert_eq!(verdicts["count"], 5, "a verdict a scan");

    // the first plan, transposed into Foxglove's rows along x, holds what the mapper sent
    let grid = &got["first_grid"]["mimnav/map/plan"];
    let (h, cells) = &maps[0];
    assert_eq!(grid["seq"].as_u64(), Some(h.seq));
    assert_eq!(grid["column_count"].as_u64(), Some(u64::from(h.cells)));
    assert_eq!(grid["cell_stride"], 2);
    let hex = grid["hex"].as_str().expect("hex");
    let bytes: Vec<u8> = (0..hex.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&hex[i..i + 2], 16).expect("hex"))
        .collect();
    let n = h.cells as usize;
    let mut sent = Vec::with_capacity(2 * n * n);
    for c in 0..n {
        for r in 0..n {
            let cell = cells[r * n + c];
            sent.extend_from_slice(&[cell.class, cell.cost]);
        }
    }
    assert_eq!(bytes.len(), sent.len());
    assert!(bytes == sent, "the plan's classes and costs, cell for cell");
    assert!(
        sent.iter().step_by(2).any(|&c| c != sent[0]),
        "a map with more than one class"
    );
}

#[test]
fn a_bad_sample_is_counted_and_skipped_and_the_recording_goes_on() {
    let domain = PrivateDomain::new("e2e-record-bad");
    let file = temp_mcap("record-bad");
    let mut recorder = start_recorder(&domain, &file.0, &["--topic", "map/plan"]);
    let node = ipc::node(&domain.config(), "e2e-record-bad-pub").expect("node");
    let publisher = ipc::plan_publisher(&node, 4).expect("map/plan");
    let cells = [PlanCell::default(); 4];
    // a header that claims 3 × 3 cells over a payload of 4, then a good one
    let bad = MapHeader {
        seq: 0,
        cells: 3,
        cell_m: 0.1,
        ..Default::default()
    };
    publisher.publish(bad, &cells).expect("publish");
    std::thread::sleep(Duration::from_millis(100));
    let good = MapHeader {
        seq: 1,
        cells: 2,
        ..bad
    };
    publisher.publish(good, &cells).expect("publish");
    std::thread::sleep(Duration::from_millis(300));
    let status = recorder
        .terminate(Duration::from_secs(5))
        .expect("the recorder ends within 5 s of SIGTERM");
    assert!(status.success(), "{status}");
    let mut stdout = String::new();
    std::io::Read::read_to_string(&mut recorder.0.stdout.take().unwrap(), &mut stdout).unwrap();
    assert!(
        stdout.contains("mimnav/map/plan: 1 written, 0 dropped (not kept up with), 1 bad"),
        "{stdout}"
    );
}

#[test]
fn max_bytes_ends_the_recording_cleanly() {
    let Some(python) = python_with_mcap("max_bytes_ends_the_recording") else {
        return;
    };
    let domain = PrivateDomain::new("e2e-record-max");
    let file = temp_mcap("record-max");
    const MAX: u64 = 3_000_000;
    let mut recorder = start_recorder(
        &domain,
        &file.0,
        &["--topic", "lidar/points", "--max-bytes", &MAX.to_string()],
    );
    let _drv = driver(&domain, &["--set", "velodyne.replay_loop=true"]);
    let status = recorder
        .wait(Duration::from_secs(20))
        .expect("the recorder ends by itself");
    assert!(status.success(), "{status}");
    let mut stdout = String::new();
    std::io::Read::read_to_string(&mut recorder.0.stdout.take().unwrap(), &mut stdout).unwrap();
    assert!(stdout.contains("ended by --max-bytes"), "{stdout}");
    let size = std::fs::metadata(&file.0).expect("file").len();
    // it stops at the first turn past the limit: at most a few revolutions over
    assert!((MAX..MAX + 3_000_000).contains(&size), "{size} bytes");
    let got = read_mcap(&python, &file.0);
    assert_eq!(got["summary"], true, "{}", got["truncated"]);
    let n = got["topics"]["mimnav/lidar/points"]["count"]
        .as_u64()
        .unwrap();
    assert_eq!(got["stats"]["mimnav/lidar/points"].as_u64(), Some(n));
    assert!(n >= 3, "{n} revolutions");
}

/// Every revolution a subscriber got, whole.
type Revolutions = Vec<(PointsHeader, Vec<Point>)>;

fn drain_points(sub: &ipc::PointsSubscriber, into: &mut Revolutions) {
    while let Some(s) = sub.receive().expect("receive") {
        into.push((*s.user_header(), s.payload().to_vec()));
    }
}

fn drain_plans(sub: &ipc::PlanSubscriber, into: &mut Vec<(MapHeader, Vec<PlanCell>)>) {
    while let Some(s) = sub.receive().expect("receive") {
        into.push((*s.user_header(), s.payload().to_vec()));
    }
}

fn mapper(domain: &PrivateDomain) -> Proc {
    Proc::start(
        Command::new(bin("mimnav-mapper"))
            .args(config_args(domain))
            .stderr(Stdio::null()),
    )
}

/// Issue 25 item 2: `mimnav replay run.mcap` feeds a recording of the driver and the odometry
/// into another stack (here: another domain with its own mapper). Every revolution and
/// odometry sample arrives as it was first sent (only `rx_mono_ns` is the replay's own), and
/// the mapper makes the same maps of them. No Python: mimnav reads its own recording.
#[test]
fn a_recording_replays_into_a_stack_as_it_was_sent() {
    let first = PrivateDomain::new("e2e-replay-rec");
    let file = temp_mcap("replay");
    let topics = [
        "--topic",
        "lidar/points",
        "--topic",
        "lidar/scan2d",
        "--topic",
        "odom",
        "--topic",
        "map/plan",
    ];
    let mut recorder = start_recorder(&first, &file.0, &topics);
    let node = ipc::node(&first.config(), "e2e-replay-rec-tap").expect("node");
    let points = ipc::points_subscriber(&node).expect("lidar/points");
    let plans = ipc::plan_subscriber(&node).expect("map/plan");
    let odom = ipc::odom_publisher(&node).expect("odom");
    let mut mapper_a = mapper(&first);
    std::thread::sleep(Duration::from_millis(300));
    // odometry whose numbers need every bit of an f64 to come back
    let sent_odom: Vec<Odometry> = (0..3u32)
        .map(|k| Odometry {
            seq: u64::from(k),
            stamp_ns: 1_700_000_000_000_000_000 + u64::from(k) * 40_000_000,
            rx_mono_ns: ipc::monotonic_ns(),
            x: 0.1 + f64::from(k) / 3.0,
            y: -1.0 / 7.0,
            yaw: 0.3 + f64::from(k) * std::f64::consts::PI / 9.0,
            v: 0.3,
            omega: -0.1,
        })
        .collect();
    for o in &sent_odom {
        odom.publish(*o).expect("publish odom");
    }
    std::thread::sleep(Duration::from_millis(100));
    let mut drv = driver(&first, &["--set", "velodyne.replay_linger_s=1"]);
    let (mut revs, mut maps) = (Vec::new(), Vec::new());
    let until = Instant::now() + Duration::from_secs(20);
    while maps.len() < 5 && Instant::now() < until {
        points.heard_within(Duration::from_millis(20));
        drain_points(&points, &mut revs);
        drain_plans(&plans, &mut maps);
    }
    assert_eq!(revs.len(), 5, "the capture's revolutions");
    assert_eq!(maps.len(), 5, "a map a revolution");
    let _ = drv.wait(Duration::from_secs(5));
    std::thread::sleep(Duration::from_millis(500));
    let _ = mapper_a.terminate(Duration::from_secs(2));
    let status = recorder
        .terminate(Duration::from_secs(5))
        .expect("the recorder ends within 5 s of SIGTERM");
    assert!(status.success(), "{status}");

    // the second stack: its own domain, its own mapper
    let second = PrivateDomain::new("e2e-replay-play");
    let node = ipc::node(&second.config(), "e2e-replay-play-tap").expect("node");
    let points = ipc::points_subscriber(&node).expect("lidar/points");
    let plans = ipc::plan_subscriber(&node).expect("map/plan");
    let odom = ipc::odom_subscriber(&node).expect("odom");
    let mut mapper_b = mapper(&second);
    std::thread::sleep(Duration::from_millis(300));
    let started = Instant::now();
    let mut replay = Proc::start(
        Command::new(bin("mimnav"))
            .args(config_args(&second))
            .arg("replay")
            .arg(&file.0)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped()),
    );
    let (mut revs_b, mut maps_b, mut odom_b) = (Vec::new(), Vec::new(), Vec::new());
    let until = Instant::now() + Duration::from_secs(20);
    while (maps_b.len() < 5 || replay.0.try_wait().expect("wait").is_none())
        && Instant::now() < until
    {
        points.heard_within(Duration::from_millis(10));
        drain_points(&points, &mut revs_b);
        drain_plans(&plans, &mut maps_b);
        while let Some(o) = odom.receive().expect("receive") {
            odom_b.push(o);
        }
    }
    let took = started.elapsed();
    let status = replay
        .wait(Duration::from_secs(5))
        .expect("the replay ends");
    let (mut stdout, mut stderr) = (String::new(), String::new());
    std::io::Read::read_to_string(&mut replay.0.stdout.take().expect("stdout"), &mut stdout)
        .expect("read stdout");
    std::io::Read::read_to_string(&mut replay.0.stderr.take().expect("stderr"), &mut stderr)
        .expect("read stderr");
    assert!(status.success(), "{stdout}{stderr}");
    let _ = mapper_b.terminate(Duration::from_secs(2));
    assert!(
        stdout.contains("5 revolutions, 5 scans, 3 odometry samples replayed"),
        "{stdout}"
    );
    // the 5 maps, and the 3 transforms written with the odometry
    assert!(
        stdout.contains("8 messages of other topics not replayed"),
        "{stdout}"
    );
    // recorded in real time over about half a second: replayed at that pace, not at once
    assert!(took >= Duration::from_millis(350), "{took:?}");

    let same_but_rx = |a: &PointsHeader, b: &PointsHeader| {
        PointsHeader {
            rx_mono_ns: 0,
            ..*a
        } == PointsHeader {
            rx_mono_ns: 0,
            ..*b
        }
    };
    assert_eq!(revs_b.len(), revs.len(), "every revolution replayed");
    for ((ha, pa), (hb, pb)) in revs.iter().zip(&revs_b) {
        assert!(same_but_rx(ha, hb), "{ha:?} vs {hb:?}");
        assert!(hb.rx_mono_ns > ha.rx_mono_ns, "stamped by the replay");
        assert_eq!(pa.len(), pb.len());
        assert!(
            pa.iter()
                .zip(pb)
                .all(|(a, b)| a.x.to_bits() == b.x.to_bits()
                    && a.y.to_bits() == b.y.to_bits()
                    && a.z.to_bits() == b.z.to_bits()
                    && (a.time_offset_ns, a.distance_raw, a.azimuth_cdeg)
                        == (b.time_offset_ns, b.distance_raw, b.azimuth_cdeg)
                    && (a.intensity, a.laser_id, a.ring, a.return_type)
                        == (b.intensity, b.laser_id, b.ring, b.return_type)),
            "revolution {}: every point, every field",
            ha.seq
        );
    }
    assert_eq!(odom_b.len(), sent_odom.len());
    for (a, b) in sent_odom.iter().zip(&odom_b) {
        assert_eq!(
            Odometry {
                rx_mono_ns: 0,
                ..*a
            },
            Odometry {
                rx_mono_ns: 0,
                ..*b
            }
        );
    }
    // the second mapper made the first one's maps of them
    assert_eq!(maps_b.len(), maps.len());
    for ((ha, ca), (hb, cb)) in maps.iter().zip(&maps_b) {
        assert_eq!((ha.seq, ha.cells), (hb.seq, hb.cells));
        assert!(ca == cb, "map {}: cell for cell", ha.seq);
    }
}

/// A recording cut short (its recorder was killed) replays up to its last complete chunk and
/// says so; a file that is not MCAP or holds nothing to replay is refused with a clear message.
#[test]
fn a_damaged_or_empty_recording_is_named() {
    let domain = PrivateDomain::new("e2e-replay-bad");
    let file = temp_mcap("replay-bad");
    let mut recorder = start_recorder(&domain, &file.0, &["--topic", "lidar/points"]);
    let mut drv = driver(&domain, &["--set", "velodyne.replay_linger_s=1"]);
    let _ = drv.wait(Duration::from_secs(10));
    std::thread::sleep(Duration::from_millis(1500));
    // SIGKILL: no summary, no end magic
    recorder.0.kill().expect("kill the recorder");
    let _ = recorder.0.wait();
    let run = |path: &Path| {
        Command::new(bin("mimnav"))
            .args(config_args(&domain))
            .arg("replay")
            .arg("--fast")
            .arg("--quiet")
            .arg(path)
            .output()
            .expect("run mimnav replay")
    };
    let out = run(&file.0);
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(out.status.success(), "{stdout}{stderr}");
    assert!(stdout.contains("5 revolutions"), "{stdout}");
    assert!(stderr.contains("ends early"), "{stderr}");

    // an MCAP file with only the magic: nothing to replay
    let empty = temp_mcap("replay-empty");
    std::fs::write(&empty.0, b"\x89MCAP0\r\n").expect("write");
    let out = run(&empty.0);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("no lidar/points, lidar/scan2d or odom"),
        "{stderr}"
    );
}

/// `--rotate-bytes`: a recording goes on in numbered files, each whole (its own summary), and
/// together they hold every revolution once, in order.
#[test]
fn a_rotated_recording_is_whole_files_that_hold_every_revolution_once() {
    let Some(python) = python_with_mcap("a_rotated_recording") else {
        return;
    };
    let domain = PrivateDomain::new("e2e-record-rotate");
    let file = temp_mcap("rotate");
    let parts: Vec<TempFile> = (1..10)
        .map(|k| {
            let name = file.0.file_stem().unwrap().to_string_lossy().to_string();
            TempFile(file.0.with_file_name(format!("{name}-{k}.mcap")))
        })
        .collect();
    // about a revolution a file: the capture's revolutions take about 0.9 MB each
    let mut recorder = start_recorder(
        &domain,
        &file.0,
        &["--topic", "lidar/points", "--rotate-bytes", "500000"],
    );
    let mut drv = driver(&domain, &["--set", "velodyne.replay_linger_s=1"]);
    let _ = drv.wait(Duration::from_secs(10));
    std::thread::sleep(Duration::from_millis(300));
    let status = recorder
        .terminate(Duration::from_secs(5))
        .expect("the recorder ends within 5 s of SIGTERM");
    assert!(status.success(), "{status}");
    let mut seqs = Vec::new();
    let mut files = 0;
    for f in std::iter::once(&file).chain(&parts) {
        if !f.0.exists() {
            break;
        }
        files += 1;
        let got = read_mcap(&python, &f.0);
        assert_eq!(got["summary"], true, "{} is whole", f.0.display());
        seqs.extend(u64s(&got["topics"]["mimnav/lidar/points"]["seqs"]));
    }
    assert!(files >= 3, "{files} files");
    assert_eq!(seqs, [0, 1, 2, 3, 4], "every revolution once, in order");
}

/// Issue 25, "a sampled map and command decode to the values the stack sent": commands
/// published on `cmd_vel` are read back by PyPI's `mcap` with every field as sent.
#[test]
fn records_the_commands_as_they_were_sent() {
    let Some(python) = python_with_mcap("records_the_commands") else {
        return;
    };
    let domain = PrivateDomain::new("e2e-record-cmd");
    let file = temp_mcap("record-cmd");
    let mut recorder = start_recorder(&domain, &file.0, &["--topic", "cmd_vel"]);
    let node = ipc::node(&domain.config(), "e2e-record-cmd-pub").expect("node");
    let cmd = ipc::cmd_vel_publisher(&node).expect("cmd_vel");
    let sent: Vec<VelocityCommand> = (0..5u8)
        .map(|k| VelocityCommand {
            seq: u64::from(k),
            stamp_mono_ns: ipc::monotonic_ns(),
            source_stamp_ns: 1_700_000_000_000_000_000 + u64::from(k),
            source_seq: 100 + u64::from(k),
            valid_until_mono_ns: ipc::monotonic_ns() + 300_000_000,
            v: 0.1 * f32::from(k),
            omega: -0.05 * f32::from(k),
            status: k % 3,
            flags: k,
            ..VelocityCommand::default()
        })
        .collect();
    for c in &sent {
        cmd.publish(*c).expect("publish");
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(300));
    let status = recorder
        .terminate(Duration::from_secs(5))
        .expect("the recorder ends within 5 s of SIGTERM");
    assert!(status.success(), "{status}");
    let got = read_mcap(&python, &file.0);
    let t = &got["topics"]["mimnav/cmd_vel"];
    assert_eq!(t["schema"], "mimnav.VelocityCommand");
    assert_eq!(t["count"], 5, "every command");
    assert_eq!(got["stats"]["mimnav/cmd_vel"], 5);
    let messages = got["messages"]["mimnav/cmd_vel"]
        .as_array()
        .expect("messages");
    for (m, c) in messages.iter().zip(&sent) {
        let u = |k: &str| m[k].as_u64().expect(k);
        assert_eq!(
            (
                u("seq"),
                u("stamp_mono_ns"),
                u("source_stamp_ns"),
                u("source_seq"),
                u("valid_until_mono_ns")
            ),
            (
                c.seq,
                c.stamp_mono_ns,
                c.source_stamp_ns,
                c.source_seq,
                c.valid_until_mono_ns
            )
        );
        assert_eq!(m["v"].as_f64().expect("v") as f32, c.v);
        assert_eq!(m["omega"].as_f64().expect("omega") as f32, c.omega);
        assert_eq!(
            (u("status"), u("flags")),
            (u64::from(c.status), u64::from(c.flags))
        );
    }
}
