use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use mimnav_shared::ipc::{self, Listening, PrivateDomain};
use mimnav_shared::topics::foliage_class;

use crate::util::{Proc, bin, config_args, root, shipped_config};

#[test]
fn the_classifier_alarms_on_the_wall_behind_the_robot_in_the_bundled_capture() {
    // scenario 2's start: the room's back wall 1.5 m behind the sensor, within d_max = 3 m
    let domain = PrivateDomain::new("e2e-foliage");
    let args = config_args(&domain);
    let node = ipc::node(&domain.config(), "e2e-foliage-tap").expect("node");
    let alarms = ipc::foliage_subscriber(&node).expect("foliage/alarm");
    let scans = ipc::scan_subscriber(&node).expect("lidar/scan2d");
    let mut foliage = Proc::start(
        Command::new(bin("mimnav-foliage"))
            .args(&args)
            .stderr(Stdio::piped()),
    );
    std::thread::sleep(Duration::from_millis(300));
    let mut driver = Proc::start(
        Command::new(bin("mimnav-velodyne"))
            .args(&args)
            .arg("--pcap")
            .arg(root().join("captures/scenario2_curtain_door.pcap"))
            .args(["--set", "velodyne.replay_linger_s=2"]),
    );
    let (mut verdicts, mut scan_lens) = (Vec::new(), Vec::new());
    let until = Instant::now() + Duration::from_secs(15);
    while verdicts.len() < 4 && Instant::now() < until {
        alarms.heard_within(Duration::from_millis(50));
        while let Some(s) = scans.receive().expect("receive") {
            scan_lens.push((s.user_header().seq, s.payload().len()));
        }
        while let Some(s) = alarms.receive().expect("receive") {
            let classes: Vec<u8> = s.payload().iter().map(|r| r.class).collect();
            verdicts.push((*s.user_header(), classes));
        }
    }
    let _ = driver.terminate(Duration::from_secs(1));
    let status = foliage
        .terminate(Duration::from_secs(1))
        .expect("the classifier stops within 1 s of SIGTERM");
    assert!(status.success(), "{status}");
    assert!(
        verdicts.len() >= 4,
        "a verdict per scan: {}",
        verdicts.len()
    );
    for (k, (h, classes)) in verdicts.iter().enumerate() {
        assert_eq!(h.source_seq, k as u64, "each verdict names its scan");
        assert_eq!(h.count as usize, classes.len());
        if let Some(&(_, len)) = scan_lens.iter().find(|(seq, _)| *seq == h.source_seq) {
            assert_eq!(len, classes.len(), "a class for every return");
        }
        assert!(classes.iter().all(|&c| c <= foliage_class::PRUNED));
        assert_eq!(h.sectors, 36);
    }
    // an obstacle must be seen twice before it alarms; from the second scan on the wall does
    for (h, classes) in &verdicts[1..] {
        assert_eq!(h.alarm, 1, "scan {}", h.source_seq);
        let obstacles = classes
            .iter()
            .filter(|&&c| c == foliage_class::OBSTACLE)
            .count();
        assert_eq!(obstacles, h.obstacles as usize);
        assert!(obstacles > 20, "{obstacles}");
        // the sector straight behind (bearing π: the last sector) holds the wall at ~1.5 m
        let behind = h.nearest_m[h.sectors as usize - 1];
        assert!((1.4..1.7).contains(&behind), "behind: {behind}");
    }
    assert_eq!(verdicts[0].0.alarm, 0, "held back on its first sight");
}

/// `mimnav foliage-eval ARGS` with the shipped config; (stdout, stderr, success).
fn foliage_eval_args(args: &[String]) -> (String, String, bool) {
    let out = Command::new(bin("mimnav"))
        .arg("--config")
        .arg(shipped_config())
        .arg("foliage-eval")
        .args(args)
        .output()
        .expect("run mimnav foliage-eval");
    (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
        out.status.success(),
    )
}

/// One seed of `mimnav foliage-eval` on one bundled foliage world, quiet, with JSON lines.
fn foliage_eval(world: &str, extra: &[&str]) -> (String, String, bool) {
    let mut args: Vec<String> = ["--quiet", "--json", "--seeds", "1", "--world"]
        .map(String::from)
        .to_vec();
    args.push(
        root()
            .join(format!("config/worlds/foliage/{world}.toml"))
            .display()
            .to_string(),
    );
    args.extend(extra.iter().map(|s| s.to_string()));
    foliage_eval_args(&args)
}

