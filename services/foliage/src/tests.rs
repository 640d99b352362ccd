//! Unit and integration tests. No dev-dependencies: a tiny deterministic PRNG and a planar scene
//! simulator (trunks, walls, a grass field) live here.

use std::f32::consts::{PI, TAU};

use super::*;
use crate::low_freq::differences;
use mimnav_shared::pose::pose2;

// ---------------------------------------------------------------------------------------------
// Deterministic noise and a small planar scene simulator
// ---------------------------------------------------------------------------------------------

/// SplitMix64: deterministic, seedable, good enough for test noise.
struct Rng(u64);

impl Rng {
    fn new(seed: u64) -> Self {
        Self(seed)
    }
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    fn uniform(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit()
    }
    /// Approximately normal (Irwin–Hall of 4 uniforms), standard deviation `sigma`.
    fn normal(&mut self, sigma: f32) -> f32 {
        let s: f32 = (0..4).map(|_| self.unit()).sum::<f32>() - 2.0;
        s * sigma * 3.0f32.sqrt()
    }
    fn exp(&mut self, mean: f32) -> f32 {
        -mean * (1.0 - self.unit()).ln()
    }
}

const NE: usize = 1800;
const THETA: f32 = TAU / NE as f32;

fn wrap_angle(a: f32) -> f32 {
    let t = (a + PI).rem_euclid(TAU) - PI;
    if t <= -PI { t + TAU } else { t }
}

/// Range along the ray at `angle` to a disc centred at (cx, cy) of radius `rad`, if hit.
fn ray_disc(angle: f32, cx: f32, cy: f32, rad: f32) -> Option<f32> {
    let (dx, dy) = (angle.cos(), angle.sin());
    let b = dx * cx + dy * cy;
    let c = cx * cx + cy * cy - rad * rad;
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    let t = b - disc.sqrt();
    (t > 0.0).then_some(t)
}

/// Range along the ray at `angle` to the segment (x0,y0)-(x1,y1), if hit.
fn ray_segment(angle: f32, p0: (f32, f32), p1: (f32, f32)) -> Option<f32> {
    let (dx, dy) = (angle.cos(), angle.sin());
    let (ex, ey) = (p1.0 - p0.0, p1.1 - p0.1);
    let den = dx * ey - dy * ex;
    if den.abs() < 1e-9 {
        return None;
    }
    let t = (p0.0 * ey - p0.1 * ex) / den;
    let u = (p0.0 * dy - p0.1 * dx) / den;
    (t > 0.0 && (0.0..=1.0).contains(&u)).then_some(t)
}

/// The range a VLP-16 reports for a surface at `best` m (∞: none, reported as 0): Gaussian noise
/// of `sigma`, at least 1 cm, quantised to 2 mm.
fn measured(rng: &mut Rng, best: f32, sigma: f32) -> f32 {
    if best.is_finite() {
        let noisy = (best + rng.normal(sigma)).max(0.01);
        (noisy / 0.002).round() * 0.002
    } else {
        0.0
    }
}

#[derive(Clone)]
struct Scene {
    discs: Vec<(f32, f32, f32)>,
    segments: Vec<((f32, f32), (f32, f32))>,
    /// Grass field: (inner radius, outer radius, mean free path of a beam in it).
    grass: Option<(f32, f32, f32)>,
    /// Range noise, metres (standard deviation).
    sigma: f32,
}

impl Scene {
    fn open() -> Self {
        Self {
            discs: vec![],
            segments: vec![],
            grass: None,
            sigma: 0.01,
        }
    }
    /// One revolution of one VLP-16 laser: 1800 returns, clockwise (angles decrease in firing
    /// order), random azimuth phase, Gaussian range noise, 2 mm quantisation.
    fn scan(&self, rng: &mut Rng) -> (Vec<f32>, Vec<f32>) {
        let phase = rng.unit();
        let start = rng.uniform(-PI, PI);
        let mut angles = Vec::with_capacity(NE);
        let mut ranges = Vec::with_capacity(NE);
        for r in 0..NE {
            let a = wrap_angle(start - (r as f32 + phase) * THETA);
            let mut best = f32::INFINITY;
            for &(cx, cy, rad) in &self.discs {
                if let Some(t) = ray_disc(a, cx, cy, rad) {
                    best = best.min(t);
                }
            }
            for &(p0, p1) in &self.segments {
                if let Some(t) = ray_segment(a, p0, p1) {
                    best = best.min(t);
                }
            }
            if let Some((g0, g1, mfp)) = self.grass {
                let t = g0 + rng.exp(mfp);
                if t < g1 {
                    best = best.min(t);
                }
            }
            angles.push(a);
            ranges.push(measured(rng, best, self.sigma));
        }
        (angles, ranges)
    }
}

fn grass_field() -> Scene {
    Scene {
        grass: Some((0.5, 4.0, 1.0)),
        ..Scene::open()
    }
}

fn classifier() -> Classifier {
    match Classifier::new(FoliageParams::default()) {
        Ok(c) => c,
        Err(e) => panic!("default params rejected: {e}"),
    }
}

/// A classifier with the given parameters.
fn classifier_with(params: FoliageParams) -> Classifier {
    Classifier::new(params).unwrap_or_else(|e| panic!("params rejected: {e}"))
}

/// A classifier with 4-beam windows (α = 0.8°, the default before the simulated evaluation): the
/// setting for a scan whose obstacle returns are the farthest ones of a partly hidden obstacle (a
/// last-return scan in grass), where more beams per window make it likelier that one reaches.
fn classifier_wide_windows() -> Classifier {
    match Classifier::new(FoliageParams {
        window_rad: 0.8f32.to_radians(),
        ..Default::default()
    }) {
        Ok(c) => c,
        Err(e) => panic!("params rejected: {e}"),
    }
}

/// Window of an angle under the default parameters.
fn window_of(angle: f32) -> usize {
    let p = FoliageParams::default();
    angle_bin(angle, p.window_rad, p.n_windows()).map_or(usize::MAX, |w| w as usize)
}

fn prepared(angles: &[f32], ranges: &[f32], p: &FoliageParams) -> (Vec<f32>, Vec<u32>, Vec<u32>) {
    let (mut r, mut w, mut s) = (vec![], vec![], vec![]);
    prepare_scan(angles, ranges, p, &mut r, &mut w, &mut s);
    (r, w, s)
}

/// Runs FIND-LOW-FREQ and GET-OBST-CANDIDATES on one scan with a fresh history.
fn candidates_of(angles: &[f32], ranges: &[f32]) -> Vec<f32> {
    let p = FoliageParams::default();
    let (r, w, s) = prepared(angles, ranges, &p);
    let scan = Scan {
        ranges: &r,
        windows: &w,
        sectors: &s,
    };
    let mut low = LowFreq::default();
    find_low_freq(scan, p.n_windows(), &mut low);
    let hist = History::free_space(p.n_windows(), p.k1);
    let (mut tk, mut rc, mut work) = (vec![], vec![], WindowWork::default());
    get_obst_candidates(&p, scan, &low, &hist, &mut tk, &mut rc, &mut work);
    rc
}

/// Number of distinct windows holding a candidate.
fn candidate_windows(angles: &[f32], rc: &[f32]) -> usize {
    let mut w: Vec<usize> = (0..rc.len())
        .filter(|&i| rc[i] > 0.0)
        .map(|i| window_of(angles[i]))
        .collect();
    w.sort_unstable();
    w.dedup();
    w.len()
}

// ---------------------------------------------------------------------------------------------
// Parameters and binning
// ---------------------------------------------------------------------------------------------

#[test]
fn default_params_are_valid_and_sized_for_vlp16() {
    let p = FoliageParams::default();
    assert_eq!(p.validate(), Ok(()));
    assert_eq!(p.n_windows(), 900, "0.4 deg windows");
    assert_eq!(p.n_sectors(), 36, "10 deg sectors");
}

#[test]
fn validate_names_the_key_and_range() {
    use mimnav_shared::config::{Allowed, ParamError};
    let bad = [
        FoliageParams {
            k1: -1.0,
            ..Default::default()
        },
        FoliageParams {
            k3: 0.0,
            ..Default::default()
        },
        FoliageParams {
            d_max_m: f32::NAN,
            ..Default::default()
        },
        FoliageParams {
            window_rad: 1.0,
            ..Default::default()
        },
        FoliageParams {
            thin_min: 10,
            ..Default::default()
        },
        FoliageParams {
            thin_window: 0,
            ..Default::default()
        },
    ];
    let keys = [
        "foliage.k1",
        "foliage.k3",
        "foliage.d_max_m",
        "foliage.window_deg",
        "foliage.thin_min",
        "foliage.thin_window",
    ];
    for (p, key) in bad.iter().zip(keys) {
        let err = p.validate().expect_err(key);
        assert!(
            matches!(err.get(key), Some(ParamError::OutOfRange { .. })),
            "{err:?} should name {key} and its range"
        );
        assert!(err.to_string().contains("allowed"), "{err}");
        assert!(Classifier::new(*p).is_err());
    }
    assert_eq!(
        bad[1].validate().expect_err("k3").0[0],
        ParamError::OutOfRange {
            key: "foliage.k3".into(),
            value: 0.0,
            allowed: Allowed::above(0.0, 1000.0),
        }
    );
    let err = FoliageParams {
        d_min_m: 2.0,
        d_max_m: 1.0,
        ..Default::default()
    }
    .validate()
    .expect_err("d_min above d_max");
    assert!(err.to_string().contains("foliage.d_max_m"), "{err}");
}

#[test]
fn windows_wrap_around_pi() {
    let p = FoliageParams::default();
    let n = p.n_windows();
    assert_eq!(angle_bin(-PI, p.window_rad, n), Some(0));
    assert_eq!(
        angle_bin(PI, p.window_rad, n),
        Some(0),
        "pi and -pi are the same direction"
    );
    assert_eq!(angle_bin(PI - 1e-4, p.window_rad, n), Some(n as u32 - 1));
    assert_eq!(angle_bin(-PI + 1e-4, p.window_rad, n), Some(0));
    assert_eq!(angle_bin(0.0, p.window_rad, n), Some(n as u32 / 2));
    // Out-of-range angles wrap onto the circle.
    assert_eq!(
        angle_bin(0.1 + TAU, p.window_rad, n),
        angle_bin(0.1, p.window_rad, n)
    );
    assert_eq!(angle_bin(f32::NAN, p.window_rad, n), None);
    assert_eq!(
        bin_count(1.0f32.to_radians()),
        360,
        "no sliver window from f32 rounding"
    );
    assert_eq!(bin_count(0.7), 9);
}

