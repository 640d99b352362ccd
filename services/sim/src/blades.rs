//! Grass as blades standing in the ground (DESIGN §9, improved): each grass patch is a field of
//! vertical blades at seeded positions, swaying slowly, that every beam meets where it really
//! passes.
//!
//! Why not draw each beam's blades independently: a VLP-16's spot (12.7 mm at the lens, 3 mrad
//! horizontal divergence) is wider than the spacing of its firings (0.2°, 3.5 mrad at 600 rpm,
//! 7 mm at 2 m), so one blade shades two or three neighbouring beams of a laser, and the lasers
//! of one firing sequence, which look along the same azimuth, meet the same blades at their own
//! heights. The gaps through grass are runs of beams ("if a beam penetrates the foliage, its
//! immediate neighbours are likely to penetrate it through the same clear", the foliage paper's
//! third locality principle). Independent draws break that, and with it the spatial structure the
//! foliage classifier reads.
//!
//! The model:
//! - a blade (or a tuft of them) is a vertical strip from the ground to the patch's top, 4–12 mm
//!   wide, as wide seen from every azimuth;
//! - a beam is a horizontal strip of width `D(t) = 12.7 mm + 3 mrad · t` at range `t`; where it
//!   overlaps a blade by `L`, the blade intercepts `L / D` of it (the mean over the beams that
//!   meet a blade is `w / (w + D)`, 0.3 for an 8 mm blade at 2 m, as the old model's 10–40 %);
//! - blades are scattered uniformly (a Poisson field), about `29 · density` per m²: as many as
//!   take from a beam 2 m out the same share per metre as `density` hits drawn for each beam
//!   (the same mean `−ln` of what gets through), so `density` in a world file means the same
//!   grass for one beam in either model ([`areal_density`]);
//! - each blade sways along its own direction, `A · wave(f·t + φ)`, `A` 5–30 mm, `f` 0.3–1.5 Hz:
//!   over one revolution (0.1 s) a blade moves a few millimetres to 3 cm, so a standing sensor
//!   sees mostly the same blades from one scan to the next, and new gaps open slowly.
//!
//! Bushes keep the per-beam draws ([`crate::physics`]): their leaves are a volume of scatterers
//! small next to the beam, and they are solid either way.

/// Beam width at the lens, m (VLP-16 spot, horizontal).
pub const BEAM_WIDTH_M: f64 = 0.0127;
/// Horizontal beam divergence, rad.
pub const BEAM_DIVERGENCE_RAD: f64 = 0.003;
/// Blade width range, m.
const BLADE_WIDTH_M: (f64, f64) = (0.004, 0.012);
/// Sway amplitude range, m.
const SWAY_M: (f64, f64) = (0.005, 0.03);
/// Sway frequency range, Hz.
const SWAY_HZ: (f64, f64) = (0.3, 1.5);
/// Side of the field's cells, m.
const CELL_M: f64 = 0.1;
/// Most cells the blade fields of one world may have in all: each costs 4 bytes (16 MB in
/// all), one per 10 × 10 cm of each grass patch's bounding box (40 000 m² of boxes).
pub const MAX_FIELD_CELLS: f64 = 4_000_000.0;
/// Most blades (expected) the blade fields of one world may hold in all: each costs 28 bytes
/// (about 120 MB in all with the slack reserved).
pub const MAX_FIELD_BLADES: f64 = 4_000_000.0;

/// The size of the blade field over the box `min`–`max` at `density`: its cells and the
/// blades expected in it. What [`BladeField::new`] allocates; the world loader refuses a world
/// whose fields exceed [`MAX_FIELD_CELLS`] or [`MAX_FIELD_BLADES`] before anything is built.
pub fn field_size(min: [f64; 2], max: [f64; 2], density: f64) -> (f64, f64) {
    let nx = ((max[0] - min[0]) / CELL_M).ceil().max(1.0);
    let ny = ((max[1] - min[1]) / CELL_M).ceil().max(1.0);
    let cells = nx * ny;
    let lambda = areal_density(density.max(0.0)) * CELL_M * CELL_M;
    (cells, lambda * cells)
}
/// The beam is `D(t)` wide at range `t`.
#[inline]
pub fn beam_width(t: f64) -> f64 {
    BEAM_WIDTH_M + BEAM_DIVERGENCE_RAD * t
}

/// Mean `−ln(1 − intercept)` of a blade hit drawn for each beam on its own (intercepts uniform
/// in 10–40 %, [`crate::physics`]): `[(1 − x)·ln(1 − x) + x]` from 0.1 to 0.4, over 0.3.
pub fn drawn_log_loss_per_hit() -> f64 {
    let f = |x: f64| (1.0 - x) * (1.0 - x).ln() + x;
    (f(0.4) - f(0.1)) / 0.3
}

