use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use mimnav_shared::ipc::{self, Listening, PrivateDomain};
use mimnav_shared::topics::foliage_class;

use crate::util::{Proc, bin, config_args, root};

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