/// The value of `"key":N` in a JSON line (the first one).
fn json_lines(stdout: &str) -> Vec<serde_json::Value> {
    (stdout.lines().filter(|l| l.starts_with('{')))
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

#[test]
fn foliage_eval_counts_no_false_alarm_in_dense_grass() {
    // 100 scans standing and 100 driving through dense grass taller than the sensor, seed 1: the
    // classifier must not alarm once (the target is at most 1 in 1000).
    let (stdout, stderr, ok) = foliage_eval("grass_dense", &["--scans", "100"]);
    assert!(ok, "{stdout}\n{stderr}");
    let episodes = json_lines(&stdout);
    assert_eq!(episodes.len(), 2, "standing and moving: {stdout}");
    for e in &episodes {
        assert_eq!(
            (e["scans"].as_u64(), e["false_alarms"].as_u64()),
            (Some(100), Some(0)),
            "{e}"
        );
        assert_eq!(e["alarms"].as_u64(), Some(0), "{e}");
    }
    assert!(
        stdout.contains("| foliage: dense grass |"),
        "the table: {stdout}"
    );
    assert!(stdout.contains("0 false alarms in 200 scans"), "{stdout}");
}

#[test]
fn foliage_eval_alarms_on_a_trunk_in_the_clear_from_the_second_scan() {
    // Standing 20 scans at the start of the mown lane: the 0.3 m trunk 2.1 m ahead-left is
    // visible in every scan, and the classifier confirms it from the second one on (the first
    // cannot: REMOVE-NEW-OBST wants it seen in one of the last two scans). The 0.35 m rock 2.9 m
    // away is below the -1° laser's beam (0.45 m up there) and never visible.
    let (stdout, stderr, ok) = foliage_eval(
        "obstacles_clear",
        &["--scans", "20", "--motion", "standing"],
    );
    assert!(ok, "{stdout}\n{stderr}");
    let episodes = json_lines(&stdout);
    let episode = episodes
        .first()
        .unwrap_or_else(|| panic!("no episode in {stdout}"));
    assert_eq!(episode["false_alarms"], 0, "{episode}");
    let obstacles = episode["obstacles"].as_array().expect("obstacles");
    let find = |label: &str| {
        (obstacles.iter())
            .find(|o| o["label"] == label && o["in_range"] == 20)
            .unwrap_or_else(|| panic!("{label} in range in {episode}"))
    };
    let trunk = find("trunk 0.30 m wide, 5.00 m tall");
    let counts = |o: &serde_json::Value, keys: &[&str]| -> Vec<Option<u64>> {
        keys.iter().map(|k| o[*k].as_u64()).collect()
    };
    // in the clear every view of it is a run of neighbouring returns
    let keys = [
        "visible",
        "alarmed",
        "delay_scans",
        "visible_run",
        "alarmed_run",
    ];
    let want = [20, 19, 1, 20, 19].map(Some);
    assert_eq!(counts(trunk, &keys), want, "{trunk}");
    let rock = find("rock 0.50 m wide, 0.35 m tall");
    let keys = ["out_of_beam", "visible", "visible_run"];
    assert_eq!(counts(rock, &keys), [20, 0, 0].map(Some), "{rock}");
    // no 0.3 m trunk 2 m away spans 200 consecutive firings (0.2° apart)
    let (stdout, stderr, ok) = foliage_eval(
        "obstacles_clear",
        &["--scans", "3", "--motion", "standing", "--min-run", "200"],
    );
    assert!(ok, "{stdout}\n{stderr}");
    assert!(
        stdout.contains("visible as a run (≥ 200 consecutive returns on it): –"),
        "{stdout}"
    );
}

#[test]
fn foliage_eval_refuses_bad_arguments_clearly() {
    let world = root().join("config/worlds/foliage/grass_sparse.toml");
    let world = world.display().to_string();
    for (args, expect) in [
        (&["--seeds", "0"][..], "--seeds must be at least 1"),
        (&["--scans", "0"][..], "--scans 0 is out of range"),
        (
            &["--min-returns", "0"][..],
            "--min-returns must be at least 1",
        ),
        (&["--min-run", "0"][..], "--min-run must be at least 1"),
        (
            &["--robot", "turtlebot2", "--speed", "3"][..],
            "above turtlebot2's top speed",
        ),
        (&["--robot", "nosuchbot"][..], "nosuchbot"),
        (
            &["--world", "/nonexistent/world.toml"][..],
            "/nonexistent/world.toml",
        ),
        (&["--motion", "flying"][..], "invalid value 'flying'"),
        (&["--sensor", "radar"][..], "invalid value 'radar'"),
        (
            &[
                "--sensor",
                "sick",
                "--set",
                "sick.frequency_hz=50",
                "--set",
                "sick.resolution_deg=0.25",
            ][..],
            "sick.frequency_hz",
        ),
    ] {
        let mut a: Vec<String> = args.iter().map(|s| s.to_string()).collect();
        if !args.contains(&"--world") {
            a.extend(["--world".to_string(), world.clone()]);
        }
        let (stdout, stderr, ok) = foliage_eval_args(&a);
        assert!(!ok, "{args:?} accepted: {stdout}");
        assert!(stderr.contains(expect), "{args:?}: {stderr}");
    }
}

#[test]
fn foliage_eval_with_the_simulated_sick_alarms_on_a_trunk_and_not_on_grass() {
    // issue 26: the simulated LMS1xx, its telegrams through the SICK driver's session and
    // conversion. Standing at the start of the mown lane, the 0.3 m trunk 2.1 m ahead-left is
    // in the scan plane (0.4 m up) in every scan and confirmed from the second scan on; the
    // 0.35 m rock is below the plane, out of the beam.
    let (stdout, stderr, ok) = foliage_eval(
        "obstacles_clear",
        &["--sensor", "sick", "--scans", "20", "--motion", "standing"],
    );
    assert!(ok, "{stdout}\n{stderr}");
    assert!(stdout.contains("SICK LMS1xx at 25 Hz"), "{stdout}");
    let episodes = json_lines(&stdout);
    let episode = episodes
        .first()
        .unwrap_or_else(|| panic!("no episode in {stdout}"));
    assert_eq!(episode["sensor"], "sick", "{episode}");
    assert_eq!(episode["false_alarms"], 0, "{episode}");
    let obstacles = episode["obstacles"].as_array().expect("obstacles");
    let find = |label: &str| {
        (obstacles.iter())
            .find(|o| o["label"] == label && o["in_range"] == 20)
            .unwrap_or_else(|| panic!("{label} in range in {episode}"))
    };
    let trunk = find("trunk 0.30 m wide, 5.00 m tall");
    let keys = ["visible", "alarmed", "delay_scans"];
    let counts: Vec<Option<u64>> = keys.iter().map(|k| trunk[*k].as_u64()).collect();
    assert_eq!(counts, [20, 19, 1].map(Some), "{trunk}");
    let rock = find("rock 0.50 m wide, 0.35 m tall");
    assert_eq!(
        (rock["out_of_beam"].as_u64(), rock["visible"].as_u64()),
        (Some(20), Some(0)),
        "{rock}"
    );
    // deterministic per seed, whatever the threads
    let args = [
        "--sensor", "sick", "--scans", "20", "--motion", "standing", "--jobs", "2",
    ];
    let (again, _, ok) = foliage_eval("obstacles_clear", &args);
    assert!(ok);
    assert_eq!(json_lines(&again), episodes);
    // dense grass taller than the scan plane, standing and driving through it: no alarm, in
    // the LMS1xx's figure and the TiM5xx's (1° steps, its window widened to 1°)
    for model in ["lms1xx", "tim5xx"] {
        let set = format!("sick.model=\"{model}\"");
        let (stdout, stderr, ok) = foliage_eval(
            "grass_dense",
            &["--set", &set, "--sensor", "sick", "--scans", "150"],
        );
        assert!(ok, "{model}: {stdout}\n{stderr}");
        let episodes = json_lines(&stdout);
        assert_eq!(episodes.len(), 2, "{model}: {stdout}");
        for e in &episodes {
            assert_eq!(e["scans"].as_u64(), Some(150), "{model}: {e}");
            assert_eq!(e["false_alarms"].as_u64(), Some(0), "{model}: {e}");
        }
    }
}
