//! `mimnav record` behind the driver replaying the bundled capture, the file read back with
//! PyPI's `mcap` package (`tests/mcap_read.py`): after a clean end and after a SIGKILL.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use mimnav_shared::ipc::{self, Listening, PrivateDomain};
use mimnav_shared::topics::{MapHeader, PlanCell, Point};
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
    assert_eq!(topics.len(), 10, "a channel for every topic: {topics:?}");
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
