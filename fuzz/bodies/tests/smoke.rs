//! The CI smoke run of every fuzz target, on stable and without cargo-fuzz: each target's body
//! over its seed corpus (made at run time from `../shared/data/velodyne` and `config/`; a SKIP
//! line when the captures are missing) and then over mutations of the seeds from a fixed seed,
//! until a target's count of inputs or `BUDGET` of time, whichever comes first (about 25 s in
//! all in a debug build, the five in parallel under nextest). A panic here is a crash:
//! reproduce it with `cargo +nightly fuzz run TARGET FILE` after writing the input out (the
//! failing input is printed in hex).
use std::time::{Duration, Instant};

use mimnav_fuzz_bodies::{Rng, mutate, run, seeds};

const BUDGET: Duration = Duration::from_secs(15);

fn smoke(target: &str, mutations: usize, needs_captures: bool) {
    let corpus = seeds(target);
    if corpus.is_empty() {
        assert!(needs_captures, "{target}: no seeds from config/");
        println!(
            "SKIP {target}: no captures in {} (only random inputs run)",
            mimnav_fuzz_bodies::captures_dir().display()
        );
    }
    let start = Instant::now();
    for (name, bytes) in &corpus {
        let r = std::panic::catch_unwind(|| run(target, bytes));
        assert!(r.is_ok(), "{target}: seed {name} crashed");
    }
    let mut rng = Rng::new(0x6d69_6d6e_6176 ^ target.len() as u64);
    let mut n = 0;
    while n < mutations && start.elapsed() < BUDGET {
        let mut input = if corpus.is_empty() {
            (0..rng.below(2048)).map(|_| rng.next_u64() as u8).collect()
        } else {
            corpus[rng.below(corpus.len())].1.clone()
        };
        mutate(&mut input, &mut rng);
        let r = std::panic::catch_unwind(|| run(target, &input));
        assert!(
            r.is_ok(),
            "{target}: mutation {n} crashed on {} bytes: {}",
            input.len(),
            input.iter().map(|b| format!("{b:02x}")).collect::<String>()
        );
        n += 1;
    }
    println!(
        "{target}: {} seeds and {n} mutations in {:.1} s, no crash",
        corpus.len(),
        start.elapsed().as_secs_f64()
    );
}

#[test]
fn smoke_velodyne_stream() {
    smoke("velodyne_stream", 60_000, true);
}

#[test]
fn smoke_capture() {
    smoke("capture", 100_000, true);
}

#[test]
fn smoke_config() {
    smoke("config", 10_000, false);
}

#[test]
fn smoke_world() {
    smoke("world", 50_000, false);
}

#[test]
fn smoke_kobuki_frames() {
    smoke("kobuki_frames", 400_000, false);
}

#[test]
fn smoke_sick_cola() {
    smoke("sick_cola", 200_000, false);
}
