//! Issue 23 items 2, 3 and 7 at the command line: a world, a goal, a config or a capture the
//! stack cannot use is refused with a named error and a non-zero exit, never an abort, a
//! silent success or a robot driven by NaN.

use std::net::Ipv4Addr;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use mimnav_shared::ipc::PrivateDomain;
use mimnav_velodyne::capture::PcapDatagramWriter;

use crate::util::{TempFile, bin, shipped_config};

fn temp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("mimnav-e2e-bad-{}-{name}", std::process::id()))
}

fn mimnav(args: &[&str]) -> Output {
    Command::new(bin("mimnav"))
        .arg("--config")
        .arg(shipped_config())
        .args(args)
        .output()
        .expect("run mimnav")
}

fn shown(out: &Output) -> String {
    format!(
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// Issue 23 item 2: grass 500 × 500 m at density 500 with `sim.grass_blades=true` aborted the
/// simulator (`memory allocation of 110278336560 bytes failed`) and `mimnav sim` exited 1 with
/// no message. It is refused at load: the file, the key, the value and the limit.
#[test]
fn issue23_2_a_valid_world_aborts_the_simulator_mimnav_sim_refuses_it_by_name() {
    let world = TempFile(temp("huge_grass.toml"));
    let out_pcap = TempFile(temp("huge_grass.pcap"));
    std::fs::write(
        &world.0,
        "name = \"huge\"\nstart = [0.0, 0.0, 0.0]\ngoal = [3.0, 0.0]\ntime_limit_s = 10.0\n\
         [[grass]]\ncenter = [0.0, 0.0]\nsize = [500.0, 500.0]\ndensity = 500.0\n",
    )
    .expect("write");
    let out = mimnav(&[
        "sim",
        "--world",
        &world.0.display().to_string(),
        "--set",
        "sim.grass_blades=true",
        "--pcap",
        &out_pcap.0.display().to_string(),
        "--seconds",
        "0.2",
    ]);
    let all = shown(&out);
    assert!(!out.status.success(), "{all}");
    assert!(!all.contains("memory allocation"), "{all}");
    assert!(
        all.contains(&world.0.display().to_string()),
        "names the file: {all}"
    );
    assert!(all.contains("grass[0]"), "names the patch: {all}");
    assert!(all.contains("limit of 4000000"), "names the limit: {all}");
}

/// Issue 23 item 3: a NaN start, a NaN goal and a NaN config value are refused where they are
/// given, by key, with a non-zero exit.
#[test]
fn issue23_3_non_finite_values_accepted_are_refused_at_the_command_line() {
    let world = TempFile(temp("nan_start.toml"));
    let out_pcap = TempFile(temp("nan_start.pcap"));
    std::fs::write(
        &world.0,
        "name = \"nan\"\nstart = [nan, 0.0, 0.0]\ngoal = [3.0, 0.0]\ntime_limit_s = 10.0\n",
    )
    .expect("write");
    let out = mimnav(&[
        "sim",
        "--world",
        &world.0.display().to_string(),
        "--pcap",
        &out_pcap.0.display().to_string(),
    ]);
    let all = shown(&out);
    assert!(!out.status.success(), "{all}");
    assert!(all.contains("start[0] = NaN"), "{all}");

    let out = mimnav(&["goal", "nan", "1.0"]);
    let all = shown(&out);
    assert!(!out.status.success(), "{all}");
    assert!(all.contains("goal X = NaN"), "{all}");

    let out = mimnav(&["--set", "planner.goal_weight=inf", "check-config"]);
    let all = shown(&out);
    assert!(!out.status.success(), "{all}");
    assert!(all.contains("planner.goal_weight"), "{all}");
}

/// A small capture of VLP-16-sized datagrams.
fn capture(path: &Path, n: usize) {
    let file = std::fs::File::create(path).expect("create");
    let mut w = PcapDatagramWriter::new(std::io::BufWriter::new(file)).expect("header");
    let src = (Ipv4Addr::new(192, 168, 1, 201), 2368);
    let dst = (Ipv4Addr::new(255, 255, 255, 255), 2368);
    for i in 0..n {
        w.write(
            1_700_000_000_000_000_000 + i as u64 * 1_327_000,
            src,
            dst,
            &[0u8; 1206],
        )
        .expect("write");
    }
    std::io::Write::flush(&mut w.into_inner()).expect("flush");
}

/// The driver replaying `path` once, as fast as it can, in its own domain.
fn driver_replay(path: &Path) -> Output {
    let domain = PrivateDomain::new("e2e-bad-capture");
    Command::new(bin("mimnav-velodyne"))
        .arg("--config")
        .arg(shipped_config())
        .args(domain.set_args())
        .args(["--pcap", &path.display().to_string()])
        .args(["--set", "velodyne.replay_fast=true"])
        .args(["--set", "velodyne.replay_linger_s=0"])
        .output()
        .expect("run mimnav-velodyne")
}

/// Issue 23 item 7: impossible record lengths are refused before reading, naming the offset
/// and the length; a capture on an unknown link type replayed nothing and exited 0. Both fail
/// `mimnav replay` and the driver's replay mode with a named error.
#[test]
fn issue23_7_impossible_record_lengths_and_unknown_link_types_fail_the_replay() {
    let file = TempFile(temp("impossible.pcap"));
    capture(&file.0, 20);
    let mut bytes = std::fs::read(&file.0).expect("read");
    let at = 24 + 16 + 1248; // the second record
    bytes[at + 8..at + 12].copy_from_slice(&0x7FFF_FFF0u32.to_le_bytes());
    std::fs::write(&file.0, &bytes).expect("write");
    let says = format!("impossible record at byte offset {at}");
    let out = mimnav(&["replay", "--fast", "-q", &file.0.display().to_string()]);
    let all = shown(&out);
    assert!(!out.status.success(), "{all}");
    assert!(all.contains(&says), "{all}");
    let out = driver_replay(&file.0);
    let all = shown(&out);
    assert!(!out.status.success(), "{all}");
    assert!(all.contains(&says), "{all}");

    // link type 201 (Bluetooth HCI) in the pcap header
    capture(&file.0, 3);
    let mut bytes = std::fs::read(&file.0).expect("read");
    bytes[20..24].copy_from_slice(&201u32.to_le_bytes());
    std::fs::write(&file.0, &bytes).expect("write");
    // and a pcapng file whose only interface is on it
    let ng = TempFile(temp("bluetooth.pcapng"));
    let mut b = Vec::new();
    let word = |b: &mut Vec<u8>, v: u32| b.extend_from_slice(&v.to_le_bytes());
    // section header block
    for v in [
        0x0A0D_0D0A,
        28,
        0x1A2B_3C4D,
        1,
        0xFFFF_FFFF,
        0xFFFF_FFFF,
        28,
    ] {
        word(&mut b, v);
    }
    // interface description block: link type 201, snaplen 65535
    for v in [1, 20, 201, 65535, 20] {
        word(&mut b, v);
    }
    // one enhanced packet block of 100 bytes
    for v in [6, 132, 0, 0, 1, 100, 100] {
        word(&mut b, v);
    }
    b.extend_from_slice(&[0x45; 100]);
    word(&mut b, 132);
    std::fs::write(&ng.0, &b).expect("write");
    for path in [&file.0, &ng.0] {
        let out = mimnav(&["replay", "--fast", "-q", &path.display().to_string()]);
        let all = shown(&out);
        assert!(!out.status.success(), "{}: {all}", path.display());
        assert!(all.contains("link type 201 is not supported"), "{all}");
        let out = driver_replay(path);
        let all = shown(&out);
        assert!(!out.status.success(), "{}: {all}", path.display());
        assert!(all.contains("link type 201 is not supported"), "{all}");
    }
}