#[test]
fn candidates_and_neighbours_wrap_around_pi() {
    // A wall at 2 m straddling the ±pi seam, angles increasing (counter-clockwise order).
    let angles: Vec<f32> = (0..NE)
        .map(|r| wrap_angle(-PI + (r as f32 + 0.5) * THETA))
        .collect();
    let ranges: Vec<f32> = angles
        .iter()
        .map(|a| if a.abs() > PI - 0.3 { 2.0 } else { 0.0 })
        .collect();
    let rc = candidates_of(&angles, &ranges);
    let near_seam = |a: f32| a.abs() > PI - 0.03;
    assert!(
        angles
            .iter()
            .zip(&rc)
            .any(|(&a, &c)| near_seam(a) && c > 0.0),
        "windows next to the seam see their neighbours across it"
    );
    // RELAX-OBST wraps the slice: the last return joins a candidate at index 0.
    let mut c = classifier();
    let v = c.classify(&angles, &ranges);
    assert_eq!(
        v.classes[0],
        class::PRUNED,
        "first scan: candidate, held back"
    );
    assert_eq!(v.classes[NE - 1], class::PRUNED);
    let v = c.classify(&angles, &ranges);
    assert!(v.alarm);
    assert_eq!(v.classes[0], class::OBSTACLE);
    assert_eq!(v.classes[NE - 1], class::OBSTACLE);
    // Both ends of the seam report in their own sectors (first and last).
    assert_eq!(v.nearest_per_sector[0], 2.0);
    assert_eq!(v.nearest_per_sector[35], 2.0);
}

// ---------------------------------------------------------------------------------------------
// FIND-LOW-FREQ
// ---------------------------------------------------------------------------------------------

#[test]
fn find_low_freq_exact_values() {
    // 8 windows of 45 deg; a few returns per window, including non-maxima and non-returns.
    let p = FoliageParams {
        window_rad: PI / 4.0,
        ..Default::default()
    };
    assert_eq!(p.n_windows(), 8);
    let centre = |i: usize, off: f32| -PI + (i as f32 + 0.5 + off) * PI / 4.0;
    let mut angles = vec![];
    let mut ranges = vec![];
    let mut put = |i: usize, off: f32, r: f32| {
        angles.push(centre(i, off));
        ranges.push(r);
    };
    put(0, 0.0, 2.0);
    put(0, 0.2, 1.0);
    put(1, -0.2, 1.5);
    put(1, 0.2, 2.0);
    put(2, 0.0, 2.5);
    put(2, 0.1, f32::NAN);
    put(3, 0.0, 3.0);
    put(3, 0.3, -3.5);
    put(4, 0.0, 0.0);
    put(4, 0.1, f32::INFINITY);
    put(5, 0.0, 1.0);
    put(6, 0.0, 1.0);
    put(6, 0.1, 0.25);
    put(7, 0.0, 1.5);
    let (r, w, s) = prepared(&angles, &ranges, &p);
    let mut low = LowFreq::default();
    find_low_freq(
        Scan {
            ranges: &r,
            windows: &w,
            sectors: &s,
        },
        8,
        &mut low,
    );

    assert_eq!(low.v, vec![2.0, 2.0, 2.5, 3.0, 0.0, 1.0, 1.0, 1.5]);
    // dv(i) = v(i+1) - v(i), wrapped: dv(7) = v(0) - v(7).
    assert_eq!(low.dv, vec![0.0, 0.5, 0.5, -3.0, 1.0, 0.0, 0.5, 0.5]);
    // nad2v(i) = |dv(i+1) - dv(i)| / v(i), 0 where v(i) = 0.
    let expect = [
        0.5f32 / 2.0,
        0.0 / 2.0,
        3.5 / 2.5,
        4.0 / 3.0,
        0.0,
        0.5 / 1.0,
        0.0 / 1.0,
        0.5 / 1.5,
    ];
    assert_eq!(low.nad2v, expect.to_vec());
}

// ---------------------------------------------------------------------------------------------
// GET-OBST-CANDIDATES
// ---------------------------------------------------------------------------------------------

/// A flat wall 2 m in front (x = 2, y in [-1, 1]), nothing elsewhere, VLP-16 noise.
fn wall_scan(rng: &mut Rng) -> (Vec<f32>, Vec<f32>) {
    Scene {
        segments: vec![((2.0, -1.0), (2.0, 1.0))],
        ..Scene::open()
    }
    .scan(rng)
}

/// Grass band all around: every return at 1.5 m ± `jitter` (uniform, independent from return to
/// return), i.e. neighbouring returns differ by up to 60–100 %.
fn grass_band_scan(rng: &mut Rng, jitter: f32) -> (Vec<f32>, Vec<f32>) {
    let phase = rng.unit();
    let angles: Vec<f32> = (0..NE)
        .map(|r| wrap_angle(PI - (r as f32 + phase) * THETA))
        .collect();
    let ranges = (0..NE)
        .map(|_| 1.5 * (1.0 + rng.uniform(-jitter, jitter)))
        .collect();
    (angles, ranges)
}

#[test]
fn flat_wall_becomes_candidate_grass_band_does_not() {
    let mut rng = Rng::new(7);
    let (a, r) = wall_scan(&mut rng);
    let rc = candidates_of(&a, &r);
    let on_wall = r.iter().filter(|&&x| x > 0.0).count();
    let cands: Vec<usize> = (0..NE).filter(|&i| rc[i] > 0.0).collect();
    assert!(
        cands.len() >= 20,
        "wall windows become candidates: {} of {on_wall}",
        cands.len()
    );
    assert!(
        cands.iter().all(|&i| r[i] > 1.9 && r[i] < 2.9),
        "candidates lie on the wall"
    );

    // The wall spans 2·atan(1/2) = 53° = 66 windows; nearly all of them hold a candidate.
    let wall_windows = candidate_windows(&a, &rc);
    assert!(
        wall_windows >= 53,
        "wall: only {wall_windows} of 66 windows hold a candidate"
    );

    // The band covers all 450 windows; a max filter over 4 returns can look smooth by chance, so
    // the test is on the rate: over 30 scans at most 0.25 % of the windows, and no scan with more
    // than a tenth of what the (much narrower) wall gives.
    let mut band_windows = 0;
    for seed in 1..=30 {
        let jitter = [0.3, 0.4, 0.5][seed as usize % 3];
        let (a, r) = grass_band_scan(&mut Rng::new(seed), jitter);
        let rc = candidates_of(&a, &r);
        let n = candidate_windows(&a, &rc);
        assert!(
            n * 10 <= wall_windows,
            "seed {seed}: {n} band windows vs {wall_windows} on the wall"
        );
        band_windows += n;
    }
    assert!(
        band_windows * 400 <= 30 * 450,
        "band: {band_windows} candidate windows in 30 scans"
    );
}

/// `GET-OBST-CANDIDATES` on hand-made window values: returns `ranges` in `windows` (one sector),
/// `low` and `hist` as given. Returns the candidate count, `R_c` and `T_k`.
fn candidates_given(
    p: &FoliageParams,
    ranges: &[f32],
    windows: &[u32],
    low: &LowFreq,
    hist: &History,
) -> (usize, Vec<f32>, Vec<f32>) {
    let sectors = vec![0u32; ranges.len()];
    let scan = Scan {
        ranges,
        windows,
        sectors: &sectors,
    };
    let (mut tk, mut rc, mut work) = (vec![], vec![], WindowWork::default());
    let count = get_obst_candidates(p, scan, low, hist, &mut tk, &mut rc, &mut work);
    (count, rc, tk)
}

#[test]
fn candidate_threshold_carry_and_raise() {
    // 16 windows; nad2v 0 everywhere, one return (the maximum) in window 5 only.
    let p = FoliageParams {
        window_rad: TAU / 16.0,
        ..Default::default()
    };
    let n = 16;
    let low = LowFreq {
        v: {
            let mut v = vec![0.0; n];
            v[5] = 2.0;
            v
        },
        dv: vec![0.0; n],
        nad2v: vec![0.0; n],
    };
    let mut hist = History::new(n);
    hist.t_prev1[3] = 0.1;
    hist.t_prev2[3] = 0.2;
    let (count, rc, tk) = candidates_given(&p, &[1.0, 2.0, 2.0, 2.0], &[5, 5, 5, 9], &low, &hist);
    // Both returns tied at v(5) = 2.0 are candidates; the 1.0 one and window 9 (v = 0) are not.
    assert_eq!(count, 2);
    assert_eq!(rc, vec![0.0, 2.0, 2.0, 0.0]);
    let k1 = p.k1;
    let d = p.delta;
    // T_k = K1 + max(T_{k-1}, T_{k-2}) / 2, then + 2 candidates × (δ/2 at ±1, δ/4 at ±2).
    let expect = |i: usize| -> f32 {
        let base = if i == 3 { k1 + 0.2 / 2.0 } else { k1 };
        base + match i {
            4 | 6 => 2.0 * d / 2.0,
            3 | 7 => 2.0 * d / 4.0,
            _ => 0.0,
        }
    };
    for (i, &t) in tk.iter().enumerate() {
        assert!(
            (t - expect(i)).abs() < 1e-6,
            "T_k({i}) = {t}, expected {}",
            expect(i)
        );
    }
    assert_eq!(carry_threshold(0.025, 0.05, 0.01), 0.025 + 0.025);
}

#[test]
fn raised_threshold_carries_to_next_scan() {
    // nad2v(7) = 0.03 is above K1 = 0.025: window 7 blocks its neighbourhood on a fresh history,
    // but passes once the previous scan raised T(7).
    let p = FoliageParams {
        window_rad: TAU / 16.0,
        ..Default::default()
    };
    let n = 16;
    let mut nad2v = vec![0.0; n];
    nad2v[7] = 0.03;
    let low = LowFreq {
        v: vec![1.0; n],
        dv: vec![0.0; n],
        nad2v,
    };
    let ranges = [1.0f32];
    let windows = [6u32];
    let sectors = [0u32];
    let scan = Scan {
        ranges: &ranges,
        windows: &windows,
        sectors: &sectors,
    };
    let (mut tk, mut rc, mut work) = (vec![], vec![], WindowWork::default());
    let mut hist = History::new(n);
    assert_eq!(
        get_obst_candidates(&p, scan, &low, &hist, &mut tk, &mut rc, &mut work),
        0
    );
    hist.t_prev1[7] = p.k1 + p.delta / 2.0; // as left by a candidate in window 6 or 8
    assert_eq!(
        get_obst_candidates(&p, scan, &low, &hist, &mut tk, &mut rc, &mut work),
        1
    );
}

