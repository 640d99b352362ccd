//! What one laser beam returns: the material model of DESIGN §9.
//!
//! A beam walks through the things it meets in order of distance, carrying the fraction `f` of
//! its energy still going forward:
//! - an opaque surface returns `reflectivity · cos(incidence) · f` and ends the beam;
//! - glass returns only within `sim.glass_specular_deg` of normal incidence, then as a sharp spike
//!   (120 to 255, highest at normal incidence, in the sensor's retro-reflector range) and passes
//!   70 % on; otherwise it passes 92 % on and returns nothing;
//! - a curtain is hit with probability `1 − (1 − coverage)^(1 / cos(incidence))`; a hit strand
//!   intercepts 30–80 % of the beam and returns that share of its reflectivity, its range
//!   jittering by a few centimetres as strands sway;
//! - grass and bushes are volumes: blade hits come at exponentially distributed distances
//!   (`density` per metre), each intercepting 10–40 % of the beam (a blade is thinner than the
//!   beam's footprint), drawn for each beam on its own;
//! - or, with `sim.grass_blades`, grass is a field of blades standing in the ground
//!   ([`crate::blades`]): the beam meets the blades its footprint really overlaps, each
//!   intercepting the share it covers, so neighbouring beams meet the same blades;
//! - the beam ends when less than 5 % of it is left.
//!
//! Echoes closer than 0.2 m along the beam arrive as one pulse and are reported as one echo with
//! their summed intensity (dense foliage returns strongly, sparse blades weakly). Echoes weaker
//! than 1 reflectivity unit are not detected. The sensor reports the last echo and
//! the strongest one (the second strongest when the last is also the strongest).

use crate::config::SimConfig;

use crate::blades::{BladeField, NearBlade, beam_width, intercept as blade_intercept};
use crate::geometry::{Hit, intersect};
use crate::world::{Material, Object, Scene, Shape};

/// Farthest range the sensor reports, m.
pub const MAX_RANGE_M: f64 = 100.0;

/// One echo of a beam.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Echo {
    /// Range, m.
    pub range: f64,
    /// Reported reflectivity, 0–255.
    pub intensity: f64,
}

/// Echoes closer than this along the beam reach the receiver as one pulse: the sensor reports
/// one echo with their summed intensity at their intensity-weighted range. This is what makes
/// dense foliage (a bush) return strongly while sparse blades (grass) stay weak.
const MERGE_M: f64 = 0.2;

/// Minimum detectable echo intensity.
const MIN_INTENSITY: f64 = 1.0;
/// The beam is spent below this fraction.
const MIN_FRACTION: f64 = 0.05;
/// Blade hits sampled per volume crossing at most: each intercepts at least 10 % of the beam, so
/// after 29 hits less than 0.9^29 < 5 % is left and the beam is spent anyway.
const MAX_BLADE_HITS: usize = 29;

#[derive(Debug, Clone, Copy)]
enum Event {
    Surface {
        t: f64,
        cos: f64,
        reflectivity: f64,
    },
    Glass {
        t: f64,
        cos: f64,
    },
    Strand {
        t: f64,
        cos: f64,
        coverage: f64,
        reflectivity: f64,
    },
    Blade {
        t: f64,
        intercept: f64,
        reflectivity: f64,
    },
}

impl Event {
    fn t(&self) -> f64 {
        match *self {
            Event::Surface { t, .. }
            | Event::Glass { t, .. }
            | Event::Strand { t, .. }
            | Event::Blade { t, .. } => t,
        }
    }
}

/// Grass gathered along one horizontal ray: the lasers of a firing sequence look along the same
/// azimuth and share it.
#[derive(Debug, Default)]
struct Gathered {
    /// Object index.
    obj: usize,
    /// Ray origin and horizontal unit direction.
    o: [f64; 2],
    u: [f64; 2],
    /// Distances along the ray gathered, `[a0, a1)`.
    a0: f64,
    a1: f64,
    /// When, s.
    time_s: f64,
    blades: Vec<NearBlade>,
}

