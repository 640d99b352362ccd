//! One revolution through the whole mapper (binning into n = 200, m = 4 layers, classes, glass
//! detection and memory, plan cost), one core: the real dual-return capture's revolutions, and a
//! simulated revolution of scenario 1 (glass in view) for comparison; each also with the surface
//! cue off (`mapper.surface_min_returns = 0`) and with tall cells not kept
//! (`mapper.tall_memory_s = 0`), to show what each costs.
//!
//! `cargo bench -p mimnav-mapper --bench mapper`

use std::path::PathBuf;
use std::time::Instant;

use mimnav_mapper::glass::Pose2;
use mimnav_mapper::{Mapper, MapperParams, Odom, OdomInput};
use mimnav_shared::topics::Point;
use mimnav_velodyne::capture::CaptureReader;
use mimnav_velodyne::revolution::{Assembler, AssemblerConfig};

fn time(name: &str, revs: &[Vec<Point>]) {
    time_with(name, MapperParams::default(), revs);
    let mut off = MapperParams::default();
    off.mapper.surface_min_returns = 0;
    time_with(&format!("{name}, surface cue off"), off, revs);
    let mut off = MapperParams::default();
    off.mapper.tall_memory_s = 0.0;
    time_with(&format!("{name}, tall cells not kept"), off, revs);
}

fn time_with(name: &str, params: MapperParams, revs: &[Vec<Point>]) {
    let mut mapper = Mapper::new(params);
    let odom = OdomInput::Fresh(Odom {
        pose: Pose2::default(),
        v: 0.3,
        omega: 0.2,
    });
    for r in revs {
        mapper.update(r, odom, 0);
    }
    let mut best = f64::INFINITY;
    let mut total = 0.0;
    let mut n = 0;
    let start = Instant::now();
    while start.elapsed().as_secs_f64() < 3.0 {
        for r in revs {
            let t = Instant::now();
            mapper.update(r, odom, 0);
            let us = t.elapsed().as_secs_f64() * 1e6;
            best = best.min(us);
            total += us;
            n += 1;
        }
    }
    let points = revs.iter().map(Vec::len).sum::<usize>() / revs.len().max(1);
    let stats = revs
        .last()
        .map(|r| mapper.update(r, odom, 0))
        .unwrap_or_default();
    println!(
        "{name}: {points} points a revolution: mean {:.0} µs, best {best:.0} µs ({n} revolutions); \
         glass cells detected {}, in memory {}, extrapolated {}; surface cells found {}, in memory {}; tall cells in memory {}",
        total / n as f64,
        stats.glass_detected,
        stats.glass_memory,
        stats.glass_extended,
        stats.surface_found,
        stats.surface_memory,
        stats.tall_memory
    );
}

fn main() {
    let path = match std::env::var_os("MIMNAV_SHARED_DATA") {
        Some(d) => PathBuf::from(d).join("velodyne/vlp16_dual_nebula.pcap"),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../../../shared/data/velodyne/vlp16_dual_nebula.pcap"),
    };
    let mut asm = Assembler::new(AssemblerConfig::default());
    let mut revs = Vec::new();
    match CaptureReader::open(&path) {
        Ok(mut r) => {
            while let Ok(Some(d)) = r.next() {
                if let Ok(Some(rev)) = asm.push(d.payload, d.ts_ns, 0) {
                    revs.push(rev.points.clone());
                }
            }
            time("real dual capture", &revs);
        }
        Err(e) => println!("SKIP real capture: {e}"),
    }
    let world = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../config/worlds/scenario1_glass_wall.toml");
    let scene = mimnav_sim::world::WorldFile::load(&world)
        .expect("world")
        .compile();
    let mut sim = mimnav_sim::Sim::new(
        scene,
        mimnav_sim::SimSettings::default(),
        1,
        mimnav_sim::DEFAULT_EPOCH_NS,
    );
    let mut asm = Assembler::new(AssemblerConfig::default());
    let mut revs = Vec::new();
    while revs.len() < 5 {
        let s = sim.step();
        if let Ok(Some(rev)) = asm.push(&s.data, s.first_firing_ns, 0) {
            revs.push(rev.points.clone());
        }
    }
    time("simulated scenario 1", &revs);
}
