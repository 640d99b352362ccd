use std::process::Command;

use crate::util::{bin, reference_counts, shipped_config, velodyne_data};

#[test]
fn replay_prints_every_revolution_of_the_dual_capture() {
    let Some(data) = velodyne_data("replay_prints_every_revolution") else {
        return;
    };
    let expected = reference_counts(&data, "vlp16_dual_nebula");
    let out = Command::new(bin("mimnav"))
        .arg("--config")
        .arg(shipped_config())
        .arg("replay")
        .arg(data.join("vlp16_dual_nebula.pcap"))
        .output()
        .expect("run mimnav replay");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    let counts: Vec<u32> = stdout
        .lines()
        .filter(|l| l.starts_with("rev "))
        .map(|l| {
            l.split_whitespace()
                .nth(2)
                .expect("count")
                .parse()
                .expect("number")
        })
        .collect();
    assert_eq!(counts, expected, "{stdout}");
    let total: u32 = expected.iter().sum();
    assert!(
        stdout.contains(&format!("{} revolutions, {total} points", expected.len())),
        "{stdout}"
    );
    assert!(stdout.contains("0 revolutions lost"), "{stdout}");
}

#[test]
fn replay_of_a_missing_file_fails_clearly() {
    let out = Command::new(bin("mimnav"))
        .arg("--config")
        .arg(shipped_config())
        .args(["replay", "/nonexistent/x.pcap"])
        .output()
        .expect("run");
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.starts_with("mimnav: ") && err.contains("/nonexistent/x.pcap"),
        "{err}"
    );
}

#[test]
fn check_config_accepts_the_shipped_config() {
    let out = Command::new(bin("mimnav"))
        .arg("--config")
        .arg(shipped_config())
        .arg("check-config")
        .output()
        .expect("run");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}");
    assert!(stdout.contains("mimnav.toml: ok"), "{stdout}");
    assert!(stdout.contains("turtlebot2"), "{stdout}");
}

/// The score-map table's row for `world`: [solid P R F, passable P R F, glass P R F, glass at the
/// end P R F, glass of the panes faced P R F], None where the class never occurs.
fn score_row(out: &str, world: &str) -> Vec<Option<[f64; 3]>> {
    let line = out
        .lines()
        .find(|l| l.starts_with(&format!("| {world}")))
        .unwrap_or_else(|| panic!("{world} in {out}"));
    line.split('|')
        .skip(2)
        .take(5)
        .map(|cell| {
            let v: Vec<f64> = cell
                .split_whitespace()
                .filter_map(|x| x.parse().ok())
                .collect();
            (v.len() == 3).then(|| [v[0], v[1], v[2]])
        })
        .collect()
}

#[test]
fn score_map_meets_the_targets_where_the_readme_says_it_does() {
    let out = Command::new(bin("mimnav"))
        .arg("--config")
        .arg(shipped_config())
        .arg("score-map")
        .output()
        .expect("run mimnav score-map");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let f = |row: &[Option<[f64; 3]>], k: usize| {
        row[k]
            .map(|v| v[2])
            .unwrap_or_else(|| panic!("class {k} scored: {stdout}"))
    };
    let s1 = score_row(&stdout, "scenario 1");
    assert!(
        f(&s1, 0) >= 0.95 && f(&s1, 2) >= 0.95,
        "scenario 1: {stdout}"
    );
    assert!(
        f(&s1, 3) >= 0.95,
        "scenario 1: the glass wall stays mapped after driving past it: {stdout}"
    );
    // every pane of scenario 1 is faced on its survey, so leaving out the panes not faced yet
    // can only drop glass the map could not hold
    assert!(
        f(&s1, 4) >= f(&s1, 2) - 1e-9,
        "scenario 1: the faced panes score no worse than all glass: {stdout}"
    );
    let s2 = score_row(&stdout, "scenario 2");
    assert!(
        f(&s2, 0) >= 0.95 && f(&s2, 1) >= 0.95 && f(&s2, 2) >= 0.95,
        "scenario 2: {stdout}"
    );
    let s3 = score_row(&stdout, "scenario 3");
    assert!(
        f(&s3, 0) >= 0.95 && f(&s3, 1) >= 0.95,
        "scenario 3: {stdout}"
    );
    // solid was 0.920 before tall cells were kept (mapper.tall_memory_s)
    let s4 = score_row(&stdout, "scenario 4");
    assert!(
        f(&s4, 1) >= 0.95 && f(&s4, 0) >= 0.95,
        "scenario 4: {stdout}"
    );
    let wall = score_row(&stdout, "one wall");
    assert!(
        f(&wall, 0) >= 0.95 && wall[2].is_none(),
        "one wall: {stdout}"
    );
}

