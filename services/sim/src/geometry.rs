//! Ray–shape intersections and 2-D distances for the scene's shapes.
//!
//! A ray is `o + t·d` with `d` a unit vector, so `t` is the distance along the beam. Every shape
//! stands vertically on the ground, so the horizontal part of a test is 2-D and the vertical part
//! clips `t` to the heights where `o.z + t·d.z` lies between the shape's bottom and top.

use crate::world::Shape;

/// Where a ray enters (and leaves) a shape, and how steeply it meets the entry surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Distance to the entry point.
    pub t_in: f64,
    /// Distance to the exit point (equal to `t_in` for a sheet).
    pub t_out: f64,
    /// |cos| of the angle between the beam and the entry surface's normal.
    pub cos_incidence: f64,
}

#[inline]
fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// The ray's `t` interval between heights `z0` and `z1`.
#[inline]
fn z_interval(oz: f64, dz: f64, z0: f64, z1: f64) -> Option<(f64, f64)> {
    if dz.abs() < 1e-12 {
        return (oz >= z0 && oz <= z1).then_some((f64::NEG_INFINITY, f64::INFINITY));
    }
    let a = (z0 - oz) / dz;
    let b = (z1 - oz) / dz;
    Some(if a < b { (a, b) } else { (b, a) })
}

/// Intersects the ray `o + t·d` (`d` unit) with `shape`; only hits with `t > 1e-6` count.
pub fn intersect(shape: &Shape, o: [f64; 3], d: [f64; 3]) -> Option<Hit> {
    const EPS: f64 = 1e-6;
    let o2 = [o[0], o[1]];
    let d2 = [d[0], d[1]];
    match shape {
        Shape::Sheet { a, b, z0, z1 } => {
            let e = [b[0] - a[0], b[1] - a[1]];
            let denom = cross(d2, e);
            if denom.abs() < 1e-12 {
                return None;
            }
            let ao = [a[0] - o2[0], a[1] - o2[1]];
            let t = cross(ao, e) / denom;
            let s = cross(ao, d2) / denom;
            if t <= EPS || !(0.0..=1.0).contains(&s) {
                return None;
            }
            let z = o[2] + t * d[2];
            if z < *z0 || z > *z1 {
                return None;
            }
            let len = e[0].hypot(e[1]);
            let cos = (d2[0] * e[1] - d2[1] * e[0]).abs() / len;
            Some(Hit {
                t_in: t,
                t_out: t,
                cos_incidence: cos,
            })
        }
        Shape::Cylinder { c, r, z0, z1 } => {
            let f = [o2[0] - c[0], o2[1] - c[1]];
            let qa = d2[0] * d2[0] + d2[1] * d2[1];
            if qa < 1e-15 {
                return None;
            }
            let qb = 2.0 * (f[0] * d2[0] + f[1] * d2[1]);
            let qc = f[0] * f[0] + f[1] * f[1] - r * r;
            let disc = qb * qb - 4.0 * qa * qc;
            if disc < 0.0 {
                return None;
            }
            let sq = disc.sqrt();
            let (s0, s1) = ((-qb - sq) / (2.0 * qa), (-qb + sq) / (2.0 * qa));
            let (h0, h1) = z_interval(o[2], d[2], *z0, *z1)?;
            let t_in = s0.max(h0);
            let t_out = s1.min(h1);
            if t_in >= t_out || t_out <= EPS {
                return None;
            }
            let cos = if s0 >= h0 {
                // entered through the side: the normal is radial
                let p = [o2[0] + s0 * d2[0] - c[0], o2[1] + s0 * d2[1] - c[1]];
                ((p[0] * d[0] + p[1] * d[1]) / r).abs()
            } else {
                d[2].abs()
            };
            Some(Hit {
                t_in: t_in.max(0.0),
                t_out,
                cos_incidence: cos.min(1.0),
            })
        }
        Shape::Prism { poly, z0, z1 } => {
            let mut t_in = f64::NEG_INFINITY;
            let mut t_out = f64::INFINITY;
            let mut normal_in = [0.0, 0.0];
            let n = poly.len();
            for i in 0..n {
                let p = poly[i];
                let q = poly[(i + 1) % n];
                // outward normal of a counter-clockwise polygon's edge
                let nrm = [q[1] - p[1], -(q[0] - p[0])];
                let num = nrm[0] * (p[0] - o2[0]) + nrm[1] * (p[1] - o2[1]);
                let den = nrm[0] * d2[0] + nrm[1] * d2[1];
                if den.abs() < 1e-15 {
                    if num < 0.0 {
                        return None;
                    }
                    continue;
                }
                let t = num / den;
                if den < 0.0 {
                    if t > t_in {
                        t_in = t;
                        normal_in = nrm;
                    }
                } else if t < t_out {
                    t_out = t;
                }
            }
            let (h0, h1) = z_interval(o[2], d[2], *z0, *z1)?;
            let side = t_in >= h0;
            let t_enter = t_in.max(h0);
            let t_exit = t_out.min(h1);
            if t_enter >= t_exit || t_exit <= EPS {
                return None;
            }
            let cos = if side {
                let len = normal_in[0].hypot(normal_in[1]);
                ((normal_in[0] * d[0] + normal_in[1] * d[1]) / len).abs()
            } else {
                d[2].abs()
            };
            Some(Hit {
                t_in: t_enter.max(0.0),
                t_out: t_exit,
                cos_incidence: cos.min(1.0),
            })
        }
    }
}