/// Blades per m² that take from a beam 2 m out as much per metre as `density` hits drawn for
/// each beam on its own do: the same mean `−ln` of the share that gets through, so the world
/// files' `density` means the same grass for one beam in either model.
pub fn areal_density(density: f64) -> f64 {
    // ∫ −ln(1 − L(e)/D) de over the offsets e at which a blade w wide meets the beam, averaged
    // over w (midpoint rule)
    let big_d = beam_width(2.0);
    let (nw, ne) = (32, 256);
    let mut per_blade = 0.0;
    for i in 0..nw {
        let w =
            BLADE_WIDTH_M.0 + (BLADE_WIDTH_M.1 - BLADE_WIDTH_M.0) * (i as f64 + 0.5) / nw as f64;
        let span = w + big_d;
        for j in 0..ne {
            let e = -0.5 * span + span * (j as f64 + 0.5) / ne as f64;
            per_blade -= (1.0 - intercept(e, w, big_d)).ln() * span / ne as f64;
        }
    }
    per_blade /= nw as f64;
    density * drawn_log_loss_per_hit() / per_blade
}

/// Share of a beam `D` wide whose centre passes `perp` from the centre of a blade `w` wide.
#[inline]
pub fn intercept(perp: f64, w: f64, big_d: f64) -> f64 {
    let lo = (perp - 0.5 * w).max(-0.5 * big_d);
    let hi = (perp + 0.5 * w).min(0.5 * big_d);
    ((hi - lo) / big_d).max(0.0)
}

/// A smooth periodic wave in [−1, 1] with period 1, close to `sin(2π·x)` (two parabolas; its
/// slope is continuous), much cheaper than `sin` for the millions of blade positions a run asks.
#[inline]
fn wave(x: f64) -> f64 {
    // x ≥ 0 here (time, frequency and phase are), where truncation is the floor
    let u = x - (x.max(0.0) as u64) as f64;
    if u < 0.5 {
        16.0 * u * (0.5 - u)
    } else {
        let v = u - 0.5;
        -16.0 * v * (0.5 - v)
    }
}

#[derive(Debug, Clone, Copy)]
struct Blade {
    /// Rest position relative to the field's origin, m.
    x: f32,
    y: f32,
    /// Width, m.
    w: f32,
    /// Sway vector (amplitude along its direction), m.
    ax: f32,
    ay: f32,
    /// Sway frequency, Hz, and phase, cycles.
    hz: f32,
    phase: f32,
}

/// SplitMix64 step: the field's draws are a pure function of the seed and the cell, so a field
/// is the same whatever order beams visit it in.
#[inline]
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

struct Draws(u64);

impl Draws {
    fn unit(&mut self) -> f64 {
        self.0 = mix(self.0);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, (a, b): (f64, f64)) -> f64 {
        a + (b - a) * self.unit()
    }
    /// Poisson count of mean `lambda` (Knuth; `lambda` is a few at most).
    fn poisson(&mut self, lambda: f64) -> usize {
        let limit = (-lambda).exp();
        let mut p = self.unit();
        let mut k = 0;
        while p > limit && k < 1000 {
            p *= self.unit();
            k += 1;
        }
        k
    }
}

/// A blade near a horizontal ray: its position at the time asked (world frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NearBlade {
    /// Position, m (world frame).
    pub x: f64,
    /// Position, m (world frame).
    pub y: f64,
    /// Width, m.
    pub w: f64,
    /// Distance along the gathering ray, m (horizontal).
    pub along: f64,
}

/// The blades of one grass patch over its bounding box, bucketed in square cells.
#[derive(Debug, Clone)]
pub struct BladeField {
    x0: f64,
    y0: f64,
    nx: usize,
    ny: usize,
    /// `blades[start[c]..start[c + 1]]` are cell `c`'s (row-major, x fastest).
    start: Vec<u32>,
    blades: Vec<Blade>,
}

