//! Times `Classifier::classify_moved` (with the sensor driving, as the service runs it) and
//! `Classifier::classify` (no odometry) on synthetic VLP-16 scans (1800 returns, one laser, one turn):
//! walls, a trunk and posts, and grass of varying density, with range noise and 2 mm quantisation,
//! made by the unit tests' scene simulator (`mimnav_foliage::scene`).
//!
//! Run: `cargo bench -p mimnav-foliage --bench scan [-- <scans> [<kind 0..5>]]`

use std::hint::black_box;
use std::time::Instant;

use mimnav_foliage::scene::{NE, Rng, Scene};
use mimnav_foliage::{Classifier, FoliageParams, Motion};

/// Scene `k`: a corridor of walls, a trunk and two posts, and grass whose density depends on `k`
/// (from none to dense), in the unit tests' scene simulator.
fn scene(k: usize) -> Scene {
    let mfp = [0.0f32, 0.6, 1.0, 2.0, 4.0][k % 5];
    Scene {
        segments: vec![
            ((2.5, -3.0), (2.5, 3.0)),
            ((-3.0, 1.8), (1.0, 2.2)),
            ((-2.0, -2.6), (1.5, -1.9)),
        ],
        discs: vec![(1.2, 0.8, 0.15), (-1.0, -0.5, 0.05), (0.3, -1.2, 0.05)],
        // grass from 0.4 m on, no return beyond 30 m
        grass: (mfp > 0.0).then_some((0.4, 30.0, mfp)),
        ..Scene::open()
    }
}

fn main() {
    // cargo bench passes --bench: only the plain arguments count
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let n_scans: usize = args.first().and_then(|s| s.parse().ok()).unwrap_or(20_000);
    let mut rng = Rng::new(42);
    // Optional second argument: only scenes of one grass kind (0..5, see the table printed).
    let only: Option<usize> = args.get(1).and_then(|s| s.parse().ok());
    let scans: Vec<(Vec<f32>, Vec<f32>)> = (0..100)
        .map(|k| scene(only.unwrap_or(k / 10)).scan(&mut rng))
        .collect();
    let mut clf = match Classifier::new(FoliageParams::default()) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("bad parameters: {e}");
            std::process::exit(1);
        }
    };
    // The service's path: odometry says the robot drove 5 cm since the last scan, so the
    // default 2 earlier scans are carried (interpretation 17); then without odometry (the paper's
    // pipeline, nothing carried).
    let moving = Some(Motion {
        dx_m: 0.05,
        ..Motion::default()
    });
    for (label, motion) in [
        (
            "classify_moved(), driving 5 cm a scan (2 scans carried)",
            moving,
        ),
        ("classify(), no odometry (nothing carried)", None),
    ] {
        time_scans(&mut clf, &scans, n_scans, only, label, motion);
    }
}

fn time_scans(
    clf: &mut Classifier,
    scans: &[(Vec<f32>, Vec<f32>)],
    n_scans: usize,
    only: Option<usize>,
    label: &str,
    motion: Option<Motion>,
) {
    clf.reset();
    // Warm-up: sizes the buffers, fills the caches.
    for (a, r) in scans.iter().take(50) {
        black_box(clf.classify_moved(a, r, motion).alarm);
    }
    let mut times = Vec::with_capacity(n_scans);
    let mut per_kind = [(0.0f64, 0usize); 5];
    let mut alarms = 0usize;
    let mut obstacles = 0usize;
    let total = Instant::now();
    for i in 0..n_scans {
        let (a, r) = &scans[i % scans.len()];
        let t0 = Instant::now();
        let v = clf.classify_moved(black_box(a), black_box(r), black_box(motion));
        let dt = t0.elapsed();
        alarms += usize::from(v.alarm);
        obstacles += v.obstacle_count;
        let us = dt.as_secs_f64() * 1e6;
        times.push(us);
        let kind = &mut per_kind[only.unwrap_or((i % scans.len()) / 10) % 5];
        kind.0 += us;
        kind.1 += 1;
    }
    let wall = total.elapsed().as_secs_f64();
    times.sort_by(f64::total_cmp);
    let mean = times.iter().sum::<f64>() / times.len().max(1) as f64;
    let pct = |p: f64| times[((times.len() as f64 - 1.0) * p).round() as usize];
    println!(
        "{label}: {n_scans} scans x {NE} returns: mean {mean:.1} us, p50 {:.1} us, p99 {:.1} us, max {:.1} us \
         ({:.0} scans/s; {alarms} alarms, {:.0} obstacle returns/scan)",
        pct(0.5),
        pct(0.99),
        pct(1.0),
        n_scans as f64 / wall,
        obstacles as f64 / n_scans.max(1) as f64
    );
    let kinds = [
        "no grass",
        "grass mfp 0.6 m",
        "grass mfp 1 m",
        "grass mfp 2 m",
        "grass mfp 4 m",
    ];
    for (name, (sum, n)) in kinds.iter().zip(per_kind) {
        println!("  {name:>16}: mean {:.1} us", sum / n.max(1) as f64);
    }
}