/// Interpretation 15: a window passes, blocked neighbourhood or not, when its maximum is near the
/// obstacle confirmed last scan in it or in the window beside it (a bearing that drifted), but
/// not two windows away, not at another range, and not with `hold_obstacles` off.
#[test]
fn held_obstacle_passes_its_own_and_the_neighbouring_windows() {
    let n = 16;
    // every window blocks: nothing passes the paper's test alone
    let mut low = LowFreq {
        v: vec![2.0; n],
        dv: vec![0.0; n],
        nad2v: vec![1.0; n],
    };
    low.v[6] = 2.01;
    low.v[7] = 2.3;
    let (ranges, windows) = ([2.0f32, 2.01, 2.0, 2.3], [5u32, 6, 8, 7]);
    let mut hist = History::free_space(n, 0.02);
    hist.obst_prev[5] = 2.0; // confirmed last scan in window 5 only
    hist.obst_prev[7] = 2.0; // and in window 7, where the maximum is now 0.3 m farther
    for (hold, expect) in [(true, vec![2.0, 2.01, 2.0, 0.0]), (false, vec![0.0; 4])] {
        let p = FoliageParams {
            window_rad: TAU / n as f32,
            hold_obstacles: hold,
            ..Default::default()
        };
        let (_, rc, _) = candidates_given(&p, &ranges, &windows, &low, &hist);
        // window 5 (its own), 6 (beside 5 and 7) and 8 (beside 7) pass; 7 is at another range
        assert_eq!(rc, expect, "hold_obstacles = {hold}");
    }
    // two windows away from anything held: blocked
    hist.obst_prev.fill(0.0);
    hist.obst_prev[3] = 2.0;
    let p = FoliageParams {
        window_rad: TAU / n as f32,
        ..Default::default()
    };
    let (_, rc, _) = candidates_given(&p, &ranges, &windows, &low, &hist);
    assert_eq!(rc, vec![0.0; 4]);
}

// ---------------------------------------------------------------------------------------------
// RELAX-OBST
// ---------------------------------------------------------------------------------------------

#[test]
fn relax_extends_within_tolerance_and_stops_at_jump() {
    let p = FoliageParams::default(); // a = 0.01, b = 0.03: T ≈ 0.05 m at 2 m with no evidence
    let ranges = [2.0f32, 2.01, 0.0, 2.03, 2.5, 2.51, 2.52, 1.4, 1.3, 2.02];
    let n = ranges.len();
    let windows = vec![0u32; n];
    let sectors = vec![0u32; n];
    let scan = Scan {
        ranges: &ranges,
        windows: &windows,
        sectors: &sectors,
    };
    let hist = History::new(8);
    let mut rc = vec![0.0; n];
    rc[0] = 2.0;
    let mut q = RelaxWork::default();
    let added = relax_obst(&p, scan, &hist, &mut rc, &mut q);
    // Joined: 1 (from 0), 9 (r-1 of 0, wrapped), 3 (r+2 of 1, over the no-return at 2).
    // Not joined: 4–6 (0.47 m jump), 7 and 8 (1.4 m, 1.3 m), 2 (no return).
    assert_eq!(
        rc,
        vec![2.0, 2.01, 0.0, 2.03, 0.0, 0.0, 0.0, 0.0, 0.0, 2.02]
    );
    assert_eq!(added, 3);

    // With evidence on the window the tolerance grows by C = 1 + K2·(25 + 0) = 2.25 (≈ 0.113 m):
    // a 0.1 m step is now bridged, the 0.47 m jump still is not.
    let ranges2 = [2.0f32, 2.1, 2.2, 2.67];
    let mut hist = History::new(8);
    let windows2 = [0u32; 4];
    let sectors2 = [0u32; 4];
    let scan2 = Scan {
        ranges: &ranges2,
        windows: &windows2,
        sectors: &sectors2,
    };
    let mut rc = vec![2.0, 0.0, 0.0, 0.0];
    relax_obst(&p, scan2, &hist, &mut rc, &mut q);
    assert_eq!(
        rc,
        vec![2.0, 0.0, 0.0, 0.0],
        "0.1 m > 0.05 m without evidence"
    );
    hist.c_prev1[0] = 25.0;
    let mut rc = vec![2.0, 0.0, 0.0, 0.0];
    relax_obst(&p, scan2, &hist, &mut rc, &mut q);
    assert_eq!(rc, vec![2.0, 2.1, 2.2, 0.0]);
    let t = relax_tolerance(&p, 2.1, 25.0, 0.0);
    assert!((t - 2.25 * (0.01 * 2.1 + 0.03)).abs() < 1e-6);
}

// ---------------------------------------------------------------------------------------------
// Pruning
// ---------------------------------------------------------------------------------------------

#[test]
fn remove_new_obst_needs_evidence_nearby() {
    let n_w = 32;
    let mut hist = History::new(n_w);
    hist.c_prev2[10] = 3.0;
    let windows: Vec<u32> = (5..16).collect();
    let rc = vec![1.0f32; windows.len()];
    let sectors = vec![0u32; windows.len()];
    let scan = Scan {
        ranges: &rc,
        windows: &windows,
        sectors: &sectors,
    };
    let mut rf = vec![];
    remove_new_obst(scan, &hist, &rc, &mut rf);
    let kept: Vec<u32> = windows
        .iter()
        .zip(&rf)
        .filter(|(_, f)| **f > 0.0)
        .map(|(w, _)| *w)
        .collect();
    assert_eq!(kept, vec![8, 9, 10, 11, 12]);
    // Wrap: evidence in window 0 supports window n_w - 1.
    let mut hist = History::new(n_w);
    hist.c_prev1[0] = 1.0;
    assert!(hist.seen_near(n_w - 2) && hist.seen_near(1) && !hist.seen_near(n_w - 3));
}

#[test]
fn obstacle_seen_once_is_held_back_until_seen_again() {
    let mut c = classifier();
    let mut rng = Rng::new(3);
    let (a, r) = wall_scan(&mut rng);
    let v = c.classify(&a, &r);
    assert!(!v.alarm, "new obstacle: held back");
    assert!(v.candidate_count > 50);
    assert_eq!(v.obstacle_count, 0);
    assert!(v.classes.contains(&class::PRUNED));
    // An empty scan in between: the evidence of the first scan is still in C_{k-2}.
    let v = c.classify(&a, &vec![0.0; a.len()]);
    assert!(!v.alarm);
    let (a, r) = wall_scan(&mut rng);
    let v = c.classify(&a, &r);
    assert!(v.alarm, "seen again: confirmed");
    assert!(v.obstacle_count > 50);
    let front = v.nearest_per_sector[18]; // sector [0, 10 deg)
    assert!(front > 1.95 && front < 2.1, "R_s ahead = {front}");
    assert_eq!(v.nearest_per_sector[0], f32::INFINITY);

    // After a reset it is new again.
    c.reset();
    let v = c.classify(&a, &r);
    assert!(!v.alarm);
}