impl BladeField {
    /// The blades over the box `min`–`max` (m) at `density` hits per metre (see
    /// [`areal_density`]), drawn from `seed`.
    pub fn new(min: [f64; 2], max: [f64; 2], density: f64, seed: u64) -> Self {
        let nx = (((max[0] - min[0]) / CELL_M).ceil().max(1.0) as usize).min(1 << 14);
        let ny = (((max[1] - min[1]) / CELL_M).ceil().max(1.0) as usize).min(1 << 14);
        let lambda = areal_density(density.max(0.0)) * CELL_M * CELL_M;
        // the world loader bounds both (field_size); never reserve more than the bound here
        let cells = (nx * ny).min(MAX_FIELD_CELLS as usize);
        let expected = (lambda * (nx * ny) as f64 * 1.1).min(MAX_FIELD_BLADES * 1.1);
        let mut start = Vec::with_capacity(cells + 1);
        let mut blades = Vec::with_capacity(expected as usize);
        for iy in 0..ny {
            for ix in 0..nx {
                start.push(blades.len() as u32);
                let mut r = Draws(mix(seed ^ mix(((iy as u64) << 32) | ix as u64)));
                for _ in 0..r.poisson(lambda) {
                    let (sx, sy) = (r.unit(), r.unit());
                    let dir = std::f64::consts::TAU * r.unit();
                    let amp = r.range(SWAY_M);
                    blades.push(Blade {
                        x: ((ix as f64 + sx) * CELL_M) as f32,
                        y: ((iy as f64 + sy) * CELL_M) as f32,
                        w: r.range(BLADE_WIDTH_M) as f32,
                        ax: (amp * dir.cos()) as f32,
                        ay: (amp * dir.sin()) as f32,
                        hz: r.range(SWAY_HZ) as f32,
                        phase: r.unit() as f32,
                    });
                }
            }
        }
        start.push(blades.len() as u32);
        BladeField {
            x0: min[0],
            y0: min[1],
            nx,
            ny,
            start,
            blades,
        }
    }

    /// Number of blades.
    pub fn len(&self) -> usize {
        self.blades.len()
    }

    /// Whether the field has no blade.
    pub fn is_empty(&self) -> bool {
        self.blades.is_empty()
    }

