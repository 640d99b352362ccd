//! `RELAX-OBST` (paper §4.3): candidates grown to their smooth neighbours within the range error
//! model's tolerance.

use crate::FoliageParams;
use crate::bins::{NO_BIN, Scan};
use crate::bits::{select, wrap};
use crate::history::History;

/// Tolerance of `RELAX-OBST` (lines 5–7): `T = C · (a·R + b)` with `C = 1 + K2 · (C_{k-1} + C_{k-2})`
/// and `a·R + b` the range error model of Eq. 1.
// Interpretation (5, 11): evaluated at the non-candidate's range and window; b in metres.
pub fn relax_tolerance(params: &FoliageParams, range: f32, c_prev1: f32, c_prev2: f32) -> f32 {
    let c = 1.0 + params.k2 * (c_prev1 + c_prev2);
    c * (params.range_error_a * range + params.range_error_b_m)
}

/// Reusable scratch of [`relax_obst`] (per return). Allocates only when the scan grows.
#[derive(Debug, Clone, Default)]
pub struct RelaxWork {
    pub(crate) stack: Vec<u32>,
    pub(crate) can_join: Vec<u8>,
    pub(crate) tol: Vec<f32>,
}

/// Neighbour offsets of `RELAX-OBST`; bit `k` of a return's `can_join` mask is offset `OFFSETS[k]`.
const OFFSETS: [isize; 4] = [-2, -1, 1, 2];

/// The `can_join` mask of [`relax_obst`]: bit `k` set when `|range − near[k]| < tol` (0 for a
/// NaN `tol`).
#[inline(always)]
fn can_join_mask(range: f32, tol: f32, near: [f32; 4]) -> u8 {
    let mut m = 0u8;
    for (k, n) in near.into_iter().enumerate() {
        // Interpretation (5): strict comparison, tolerance of the joining return r.
        m |= u8::from((range - n).abs() < tol) << k;
    }
    m
}

