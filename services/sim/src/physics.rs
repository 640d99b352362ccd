//! What one laser beam returns: the material model of DESIGN §9.
//!
//! A beam walks through the things it meets in order of distance, carrying the fraction `f` of
//! its energy still going forward:
//! - an opaque surface returns `reflectivity · cos(incidence) · f` and ends the beam;
//! - glass returns only within `glass_specular` of normal incidence, then as a sharp spike
//!   (120 to 255, highest at normal incidence, in the sensor's retro-reflector range) and passes
//!   70 % on; otherwise it passes 92 % on and returns nothing;
//! - a curtain is hit with probability `1 − (1 − coverage)^(1 / cos(incidence))`; a hit strand
//!   intercepts 30–80 % of the beam and returns that share of its reflectivity, its range
//!   jittering by a few centimetres as strands sway;
//! - grass and bushes are volumes: blade hits come at exponentially distributed distances
//!   (`density` per metre), each intercepting 10–40 % of the beam (a blade is thinner than the
//!   beam's footprint);
//! - the beam ends when less than 5 % of it is left.
//!
//! Echoes closer than 0.2 m along the beam arrive as one pulse and are reported as one echo with
//! their summed intensity (dense foliage returns strongly, sparse blades weakly). Echoes weaker
//! than 1 reflectivity unit are not detected. The sensor reports the last echo and
//! the strongest one (the second strongest when the last is also the strongest).

use crate::geometry::{Hit, intersect};
use crate::world::{Material, Object, Scene};

/// Tunable physics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhysicsParams {
    /// Standard deviation of the range noise of solid surfaces, m.
    pub range_noise_m: f64,
    /// Standard deviation of the intensity noise.
    pub intensity_noise: f64,
    /// Glass returns only within this angle of normal incidence, rad.
    pub glass_specular_rad: f64,
    /// Farthest range the sensor reports, m.
    pub max_range_m: f64,
}

impl Default for PhysicsParams {
    fn default() -> Self {
        PhysicsParams {
            range_noise_m: 0.015,
            intensity_noise: 1.5,
            glass_specular_rad: 3f64.to_radians(),
            max_range_m: 100.0,
        }
    }
}

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

/// Reusable buffers of the beam model.
#[derive(Debug, Default)]
pub struct BeamCaster {
    events: Vec<Event>,
    echoes: Vec<Echo>,
}

fn normal(rng: &mut fastrand::Rng) -> f64 {
    // Box–Muller
    let u1 = rng.f64().max(1e-12);
    let u2 = rng.f64();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

impl BeamCaster {
    /// The echoes of the beam from `o` along unit `d`, considering the objects `candidates`
    /// indexes into `scene.objects`. The slice is valid until the next call.
    pub fn cast(
        &mut self,
        scene: &Scene,
        candidates: &[usize],
        o: [f64; 3],
        d: [f64; 3],
        params: &PhysicsParams,
        rng: &mut fastrand::Rng,
    ) -> &[Echo] {
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
            if ev.t() > params.max_range_m {
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
                    if angle < params.glass_specular_rad {
                        let spike = 120.0 + 135.0 * (1.0 - angle / params.glass_specular_rad);
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