/// A gathered ray serves another beam whose horizontal direction is within this angle of it
/// (the 16 lasers of a sequence sweep 0.13° at 600 rpm).
const GATHER_SHARE_RAD: f64 = 0.0035;
/// Gathering margin, [`BladeField::gather`]'s `(m0, m1)`: half the widest blade and the beam's
/// half width at the lens; half the divergence for a beam up to 15° steep, and the directions a
/// gathered ray serves.
const GATHER_MARGIN: (f64, f64) = (
    0.006 + 0.5 * crate::blades::BEAM_WIDTH_M,
    0.5 * crate::blades::BEAM_DIVERGENCE_RAD / 0.96 + GATHER_SHARE_RAD,
);
/// `cos(GATHER_SHARE_RAD)` (to 1e-11).
const GATHER_SHARE_COS: f64 = 1.0 - 0.5 * GATHER_SHARE_RAD * GATHER_SHARE_RAD;
/// ... and was gathered within this time (a blade sways 0.3 mm in 1 ms at most).
const GATHER_SHARE_S: f64 = 0.001;
/// Grass is gathered a metre at a time, as far as a beam gets.
const GATHER_STEP_M: f64 = 1.0;

/// Reusable buffers of the beam model, and the grass fields of the scene it casts in.
#[derive(Debug, Default)]
pub struct BeamCaster {
    events: Vec<Event>,
    echoes: Vec<Echo>,
    /// Seed of the grass fields.
    seed: u64,
    /// The grass field of each object, built when a beam first crosses it.
    fields: Vec<Option<BladeField>>,
    gathered: Vec<Gathered>,
}

