//! `UPDATE-AND-ARCHIVE` (paper §6): the alarm and the nearest obstacle per sector `R_s`, and the
//! evidence learnt fast and forgotten slowly.

use crate::FoliageParams;
use crate::bins::{NO_BIN, Scan};
use crate::bits::select;
use crate::history::History;

/// One window's evidence update (`UPDATE-AND-ARCHIVE` lines 12–18): returns the new `C_{k-1}`
/// from this scan's `C_k` and the previous `C_{k-1}`.
///
/// * `C_k > C_{k-1}`: `C_k + C_{k-1}` — learn fast;
/// * otherwise `C_{k-1} − ⌈(C_k + C_{k-1}) / 2⌉` — forget slowly (interpretation 10: the bracket is
///   a ceiling, so the evidence reaches 0 after a finite number of scans);
/// * never below 0.
pub fn evidence_step(c_k: f32, c_prev1: f32) -> f32 {
    // (Branch-free: windows with and without evidence alternate along the circle. With no
    // evidence now or before, both branches give 0.)
    let learn = c_k + c_prev1;
    // Interpretation (10): the bracket of line 16 is a ceiling, so old evidence expires.
    let forget = c_prev1 - ceil_exact((c_k + c_prev1) / 2.0);
    let forget = select(forget > 0.0, forget, 0.0);
    select(c_k > c_prev1, learn, forget)
}

/// `x.ceil()` without the libm call and without a branch (a call the compiler may not skip
/// would run for every window): exact for every `f32`. From `2²³` up every `f32` is an integer,
/// so only smaller magnitudes are rounded; NaN and ±∞ are returned as they are.
#[inline]
fn ceil_exact(x: f32) -> f32 {
    let t = (x as i32) as f32; // truncation towards 0 (exact for |x| < 2²³)
    // t + 1 above a positive fraction; the sign of x kept, so that ceil(-0.5) is -0
    let c = (t + f32::from(u8::from(t < x))).copysign(x);
    select(x.abs() < 8_388_608.0, c, x)
}

/// `UPDATE-AND-ARCHIVE(A, R_c)` (paper §6).
///
/// * `C_k(i) = K3` in every window holding a candidate of `rc` (lines 4–7; from `R_c`, not `R_f`, so
///   pruning lowers the alarms without forgetting the obstacle — interpretation 9); `c_k` is resized
///   to the window count of `history`.
/// * `nearest[s]` = the smallest `R_f` range in sector `s`, `f32::INFINITY` if none (lines 8–9, from
///   the pruned `rf`).
/// * returns `alarm` = any obstacle left in `rf` (line 10, interpretation 9).
/// * archives the evidence: `C_{k-2} ← C_{k-1}`, then `C_{k-1} ← evidence_step(C_k, C_{k-1})`
///   (lines 11–18);
///   and the farthest `R_f` range per window into `history.obst_prev` (interpretation 15).
pub fn update_and_archive(
    params: &FoliageParams,
    scan: Scan<'_>,
    rc: &[f32],
    rf: &[f32],
    history: &mut History,
    c_k: &mut Vec<f32>,
    nearest: &mut [f32],
) -> bool {
    let n_w = history.n_windows();
    c_k.clear();
    c_k.resize(n_w, 0.0);
    nearest.fill(f32::INFINITY);
    let mut alarm = false;
    let ne = scan.len().min(rc.len());
    // Interpretation (9, DESIGN): C_k from R_c; alarm and R_s from the pruned R_f. Consecutive
    // returns mostly share a window and a sector: the current run's flag and minimum stay in
    // registers.
    let (mut cur_w, mut cur_cand) = (NO_BIN, false);
    // The running minimum is kept on integer keys, `bits(R_f) − 1` (wrapping): the bits of
    // non-negative floats are ordered like the floats, and a non-obstacle (0.0) wraps to the
    // largest key, so no select is needed per return (the compiler turns selects into branches,
    // mispredicted where obstacles and foliage interleave).
    let key_to_range = |key: u32| {
        let bits = key.wrapping_add(1);
        if bits > 0 && bits < f32::INFINITY.to_bits() {
            f32::from_bits(bits)
        } else {
            f32::INFINITY
        }
    };
    let (mut cur_s, mut cur_min) = (NO_BIN, u32::MAX);
    // what `hold_obstacles` holds next scan: the farthest R_f per window (max with 0 for
    // non-obstacles, so no branch)
    history.obst_prev[..n_w].fill(0.0);
    let per_return = rc[..ne]
        .iter()
        .zip(&scan.windows[..ne])
        .zip(&scan.sectors[..ne])
        .enumerate();
    for (r, ((&c, &w), &sector)) in per_return {
        if w != cur_w {
            if let Some(ck) = c_k.get_mut(cur_w as usize) {
                *ck = if cur_cand { params.k3 } else { *ck };
            }
            (cur_w, cur_cand) = (w, false);
        }
        cur_cand |= c > 0.0;
        if sector != cur_s {
            if let Some(s) = nearest.get_mut(cur_s as usize) {
                *s = s.min(key_to_range(cur_min));
            }
            (cur_s, cur_min) = (sector, u32::MAX);
        }
        let f = rf.get(r).copied().unwrap_or(0.0);
        if let Some(o) = history.obst_prev.get_mut(w as usize) {
            *o = o.max(f);
        }
        let obstacle = f > 0.0;
        alarm |= obstacle;
        cur_min = cur_min.min(f.to_bits().wrapping_sub(1));
    }
    if cur_cand && let Some(ck) = c_k.get_mut(cur_w as usize) {
        *ck = params.k3;
    }
    if let Some(s) = nearest.get_mut(cur_s as usize) {
        *s = s.min(key_to_range(cur_min));
    }
    let History {
        c_prev1, c_prev2, ..
    } = history;
    c_prev2[..n_w].copy_from_slice(&c_prev1[..n_w]);
    for (c1, &ck) in c_prev1[..n_w].iter_mut().zip(c_k.iter()) {
        *c1 = evidence_step(ck, *c1);
    }
    alarm
}
