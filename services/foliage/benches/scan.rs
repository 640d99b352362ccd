//! Times `Classifier::classify_moved` (with the sensor driving, as the service runs it) and
//! `Classifier::classify` (no odometry) on synthetic VLP-16 scans (1800 returns, one laser, one turn):
//! walls, a trunk and posts, and grass of varying density, with range noise and 2 mm quantisation.
//!
//! Run: `cargo bench -p mimnav-foliage --bench scan [-- <scans> [<kind 0..5>]]`

use std::f32::consts::{PI, TAU};
use std::hint::black_box;
use std::time::Instant;

use mimnav_foliage::{Classifier, FoliageParams, Motion};

const NE: usize = 1800;

/// SplitMix64.
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
    fn normal(&mut self, sigma: f32) -> f32 {
        let s: f32 = (0..4).map(|_| self.unit()).sum::<f32>() - 2.0;
        s * sigma * 3.0f32.sqrt()
    }
}

fn ray_disc(a: f32, cx: f32, cy: f32, rad: f32) -> Option<f32> {
    let b = a.cos() * cx + a.sin() * cy;
    let disc = b * b - (cx * cx + cy * cy - rad * rad);
    (disc >= 0.0).then(|| b - disc.sqrt()).filter(|t| *t > 0.0)
}

fn ray_segment(a: f32, p0: (f32, f32), p1: (f32, f32)) -> Option<f32> {
    let (dx, dy) = (a.cos(), a.sin());
    let (ex, ey) = (p1.0 - p0.0, p1.1 - p0.1);
    let den = dx * ey - dy * ex;
    if den.abs() < 1e-9 {
        return None;
    }
    let t = (p0.0 * ey - p0.1 * ex) / den;
    let u = (p0.0 * dy - p0.1 * dx) / den;
    (t > 0.0 && (0.0..=1.0).contains(&u)).then_some(t)
}

/// One scan of scene `k`: a corridor of walls, a trunk and two posts, and grass whose density
/// changes from scan to scan (from none to dense).
fn scan(rng: &mut Rng, k: usize) -> (Vec<f32>, Vec<f32>) {
    let mfp = [0.0f32, 0.6, 1.0, 2.0, 4.0][k % 5];
    let walls = [
        ((2.5f32, -3.0f32), (2.5f32, 3.0f32)),
        ((-3.0, 1.8), (1.0, 2.2)),
        ((-2.0, -2.6), (1.5, -1.9)),
    ];
    let discs = [
        (1.2f32, 0.8f32, 0.15f32),
        (-1.0, -0.5, 0.05),
        (0.3, -1.2, 0.05),
    ];
    let phase = rng.unit();
    let mut angles = Vec::with_capacity(NE);
    let mut ranges = Vec::with_capacity(NE);
    for r in 0..NE {
        // Clockwise sweep: the azimuth decreases in firing order.
        let a = {
            let t = (PI - (r as f32 + phase) * TAU / NE as f32 + PI).rem_euclid(TAU) - PI;
            if t <= -PI { t + TAU } else { t }
        };
        let mut best = f32::INFINITY;
        for &(p0, p1) in &walls {
            if let Some(t) = ray_segment(a, p0, p1) {
                best = best.min(t);
            }
        }
        for &(cx, cy, rad) in &discs {
            if let Some(t) = ray_disc(a, cx, cy, rad) {
                best = best.min(t);
            }
        }
        if mfp > 0.0 {
            best = best.min(0.4 - mfp * (1.0 - rng.unit()).ln());
        }
        let range = if best < 30.0 {
            ((best + rng.normal(0.01)) / 0.002).round() * 0.002
        } else {
            0.0
        };
        angles.push(a);
        ranges.push(range);
    }
    (angles, ranges)
}

fn main() {
    // cargo bench passes --bench: only the plain arguments count
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let n_scans: usize = args.first().and_then(|s| s.parse().ok()).unwrap_or(20_000);
    let mut rng = Rng(42);
    // Optional second argument: only scenes of one grass kind (0..5, see the table printed).
    let only: Option<usize> = args.get(1).and_then(|s| s.parse().ok());
    let scans: Vec<(Vec<f32>, Vec<f32>)> = (0..100)
        .map(|k| scan(&mut rng, only.unwrap_or(k / 10)))
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
