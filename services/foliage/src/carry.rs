//! Carried scans (beyond the paper, interpretation 17): the sensor's [`Motion`] between scans and
//! the window maxima of earlier scans moved into this scan's frame.

use std::f32::consts::PI;

use mimnav_shared::pose::{Pose2, Pose2Ext};

use crate::bits::select;

/// The sensor's motion from the previous scan to this one: this scan's sensor pose in the frame of
/// the previous scan's sensor (x forward, y left, θ counter-clockwise; REP-103), for
/// [`Classifier::classify_moved`](crate::Classifier::classify_moved).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Motion {
    /// Forward, metres.
    pub dx_m: f32,
    /// Left, metres.
    pub dy_m: f32,
    /// Counter-clockwise turn, radians.
    pub dtheta_rad: f32,
}

impl Motion {
    /// The largest step between two scans taken as motion, metres: a longer one (a pose reset,
    /// a jump in odometry) makes the earlier scans' positions meaningless and they are dropped.
    pub const MAX_STEP_M: f32 = 2.0;
    /// The largest turn between two scans taken as motion, radians (45°; see `MAX_STEP_M`).
    pub const MAX_TURN_RAD: f32 = PI / 4.0;

    /// The motion between two poses of the sensor in any fixed frame: the second pose in the
    /// frame of the first.
    pub fn between(from: &Pose2, to: &Pose2) -> Motion {
        let m = from.motion_to(to);
        Motion {
            dx_m: m.x() as f32,
            dy_m: m.y() as f32,
            dtheta_rad: m.yaw() as f32,
        }
    }

    /// Finite, no longer than [`Motion::MAX_STEP_M`] and no wider than [`Motion::MAX_TURN_RAD`].
    pub fn is_plausible(&self) -> bool {
        let step = self.dx_m.hypot(self.dy_m);
        step.is_finite()
            && step <= Self::MAX_STEP_M
            && self.dtheta_rad.is_finite()
            && self.dtheta_rad.abs() <= Self::MAX_TURN_RAD
    }
}

/// `atan2(y, x)` to within 1.2·10⁻⁵ rad, without a libm call: the polynomial of Abramowitz &
/// Stegun 4.4.49 (|ε| ≤ 10⁻⁵ on [0, 1]) with the octant folded in. `(0, 0)` gives 0; NaN in, NaN
/// out. Carried maxima are re-binned with it into windows of several mrad.
pub fn fast_atan2(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    let a = select(hi > 0.0, lo / hi, 0.0);
    let s = a * a;
    let r =
        a * (0.999_866 + s * (-0.330_299_5 + s * (0.180_141 + s * (-0.085_133 + s * 0.020_835_1))));
    let r = select(ay > ax, std::f32::consts::FRAC_PI_2 - r, r);
    let r = select(x < 0.0, PI - r, r);
    let r = select(y < 0.0, -r, r);
    select(x.is_nan() | y.is_nan(), f32::NAN, r)
}

/// One carried scan: its window maxima (as points at their windows' centre angles) and its
/// sensor position, both in the present frame.
#[derive(Debug, Clone, Default)]
struct CarriedScan {
    origin: [f32; 2],
    xs: Vec<f32>,
    ys: Vec<f32>,
}

/// The earlier scans of interpretation 17, newest first (at most `carry_scans`).
#[derive(Debug, Clone, Default)]
pub(crate) struct Carry {
    scans: Vec<CarriedScan>,
    /// Emptied scans, for their allocations.
    spare: Vec<CarriedScan>,
    /// `cos` and `sin` of each window's centre angle.
    cos: Vec<f32>,
    sin: Vec<f32>,
    /// Scratch: the window and range of each carried point.
    bins: Vec<i32>,
    ranges: Vec<f32>,
}

