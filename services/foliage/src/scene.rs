//! Deterministic noise and a small planar scene simulator, for the unit tests and the `scan` bench
//! (not part of the classifier's API, hence hidden from the docs): one VLP-16 laser's revolution
//! among discs (trunks, posts), segments (walls) and grass, with the sensor's range noise and
//! quantisation; a grass band all around and a grass strip across the path. No dependencies.

use std::f32::consts::{PI, TAU};

/// SplitMix64: deterministic, seedable, good enough for test noise.
pub struct Rng(u64);

impl Rng {
    /// A generator seeded with `seed`.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit()
    }
    /// Approximately normal (Irwin–Hall of 4 uniforms), standard deviation `sigma`.
    pub fn normal(&mut self, sigma: f32) -> f32 {
        let s: f32 = (0..4).map(|_| self.unit()).sum::<f32>() - 2.0;
        s * sigma * 3.0f32.sqrt()
    }
    /// Exponential with mean `mean` (a beam's free path in grass).
    pub fn exp(&mut self, mean: f32) -> f32 {
        -mean * (1.0 - self.unit()).ln()
    }
}

/// Returns per revolution of one VLP-16 laser at 600 rpm.
pub const NE: usize = 1800;

/// The azimuth step between two returns, radians.
pub const THETA: f32 = TAU / NE as f32;

/// `a` wrapped onto `(-π, π]`.
pub fn wrap_angle(a: f32) -> f32 {
    let t = (a + PI).rem_euclid(TAU) - PI;
    if t <= -PI { t + TAU } else { t }
}

/// Range along the ray at `angle` to a disc centred at (cx, cy) of radius `rad`, if hit.
pub fn ray_disc(angle: f32, cx: f32, cy: f32, rad: f32) -> Option<f32> {
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
pub fn ray_segment(angle: f32, p0: (f32, f32), p1: (f32, f32)) -> Option<f32> {
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
pub fn measured(rng: &mut Rng, best: f32, sigma: f32) -> f32 {
    if best.is_finite() {
        let noisy = (best + rng.normal(sigma)).max(0.01);
        (noisy / 0.002).round() * 0.002
    } else {
        0.0
    }
}

/// A static planar scene around the sensor at the origin (x forward, y left).
#[derive(Clone)]
pub struct Scene {
    /// Discs: (centre x, centre y, radius), metres.
    pub discs: Vec<(f32, f32, f32)>,
    /// Walls: segments from one end to the other, metres.
    pub segments: Vec<((f32, f32), (f32, f32))>,
    /// Grass field: (inner radius, outer radius, mean free path of a beam in it).
    pub grass: Option<(f32, f32, f32)>,
    /// Range noise, metres (standard deviation).
    pub sigma: f32,
}

impl Scene {
    /// Nothing around, 1 cm range noise.
    pub fn open() -> Self {
        Self {
            discs: vec![],
            segments: vec![],
            grass: None,
            sigma: 0.01,
        }
    }
    /// One revolution of one VLP-16 laser: 1800 returns, clockwise (angles decrease in firing
    /// order), random azimuth phase, Gaussian range noise, 2 mm quantisation.
    pub fn scan(&self, rng: &mut Rng) -> (Vec<f32>, Vec<f32>) {
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

/// Grass from 0.5 to 4 m all around, 1 m mean free path.
pub fn grass_field() -> Scene {
    Scene {
        grass: Some((0.5, 4.0, 1.0)),
        ..Scene::open()
    }
}

/// Grass band all around: every return at 1.5 m ± `jitter` (uniform, independent from return to
/// return), i.e. neighbouring returns differ by up to 60–100 %.
pub fn grass_band_scan(rng: &mut Rng, jitter: f32) -> (Vec<f32>, Vec<f32>) {
    let phase = rng.unit();
    let angles: Vec<f32> = (0..NE)
        .map(|r| wrap_angle(PI - (r as f32 + phase) * THETA))
        .collect();
    let ranges = (0..NE)
        .map(|_| 1.5 * (1.0 + rng.uniform(-jitter, jitter)))
        .collect();
    (angles, ranges)
}

/// One scan from `(x, 0)`, heading +x, of a static grass strip across the path, `x0 ≤ x ≤ x1`
/// (every y): a beam in it stops at a blade an exponential distance (mean `mfp`) past where it
/// enters, or, with `mfp = None`, uniformly anywhere before it leaves (the hard case of a dense
/// strip with a sharp far edge, no beam passing through). `trunk`: a disc (centre x, y, radius).
pub fn strip_scan(
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