fn normal(rng: &mut fastrand::Rng) -> f64 {
    // Box–Muller
    let u1 = rng.f64().max(1e-12);
    let u2 = rng.f64();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

impl BeamCaster {
    /// A caster whose grass fields are drawn from `seed`: the same seed, the same blades.
    pub fn new(seed: u64) -> Self {
        BeamCaster {
            seed,
            ..BeamCaster::default()
        }
    }

    /// The echoes of the beam from `o` along unit `d` at `time_s` (s, for the grass's sway),
    /// considering the objects `candidates` indexes into `scene.objects`. The slice is valid
    /// until the next call. A caster serves one scene: its grass fields are built for it.
    #[allow(clippy::too_many_arguments)]
    pub fn cast(
        &mut self,
        scene: &Scene,
        candidates: &[usize],
        o: [f64; 3],
        d: [f64; 3],
        time_s: f64,
        params: &SimConfig,
        rng: &mut fastrand::Rng,
    ) -> &[Echo] {
        let glass_specular_rad = params.glass_specular_deg.to_radians();
        self.events.clear();
        self.echoes.clear();
        for &i in candidates {
            let obj: &Object = &scene.objects[i];
            let Some(Hit {
                t_in,
                t_out,
                cos_incidence: cos,
            }) = intersect(&obj.shape, o, d)
            else {
                continue;
            };
            match obj.material {
                Material::Opaque { reflectivity } => {
                    if t_in > 0.0 {
                        self.events.push(Event::Surface {
                            t: t_in,
                            cos,
                            reflectivity,
                        });
                    }
                }
                Material::Glass => self.events.push(Event::Glass { t: t_in, cos }),
                Material::Strands {
                    coverage,
                    reflectivity,
                } => self.events.push(Event::Strand {
                    t: t_in,
                    cos,
                    coverage,
                    reflectivity,
                }),
                Material::Foliage {
                    density,
                    reflectivity,
                    blades: true,
                } if params.grass_blades => {
                    if density > 0.0 {
                        self.blade_events(
                            obj,
                            i,
                            (density, reflectivity),
                            o,
                            d,
                            (t_in, t_out),
                            time_s,
                        );
                    }
                }
                Material::Foliage {
                    density,
                    reflectivity,
                    ..
                } => {
                    if density <= 0.0 {
                        continue;
                    }
                    let mut t = t_in;
                    for _ in 0..MAX_BLADE_HITS {
                        t += -(rng.f64().max(1e-12)).ln() / density;
                        if t >= t_out {
                            break;
                        }
                        let intercept = 0.1 + 0.3 * rng.f64();
                        self.events.push(Event::Blade {
                            t,
                            intercept,
                            reflectivity,
                        });
                    }
                }
            }
        }
        if d[2] < -1e-9 {
            let t = -o[2] / d[2];
            self.events.push(Event::Surface {
                t,
                cos: -d[2],
                reflectivity: scene.ground_reflectivity,
            });
        }
        self.events.sort_unstable_by(|a, b| a.t().total_cmp(&b.t()));
        let mut f = 1.0;
        for ev in &self.events {
            if ev.t() > MAX_RANGE_M {
                break;
            }
            match *ev {
                Event::Surface {
                    t,
                    cos,
                    reflectivity,
                } => {
                    let i = reflectivity * cos * f + params.intensity_noise * normal(rng);
                    if i >= MIN_INTENSITY {
                        let range = t + params.range_noise_m * normal(rng);
                        self.echoes.push(Echo {
                            range,
                            intensity: i,
                        });
                    }
                    f = 0.0;
                }
                Event::Glass { t, cos } => {
                    let angle = cos.clamp(-1.0, 1.0).acos();
                    if angle < glass_specular_rad {
                        let spike = 120.0 + 135.0 * (1.0 - angle / glass_specular_rad);
                        let range = t + 0.3 * params.range_noise_m * normal(rng);
                        self.echoes.push(Echo {
                            range,
                            intensity: spike * f,
                        });
                        f *= 0.7;
                    } else {
                        f *= 0.92;
                    }
                }
                Event::Strand {
                    t,
                    cos,
                    coverage,
                    reflectivity,
                } => {
                    let p_hit = 1.0 - (1.0 - coverage).powf(1.0 / cos.max(0.05));
                    if rng.f64() < p_hit {
                        let intercept = 0.3 + 0.5 * rng.f64();
                        let i = reflectivity * intercept * f + params.intensity_noise * normal(rng);
                        if i >= MIN_INTENSITY {
                            self.echoes.push(Echo {
                                range: t + 0.03 * normal(rng),
                                intensity: i,
                            });
                        }
                        f *= 1.0 - intercept;
                    }
                }
                Event::Blade {
                    t,
                    intercept,
                    reflectivity,
                } => {
                    let i = reflectivity * intercept * f + params.intensity_noise * normal(rng);
                    if i >= MIN_INTENSITY {
                        self.echoes.push(Echo {
                            range: t + 0.02 * normal(rng),
                            intensity: i,
                        });
                    }
                    f *= 1.0 - intercept;
                }
            }
            if f < MIN_FRACTION {
                break;
            }
        }
        self.merge();
        &self.echoes
    }

    /// Pushes the blades of grass object `i` the beam from `o` along `d` meets between `t_in`
    /// and `t_out`, up to where less than [`MIN_FRACTION`] of it would be left.
    #[allow(clippy::too_many_arguments)]
    fn blade_events(
        &mut self,
        obj: &Object,
        i: usize,
        (density, reflectivity): (f64, f64),
        o: [f64; 3],
        d: [f64; 3],
        (t_in, t_out): (f64, f64),
        time_s: f64,
    ) {
        let c = d[0].hypot(d[1]);
        if c < 1e-6 {
            return;
        }
        let u = [d[0] / c, d[1] / c];
        let o2 = [o[0], o[1]];
        let (a_in, a_out) = (t_in * c, t_out * c);
        if self.fields.len() <= i {
            self.fields.resize_with(i + 1, || None);
        }
        let field = self.fields[i].get_or_insert_with(|| {
            let (lo, hi) = shape_box(&obj.shape);
            BladeField::new(
                lo,
                hi,
                density,
                self.seed ^ (i as u64).wrapping_mul(0x2545_F491),
            )
        });
        // the gathered ray this beam can share, or a fresh one
        let k = match self.gathered.iter().position(|g| g.obj == i) {
            Some(k) => k,
            None => {
                self.gathered.push(Gathered {
                    obj: i,
                    a0: f64::INFINITY,
                    ..Gathered::default()
                });
                self.gathered.len() - 1
            }
        };
        let g = &mut self.gathered[k];
        let shared = g.o == o2
            && g.u[0] * u[0] + g.u[1] * u[1] >= GATHER_SHARE_COS
            && g.a0 <= (a_in - 0.005).max(0.0)
            && (time_s - g.time_s).abs() <= GATHER_SHARE_S;
        if !shared {
            g.o = o2;
            g.u = u;
            g.time_s = time_s;
            g.a0 = (a_in - 0.01).max(0.0);
            g.a1 = g.a0;
            g.blades.clear();
        }
        let mut f = 1.0;
        let mut next = 0;
        loop {
            while next < g.blades.len() {
                let b = g.blades[next];
                next += 1;
                let (rx, ry) = (b.x - o[0], b.y - o[1]);
                let t = (rx * u[0] + ry * u[1]) / c;
                if t >= t_out + 0.01 {
                    // sorted along the gathered ray, which differs from this one by less
                    return;
                }
                if t <= t_in || t >= t_out {
                    continue;
                }
                let perp = rx * u[1] - ry * u[0];
                let intercept = blade_intercept(perp, b.w, beam_width(t));
                if intercept <= 0.0 {
                    continue;
                }
                self.events.push(Event::Blade {
                    t,
                    intercept,
                    reflectivity,
                });
                f *= 1.0 - intercept;
                if f < MIN_FRACTION {
                    return;
                }
            }
            if g.a1 >= a_out + 0.01 {
                return;
            }
            let a1 = (g.a1 + GATHER_STEP_M).min(a_out + 0.01);
            field.gather(o2, g.u, g.a1, a1, GATHER_MARGIN, time_s, &mut g.blades);
            g.a1 = a1;
        }
    }

    /// Merges echoes closer than [`MERGE_M`] (the echoes are in walk order, nearest first up to
    /// the range jitter).
    fn merge(&mut self) {
        if self.echoes.len() < 2 {
            return;
        }
        self.echoes
            .sort_unstable_by(|a, b| a.range.total_cmp(&b.range));
        let mut out = 0;
        for k in 1..self.echoes.len() {
            let e = self.echoes[k];
            let g = &mut self.echoes[out];
            if e.range - g.range <= MERGE_M {
                let w = g.intensity + e.intensity;
                if w > 0.0 {
                    g.range = (g.range * g.intensity + e.range * e.intensity) / w;
                }
                g.intensity = w;
            } else {
                out += 1;
                self.echoes[out] = e;
            }
        }
        self.echoes.truncate(out + 1);
    }
}

/// The horizontal bounding box of a shape.
fn shape_box(shape: &Shape) -> ([f64; 2], [f64; 2]) {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    let mut add = |p: [f64; 2], r: f64| {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k] - r);
            hi[k] = hi[k].max(p[k] + r);
        }
    };
    match shape {
        Shape::Sheet { a, b, .. } => {
            add(*a, 0.0);
            add(*b, 0.0);
        }
        Shape::Prism { poly, .. } => poly.iter().for_each(|p| add(*p, 0.0)),
        Shape::Cylinder { c, r, .. } => add(*c, *r),
    }
    (lo, hi)
}

