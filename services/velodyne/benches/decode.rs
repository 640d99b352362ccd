//! Decode throughput on the real dual-return capture: packets/s and points/s through the whole
//! driver library (validation, decoding, revolution assembly, planar scan), one core, packets
//! looped in memory — the same measure as `bench/velodyne_decoder_baseline.py`.
//!
//! `cargo bench -p mimnav-velodyne --bench decode [-- --seconds N] [-- --json]`

use std::path::PathBuf;
use std::time::{Duration, Instant};

use mimnav_velodyne::capture::CaptureReader;
use mimnav_velodyne::revolution::{Assembler, AssemblerConfig, max_points_per_revolution};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let json = args.iter().any(|a| a == "--json");
    let seconds = args
        .iter()
        .position(|a| a == "--seconds")
        .and_then(|i| args.get(i + 1))
        .and_then(|s| s.parse::<f64>().ok())
        .unwrap_or(3.0);
    let path = match std::env::var_os("MIMNAV_SHARED_DATA") {
        Some(d) => PathBuf::from(d).join("velodyne/vlp16_dual_nebula.pcap"),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../../../shared/data/velodyne/vlp16_dual_nebula.pcap"),
    };
    let mut reader = match CaptureReader::open(&path) {
        Ok(r) => r,
        Err(e) => {
            println!("SKIP: decode benchmark needs the shared dual capture: {e}");
            return;
        }
    };
    let mut packets: Vec<(u64, Vec<u8>)> = Vec::new();
    while let Ok(Some(d)) = reader.next() {
        if d.payload.len() == 1206 {
            packets.push((d.ts_ns, d.payload.to_vec()));
        }
    }
    let span = packets.last().map_or(0, |p| p.0) - packets.first().map_or(0, |p| p.0) + 663_550;
    let config = AssemblerConfig {
        max_duration_ns: 150_000_000,
        max_points: max_points_per_revolution(600.0, 0.15),
        ..AssemblerConfig::default()
    };
    let mut asm = Assembler::new(config);
    let pass = |repeat: u64, asm: &mut Assembler| -> u64 {
        let mut points = 0u64;
        for (ts, p) in &packets {
            // shift timestamps by one capture length per pass so revolutions cut the same way
            if let Ok(Some(rev)) = asm.push(p, ts + repeat * span, 0) {
                points += u64::from(rev.header.point_count);
            }
        }
        points
    };
    pass(0, &mut asm); // warm-up
    let mut best_pps = 0.0f64;
    let mut best_points = 0.0f64;
    let mut repeats = 1u64;
    for _round in 0..5 {
        let start = Instant::now();
        let mut n_packets = 0u64;
        let mut n_points = 0u64;
        while start.elapsed() < Duration::from_secs_f64(seconds / 5.0) {
            n_points += pass(repeats, &mut asm);
            n_packets += packets.len() as u64;
            repeats += 1;
        }
        let s = start.elapsed().as_secs_f64();
        if n_packets as f64 / s > best_pps {
            best_pps = n_packets as f64 / s;
            best_points = n_points as f64 / s;
        }
    }
    if json {
        let line = serde_json::json!({
            "packets_per_s": best_pps.round(),
            "points_per_s": best_points.round(),
        });
        println!("{line}");
    } else {
        println!(
            "mimnav-velodyne decode: {:.0} packets/s, {:.1} M points/s (dual capture, in memory, \
             {} packets, best of 5 rounds over {seconds} s, one core)",
            best_pps,
            best_points / 1e6,
            packets.len()
        );
    }
}