    /// Appends to `out`, sorted by `along`, every blade (at time `time_s`) within
    /// `margin(along) = m0 + m1 · along` of the horizontal ray from `o` along unit `u` whose
    /// distance along the ray is in `[a0, a1)`.
    #[allow(clippy::too_many_arguments)]
    pub fn gather(
        &self,
        o: [f64; 2],
        u: [f64; 2],
        a0: f64,
        a1: f64,
        (m0, m1): (f64, f64),
        time_s: f64,
        out: &mut Vec<NearBlade>,
    ) {
        if a1 <= a0 {
            return;
        }
        let first = out.len();
        // reach of a blade from its rest position: the sway, and the margin at the far end
        let reach = SWAY_M.1 + m0 + m1 * a1;
        let (ox, oy) = (o[0] - self.x0, o[1] - self.y0);
        // walk the cells along the major axis of the ray, a column at a time
        let x_major = u[0].abs() >= u[1].abs();
        let (ua, ub) = if x_major { (u[0], u[1]) } else { (u[1], u[0]) };
        let (oa, ob) = if x_major { (ox, oy) } else { (oy, ox) };
        let (na, nb) = if x_major {
            (self.nx, self.ny)
        } else {
            (self.ny, self.nx)
        };
        let pa = [oa + ua * a0, oa + ua * a1];
        let (lo_a, hi_a) = (pa[0].min(pa[1]) - reach, pa[0].max(pa[1]) + reach);
        let slope = ub / ua;
        let widen = reach * (1.0 + slope * slope).sqrt();
        // cell index of a coordinate, clamped below at 0 (truncation is the floor there)
        let index = |v: f64| (v.max(0.0) / CELL_M) as usize;
        if hi_a < 0.0 || lo_a >= na as f64 * CELL_M {
            return;
        }
        let col_lo = index(lo_a);
        let col_hi = index(hi_a).min(na - 1);
        for col in col_lo..=col_hi {
            let ca = (col as f64 * CELL_M).max(lo_a);
            let cb = ((col + 1) as f64 * CELL_M).min(hi_a);
            let b_at = |a: f64| ob + (a - oa) * slope;
            let (b0, b1) = (b_at(ca), b_at(cb));
            let lo_b = b0.min(b1) - widen;
            let hi_b = b0.max(b1) + widen;
            if hi_b < 0.0 || lo_b >= nb as f64 * CELL_M {
                continue;
            }
            for row in index(lo_b)..=index(hi_b).min(nb - 1) {
                let cell = if x_major {
                    row * self.nx + col
                } else {
                    col * self.nx + row
                };
                let s = self.start[cell] as usize;
                let e = self.start[cell + 1] as usize;
                for b in &self.blades[s..e] {
                    // rest position first: most blades of a cell are too far off the ray to
                    // need their sway
                    let (rx, ry) = (f64::from(b.x) - ox, f64::from(b.y) - oy);
                    let along = rx * u[0] + ry * u[1];
                    let perp = rx * u[1] - ry * u[0];
                    let m = m0 + m1 * (along.max(0.0) + SWAY_M.1) + SWAY_M.1;
                    if perp.abs() > m || along < a0 - SWAY_M.1 || along >= a1 + SWAY_M.1 {
                        continue;
                    }
                    let k = wave(f64::from(b.hz) * time_s + f64::from(b.phase));
                    let (sx, sy) = (rx + f64::from(b.ax) * k, ry + f64::from(b.ay) * k);
                    let along = sx * u[0] + sy * u[1];
                    let perp = sx * u[1] - sy * u[0];
                    if along < a0 || along >= a1 || perp.abs() > m0 + m1 * along.max(0.0) {
                        continue;
                    }
                    out.push(NearBlade {
                        x: sx + o[0],
                        y: sy + o[1],
                        w: f64::from(b.w),
                        along,
                    });
                }
            }
        }
        out[first..].sort_unstable_by(|p, q| p.along.total_cmp(&q.along));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wave_is_close_to_a_sine() {
        for i in 0..1000 {
            let x = i as f64 / 250.0;
            let err = (wave(x) - (std::f64::consts::TAU * x).sin()).abs();
            assert!(err < 0.06, "wave({x}) off by {err}");
        }
    }

    #[test]
    fn intercept_is_the_overlap_share() {
        // a blade narrower than the beam, centred: w / D
        assert!((intercept(0.0, 0.008, 0.02) - 0.4).abs() < 1e-12);
        // half off the beam's edge
        assert!((intercept(0.01, 0.008, 0.02) - 0.2).abs() < 1e-12);
        // clear of it
        assert_eq!(intercept(0.02, 0.008, 0.02), 0.0);
        // a blade wider than the beam covers it
        assert!((intercept(0.001, 0.05, 0.02) - 1.0).abs() < 1e-12);
    }

    /// Brute force over every blade against the cell walk, for rays in all directions.
    #[test]
    fn gather_finds_exactly_the_blades_near_the_ray() {
        let field = BladeField::new([-3.0, -2.0], [5.0, 4.0], 4.0, 11);
        assert!(field.len() > 1000, "{} blades", field.len());
        let mut out = Vec::new();
        for k in 0..64 {
            let a = k as f64 * 0.3;
            let u = [a.cos(), a.sin()];
            let o = [0.5 + 0.1 * (k % 3) as f64, 1.0 - 0.07 * (k % 5) as f64];
            let time = 0.05 * k as f64;
            let (m0, m1) = (0.012, 0.005);
            out.clear();
            field.gather(o, u, 0.3, 4.0, (m0, m1), time, &mut out);
            let mut want = Vec::new();
            for b in &field.blades {
                let kk = wave(f64::from(b.hz) * time + f64::from(b.phase));
                let x = f64::from(b.x) + field.x0 + f64::from(b.ax) * kk;
                let y = f64::from(b.y) + field.y0 + f64::from(b.ay) * kk;
                let along = (x - o[0]) * u[0] + (y - o[1]) * u[1];
                let perp = (x - o[0]) * u[1] - (y - o[1]) * u[0];
                if (0.3..4.0).contains(&along) && perp.abs() <= m0 + m1 * along {
                    want.push(along);
                }
            }
            want.sort_by(f64::total_cmp);
            let got: Vec<f64> = out.iter().map(|b| b.along).collect();
            assert_eq!(got.len(), want.len(), "ray {k}");
            for (g, w) in got.iter().zip(&want) {
                assert!((g - w).abs() < 1e-9, "ray {k}: {g} vs {w}");
            }
            assert!(!want.is_empty(), "ray {k} met no blade");
        }
    }

    /// A beam 2 m out loses as much per metre as with blades drawn for each beam.
    #[test]
    fn density_means_the_same_loss_per_metre_two_metres_out() {
        let field = BladeField::new([-10.0, -10.0], [10.0, 10.0], 4.0, 3);
        let mut out = Vec::new();
        let (mut loss, mut hits, mut metres) = (0.0, 0usize, 0.0);
        for k in 0..2000 {
            let a = k as f64 * 0.0031;
            let u = [a.cos(), a.sin()];
            out.clear();
            let d = beam_width(2.0);
            field.gather(
                [0.0, 0.0],
                u,
                1.5,
                2.5,
                (0.006 + 0.5 * d, 0.0),
                0.0,
                &mut out,
            );
            for b in &out {
                let perp = b.x * u[1] - b.y * u[0];
                let i = intercept(perp, b.w, d);
                if i > 0.0 {
                    loss -= (1.0 - i).ln();
                    hits += 1;
                }
            }
            metres += 1.0;
        }
        let want = 4.0 * drawn_log_loss_per_hit();
        let per_m = loss / metres;
        assert!(
            (per_m - want).abs() < 0.1 * want,
            "{per_m} per metre, want {want}"
        );
        // fewer, larger blades than hits drawn per beam
        let hits_per_m = hits as f64 / metres;
        assert!(
            (2.5..4.0).contains(&hits_per_m),
            "{hits_per_m} hits per metre"
        );
    }
}
