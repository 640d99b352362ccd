//! `FIND-LOW-FREQ` (paper §4.1): the window maxima (max filter) and their differences, and the
//! filled notches beyond the paper (interpretation 16).

use crate::FoliageParams;
use crate::bins::{NO_BIN, Scan};
use crate::bits::{select, wrap};
use crate::relax::relax_tolerance;

/// Output of [`find_low_freq`], one value per window.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LowFreq {
    /// `v(i)`, the largest range in window `i` (0 when it has no return).
    pub v: Vec<f32>,
    /// `dv(i) = v(i+1) − v(i)` (wrapped).
    pub dv: Vec<f32>,
    /// `nad2v(i) = |dv(i+1) − dv(i)| / v(i)`, 0 where `v(i) = 0`.
    pub nad2v: Vec<f32>,
}

/// `FIND-LOW-FREQ(A, R)` (paper §4.1, lines 1–13): max filter of the ranges over non-overlapping
/// angular windows of `α` (lines 1–5), forward difference `dv` (lines 6–7), and the normalised
/// absolute second difference `nad2v` (lines 8–12).
///
/// `n_windows` sets the length of the outputs; returns whose window is `≥ n_windows` are ignored.
/// Interpretation (4): differences wrap around the circle (`v(N_w) ≡ v(0)`).
pub fn find_low_freq(scan: Scan<'_>, n_windows: usize, out: &mut LowFreq) {
    max_filter(scan, n_windows, out);
    differences(out);
}

/// The max filter of `FIND-LOW-FREQ` (lines 1–5): `v` per window; `dv` and `nad2v` sized to
/// `n_windows` and zeroed, for [`differences`] to fill.
pub(crate) fn max_filter(scan: Scan<'_>, n_windows: usize, out: &mut LowFreq) {
    out.v.clear();
    out.v.resize(n_windows, 0.0);
    out.dv.clear();
    out.dv.resize(n_windows, 0.0);
    out.nad2v.clear();
    out.nad2v.resize(n_windows, 0.0);
    if n_windows == 0 {
        return;
    }
    // Max filter (lines 2–5). Consecutive returns mostly share a window: keep the running maximum
    // in a register and write it back when the window changes.
    let ne = scan.len();
    let (mut cur_w, mut cur_max) = (NO_BIN, 0.0f32);
    for (&range, &w) in scan.ranges[..ne].iter().zip(&scan.windows[..ne]) {
        if w != cur_w {
            if let Some(v) = out.v.get_mut(cur_w as usize)
                && cur_max > *v
            {
                *v = cur_max;
            }
            cur_w = w;
            cur_max = 0.0;
        }
        if range > cur_max {
            cur_max = range;
        }
    }
    if let Some(v) = out.v.get_mut(cur_w as usize)
        && cur_max > *v
    {
        *v = cur_max;
    }
}

/// `dv` and `nad2v` from `v` (`FIND-LOW-FREQ` lines 6–12), wrapped (interpretation 4).
pub(crate) fn differences(out: &mut LowFreq) {
    let n_windows = out.v.len().min(out.dv.len()).min(out.nad2v.len());
    for i in 0..n_windows {
        out.dv[i] = out.v[wrap(i, 1, n_windows)] - out.v[i];
    }
    for i in 0..n_windows {
        let v = out.v[i];
        out.nad2v[i] = if v == 0.0 {
            0.0
        } else {
            (out.dv[wrap(i, 1, n_windows)] - out.dv[i]).abs() / v
        };
    }
}

/// **Beyond the paper** (interpretation 16, [`FoliageParams::fill_notches`]): a window whose
/// maximum is nearer than both its neighbours', where the two windows on each side agree — `i-2`
/// with `i-1`, `i-1` with `i+1`, `i+1` with `i+2`, each pair within `RELAX-OBST`'s tolerance
/// without evidence ([`relax_tolerance`] at the nearer neighbour's range) — takes the nearer
/// neighbour's maximum: `v(i) ← min(v(i-1), v(i+1))` (values before filling, wrapped); `dv` and
/// `nad2v` are then recomputed. Foliage in front of a surface can only shorten a window's
/// maximum, never lengthen it; the paper's max filter removes the blades that share a window with
/// a return from the surface, and this removes the windows that only blades reached. The
/// neighbours must agree, as windows on one surface do, because in a dense grass band every
/// window's maximum lies near the band's far edge, and filling the dips there made the band as
/// smooth as a wall: in 200 scans of the synthetic ±30 % band of the tests, filling every notch
/// gave 95 false alarms, comparing `i±1` only 23 (both measured with throwaway variants of
/// this function), comparing all four pairs 1 (0 without filling; the test allows 1). A filled
/// window holds no return at its new maximum, so it never yields a candidate itself; it only
/// stops blocking its neighbours. Returns the number of windows filled.
pub fn fill_notches(params: &FoliageParams, low: &mut LowFreq) -> usize {
    let filled = fill_notches_in(params, &mut low.v);
    if filled > 0 {
        differences(low);
    }
    filled
}

/// The filling of [`fill_notches`] on the window maxima alone (the differences are not touched).
pub(crate) fn fill_notches_in(params: &FoliageParams, v: &mut [f32]) -> usize {
    let n = v.len();
    if n < 3 {
        return 0;
    }
    // a rolling window of the raw maxima v(i-2) … v(i+2); past the end it wraps onto the first
    // two windows' raw values, saved before they can be filled
    let (first, second) = (v[0], v[1]);
    let (mut prev2, mut prev, mut cur, mut next) = (v[n - 2], v[n - 1], first, second);
    let mut filled = 0;
    for i in 0..n {
        let next2 = match i + 2 {
            k if k < n => v[k],
            k if k == n => first,
            _ => second,
        };
        let floor = prev.min(next);
        // (branch-free: in grass, notches come and go at random)
        let tol = relax_tolerance(params, floor, 0.0, 0.0);
        let agree = |a: f32, b: f32| (a - b).abs() < tol;
        let fill = (floor > cur) & agree(prev, next) & agree(prev2, prev) & agree(next, next2);
        v[i] = select(fill, floor, cur);
        filled += usize::from(fill);
        (prev2, prev, cur, next) = (prev, cur, next, next2);
    }
    filled
}