#[test]
fn the_demo_drives_the_open_field_to_its_goal_as_separate_processes() {
    let (stdout, png) = crate::util::demo_to_goal("open_field.toml", &[]);
    // the latency line names its figures, measured over the revolutions
    let line = stdout
        .lines()
        .find(|l| l.contains("latency"))
        .unwrap_or_else(|| panic!("{stdout}"));
    let over: u32 = line
        .split(" over ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    assert!(over >= 50, "most revolutions were measured: {line}");
    assert!(
        line.contains("p50") && line.contains("p99") && !line.contains("NaN"),
        "{line}"
    );
    let bytes = std::fs::read(&png.0).expect("the PNG was written");
    assert_eq!(&bytes[1..4], b"PNG");
}

/// Issue 23, the soak: `mimnav soak` streams at several times real time and accounts for every
/// revolution the simulator completed, hop by hop, and for every service's memory.
#[test]
fn the_soak_accounts_for_every_revolution_hop_by_hop() {
    let out = Command::new(bin("mimnav"))
        .arg("--config")
        .arg(shipped_config())
        .args(["soak", "--seconds", "15", "--time-scale", "5", "--json"])
        .args(["--realtime-priority", "0", "--world"])
        .arg(shipped_config().with_file_name("worlds/open_field.toml"))
        .output()
        .expect("run mimnav soak");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    // 0: nothing lost, 3: something lost or grown (a loaded machine); both report in full
    assert!(
        matches!(out.status.code(), Some(0 | 3)),
        "{stdout}\n{stderr}"
    );
    let json = (stdout.lines().last())
        .and_then(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .unwrap_or_else(|| panic!("a JSON report last: {stdout}"));
    let n = |k: &str| json[k].as_u64().unwrap_or_else(|| panic!("{k} in {json}"));
    let (simulated, published, maps, commanded) =
        (n("simulated"), n("published"), n("maps"), n("commanded"));
    // 15 s at 600 rpm, but for the revolution the simulator starts in
    assert!((148..=151).contains(&simulated), "{json}");
    // each hop passes on no more than it got (the counts come from different topics' headers:
    // a soak counting a sample twice, or on the wrong topic, breaks this), and loopback UDP
    // loses nothing but the revolution in flight at the end
    assert!(commanded <= maps && maps <= published, "{json}");
    assert!(
        published <= simulated && published + 1 >= simulated,
        "{json}"
    );
    // the end-to-end loss is the sum of the hops' losses
    let expected = published.max(simulated - 1);
    assert_eq!(n("lost_end_to_end"), expected - commanded, "{json}");
    assert_eq!(
        n("lost_udp") + n("lost_mapper") + n("lost_planner"),
        n("lost_end_to_end"),
        "{json}"
    );
    // on a machine shared with the other tests a stall may cost a revolution, not the stream
    assert!(commanded * 100 >= expected * 95, "{json}");
    // the latency of the commands matched to their revolutions: most of them (a command for
    // want of fresh input is not), ordered percentiles, positive and below a revolution's time
    // at 5× (20 ms) but on a stalled machine
    let lat = &json["latency_ms"];
    let f = |k: &str| {
        lat[k]
            .as_f64()
            .unwrap_or_else(|| panic!("latency_ms.{k} in {json}"))
    };
    assert!(
        f("revolutions") * 100.0 >= commanded as f64 * 90.0,
        "{json}"
    );
    assert!(f("revolutions") <= commanded as f64, "{json}");
    assert!(
        0.0 < f("p50") && f("p50") <= f("p99") && f("p99") <= f("max"),
        "{json}"
    );
    assert!(f("p50") < 20.0, "{json}");
    let memory = json["memory"].as_array().expect("memory");
    let services: Vec<&str> = (memory.iter())
        .filter_map(|m| m["service"].as_str())
        .collect();
    assert_eq!(
        services,
        [
            "mimnav-foliage",
            "mimnav-mapper",
            "mimnav-planner",
            "mimnav-sim",
            "mimnav-velodyne"
        ],
        "{json}"
    );
    for m in memory {
        assert!(m["samples"].as_u64() >= Some(4), "{m}");
        assert!(m["max_kib"].as_u64() >= m["end_kib"].as_u64(), "{m}");
    }
    assert_eq!(
        out.status.code() == Some(0),
        stdout.contains("soak passed"),
        "{stdout}"
    );
}

#[test]
fn the_demo_names_a_missing_world() {
    let out = Command::new(bin("mimnav"))
        .arg("--config")
        .arg(shipped_config())
        .args(["demo", "--world", "/nonexistent/world.toml"])
        .output()
        .expect("run mimnav demo");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("/nonexistent/world.toml"), "{stderr}");
}

#[test]
fn eval_reaches_the_goal_of_scenario_2_and_the_laser_scan_baseline_does_not() {
    // one seed, two methods: the intensity map drives through the curtain; the laser scan
    // sees the curtain as a wall
    let out = Command::new(bin("mimnav"))
        .arg("--config")
        .arg(shipped_config())
        .args([
            "eval",
            "--seeds",
            "1",
            "--quiet",
            "--json",
            "--method",
            "adaptive",
            "--method",
            "laser-scan",
            "--world",
        ])
        .arg(shipped_config().with_file_name("worlds/scenario2_curtain_door.toml"))
        .output()
        .expect("run mimnav eval");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    let episodes: Vec<serde_json::Value> = (stdout.lines().filter(|l| l.starts_with('{')))
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect();
    let episode = |method: &str| {
        (episodes.iter())
            .find(|e| e["method"] == method)
            .unwrap_or_else(|| panic!("{method} in {stdout}"))
    };
    let adaptive = episode("adaptive");
    assert_eq!(adaptive["ending"], "success", "{stdout}");
    assert!(adaptive["touched"].is_null(), "{stdout}");
    // the laser scan takes the curtain for a wall: it either stays before it (the paper's
    // freezing; with the shipped margin, timeouts in 19 of 20 seeds of the table) or routes
    // around it into the glass pane (from (5.0, 0.7) to (5.0, 2.8)) it never sees
    let laser = episode("laser-scan");
    let touched = laser["touched"].as_array().map(|p| {
        let c: Vec<f64> = p.iter().filter_map(|v| v.as_f64()).collect();
        c.len() == 2 && (c[0] - 5.0).abs() < 0.01 && (0.7..=2.8).contains(&c[1])
    });
    assert!(
        (laser["ending"] == "timeout" || laser["ending"] == "froze") && touched.is_none()
            || laser["ending"] == "contact" && touched == Some(true),
        "{stdout}"
    );
    assert!(stdout.contains("| scenario 2"), "the table: {stdout}");
    // the summary line counts the paper's method, by name
    assert!(
        stdout.contains("intensity map, adaptive inflation: 100.0 % success over 1 episodes"),
        "the summary: {stdout}"
    );
}