/// Distance from point `p` to segment `a`–`b`.
pub fn point_segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let e = [b[0] - a[0], b[1] - a[1]];
    let l2 = e[0] * e[0] + e[1] * e[1];
    let s = if l2 > 0.0 {
        (((p[0] - a[0]) * e[0] + (p[1] - a[1]) * e[1]) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - s * e[0]).hypot(p[1] - a[1] - s * e[1])
}

/// Horizontal distance from point `p` to the footprint of `shape` (0 inside it).
pub fn footprint_distance(shape: &Shape, p: [f64; 2]) -> f64 {
    match shape {
        Shape::Sheet { a, b, .. } => point_segment_distance(p, *a, *b),
        Shape::Cylinder { c, r, .. } => ((p[0] - c[0]).hypot(p[1] - c[1]) - r).max(0.0),
        Shape::Prism { poly, .. } => {
            let n = poly.len();
            let inside = (0..n).all(|i| {
                let a = poly[i];
                let b = poly[(i + 1) % n];
                cross([b[0] - a[0], b[1] - a[1]], [p[0] - a[0], p[1] - a[1]]) >= 0.0
            });
            if inside {
                return 0.0;
            }
            (0..n)
                .map(|i| point_segment_distance(p, poly[i], poly[(i + 1) % n]))
                .fold(f64::INFINITY, f64::min)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(az_deg: f64, el_deg: f64) -> [f64; 3] {
        let (a, e) = (az_deg.to_radians(), el_deg.to_radians());
        [e.cos() * a.cos(), e.cos() * a.sin(), e.sin()]
    }

    #[test]
    fn sheet_hit_distance_and_incidence() {
        let s = Shape::Sheet {
            a: [5.0, -2.0],
            b: [5.0, 2.0],
            z0: 0.0,
            z1: 2.0,
        };
        let h = intersect(&s, [0.0, 0.0, 0.5], dir(0.0, 0.0)).expect("hit");
        assert!((h.t_in - 5.0).abs() < 1e-9 && (h.cos_incidence - 1.0).abs() < 1e-9);
        let h = intersect(&s, [0.0, 0.0, 0.5], dir(20.0, 0.0)).expect("hit");
        assert!((h.t_in - 5.0 / 20f64.to_radians().cos()).abs() < 1e-9);
        assert!((h.cos_incidence - 20f64.to_radians().cos()).abs() < 1e-9);
        // over the top
        assert!(intersect(&s, [0.0, 0.0, 0.5], dir(0.0, 20.0)).is_none());
        // behind
        assert!(intersect(&s, [0.0, 0.0, 0.5], dir(180.0, 0.0)).is_none());
    }

    #[test]
    fn cylinder_side_and_top() {
        let c = Shape::Cylinder {
            c: [3.0, 0.0],
            r: 0.5,
            z0: 0.0,
            z1: 0.3,
        };
        assert!(
            intersect(&c, [0.0, 0.0, 0.5], dir(0.0, 0.0)).is_none(),
            "passes over a low rock"
        );
        let h =
            intersect(&c, [0.0, 0.0, 0.5], dir(0.0, -7.0)).expect("hits the rock's top or side");
        let z = 0.5 + h.t_in * (-7f64).to_radians().sin();
        assert!((0.0..=0.3 + 1e-9).contains(&z), "{z}");
        let tall = Shape::Cylinder {
            c: [3.0, 0.0],
            r: 0.5,
            z0: 0.0,
            z1: 3.0,
        };
        let h = intersect(&tall, [0.0, 0.0, 0.5], dir(0.0, 0.0)).expect("hit");
        assert!((h.t_in - 2.5).abs() < 1e-9 && (h.t_out - 3.5).abs() < 1e-9);
        // from inside a volume the beam starts at once
        let h = intersect(&tall, [3.0, 0.0, 0.5], dir(0.0, 0.0)).expect("inside");
        assert_eq!(h.t_in, 0.0);
    }

    #[test]
    fn prism_entry_exit_and_footprint() {
        let poly = vec![[1.0, -1.0], [3.0, -1.0], [3.0, 1.0], [1.0, 1.0]];
        let p = Shape::Prism {
            poly,
            z0: 0.0,
            z1: 1.0,
        };
        let h = intersect(&p, [0.0, 0.0, 0.5], dir(0.0, 0.0)).expect("hit");
        assert!((h.t_in - 1.0).abs() < 1e-9 && (h.t_out - 3.0).abs() < 1e-9);
        assert!((h.cos_incidence - 1.0).abs() < 1e-9);
        assert_eq!(footprint_distance(&p, [2.0, 0.0]), 0.0);
        assert!((footprint_distance(&p, [0.0, 0.0]) - 1.0).abs() < 1e-9);
    }
}
