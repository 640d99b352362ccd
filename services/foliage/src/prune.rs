//! The pruning of paper §5: `REMOVE-NEW-OBST`, `REMOVE-THIN-OBST` and `CROP-RANGE`, in the paper's
//! order (interpretation 12).

use crate::FoliageParams;
use crate::bins::{NO_BIN, Scan};
use crate::bits::{keep_if, wrap};
use crate::history::History;

/// `REMOVE-NEW-OBST(A, R_c)` (paper §5, lines 1–7): `R_f(r) = R_c(r)` when the evidence of the last
/// two scans is non-zero somewhere in windows `i-2 … i+2` around the return's window `i`
/// ([`History::seen_near`], interpretation 6), else 0. An obstacle must have been seen in one of the
/// last two scans. `rf` is resized to `Ne`.
pub fn remove_new_obst(scan: Scan<'_>, history: &History, rc: &[f32], rf: &mut Vec<f32>) {
    let ne = scan.len().min(rc.len());
    rf.clear();
    rf.resize(ne, 0.0);
    // Only candidates need the answer, and consecutive candidates mostly share a window:
    // remember the last one (in grass, candidates are rare and the branch is rarely taken).
    // Interpretation (6): "seen" = non-zero C_{k-1} or C_{k-2} in windows i-2..=i+2.
    let mut last = (NO_BIN, false);
    for ((f, &c), &w) in rf.iter_mut().zip(&rc[..ne]).zip(&scan.windows[..ne]) {
        let candidate = c > 0.0;
        if candidate && last.0 != w {
            last = (w, w != NO_BIN && history.seen_near(w as usize));
        }
        let keep = last.1 & candidate;
        *f = if keep { c } else { 0.0 };
    }
}

/// `REMOVE-THIN-OBST(R_f, W_s, O_s)` (paper §5): with `d = ⌊W_s/2⌋`, an obstacle return is dropped
/// when fewer than `O_s` of the returns `r-d … r+d` (slice order, wrapped, itself included) are
/// obstacles in the copy of `R_f` taken on entry (interpretation 7). Sliding count, `O(Ne)`.
/// `copy` is scratch. Returns the number of returns dropped.
pub fn remove_thin_obst(rf: &mut [f32], w_s: usize, o_s: usize, copy: &mut Vec<f32>) -> usize {
    let ne = rf.len();
    if ne == 0 {
        return 0;
    }
    copy.clear();
    copy.extend_from_slice(rf);
    let d = w_s / 2;
    let span = 2 * d + 1;
    // Interpretation (7): the count includes the return itself and reads the entry copy.
    let is = |x: f32| usize::from(x > 0.0);
    let mut dropped = 0;
    if span >= ne {
        let total: usize = copy.iter().map(|&x| is(x)).sum();
        if total < o_s {
            for x in rf.iter_mut().filter(|x| **x > 0.0) {
                *x = 0.0;
                dropped += 1;
            }
        }
        return dropped;
    }
    let di = d as isize;
    let mut count: usize = (-di..=di).map(|k| is(copy[wrap(0, k, ne)])).sum();
    for r in 0..ne {
        // (Branch-free: obstacle and foliage returns interleave at random.)
        let drop = (copy[r] > 0.0) & (count < o_s);
        rf[r] = if drop { 0.0 } else { rf[r] };
        dropped += usize::from(drop);
        // Slide the window from r to r+1.
        count -= is(copy[wrap(r, -di, ne)]);
        count += is(copy[wrap(r, di + 1, ne)]);
    }
    dropped
}

/// `CROP-RANGE(R_f, d_min, d_max)` (paper §5): drops obstacle returns outside `[d_min, d_max]`
/// (interpretation 8), where the error model of Eq. 1 holds. Returns the number dropped.
pub fn crop_range(rf: &mut [f32], d_min: f32, d_max: f32) -> usize {
    let mut dropped = 0;
    for x in rf.iter_mut() {
        // Interpretation (8): the closed interval [d_min, d_max] is kept.
        let drop = (*x > 0.0) & !(*x >= d_min && *x <= d_max);
        *x = if drop { 0.0 } else { *x };
        dropped += usize::from(drop);
    }
    dropped
}

/// [`History::seen_near`] for every window `0 … N_w-1` into `seen` (a rolling OR over the five
/// windows), so that [`Classifier::classify`](crate::Classifier::classify)'s `REMOVE-NEW-OBST` looks the answer up per return.
pub(crate) fn seen_near_windows(history: &History, seen: &mut Vec<bool>) {
    let n = history.n_windows();
    seen.clear();
    if n == 0 {
        return;
    }
    // Interpretation (6): "seen" = non-zero C_{k-1} or C_{k-2} in windows i-2..=i+2.
    let nz = |j: usize| (history.c_prev1[j] > 0.0) | (history.c_prev2[j] > 0.0);
    let mut near = [-2, -1, 0, 1, 2].map(|d| nz(wrap(0, d, n)));
    seen.extend((0..n).map(|i| {
        let any = near.iter().fold(false, |a, &b| a | b);
        near = [near[1], near[2], near[3], near[4], nz(wrap(i, 3, n))];
        any
    }));
}

/// `REMOVE-THIN-OBST` then `CROP-RANGE` in one pass for [`Classifier::classify`](crate::Classifier::classify): `rf` from
/// `new`, the output of `REMOVE-NEW-OBST` (`0` or a positive range per return), with the results
/// of [`remove_thin_obst`] and [`crop_range`] run in that order (interpretations 7, 8, 12).
pub(crate) fn thin_and_crop(params: &FoliageParams, new: &[f32], rf: &mut Vec<f32>) {
    let ne = new.len();
    rf.clear();
    rf.resize(ne, 0.0);
    if ne == 0 {
        return;
    }
    let (o_s, d_min, d_max) = (params.thin_min, params.d_min_m, params.d_max_m);
    let is = |x: f32| usize::from(x > 0.0);
    // A return of `new` is 0 or a positive range: it survives both routines when the count of
    // obstacles around it reaches O_s and it lies within [d_min, d_max]; 0 stays 0.
    let keep = |x: f32, count: usize| keep_if(x, (count >= o_s) & (x >= d_min) & (x <= d_max));
    let d = params.thin_window / 2;
    if 2 * d + 1 >= ne {
        // the whole scan is the window
        let total: usize = new.iter().map(|&x| is(x)).sum();
        for (f, &x) in rf.iter_mut().zip(new) {
            *f = keep(x, total);
        }
        return;
    }
    let mut count: usize = (0..=2 * d)
        .map(|k| is(new[wrap(0, k as isize - d as isize, ne)]))
        .sum();
    for (r, f) in rf.iter_mut().enumerate() {
        *f = keep(new[r], count);
        // Slide the window from r to r+1 (wrapped; d < ne / 2).
        let leaving = if r >= d { r - d } else { r + ne - d };
        let entering = if r + d + 1 < ne {
            r + d + 1
        } else {
            r + d + 1 - ne
        };
        count = count - is(new[leaving]) + is(new[entering]);
    }
}
