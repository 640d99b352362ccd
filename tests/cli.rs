use std::path::PathBuf;
use std::process::Command;

use crate::util::{bin, reference_counts, velodyne_data};

fn shipped_config() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../config/mimnav.toml")
}

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