/// `RELAX-OBST(A, R, R_c)` (paper §4.3): a non-candidate return `r` with a range becomes a candidate
/// when one of its neighbours `r±1`, `r±2` (slice order, wrapped) is a candidate and
/// `|R(r) − R(r+j)| < T`, [`relax_tolerance`] evaluated at `R(r)` and at the evidence of `r`'s window
/// (lines 8–9, interpretation 5).
///
/// The range test does not depend on the candidates, so it is done first for every return and its 4
/// neighbours (a 4-bit mask, a straight pass). The "repeat until done" loop (lines 2–10) is then one
/// forward and one backward sweep, which follow smooth surfaces, and a worklist that finishes the
/// closure from the few candidates whose neighbours the sweeps could not revisit. Each return enters
/// the worklist at most once: `O(Ne)` in all, and the same fixed point as the paper's passes (the
/// tests check it against a literal transcription). Returns the number of returns added to `rc`.
pub fn relax_obst(
    params: &FoliageParams,
    scan: Scan<'_>,
    history: &History,
    rc: &mut [f32],
    work: &mut RelaxWork,
) -> usize {
    let ne = scan.len().min(rc.len());
    let RelaxWork {
        stack,
        can_join,
        tol,
    } = work;
    stack.clear();
    can_join.clear();
    if ne == 0 {
        return 0;
    }
    let (ranges, windows, rc) = (&scan.ranges[..ne], &scan.windows[..ne], &mut rc[..ne]);
    let n_h = history.n_windows();
    let (c_prev1, c_prev2) = (&history.c_prev1[..n_h], &history.c_prev2[..n_h]);

    // The tolerance of each return as the joining one (interpretation 5); NaN, which compares
    // below nothing, for a return without range or window (it never joins).
    tol.clear();
    tol.extend(ranges.iter().zip(windows).map(|(&range, &w)| {
        let (c1, c2) = match (c_prev1.get(w as usize), c_prev2.get(w as usize)) {
            (Some(&c1), Some(&c2)) => (c1, c2),
            _ => (0.0, 0.0),
        };
        let valid = (range > 0.0) & (w != NO_BIN);
        select(valid, relax_tolerance(params, range, c1, c2), f32::NAN)
    }));
    // can_join[r] bit k: r, if it has a range, would join a candidate at r + OFFSETS[k].
    can_join.resize(ne, 0);
    if ne >= 5 {
        // Away from the ends of the slice the neighbours need no wrapping: five shifted slices
        // in step, which the compiler vectorises.
        let m = ne - 4;
        let near = (
            &ranges[..m],
            &ranges[1..m + 1],
            &ranges[3..m + 3],
            &ranges[4..],
        );
        let inner = can_join[2..m + 2]
            .iter_mut()
            .zip(&ranges[2..m + 2])
            .zip(&tol[2..m + 2])
            .zip(near.0.iter().zip(near.1).zip(near.2.iter().zip(near.3)));
        for (((mask, &range), &t), ((&a, &b), (&c, &d))) in inner {
            *mask = can_join_mask(range, t, [a, b, c, d]);
        }
    }
    let ends = (0..ne.min(2)).chain(ne.saturating_sub(2).max(ne.min(2))..ne);
    for r in ends {
        let near = OFFSETS.map(|d| ranges[wrap(r, d, ne)]);
        can_join[r] = can_join_mask(ranges[r], tol[r], near);
    }

    // The worklist is a stack of exactly Ne slots: a return is pushed at most once, so `top` never
    // passes Ne. Pushes are unconditional writes with a conditional `top += 1`.
    stack.resize(ne, 0);
    let mut top = 0;
    let mut added = 0;
    let bit = |m: u8, k: usize| (m >> k) & 1 != 0;
    if ne < 8 {
        // Tiny scan: every candidate seeds the worklist.
        for (r, &c) in rc.iter().enumerate() {
            stack[top] = r as u32; // top ≤ r < ne
            top += usize::from(c > 0.0);
        }
    } else {
        // Two sweeps do most of the work along smooth surfaces: forward (joins from r-1, r-2),
        // then backward (joins from r+1, r+2). Afterwards every candidate has had its four
        // neighbours examined after it became a candidate, except those added by the backward
        // sweep (their forward neighbours were visited before) and those the forward sweep added
        // at the last two places (their wrapped forward neighbours were visited first): these
        // seed the worklist, which completes the closure exactly.
        let (mut p2, mut p1) = (rc[ne - 2] > 0.0, rc[ne - 1] > 0.0);
        for r in 0..ne {
            let (was, m) = (rc[r] > 0.0, can_join[r]);
            let join = !was & ((p1 & bit(m, 1)) | (p2 & bit(m, 0)));
            // (branch-free: joins and foliage interleave at random in grass)
            rc[r] = select(join, ranges[r], rc[r]);
            added += usize::from(join);
            (p2, p1) = (p1, was | join);
        }
        for r in [ne - 2, ne - 1] {
            stack[top] = r as u32;
            top += usize::from(rc[r] > 0.0);
        }
        let (mut n2, mut n1) = (rc[1] > 0.0, rc[0] > 0.0);
        for r in (0..ne).rev() {
            let (was, m) = (rc[r] > 0.0, can_join[r]);
            let join = !was & ((n1 & bit(m, 2)) | (n2 & bit(m, 3)));
            rc[r] = select(join, ranges[r], rc[r]);
            added += usize::from(join);
            if let Some(slot) = stack.get_mut(top) {
                *slot = r as u32;
            }
            top += usize::from(join);
            (n2, n1) = (n1, was | join);
        }
    }
    while top > 0 {
        top -= 1;
        let c = stack[top] as usize;
        for (k, d) in OFFSETS.into_iter().enumerate() {
            let r = if c >= 2 && c + 2 < ne {
                (c as isize + d) as usize
            } else {
                wrap(c, d, ne)
            };
            // r sees c at offset -d, i.e. bit 3 - k of its mask.
            let join = (rc[r] == 0.0) & bit(can_join[r], 3 - k);
            rc[r] = select(join, ranges[r], rc[r]);
            if let Some(slot) = stack.get_mut(top) {
                *slot = r as u32;
            }
            top += usize::from(join);
            added += usize::from(join);
        }
    }
    stack.clear();
    added
}