impl Carry {
    pub(crate) fn with_windows(window_rad: f32, n_windows: usize) -> Self {
        let centre = |w: usize| -std::f64::consts::PI + (w as f64 + 0.5) * f64::from(window_rad);
        Self {
            cos: (0..n_windows).map(|w| centre(w).cos() as f32).collect(),
            sin: (0..n_windows).map(|w| centre(w).sin() as f32).collect(),
            ..Self::default()
        }
    }

    pub(crate) fn clear(&mut self) {
        self.spare.append(&mut self.scans);
    }

    /// Moves every carried scan by `m` into the new frame and writes, per window, the largest range
    /// of the maxima carried from scans taken at least `min_travel` away (0 where none). False
    /// when no scan qualified (`out` is then all 0).
    pub(crate) fn advance(
        &mut self,
        m: Motion,
        min_travel: f32,
        inv_w: f32,
        out: &mut Vec<f32>,
    ) -> bool {
        let n_w = self.cos.len();
        out.clear();
        out.resize(n_w, 0.0);
        if n_w == 0 {
            return false;
        }
        let last = i32::try_from(n_w - 1).unwrap_or(i32::MAX);
        let (sin, cos) = m.dtheta_rad.sin_cos();
        let (dx, dy) = (m.dx_m, m.dy_m);
        let mut any = false;
        for carried in &mut self.scans {
            // p ← R(−dθ)·(p − d): the previous frame's point in this frame
            let [ox, oy] = carried.origin;
            let (ox, oy) = (ox - dx, oy - dy);
            carried.origin = [cos * ox + sin * oy, cos * oy - sin * ox];
            let [ox, oy] = carried.origin;
            let far_enough = ox.hypot(oy) >= min_travel;
            any |= far_enough;
            // (one pass that vectorises: move, then angle and range; the scatter below cannot)
            let n = carried.xs.len().min(carried.ys.len());
            self.bins.clear();
            self.bins.resize(n, 0);
            self.ranges.clear();
            self.ranges.resize(n, 0.0);
            let points = carried.xs[..n].iter_mut().zip(&mut carried.ys[..n]);
            let outs = self.bins.iter_mut().zip(self.ranges.iter_mut());
            for ((x, y), (b, r)) in points.zip(outs) {
                let (px, py) = (*x - dx, *y - dy);
                let (qx, qy) = (cos * px + sin * py, cos * py - sin * px);
                (*x, *y) = (qx, qy);
                // the angle is in [-π, π], so t in [0, 2π]; the `clamp` keeps t = 2π in range
                let t = fast_atan2(qy, qx) + PI;
                *b = ((t * inv_w) as i32).clamp(0, last);
                *r = (qx * qx + qy * qy).sqrt();
            }
            if !far_enough {
                continue;
            }
            for (&w, &r) in self.bins.iter().zip(&self.ranges) {
                if let Some(o) = out.get_mut(w as usize) {
                    *o = o.max(r);
                }
            }
        }
        any
    }

    /// Records this scan's window maxima `v` (before any filling) as the newest carried scan,
    /// each at its window's centre angle (at most half a window from the return's own), and keeps
    /// at most `keep` scans.
    pub(crate) fn record(&mut self, v: &[f32], keep: usize) {
        let mut newest = self.spare.pop().unwrap_or_default();
        newest.origin = [0.0, 0.0];
        let n_w = v.len().min(self.cos.len());
        newest.xs.clear();
        newest.xs.resize(n_w, 0.0);
        newest.ys.clear();
        newest.ys.resize(n_w, 0.0);
        // branch-free compaction of the windows with a return
        let mut n = 0;
        for ((&r, &c), &s) in v[..n_w].iter().zip(&self.cos).zip(&self.sin) {
            newest.xs[n] = r * c;
            newest.ys[n] = r * s;
            n += usize::from(r > 0.0);
        }
        newest.xs.truncate(n);
        newest.ys.truncate(n);
        self.scans.insert(0, newest);
        while self.scans.len() > keep {
            if let Some(old) = self.scans.pop() {
                self.spare.push(old);
            }
        }
    }
}