#[test]
fn remove_thin_drops_isolated_hits() {
    // W_s = 5 (d = 2), O_s = 3.
    let mut rf = vec![0.0f32; 20];
    rf[3] = 1.0; // isolated
    for x in &mut rf[8..11] {
        *x = 2.0; // run of 3: every member sees 3 in its 5-window
    }
    rf[14] = 1.5; // pair with a gap: 14, 16 see 2 each
    rf[16] = 1.5;
    rf[19] = 3.0; // run across the wrap: 19, 0, 1
    rf[0] = 3.0;
    rf[1] = 3.0;
    let mut copy = vec![];
    let dropped = remove_thin_obst(&mut rf, 5, 3, &mut copy);
    assert_eq!(dropped, 3);
    let kept: Vec<usize> = (0..20).filter(|&i| rf[i] > 0.0).collect();
    assert_eq!(kept, vec![0, 1, 8, 9, 10, 19]);
    // Counted on the entry copy, no cascade: with W_s = 3, O_s = 3 the middle of a run of three
    // keeps its count of 3 although both ends are dropped.
    let mut run = vec![0.0f32, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    assert_eq!(remove_thin_obst(&mut run, 3, 3, &mut copy), 2);
    assert_eq!(run, vec![0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    // Scans shorter than the window count as a whole.
    let mut small = vec![1.0f32, 0.0, 1.0];
    assert_eq!(remove_thin_obst(&mut small, 9, 3, &mut copy), 2);
    let mut small = vec![1.0f32, 1.0, 1.0];
    assert_eq!(remove_thin_obst(&mut small, 9, 3, &mut copy), 0);
    assert_eq!(remove_thin_obst(&mut [], 9, 3, &mut copy), 0);
}

#[test]
fn crop_range_drops_outside_interval() {
    let mut rf = vec![0.2f32, 0.3, 1.0, 3.0, 3.01, 0.0, 50.0];
    assert_eq!(crop_range(&mut rf, 0.3, 3.0), 3);
    assert_eq!(rf, vec![0.0, 0.3, 1.0, 3.0, 0.0, 0.0, 0.0]);
}

// ---------------------------------------------------------------------------------------------
// UPDATE-AND-ARCHIVE
// ---------------------------------------------------------------------------------------------

#[test]
fn evidence_step_values() {
    assert_eq!(evidence_step(25.0, 0.0), 25.0, "learn: C_k + C_{{k-1}}");
    assert_eq!(
        evidence_step(25.0, 12.0),
        37.0,
        "learn fast on top of old evidence"
    );
    assert_eq!(evidence_step(0.0, 25.0), 12.0, "forget: 25 - ceil(12.5)");
    assert_eq!(
        evidence_step(25.0, 25.0),
        0.0,
        "equal evidence: 25 - ceil(25), the literal rule"
    );
    assert_eq!(evidence_step(0.0, 0.5), 0.0, "never below 0");
    assert_eq!(evidence_step(0.0, 0.0), 0.0);
}

#[test]
fn evidence_grows_fast_and_decays_slowly() {
    let p = FoliageParams {
        window_rad: TAU / 16.0,
        ..Default::default()
    };
    let mut hist = History::new(16);
    let ranges = [1.0f32];
    let windows = [4u32];
    let sectors = [0u32];
    let scan = Scan {
        ranges: &ranges,
        windows: &windows,
        sectors: &sectors,
    };
    let mut ck = vec![];
    let mut nearest = vec![0.0; p.n_sectors()];
    // Candidate pattern per scan for window 4, and the expected (C_{k-1}, C_{k-2}) after each.
    let seen = [
        true, false, false, false, false, false, false, true, false, true, true, true,
    ];
    let expect = [
        (25.0, 0.0),
        (12.0, 25.0),
        (6.0, 12.0),
        (3.0, 6.0),
        (1.0, 3.0),
        (0.0, 1.0), // expired after 5 scans without it
        (0.0, 0.0),
        (25.0, 0.0),
        (12.0, 25.0),
        (37.0, 12.0), // seen again soon: learns fast, above K3
        (6.0, 37.0),  // 37 - ceil((25 + 37) / 2)
        (31.0, 6.0),
    ];
    for (k, (&s, &(e1, e2))) in seen.iter().zip(&expect).enumerate() {
        let rc = [if s { 1.0 } else { 0.0 }];
        let rf = [0.0f32];
        let alarm = update_and_archive(&p, scan, &rc, &rf, &mut hist, &mut ck, &mut nearest);
        assert!(!alarm, "alarm comes from R_f, which is empty");
        assert_eq!(ck[4], if s { p.k3 } else { 0.0 }, "C_k from R_c, scan {k}");
        assert_eq!((hist.c_prev1[4], hist.c_prev2[4]), (e1, e2), "scan {k}");
        assert_eq!(hist.c_prev1[3], 0.0, "other windows untouched");
    }
    // R_s and alarm from R_f.
    let rf = [1.0f32];
    let alarm = update_and_archive(&p, scan, &[1.0], &rf, &mut hist, &mut ck, &mut nearest);
    assert!(alarm);
    assert_eq!(nearest[0], 1.0);
    assert!(nearest[1..].iter().all(|x| x.is_infinite()));
}

// ---------------------------------------------------------------------------------------------
// Robustness
// ---------------------------------------------------------------------------------------------

#[test]
fn robust_to_empty_mismatched_nan_and_zero_scans() {
    let mut c = classifier();
    let v = c.classify(&[], &[]);
    assert!(!v.alarm);
    assert!(v.classes.is_empty());
    assert_eq!(v.nearest_per_sector.len(), 36);

    let v = c.classify(&[0.0, 0.1, 0.2], &[1.0]);
    assert_eq!(v.classes.len(), 1, "min of the two lengths");
    let v = c.classify(&[0.0], &[1.0, 2.0, 3.0]);
    assert_eq!(v.classes.len(), 1);

    let angles: Vec<f32> = (0..NE).map(|r| wrap_angle(PI - r as f32 * THETA)).collect();
    for _ in 0..3 {
        let v = c.classify(&angles, &vec![0.0; NE]);
        assert!(!v.alarm);
        assert!(v.classes.iter().all(|&k| k == class::NO_RETURN));
        assert!(v.nearest_per_sector.iter().all(|x| x.is_infinite()));
    }
    let weird = [
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        -1.0,
        0.0,
        f32::MAX,
        f32::MIN_POSITIVE,
    ];
    for _ in 0..3 {
        let ranges: Vec<f32> = (0..NE).map(|i| weird[i % weird.len()]).collect();
        let v = c.classify(&angles, &ranges);
        assert!(
            v.classes
                .iter()
                .enumerate()
                .all(|(i, &k)| (k == class::NO_RETURN) == (i % 7 < 5))
        );
        let ranges = vec![f32::NAN; NE];
        let v = c.classify(&angles, &ranges);
        assert!(!v.alarm);
        let bad_angles: Vec<f32> = (0..NE)
            .map(|i| if i % 2 == 0 { f32::NAN } else { 1e30 })
            .collect();
        let v = c.classify(&bad_angles, &vec![2.0; NE]);
        assert!(v.classes.iter().step_by(2).all(|&k| k == class::NO_RETURN));
    }
    // A flat "scan" of identical returns at one angle, and tiny scans, must not panic either.
    for n in 0..8 {
        let _ = c.classify(&vec![0.3; n], &vec![2.0; n]);
        let _ = c.classify(&vec![0.3; n], &vec![2.0; n]);
    }
}

#[test]
fn no_reallocation_after_first_scan() {
    let mut c = classifier();
    let mut rng = Rng::new(11);
    let scene = Scene {
        discs: vec![(1.5, 0.2, 0.15)],
        ..grass_field()
    };
    let (a, r) = scene.scan(&mut rng);
    c.classify(&a, &r);
    let ptrs = |c: &Classifier| {
        [
            c.ranges.as_ptr() as usize,
            c.windows.as_ptr() as usize,
            c.rc.as_ptr() as usize,
            c.rf.as_ptr() as usize,
            c.classes.as_ptr() as usize,
            c.thin_copy.as_ptr() as usize,
            c.relax_work.stack.as_ptr() as usize,
            c.relax_work.can_join.as_ptr() as usize,
            c.work.pass.as_ptr() as usize,
        ]
    };
    let caps = |c: &Classifier| {
        [
            c.ranges.capacity(),
            c.rc.capacity(),
            c.relax_work.stack.capacity(),
        ]
    };
    let (p0, c0) = (ptrs(&c), caps(&c));
    for _ in 0..20 {
        let (a, r) = scene.scan(&mut rng);
        c.classify(&a, &r);
        c.classify(&a[..900], &r[..900]);
        assert_eq!(ptrs(&c), p0);
        assert_eq!(caps(&c), c0);
    }
}

// ---------------------------------------------------------------------------------------------
// Integrated: grass field with a trunk; pure grass field
// ---------------------------------------------------------------------------------------------

#[test]
fn trunk_in_grass_alarms_by_second_scan() {
    // With 4-beam windows (see classifier_wide_windows): the default 2-beam windows confirm a
    // trunk a third hidden less reliably (the price of seeing thin trunks out to d_max, below).
    // A 0.3 m trunk 1.5 m ahead-left, inside a grass field (0.5–4 m, 2 m mean free path: a third of
    // the beams toward the trunk stop in the grass in front of it).
    let trunk = (1.5f32 * 0.3f32.cos(), 1.5 * 0.3f32.sin(), 0.15);
    let scene = Scene {
        discs: vec![trunk],
        grass: Some((0.5, 4.0, 2.0)),
        ..Scene::open()
    };
    let trunk_sector = angle_bin(0.3, FoliageParams::default().sector_rad, 36).map(|s| s as usize);
    for seed in 1..=20u64 {
        let mut rng = Rng::new(seed);
        let mut c = classifier_wide_windows();
        let (a, r) = scene.scan(&mut rng);
        let first = c.classify(&a, &r).alarm;
        let (a, r) = scene.scan(&mut rng);
        let v = c.classify(&a, &r);
        assert!(
            v.alarm,
            "seed {seed}: trunk not confirmed on scan 2 (first alarm {first})"
        );
        let s = trunk_sector.unwrap_or(0);
        let nearest = v.nearest_per_sector[s];
        // The trunk's face is at 1.35 m; RELAX-OBST may also take in a grass return a few cm in
        // front of it (within C·(a·R + b) ≈ 0.1 m once the trunk has evidence).
        assert!(
            (1.2..1.45).contains(&nearest),
            "seed {seed}: R_s toward the trunk = {nearest}"
        );
        // The obstacle returns are on the trunk, not in the grass.
        for (i, &k) in v.classes.iter().enumerate() {
            if k == class::OBSTACLE {
                let on_trunk = ray_disc(a[i], trunk.0, trunk.1, 0.2).is_some();
                assert!(
                    on_trunk,
                    "seed {seed}: obstacle at angle {} range {}",
                    a[i], r[i]
                );
            }
        }
        // And it keeps alarming while in view.
        let mut alarms = 0;
        for _ in 0..20 {
            let (a, r) = scene.scan(&mut rng);
            alarms += usize::from(c.classify(&a, &r).alarm);
        }
        assert!(
            alarms >= 19,
            "seed {seed}: trunk alarmed on {alarms}/20 later scans"
        );
    }
}

#[test]
fn wall_behind_grass_alarms() {
    // With 4-beam windows, as above.
    // A wall 2.5 m ahead seen through 2 m of grass (2 m mean free path: 37 % of the beams reach it).
    let scene = Scene {
        segments: vec![((2.5, -1.5), (2.5, 1.5))],
        grass: Some((0.5, 10.0, 2.0)),
        ..Scene::open()
    };
    let mut rng = Rng::new(5);
    let mut c = classifier_wide_windows();
    let mut alarms = 0;
    for _ in 0..10 {
        let (a, r) = scene.scan(&mut rng);
        alarms += usize::from(c.classify(&a, &r).alarm);
    }
    assert!(alarms >= 9, "{alarms}/10");
}

#[test]
fn pure_grass_field_rarely_alarms() {
    for (seed, scene) in [
        (1u64, grass_field()),
        (
            2,
            Scene {
                grass: Some((0.4, 6.0, 0.6)),
                ..Scene::open()
            },
        ),
        (
            3,
            Scene {
                grass: Some((0.5, 3.0, 1.5)),
                ..Scene::open()
            },
        ),
    ] {
        let mut rng = Rng::new(seed);
        let mut c = classifier();
        let mut alarms = 0;
        let mut candidates = 0;
        for _ in 0..200 {
            let (a, r) = scene.scan(&mut rng);
            let v = c.classify(&a, &r);
            alarms += usize::from(v.alarm);
            candidates += v.candidate_count;
        }
        assert!(
            alarms <= 1,
            "seed {seed}: {alarms} false alarms in 200 scans ({candidates} candidates)"
        );
    }
    // The hard case for a max filter: a dense band whose far edge is sharp (1.5 m ± 30–50 %).
    for (seed, jitter) in [(4u64, 0.3f32), (5, 0.5)] {
        let mut rng = Rng::new(seed);
        let mut c = classifier();
        let alarms = (0..200)
            .filter(|_| {
                let (a, r) = grass_band_scan(&mut rng, jitter);
                c.classify(&a, &r).alarm
            })
            .count();
        assert!(
            alarms <= 1,
            "band ±{jitter}: {alarms} false alarms in 200 scans"
        );
    }
}

#[test]
fn thin_trunk_in_the_clear_alarms_out_to_d_max() {
    // A 0.2 m trunk 2.8 m away (4.1°) in front of a grass field from 3.5 m on. GET-OBST-CANDIDATES
    // needs 7 consecutive smooth windows (nad2v(i-2 … i+2) reads v(i-2 … i+4)): 2.8° with the
    // default 0.4° windows, which fit on the trunk; 5.6° with 0.8° windows, which do not (the
    // simulated evaluation, `mimnav foliage-eval`, missed such trunks beyond about 1.8 m with them).
    let (d, bearing) = (2.9f32, -0.4f32);
    let scene = Scene {
        discs: vec![(d * bearing.cos(), d * bearing.sin(), 0.1)],
        grass: Some((3.5, 8.0, 1.0)),
        ..Scene::open()
    };
    for seed in 1..=10u64 {
        let mut rng = Rng::new(seed);
        let mut c = classifier();
        let mut alarms = 0;
        for _ in 0..10 {
            let (a, r) = scene.scan(&mut rng);
            alarms += usize::from(c.classify(&a, &r).alarm);
        }
        // the first scan cannot alarm (REMOVE-NEW-OBST); every later one does
        assert_eq!(alarms, 9, "seed {seed}: {alarms}/10 scans alarmed");
    }
}

#[test]
fn window_helper_is_consistent() {
    assert_eq!(window_of(-PI), 0);
    assert_eq!(window_of(0.0), 450);
    assert_eq!(window_of(PI), 0);
}

/// Parameter exploration used to choose the defaults (not a test):
/// `BEAMS=3,4,5 K1S=0.02,0.025 INITS=0,2 THINS=9/3,9/4 BS=0.03 \
///  cargo test --release tune_grid -- --ignored --nocapture`
/// (beams per window, K1, initial thresholds in units of K1, W_s/O_s, b). Per setting it prints,
/// for the simulated scenes: trunk in grass (alarm on scan 2 out of 20 runs, alarms on later
/// scans), a trunk at 2.5 m, a wall behind grass, false alarms in 5 grass fields (400 scans each),
/// clear walls at 0.5/1/2/3 m, grass-band candidates and alarms, noisy (σ = 2 cm) walls, 10 cm posts.
#[test]
#[ignore]
fn tune_grid() {
    fn list<T: std::str::FromStr>(var: &str, default: &str) -> Vec<T> {
        std::env::var(var)
            .unwrap_or(default.to_string())
            .split(',')
            .filter_map(|x| x.parse().ok())
            .collect()
    }
    let trunk = (1.5f32 * 0.3f32.cos(), 1.5 * 0.3f32.sin(), 0.15);
    let trunk1 = Scene {
        discs: vec![trunk],
        grass: Some((0.5, 4.0, 1.0)),
        ..Scene::open()
    };
    let trunk2 = Scene {
        discs: vec![trunk],
        grass: Some((0.5, 4.0, 2.0)),
        ..Scene::open()
    };
    let far_trunk = Scene {
        discs: vec![(2.5, 0.0, 0.15)],
        grass: Some((0.5, 4.0, 2.0)),
        ..Scene::open()
    };
    let wall_scene = Scene {
        segments: vec![((2.5, -1.5), (2.5, 1.5))],
        grass: Some((0.5, 10.0, 2.0)),
        ..Scene::open()
    };
    let grasses = [
        grass_field(),
        Scene {
            grass: Some((0.4, 6.0, 0.6)),
            ..Scene::open()
        },
        Scene {
            grass: Some((0.5, 3.0, 1.5)),
            ..Scene::open()
        },
        Scene {
            grass: Some((0.3, 8.0, 2.5)),
            ..Scene::open()
        },
        Scene {
            grass: Some((0.3, 2.5, 0.3)),
            ..Scene::open()
        },
    ];
    let beams: Vec<usize> = list("BEAMS", "4,5,6");
    let k1s: Vec<f32> = list("K1S", "0.025,0.04");
    let inits: Vec<f32> = list("INITS", "0,2");
    let thins: Vec<String> = list("THINS", "9/3,7/2");
    let bs: Vec<f32> = list("BS", "0.03");
    for &nb in &beams {
        for &k1 in &k1s {
            for &init in &inits {
                for th in &thins {
                    for &b in &bs {
                        let mut it = th.split('/').filter_map(|x| x.parse::<usize>().ok());
                        let (ws, os) = (it.next().unwrap_or(9), it.next().unwrap_or(3));
                        let p = FoliageParams {
                            window_rad: nb as f32 * 0.2f32.to_radians(),
                            k1,
                            thin_window: ws,
                            thin_min: os,
                            range_error_b_m: b,
                            ..Default::default()
                        };
                        let Ok(_) = Classifier::new(p) else { continue };
                        let fresh = || {
                            let mut c = Classifier::new(p).unwrap_or_else(|e| panic!("{e}"));
                            c.history.t_prev1.fill(init * k1);
                            c.history.t_prev2.fill(init * k1);
                            c
                        };
                        let run =
                            |scene: &Scene, seeds: u64, scans: usize| -> (usize, usize, usize) {
                                let (mut second, mut later, mut total) = (0, 0, 0);
                                for seed in 1..=seeds {
                                    let mut rng = Rng::new(seed * 7919);
                                    let mut c = fresh();
                                    for k in 0..scans {
                                        let (a, r) = scene.scan(&mut rng);
                                        let al = c.classify(&a, &r).alarm;
                                        if k == 1 {
                                            second += usize::from(al);
                                        }
                                        if k >= 2 {
                                            later += usize::from(al);
                                            total += 1;
                                        }
                                    }
                                }
                                (second, later, total)
                            };
                        let t1 = run(&trunk1, 20, 12);
                        let t2 = run(&trunk2, 20, 12);
                        let ft = run(&far_trunk, 20, 12);
                        let w = run(&wall_scene, 10, 12);
                        let fa: Vec<usize> = grasses.iter().map(|g| run(g, 1, 402).1).collect();
                        let clear: Vec<usize> = [0.5f32, 1.0, 2.0, 3.0]
                            .iter()
                            .map(|&d| {
                                run(
                                    &Scene {
                                        segments: vec![((d, -d), (d, d))],
                                        ..Scene::open()
                                    },
                                    5,
                                    2,
                                )
                                .0
                            })
                            .collect();
                        let noisy: Vec<usize> = [0.5f32, 1.0, 2.0, 3.0]
                            .iter()
                            .map(|&d| {
                                run(
                                    &Scene {
                                        segments: vec![((d, -d), (d, d))],
                                        sigma: 0.02,
                                        ..Scene::open()
                                    },
                                    5,
                                    2,
                                )
                                .0
                            })
                            .collect();
                        let post: Vec<usize> = [0.7f32, 1.0, 1.5]
                            .iter()
                            .map(|&d| {
                                run(
                                    &Scene {
                                        discs: vec![(d, 0.0, 0.05)],
                                        ..Scene::open()
                                    },
                                    5,
                                    4,
                                )
                                .1
                            })
                            .collect();
                        let mut band_alarms = 0;
                        for seed in 0..3u64 {
                            let mut rng = Rng::new(seed + 100);
                            let j = [0.3f32, 0.4, 0.5][seed as usize % 3];
                            let mut c = fresh();
                            for _ in 0..200 {
                                let phase = rng.unit();
                                let angles: Vec<f32> = (0..NE)
                                    .map(|r| wrap_angle(PI - (r as f32 + phase) * THETA))
                                    .collect();
                                let ranges: Vec<f32> =
                                    (0..NE).map(|_| 1.5 * (1.0 + rng.uniform(-j, j))).collect();
                                band_alarms += usize::from(c.classify(&angles, &ranges).alarm);
                            }
                        }
                        let mut band = 0;
                        let mut band_steady = 0;
                        for seed in 0..20u64 {
                            let mut rng = Rng::new(seed);
                            let j = [0.3f32, 0.4, 0.5][seed as usize % 3];
                            let angles: Vec<f32> =
                                (0..NE).map(|r| wrap_angle(PI - r as f32 * THETA)).collect();
                            let mut c = fresh();
                            for k in 0..10 {
                                let ranges: Vec<f32> =
                                    (0..NE).map(|_| 1.5 * (1.0 + rng.uniform(-j, j))).collect();
                                let n = c.classify(&angles, &ranges).candidate_count.min(1);
                                if k == 0 { band += n } else { band_steady += n }
                            }
                        }
                        eprintln!(
                            "beams {nb} k1 {k1:.3} init {init} thin {ws}/{os} b {b}: trunk(mfp1) {}/20 {}/{} | trunk(mfp2) {}/20 {}/{} | far {}/20 {}/{} | wall {}/10 {}/{} | FA {:?}/400 | clear {:?}/5 | band {}/20 {}/180 | band alarms {}/600 | noisy {:?}/5 | post(10cm) {:?}/10",
                            t1.0,
                            t1.1,
                            t1.2,
                            t2.0,
                            t2.1,
                            t2.2,
                            ft.0,
                            ft.1,
                            ft.2,
                            w.0,
                            w.1,
                            w.2,
                            fa,
                            clear,
                            band,
                            band_steady,
                            band_alarms,
                            noisy,
                            post
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn pure_routines_tolerate_mismatched_inputs() {
    let p = FoliageParams::default();
    let ranges = [1.0f32, 2.0, f32::NAN, 3.0, 1.0];
    let windows = [0u32, 7, NO_BIN, 2, 1_000];
    let sectors = [0u32, 99, NO_BIN];
    let scan = Scan {
        ranges: &ranges,
        windows: &windows,
        sectors: &sectors,
    };
    assert_eq!(scan.len(), 3);
    let mut low = LowFreq::default();
    for n in [0usize, 1, 3, 8] {
        find_low_freq(scan, n, &mut low);
        let hist = History::new(n / 2);
        let (mut tk, mut rc, mut work) = (vec![], vec![], WindowWork::default());
        get_obst_candidates(&p, scan, &low, &hist, &mut tk, &mut rc, &mut work);
        rc.truncate(1);
        let mut q = RelaxWork::default();
        relax_obst(&p, scan, &hist, &mut rc, &mut q);
        let mut rf = vec![];
        remove_new_obst(scan, &hist, &rc, &mut rf);
        remove_thin_obst(&mut rf, 0, 0, &mut vec![]);
        crop_range(&mut rf, f32::NAN, f32::NAN);
        let mut hist = History::new(n);
        hist.c_prev2.truncate(n / 2);
        let mut ck = vec![];
        update_and_archive(&p, scan, &[1.0; 5], &[1.0; 5], &mut hist, &mut ck, &mut []);
    }
}

// ---------------------------------------------------------------------------------------------
// The fast routines against literal transcriptions of the paper's "repeat until done" loops
// ---------------------------------------------------------------------------------------------

/// `GET-OBST-CANDIDATES` lines 1–19 as written: passes over the returns in order, thresholds raised
/// as soon as a candidate is found, until a pass changes nothing.
#[allow(clippy::needless_range_loop)] // kept index-based, like the pseudo-code
fn get_candidates_literal(
    p: &FoliageParams,
    scan: Scan<'_>,
    low: &LowFreq,
    hist: &History,
) -> (Vec<f32>, Vec<f32>) {
    let n_w = low.v.len();
    let ne = scan.len();
    let wrap_w = |i: usize, d: isize| (i as isize + d).rem_euclid(n_w as isize) as usize;
    let mut t: Vec<f32> = (0..n_w)
        .map(|i| carry_threshold(p.k1, hist.t_prev1[i], hist.t_prev2[i]))
        .collect();
    let mut rc = vec![0.0f32; ne];
    let mut passes = 0;
    loop {
        passes += 1;
        let mut done = true;
        for r in 0..ne {
            let (range, w) = (scan.ranges[r], scan.windows[r] as usize);
            if range == 0.0 || low.v[w] == 0.0 || rc[r] == range {
                continue;
            }
            let low_freq = (-2..=2).all(|d| low.nad2v[wrap_w(w, d)] < t[wrap_w(w, d)]);
            if range == low.v[w] && low_freq {
                rc[r] = range;
                for (d, x) in [(-2, 0.25), (-1, 0.5), (1, 0.5), (2, 0.25)] {
                    t[wrap_w(w, d)] += x * p.delta;
                }
                done = false;
            }
        }
        if done {
            break;
        }
    }
    assert!(
        passes <= 2,
        "the fixed point is reached in one pass (+1 to see no change)"
    );
    (t, rc)
}

/// `RELAX-OBST` lines 1–11 as written: passes over the returns until nothing changes.
#[allow(clippy::needless_range_loop)] // kept index-based, like the pseudo-code
fn relax_literal(p: &FoliageParams, scan: Scan<'_>, hist: &History, rc: &mut [f32]) {
    let ne = scan.len();
    loop {
        let mut done = true;
        for r in 0..ne {
            let (range, w) = (scan.ranges[r], scan.windows[r] as usize);
            if rc[r] != 0.0 || range <= 0.0 {
                continue;
            }
            let t = (1.0 + p.k2 * (hist.c_prev1[w] + hist.c_prev2[w]))
                * (p.range_error_a * range + p.range_error_b_m);
            let near = (-2isize..=2).any(|j| {
                let n = (r as isize + j).rem_euclid(ne as isize) as usize;
                rc[n] > 0.0 && (range - scan.ranges[n]).abs() < t
            });
            if near {
                rc[r] = range;
                done = false;
            }
        }
        if done {
            break;
        }
    }
}

#[test]
fn get_and_relax_match_the_papers_loops() {
    let p = FoliageParams::default();
    let n_w = p.n_windows();
    let scenes = [
        Scene {
            segments: vec![((2.0, -1.0), (2.0, 1.0)), ((-1.5, 0.5), (0.5, 1.5))],
            discs: vec![(-1.0, -1.0, 0.15)],
            grass: Some((0.5, 4.0, 2.0)),
            ..Scene::open()
        },
        grass_field(),
        Scene {
            segments: vec![((1.0, -3.0), (1.0, 3.0))],
            ..Scene::open()
        },
    ];
    let mut rng = Rng::new(99);
    let (mut found, mut relaxed) = (0, 0);
    for trial in 0..30 {
        let (a, r) = scenes[trial % scenes.len()].scan(&mut rng);
        let (rr, ww, ss) = prepared(&a, &r, &p);
        let scan = Scan {
            ranges: &rr,
            windows: &ww,
            sectors: &ss,
        };
        let mut low = LowFreq::default();
        find_low_freq(scan, n_w, &mut low);
        let mut hist = History::new(n_w);
        for i in 0..n_w {
            hist.t_prev1[i] = rng.uniform(0.0, 0.12);
            hist.t_prev2[i] = rng.uniform(0.0, 0.12);
            hist.c_prev1[i] = if rng.unit() < 0.3 {
                rng.uniform(1.0, 40.0).round()
            } else {
                0.0
            };
            hist.c_prev2[i] = if rng.unit() < 0.3 {
                rng.uniform(1.0, 40.0).round()
            } else {
                0.0
            };
        }
        let (mut tk, mut rc, mut work) = (vec![], vec![], WindowWork::default());
        found += get_obst_candidates(&p, scan, &low, &hist, &mut tk, &mut rc, &mut work);
        let (t_lit, rc_lit) = get_candidates_literal(&p, scan, &low, &hist);
        assert_eq!(rc, rc_lit, "trial {trial}: candidates");
        for (i, (x, y)) in tk.iter().zip(&t_lit).enumerate() {
            assert!((x - y).abs() < 1e-5, "trial {trial}: T_k({i}) {x} vs {y}");
        }
        let mut rc_relax = rc.clone();
        relaxed += relax_obst(&p, scan, &hist, &mut rc_relax, &mut RelaxWork::default());
        let mut rc_relax_lit = rc;
        relax_literal(&p, scan, &hist, &mut rc_relax_lit);
        assert_eq!(rc_relax, rc_relax_lit, "trial {trial}: relaxed candidates");
    }
    assert!(
        found > 1000 && relaxed > 1000,
        "a meaningful comparison: {found} / {relaxed}"
    );
}

#[test]
fn relax_matches_the_papers_loop_on_random_small_scans() {
    // Few range levels, so that joins, zigzags (r+2 then r-1) and joins across the slice ends are
    // all common; sizes on both sides of the sweep path's 8-return threshold.
    let p = FoliageParams::default();
    let mut rng = Rng::new(2024);
    let mut joined = 0;
    for trial in 0..2000 {
        let ne = 1 + (rng.next_u64() % 40) as usize;
        let levels = [0.0f32, 1.0, 1.04, 1.08, 1.5, 1.55, 3.0];
        let ranges: Vec<f32> = (0..ne)
            .map(|_| levels[(rng.next_u64() % 7) as usize])
            .collect();
        let windows: Vec<u32> = (0..ne).map(|r| (r / 3) as u32).collect();
        let sectors = vec![0u32; ne];
        let scan = Scan {
            ranges: &ranges,
            windows: &windows,
            sectors: &sectors,
        };
        let mut hist = History::new(16);
        for c in hist.c_prev1.iter_mut() {
            *c = if rng.unit() < 0.3 { 25.0 } else { 0.0 };
        }
        let rc0: Vec<f32> = ranges
            .iter()
            .map(|&x| if rng.unit() < 0.15 { x } else { 0.0 })
            .collect();
        let mut fast = rc0.clone();
        joined += relax_obst(&p, scan, &hist, &mut fast, &mut RelaxWork::default());
        let mut literal = rc0;
        relax_literal(&p, scan, &hist, &mut literal);
        assert_eq!(fast, literal, "trial {trial}: ranges {ranges:?}");
    }
    assert!(joined > 2000, "{joined}");
}

#[test]
fn get_candidates_matches_the_papers_loop_on_random_small_scans() {
    // Few windows (down to 1, so neighbourhoods fold onto themselves), quantised ranges (ties at
    // the window maximum), random thresholds carried from "previous scans".
    let p = FoliageParams::default();
    let mut rng = Rng::new(77);
    let mut found = 0;
    for trial in 0..2000 {
        let n_w = 1 + (rng.next_u64() % 20) as usize;
        let ne = (rng.next_u64() % 60) as usize;
        let ranges: Vec<f32> = (0..ne)
            .map(|_| {
                if rng.unit() < 0.1 {
                    0.0
                } else {
                    2.0 + 0.02 * (rng.next_u64() % 4) as f32
                }
            })
            .collect();
        let windows: Vec<u32> = (0..ne)
            .map(|_| (rng.next_u64() % n_w as u64) as u32)
            .collect();
        let sectors = vec![0u32; ne];
        let scan = Scan {
            ranges: &ranges,
            windows: &windows,
            sectors: &sectors,
        };
        let mut low = LowFreq::default();
        find_low_freq(scan, n_w, &mut low);
        let mut hist = History::new(n_w);
        for i in 0..n_w {
            hist.t_prev1[i] = rng.uniform(0.0, 0.1);
            hist.t_prev2[i] = rng.uniform(0.0, 0.1);
        }
        let (mut tk, mut rc, mut work) = (vec![], vec![], WindowWork::default());
        found += get_obst_candidates(&p, scan, &low, &hist, &mut tk, &mut rc, &mut work);
        let (t_lit, rc_lit) = get_candidates_literal(&p, scan, &low, &hist);
        assert_eq!(rc, rc_lit, "trial {trial}");
        for (x, y) in tk.iter().zip(&t_lit) {
            assert!((x - y).abs() < 1e-5, "trial {trial}: {x} vs {y}");
        }
    }
    assert!(found > 2000, "{found}");
}

/// The values the config file and the classifier used to disagree on (each had its own checks)
/// are refused by both now, naming the same key: the file through the loader, the classifier
/// through [`Classifier::new`].
#[test]
fn the_file_and_the_classifier_refuse_the_same_values() {
    use mimnav_shared::config::Config;
    let d = FoliageParams::default();
    let cases = [
        ("k3 = 0", "foliage.k3", FoliageParams { k3: 0.0, ..d }),
        ("k3 = 5000", "foliage.k3", FoliageParams { k3: 5000.0, ..d }),
        (
            "range_error_b_m = 2",
            "foliage.range_error_b_m",
            FoliageParams {
                range_error_b_m: 2.0,
                ..d
            },
        ),
        (
            "d_max_m = 500",
            "foliage.d_max_m",
            FoliageParams {
                d_max_m: 500.0,
                ..d
            },
        ),
        (
            "window_deg = 0.01",
            "foliage.window_deg",
            FoliageParams {
                window_rad: 0.01f32.to_radians(),
                ..d
            },
        ),
        (
            "sector_deg = 1",
            "foliage.sector_deg",
            FoliageParams {
                sector_rad: 1f32.to_radians(),
                ..d
            },
        ),
        (
            "thin_min = 0",
            "foliage.thin_min",
            FoliageParams { thin_min: 0, ..d },
        ),
        (
            "thin_window = 8\nthin_min = 9",
            "foliage.thin_min",
            FoliageParams {
                thin_window: 8,
                thin_min: 9,
                ..d
            },
        ),
        (
            "carry_min_travel_m = 5",
            "foliage.carry_min_travel_m",
            FoliageParams {
                carry_min_travel_m: 5.0,
                ..d
            },
        ),
    ];
    for (line, key, params) in cases {
        let text = format!("[foliage]\n{line}\n");
        let e = Config::from_toml(&text, std::path::Path::new("t.toml"), &[])
            .expect_err(line)
            .to_string();
        assert!(e.starts_with("t.toml: ") && e.contains(key), "{line}: {e}");
        let e = Classifier::new(params).expect_err(line);
        assert!(e.get(key).is_some(), "{line}: {e}");
    }
    // the bounds themselves are allowed by both
    let edge =
        "[foliage]\nk3 = 1000\nd_max_m = 200\nwindow_deg = 0.05\nsector_deg = 5\nthin_min = 9\n";
    let c = Config::from_toml(edge, std::path::Path::new("t.toml"), &[]).expect("bounds");
    assert!(Classifier::new(c.foliage).is_ok());
}

/// The wall of [`wall_scan`] with a blade 1 m away in every fourth window: each blade window
/// blocks the smooth-window test of the windows within 2 of it, so no window of the wall passes
/// `GET-OBST-CANDIDATES` on its own.
fn broken_wall_scan(rng: &mut Rng) -> (Vec<f32>, Vec<f32>) {
    let (a, mut r) = wall_scan(rng);
    for (&angle, range) in a.iter().zip(r.iter_mut()) {
        if *range > 0.0 && window_of(angle).is_multiple_of(4) {
            *range = 1.0;
        }
    }
    (a, r)
}

/// Beyond the paper (interpretation 15): a confirmed obstacle stays confirmed when blades break
/// every run of smooth windows in front of it, and only the returns on it are obstacles; with
/// `hold_obstacles` off, the paper's test alone loses it.
#[test]
fn confirmed_obstacle_is_held_through_broken_windows() {
    for hold in [true, false] {
        let mut rng = Rng::new(5);
        let mut c = classifier_with(FoliageParams {
            hold_obstacles: hold,
            fill_notches: false,
            ..Default::default()
        });
        for _ in 0..3 {
            let (a, r) = wall_scan(&mut rng);
            c.classify(&a, &r);
        }
        let (a, r) = wall_scan(&mut rng);
        assert!(c.classify(&a, &r).alarm, "the wall is confirmed");
        let (a, r) = broken_wall_scan(&mut rng);
        let v = c.classify(&a, &r);
        assert_eq!(v.alarm, hold, "hold_obstacles = {hold}");
        let on_wall = v
            .classes
            .iter()
            .zip(&r)
            .filter(|&(&k, _)| k == class::OBSTACLE)
            .inspect(|&(_, &range)| assert!(range > 1.9, "a blade at {range} m is no obstacle"))
            .count();
        if hold {
            assert!(on_wall > 50, "{on_wall} obstacle returns on the wall");
        }
    }
}

/// Only confirmed obstacles are held: broken scans of a wall never confirmed raise no alarm
/// (with the notches left as they are, which would otherwise confirm it).
#[test]
fn nothing_is_held_before_it_is_confirmed() {
    let mut rng = Rng::new(6);
    let mut c = classifier_with(FoliageParams {
        fill_notches: false,
        ..Default::default()
    });
    for k in 0..10 {
        let (a, r) = broken_wall_scan(&mut rng);
        let v = c.classify(&a, &r);
        assert!(!v.alarm, "scan {k}: {} obstacle returns", v.obstacle_count);
    }
}

/// Interpretation 16: a window nearer than both neighbours takes the nearer neighbour's maximum;
/// peaks, slopes, two-window notches and the circle's seam are handled as stated.
#[test]
fn fill_notches_fills_single_window_dips_only() {
    let p = FoliageParams::default();
    // the tolerance at 3 m: 0.01 · 3 + 0.03 = 0.06 m
    let mut low = LowFreq {
        //       0    1    2    3     4     5    6    7    8    9    10   11   12   13
        v: vec![
            1.0, 3.0, 3.0, 1.0, 3.02, 3.04, 1.0, 3.0, 3.2, 3.2, 0.0, 0.0, 3.0, 3.0,
        ],
        dv: vec![0.0; 14],
        nad2v: vec![0.0; 14],
    };
    // window 3 is a notch with 3.0, 3.0 before and 3.02, 3.04 after, all agreeing: it takes 3.0;
    // window 6 is a notch whose windows after (3.0, 3.2) disagree, as at a grass band's far
    // edge: it stays; windows 10–11 are a two-window dip and stay; window 0 is a notch across
    // the seam (3.0, 3.0 before, 3.0, 3.0 after): it takes 3.0
    assert_eq!(fill_notches(&p, &mut low), 2);
    assert_eq!(
        low.v,
        vec![
            3.0, 3.0, 3.0, 3.0, 3.02, 3.04, 1.0, 3.0, 3.2, 3.2, 0.0, 0.0, 3.0, 3.0
        ]
    );
    // the differences are those of the filled maxima
    let mut expect = low.clone();
    differences(&mut expect);
    assert_eq!(low, expect);
    assert!((low.dv[3] - 0.02).abs() < 1e-6 && low.nad2v[1] == 0.0);
    // a second pass finds nothing more to fill
    assert_eq!(fill_notches(&p, &mut low), 0);
    // too few windows to have neighbours on both sides: left alone
    let mut tiny = LowFreq {
        v: vec![1.0, 2.0],
        dv: vec![0.0; 2],
        nad2v: vec![0.0; 2],
    };
    assert_eq!(fill_notches(&p, &mut tiny), 0);
}

/// Interpretation 16 in the whole classifier: a wall that only blades reach in every fourth
/// window is confirmed from scratch on its second scan with `fill_notches`, and never without;
/// the blades themselves are never obstacles.
#[test]
fn notch_filling_confirms_a_wall_behind_single_blade_windows() {
    for fill in [true, false] {
        let mut rng = Rng::new(7);
        let mut c = classifier_with(FoliageParams {
            fill_notches: fill,
            ..Default::default()
        });
        let alarms: Vec<bool> = (0..4)
            .map(|_| {
                let (a, r) = broken_wall_scan(&mut rng);
                let v = c.classify(&a, &r);
                for (&k, &range) in v.classes.iter().zip(&r) {
                    assert!(
                        k != class::OBSTACLE || range > 1.9,
                        "a blade at {range} m is no obstacle"
                    );
                }
                v.alarm
            })
            .collect();
        let expect = if fill {
            // held back on the first scan (REMOVE-NEW-OBST), confirmed from the second on
            vec![false, true, true, true]
        } else {
            vec![false; 4]
        };
        assert_eq!(alarms, expect, "fill_notches = {fill}");
    }
}

/// Blades in two neighbouring windows are not a notch: a wall broken that way is not confirmed
/// from scratch even with `fill_notches` (the paper's test, unchanged).
#[test]
fn two_window_dips_are_not_filled() {
    let mut rng = Rng::new(8);
    let mut c = classifier();
    for k in 0..6 {
        let (a, mut r) = wall_scan(&mut rng);
        for (&angle, range) in a.iter().zip(r.iter_mut()) {
            if *range > 0.0 && window_of(angle) % 4 < 2 {
                *range = 1.0;
            }
        }
        let v = c.classify(&a, &r);
        assert!(!v.alarm, "scan {k}: {} obstacle returns", v.obstacle_count);
    }
}

/// `Classifier::classify` against the paper's `CLASSIFY` written out with the public routines, one
/// after the other, on a history of its own: the classifier fuses and skips work for speed, and
/// must give the same classes, alarm, `R_s` and temporal state, scan after scan (trunks in and
/// out of grass, a wall, empty stretches, both rules beyond the paper on and off).
#[test]
fn classify_matches_the_public_routines_in_order() {
    fn reference(
        p: &FoliageParams,
        hist: &mut History,
        angles: &[f32],
        ranges: &[f32],
    ) -> (bool, Vec<u8>, Vec<f32>) {
        let (r, w, s) = prepared(angles, ranges, p);
        let scan = Scan {
            ranges: &r,
            windows: &w,
            sectors: &s,
        };
        let mut low = LowFreq::default();
        find_low_freq(scan, p.n_windows(), &mut low);
        if p.fill_notches {
            fill_notches(p, &mut low);
        }
        let (mut tk, mut rc, mut work) = (vec![], vec![], WindowWork::default());
        get_obst_candidates(p, scan, &low, hist, &mut tk, &mut rc, &mut work);
        hist.archive_thresholds(&mut tk);
        relax_obst(p, scan, hist, &mut rc, &mut RelaxWork::default());
        let mut rf = vec![];
        remove_new_obst(scan, hist, &rc, &mut rf);
        remove_thin_obst(&mut rf, p.thin_window, p.thin_min, &mut vec![]);
        crop_range(&mut rf, p.d_min_m, p.d_max_m);
        let mut nearest = vec![0.0; p.n_sectors()];
        let alarm = update_and_archive(p, scan, &rc, &rf, hist, &mut vec![], &mut nearest);
        let classes = (0..r.len())
            .map(|i| match (r[i] > 0.0, rc[i] > 0.0, rf[i] > 0.0) {
                (_, _, true) => class::OBSTACLE,
                (_, true, false) => class::PRUNED,
                (true, false, false) => class::FOLIAGE,
                (false, _, _) => class::NO_RETURN,
            })
            .collect();
        (alarm, classes, nearest)
    }
    let scenes = [
        Scene {
            discs: vec![(1.5, 0.5, 0.15), (-2.0, -1.0, 0.25)],
            ..grass_field()
        },
        Scene {
            discs: vec![(2.5, -0.5, 0.1)],
            segments: vec![((-2.0, -1.0), (-2.0, 1.0))],
            ..Scene::open()
        },
        grass_field(),
        Scene::open(),
    ];
    for (hold, fill) in [(true, true), (false, false), (true, false)] {
        let p = FoliageParams {
            hold_obstacles: hold,
            fill_notches: fill,
            ..Default::default()
        };
        let mut c = classifier_with(p);
        let mut hist = History::free_space(p.n_windows(), p.k1);
        let mut rng = Rng::new(11);
        let mut alarms = 0;
        for k in 0..80 {
            let (a, r) = scenes[(k / 10) % scenes.len()].scan(&mut rng);
            let (alarm, classes, nearest) = reference(&p, &mut hist, &a, &r);
            let v = c.classify(&a, &r);
            assert_eq!(v.alarm, alarm, "scan {k} (hold {hold}, fill {fill}): alarm");
            assert_eq!(v.classes, &classes[..], "scan {k}: classes");
            assert_eq!(v.nearest_per_sector, &nearest[..], "scan {k}: R_s");
            assert_eq!(c.history(), &hist, "scan {k}: temporal state");
            alarms += usize::from(alarm);
        }
        // the scenes exercise the alarm path, not only grass
        assert!(alarms >= 20, "only {alarms} alarms in 80 scans");
    }
}

/// One scan from `(x, 0)`, heading +x, of a static grass strip across the path, `x0 ≤ x ≤ x1`
/// (every y): a beam in it stops at a blade an exponential distance (mean `mfp`) past where it
/// enters, or, with `mfp = None`, uniformly anywhere before it leaves (the hard case of a dense
/// strip with a sharp far edge, no beam passing through). `trunk`: a disc (centre x, y, radius).
fn strip_scan(
    rng: &mut Rng,
    x: f32,
    (x0, x1): (f32, f32),
    mfp: Option<f32>,
    trunk: Option<(f32, f32, f32)>,
) -> (Vec<f32>, Vec<f32>) {
    let phase = rng.unit();
    let start = rng.uniform(-PI, PI);
    let mut angles = Vec::with_capacity(NE);
    let mut ranges = Vec::with_capacity(NE);
    for r in 0..NE {
        let a = wrap_angle(start - (r as f32 + phase) * THETA);
        let dx = a.cos();
        let mut best = f32::INFINITY;
        if let Some((cx, cy, rad)) = trunk
            && let Some(t) = ray_disc(a, cx - x, cy, rad)
        {
            best = t;
        }
        if dx.abs() > 1e-6 {
            let (ta, tb) = ((x0 - x) / dx, (x1 - x) / dx);
            let (t_in, t_out) = (ta.min(tb).max(0.0), ta.max(tb));
            if t_out > t_in {
                let t = match mfp {
                    Some(m) => t_in + rng.exp(m),
                    None => t_in + rng.unit() * (t_out - t_in),
                };
                if t < t_out {
                    best = best.min(t);
                }
            }
        }
        // nothing beyond 30 m (a beam nearly along the strip would cross it far away)
        let best = if best < 30.0 { best } else { f32::INFINITY };
        angles.push(a);
        ranges.push(measured(rng, best, 0.01));
    }
    (angles, ranges)
}

// ---------------------------------------------------------------------------------------------
// Carried scans (interpretation 17)
// ---------------------------------------------------------------------------------------------

#[test]
fn fast_atan2_is_within_its_bound_of_atan2() {
    let mut worst = 0.0f64;
    for k in 0..20_000 {
        let a = -PI + TAU * (k as f32 + 0.37) / 20_000.0;
        for r in [1.0e-3f32, 0.3, 2.0, 150.0] {
            let (y, x) = (r * a.sin(), r * a.cos());
            let exact = f64::from(y).atan2(f64::from(x));
            worst = worst.max((f64::from(fast_atan2(y, x)) - exact).abs());
        }
    }
    assert!(worst < 1.2e-5, "worst error {worst:e} rad");
    // the axes, the origin and NaN
    assert_eq!(fast_atan2(0.0, 0.0), 0.0);
    assert!((fast_atan2(1.0, 0.0) - PI / 2.0).abs() < 1e-6);
    assert!((fast_atan2(-1.0, 0.0) + PI / 2.0).abs() < 1e-6);
    assert!((fast_atan2(0.0, -1.0) - PI).abs() < 1e-6);
    assert!(fast_atan2(f32::NAN, 1.0).is_nan());
    assert!(fast_atan2(1.0, f32::NAN).is_nan());
}

#[test]
fn motion_between_two_poses_is_in_the_first_pose_frame() {
    // facing +y, then 0.5 m further along +y and turned 10° left: 0.5 m forward
    let from = pose2(1.0, 2.0, std::f64::consts::FRAC_PI_2);
    let to = pose2(1.0, 2.5, std::f64::consts::FRAC_PI_2 + 10f64.to_radians());
    let m = Motion::between(&from, &to);
    assert!((m.dx_m - 0.5).abs() < 1e-6 && m.dy_m.abs() < 1e-6, "{m:?}");
    assert!((m.dtheta_rad - 10f32.to_radians()).abs() < 1e-6, "{m:?}");
    // a step to the robot's left, and a turn across ±π that is 2° and not 358°
    let m = Motion::between(&pose2(0.0, 0.0, 0.0), &pose2(0.0, 0.1, 0.0));
    assert!(m.dx_m.abs() < 1e-6 && (m.dy_m - 0.1).abs() < 1e-6, "{m:?}");
    let m = Motion::between(
        &pose2(0.0, 0.0, 179f64.to_radians()),
        &pose2(0.0, 0.0, -179f64.to_radians()),
    );
    assert!((m.dtheta_rad - 2f32.to_radians()).abs() < 1e-5, "{m:?}");
    assert!(m.is_plausible());
    // jumps and non-finite values are not motion
    let origin = pose2(0.0, 0.0, 0.0);
    assert!(!Motion::between(&origin, &pose2(3.0, 0.0, 0.0)).is_plausible());
    assert!(!Motion::between(&origin, &pose2(0.0, 0.0, 1.0)).is_plausible());
    assert!(!Motion::between(&origin, &pose2(f64::NAN, 0.0, 0.0)).is_plausible());
}

/// Classes and alarms of a classifier fed `scans` with the motion `motion_of(k)` before scan `k`.
fn run_moved(
    params: FoliageParams,
    scans: &[(Vec<f32>, Vec<f32>)],
    motion_of: impl Fn(usize) -> Option<Motion>,
) -> Vec<(bool, Vec<u8>)> {
    let mut c = classifier_with(params);
    scans
        .iter()
        .enumerate()
        .map(|(k, (a, r))| {
            let v = c.classify_moved(a, r, motion_of(k));
            (v.alarm, v.classes.to_vec())
        })
        .collect()
}

#[test]
fn nothing_is_carried_standing_still_or_without_a_plausible_motion() {
    // The synthetic sharp-edged band, where carrying earlier scans standing still would line the
    // maxima up along its edge: standing, below carry_min_travel_m, with no motion, or with a
    // jump or NaN, the verdicts are exactly the paper's pipeline (carry_scans = 0).
    let mut rng = Rng::new(21);
    let scans: Vec<_> = (0..60).map(|_| grass_band_scan(&mut rng, 0.3)).collect();
    let paper = run_moved(
        FoliageParams {
            carry_scans: 0,
            ..FoliageParams::default()
        },
        &scans,
        |_| None,
    );
    let p = FoliageParams::default();
    assert!(p.carry_scans > 0);
    let creep = Motion {
        dx_m: p.carry_min_travel_m / (p.carry_scans as f32 + 1.0),
        ..Motion::default()
    };
    type MotionOf = Box<dyn Fn(usize) -> Option<Motion>>;
    let cases: [(&str, MotionOf); 5] = [
        ("standing", Box::new(|_| Some(Motion::default()))),
        ("creeping", Box::new(move |_| Some(creep))),
        ("no odometry", Box::new(|_| None)),
        (
            "jumping",
            Box::new(|_| {
                Some(Motion {
                    dx_m: 5.0,
                    ..Motion::default()
                })
            }),
        ),
        (
            "NaN",
            Box::new(|_| {
                Some(Motion {
                    dtheta_rad: f32::NAN,
                    ..Motion::default()
                })
            }),
        ),
    ];
    for (name, motion_of) in cases {
        assert!(
            run_moved(p, &scans, motion_of) == paper,
            "{name}: the verdicts differ from the paper's"
        );
    }
    // and driving, they do differ (the test above could not fail otherwise)
    let driving = run_moved(p, &scans, |_| {
        Some(Motion {
            dx_m: 0.05,
            ..Motion::default()
        })
    });
    assert!(driving != paper, "driving carried nothing");
}

/// Scans alarmed, and the first alarm, driving at `step` m a scan from x = −1 m toward a 0.2 m
/// trunk at x = 3.2 m inside a grass strip from 0.5 to 4 m (mean free path `mfp`): 50 scans, the
/// trunk within `d_max` from the 23rd, 1.75 m away at the end.
fn trunk_in_grass_drive(
    params: FoliageParams,
    seed: u64,
    step: f32,
    mfp: f32,
) -> (usize, Option<usize>) {
    let mut rng = Rng::new(seed);
    let mut c = classifier_with(params);
    let (mut alarms, mut first) = (0, None);
    for k in 0..50 {
        let x = -1.0 + step * k as f32;
        let (a, r) = strip_scan(&mut rng, x, (0.5, 4.0), Some(mfp), Some((3.2, 0.0, 0.1)));
        let m = Motion {
            dx_m: step,
            ..Motion::default()
        };
        if c.classify_moved(&a, &r, (k > 0).then_some(m)).alarm {
            alarms += 1;
            first.get_or_insert(k);
        }
    }
    (alarms, first)
}

#[test]
fn carried_scans_find_a_trunk_hidden_in_grass_sooner_while_driving() {
    let paper = FoliageParams {
        carry_scans: 0,
        ..FoliageParams::default()
    };
    let (mut with, mut without, mut earlier, mut later) = (0, 0, 0, 0);
    for seed in 1..=10 {
        let (a0, f0) = trunk_in_grass_drive(paper, seed, 0.05, 1.5);
        let (a2, f2) = trunk_in_grass_drive(FoliageParams::default(), seed, 0.05, 1.5);
        without += a0;
        with += a2;
        match (f0, f2) {
            (Some(x), Some(y)) if y < x => earlier += 1,
            (None, Some(_)) => earlier += 1,
            (Some(x), Some(y)) if y > x => later += 1,
            (Some(_), None) => later += 1,
            _ => {}
        }
    }
    eprintln!(
        "scans alarmed: {without} without carried scans, {with} with; first alarm earlier in {earlier}, later in {later} of 10 drives"
    );
    // (measured: 3 scans alarmed without, 103 with; the first alarm earlier in all 10 drives)
    assert!(
        with >= 5 * without.max(10),
        "alarmed scans: {with} with, {without} without"
    );
    assert!(
        earlier >= 5 && later == 0,
        "first alarm earlier in {earlier}, later in {later}"
    );
}

/// Alarms in 200 scans driving at `step` m a scan over a static grass strip ([`strip_scan`]),
/// from x = −2 m to 0.5 m and again from −2 m with the classifier reset.
fn strip_drive_alarms(
    params: FoliageParams,
    seed: u64,
    step: f32,
    strip: (f32, f32),
    mfp: Option<f32>,
) -> usize {
    let mut rng = Rng::new(seed);
    let mut c = classifier_with(params);
    let mut x = -2.0f32;
    let mut alarms = 0;
    for _ in 0..200 {
        let (a, r) = strip_scan(&mut rng, x, strip, mfp, None);
        let m = Motion {
            dx_m: step,
            ..Motion::default()
        };
        alarms += usize::from(c.classify_moved(&a, &r, Some(m)).alarm);
        x += step;
        if x > 0.5 {
            x = -2.0;
            c.reset();
        }
    }
    alarms
}

#[test]
fn carried_scans_driving_through_grass_rarely_alarm() {
    // Static grass strips whose blades stop each beam an exponential distance in (Beer–Lambert,
    // as in the simulator): driving inside one toward its far edge, and toward one from outside.
    for (name, strip, mfp) in [
        ("inside, dense", (-4.0f32, 2.0f32), 0.6f32),
        ("inside, sparse", (-4.0, 2.0), 1.5),
        ("toward, dense", (1.0, 3.0), 0.6),
        ("toward, sparse", (1.0, 3.0), 1.5),
    ] {
        for step in [0.03f32, 0.05, 0.1] {
            let alarms = strip_drive_alarms(FoliageParams::default(), 11, step, strip, Some(mfp));
            assert!(
                alarms <= 1,
                "{name} at {step} m a scan: {alarms} false alarms in 200 scans"
            );
        }
    }
}

/// The price of interpretation 17, measured (run it with `cargo test -p mimnav-foliage --release
/// -- --ignored carried_scans_price --nocapture`): the false alarms in 200 scans of two hard cases
/// that neither simulated nor Beer–Lambert grass produces, with 0 and 2 carried scans: standing in
/// the synthetic sharp-edged band with the standing-still rule off (`carry_min_travel_m = 0`), and
/// driving toward a strip from 1 to 2 m that stops every beam uniformly before its far edge.
#[test]
#[ignore = "a measurement: prints the figures in docs/commands.md"]
fn carried_scans_price() {
    for carry in [0usize, 2] {
        let params = FoliageParams {
            carry_scans: carry,
            carry_min_travel_m: 0.0,
            ..FoliageParams::default()
        };
        let mut band = Vec::new();
        for (seed, jitter) in [(4u64, 0.3f32), (5, 0.5)] {
            let mut rng = Rng::new(seed);
            let mut c = classifier_with(params);
            let alarms = (0..200)
                .filter(|_| {
                    let (a, r) = grass_band_scan(&mut rng, jitter);
                    c.classify_moved(&a, &r, Some(Motion::default())).alarm
                })
                .count();
            band.push(format!("±{jitter}: {alarms}"));
        }
        let params = FoliageParams {
            carry_scans: carry,
            ..FoliageParams::default()
        };
        let mut strip = Vec::new();
        for step in [0.03f32, 0.05, 0.1] {
            let mut counts = Vec::new();
            for seed in 11..16 {
                counts.push(strip_drive_alarms(params, seed, step, (1.0, 2.0), None));
            }
            strip.push(format!("{step} m a scan: {counts:?}"));
        }
        println!(
            "carry_scans = {carry}: standing in the band (alarms in 200 scans) {}; driving toward the sharp strip (5 seeds × 200 scans) {}",
            band.join(", "),
            strip.join("; ")
        );
    }
}