/// The two returns of a dual-return firing, as the sensor reports them: (last, strongest or
/// second strongest). Identical when there was one echo; `None` when there was none.
pub fn dual_returns(echoes: &[Echo]) -> Option<(Echo, Echo)> {
    let last_i = (0..echoes.len()).max_by(|&a, &b| echoes[a].range.total_cmp(&echoes[b].range))?;
    let strongest_i =
        (0..echoes.len()).max_by(|&a, &b| echoes[a].intensity.total_cmp(&echoes[b].intensity))?;
    let last = echoes[last_i];
    if strongest_i != last_i {
        return Some((last, echoes[strongest_i]));
    }
    let second = (0..echoes.len())
        .filter(|&i| i != last_i)
        .max_by(|&a, &b| echoes[a].intensity.total_cmp(&echoes[b].intensity))
        .map_or(last, |i| echoes[i]);
    Some((last, second))
}

/// The strongest echo.
pub fn strongest(echoes: &[Echo]) -> Option<Echo> {
    echoes
        .iter()
        .copied()
        .max_by(|a, b| a.intensity.total_cmp(&b.intensity))
}

/// The last (farthest) echo.
pub fn last(echoes: &[Echo]) -> Option<Echo> {
    echoes
        .iter()
        .copied()
        .max_by(|a, b| a.range.total_cmp(&b.range))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dual_return_rules() {
        let e = |range, intensity| Echo { range, intensity };
        assert_eq!(dual_returns(&[]), None);
        let one = [e(5.0, 40.0)];
        assert_eq!(dual_returns(&one), Some((one[0], one[0])));
        // grass in front (weak), wall behind (strong): last = strongest → second strongest
        let two = [e(2.0, 8.0), e(5.0, 40.0)];
        assert_eq!(dual_returns(&two), Some((two[1], two[0])));
        // glass spike in front, wall behind: last is the wall, strongest the glass
        let glass = [e(3.0, 200.0), e(6.0, 30.0)];
        assert_eq!(dual_returns(&glass), Some((glass[1], glass[0])));
    }
}
