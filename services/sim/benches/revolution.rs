//! Time to simulate one dual-return revolution (600 rpm: about 151 packets, 29 000 firings) of
//! each bundled world, one core. The densest is scenario 4 (grass everywhere, bushes, trees).
//!
//! Worlds with grass are timed again with `sim.grass_blades` (grass as blades in the ground).
//!
//! `cargo bench -p mimnav-sim --bench revolution`

use std::path::PathBuf;
use std::time::Instant;

use mimnav_sim::world::WorldFile;
use mimnav_sim::{DEFAULT_EPOCH_NS, Sim, SimSettings};

fn main() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../config/worlds");
    let mut worlds: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("config/worlds")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    worlds.sort();
    for path in worlds {
        let w = WorldFile::load(&path).expect("world");
        for blades in [false, true] {
            if blades && w.grass.is_empty() {
                continue;
            }
            let mut settings = SimSettings::default();
            settings.sim.grass_blades = blades;
            time(
                &path,
                blades,
                Sim::new(w.compile(), settings, 1, DEFAULT_EPOCH_NS),
            );
        }
    }
}

fn time(path: &std::path::Path, blades: bool, mut sim: Sim) {
    // warm up: one revolution
    while !sim.step().completes_revolution {}
    let mut best = f64::INFINITY;
    let mut total = 0.0;
    let rounds = 20;
    for _ in 0..rounds {
        let t = Instant::now();
        while !sim.step().completes_revolution {}
        let ms = t.elapsed().as_secs_f64() * 1e3;
        best = best.min(ms);
        total += ms;
    }
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    println!(
        "{:<44} one dual revolution: best {best:6.2} ms, mean {:6.2} ms ({rounds} revolutions)",
        if blades {
            name + " (grass_blades)"
        } else {
            name
        },
        total / rounds as f64
    );
}
