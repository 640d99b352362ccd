//! `GET-OBST-CANDIDATES` (paper §4.2): thresholds carried over and raised, and the window maxima
//! in low-frequency regions as obstacle candidates `R_c`.

use crate::FoliageParams;
use crate::bins::Scan;
use crate::bits::{keep_if, wrap};
use crate::history::History;
use crate::low_freq::LowFreq;
use crate::relax::relax_tolerance;

/// `T_k(i) = K1 + max(T_{k-1}(i), T_{k-2}(i)) / 2` (`GET-OBST-CANDIDATES` lines 2–3,
/// interpretation 1).
// Interpretation (1, DESIGN): thresholds carry over from the two previous scans.
pub fn carry_threshold(k1: f32, t_prev1: f32, t_prev2: f32) -> f32 {
    k1 + t_prev1.max(t_prev2) / 2.0
}

/// Reusable scratch of [`get_obst_candidates`] (per window). Allocates only when the window count
/// grows.
#[derive(Debug, Clone, Default)]
pub struct WindowWork {
    pub(crate) ties: Vec<u32>,
    pub(crate) pass: Vec<bool>,
}

impl WindowWork {
    /// Scratch pre-sized for `n_windows` windows.
    pub fn with_windows(n_windows: usize) -> Self {
        Self {
            ties: Vec::with_capacity(n_windows),
            pass: Vec::with_capacity(n_windows),
        }
    }
}

/// `GET-OBST-CANDIDATES(A, R, v, nad2v)` (paper §4.2). Writes the thresholds `T_k` of this scan into
/// `t_k` (one per window of `low`) and the candidates into `rc` (`R_c(r) = R(r)` for a candidate, 0
/// otherwise; resized to `Ne`). Returns the number of candidates.
///
/// * `T_k(i) = K1 + max(T_{k-1}(i), T_{k-2}(i)) / 2` (lines 2–3, interpretation 1).
/// * A return `r` of window `i` becomes a candidate when it is the window maximum
///   (`R(r) = v(i) > 0`, fast rejection of line 9) and `nad2v(j) < T_k(j)` for all `j ∈ i-2 … i+2`
///   (update condition of line 11, interpretation 3). (In [`Classifier::classify_moved`](crate::Classifier::classify_moved) with
///   carried scans, interpretation 17, `v` holds the merged maxima and the tie is with the scan's
///   own, which must agree with the merged one.)
/// * Each new candidate raises `T_k(i±1)` by `δ/2` and `T_k(i±2)` by `δ/4` (lines 13–15,
///   interpretation 2).
///
/// **The "repeat until done" loop (lines 4–18) in one pass.** Thresholds only grow, so the paper's
/// repeated passes reach the least fixed point, and that fixed point is the set of windows that
/// pass with the thresholds at entry: a window `m` with `nad2v(m) ≥ T_k(m)` blocks every window
/// within 2 of it, and its threshold could only be raised by a candidate within 2 of `m` — whose
/// own condition requires `nad2v(m) < T_k(m)`, so the first such raise can never happen. Hence one
/// linear pass over the windows (a rolling count of blocking windows in `i-2 … i+2`), then the
/// raises, gives exactly the paper's candidates and final thresholds, in `O(Ne + N_w)`. (The unit
/// tests check this against a literal transcription of the paper's loop.)
pub fn get_obst_candidates(
    params: &FoliageParams,
    scan: Scan<'_>,
    low: &LowFreq,
    history: &History,
    t_k: &mut Vec<f32>,
    rc: &mut Vec<f32>,
    work: &mut WindowWork,
) -> usize {
    candidates_in(params, scan, &low.v, low, history, t_k, rc, work)
}

/// [`get_obst_candidates`] with the window maxima the returns are matched against (`v_own`)
/// apart from the `v` of `low` the differences came from (interpretation 17): a window passes
/// only where `v(i) − v_own(i)` is within `RELAX-OBST`'s tolerance without evidence. With
/// `v_own = low.v` that always holds and this is the paper's routine.
#[allow(clippy::too_many_arguments)]
pub(crate) fn candidates_in(
    params: &FoliageParams,
    scan: Scan<'_>,
    v_own: &[f32],
    low: &LowFreq,
    history: &History,
    t_k: &mut Vec<f32>,
    rc: &mut Vec<f32>,
    work: &mut WindowWork,
) -> usize {
    let n_w = low.v.len().min(low.nad2v.len()).min(v_own.len());
    let ne = scan.len();
    t_k.clear();
    let (t_prev1, t_prev2) = (&history.t_prev1, &history.t_prev2);
    if t_prev1.len() >= n_w && t_prev2.len() >= n_w {
        let carried = t_prev1[..n_w].iter().zip(&t_prev2[..n_w]);
        t_k.extend(carried.map(|(&t1, &t2)| carry_threshold(params.k1, t1, t2)));
    } else {
        for i in 0..n_w {
            let t1 = t_prev1.get(i).copied().unwrap_or(0.0);
            let t2 = t_prev2.get(i).copied().unwrap_or(0.0);
            t_k.push(carry_threshold(params.k1, t1, t2));
        }
    }
    rc.clear();
    if n_w == 0 {
        rc.resize(ne, 0.0);
        return 0;
    }
    let WindowWork { ties, pass } = work;
    ties.clear();
    ties.resize(n_w, 0);
    pass.clear();
    pass.resize(n_w, false);
    let v = &v_own[..n_w];
    let v_smooth = &low.v[..n_w];

    // Fast rejection (line 9): only non-zero returns at their window's maximum can qualify; `rc`
    // keeps them for now, and they are counted per window (ties included). Consecutive returns
    // mostly share a window, so the count of the current run stays in a register.
    let (mut cur_w, mut cur_n) = (usize::MAX, 0u32);
    let maxima = scan.ranges[..ne].iter().zip(&scan.windows[..ne]);
    rc.extend(maxima.map(|(&range, &w)| {
        let w = w as usize;
        if w != cur_w {
            if let Some(t) = ties.get_mut(cur_w) {
                *t += cur_n;
            }
            (cur_w, cur_n) = (w, 0);
        }
        let at_max = range > 0.0 && range == v.get(w).copied().unwrap_or(f32::NAN);
        cur_n += u32::from(at_max);
        keep_if(range, at_max)
    }));
    if let Some(t) = ties.get_mut(cur_w) {
        *t += cur_n;
    }

    // Update condition (line 11). Interpretation (3): nad2v(j) < T_k(j) for each j in i-2..=i+2,
    // evaluated on the thresholds at entry (see the fixed-point argument above).
    // A NaN nad2v (overflowing ranges) blocks, like any value not below the threshold.
    let below = |j: usize| low.nad2v[j] < t_k[j];
    let blocked = |j: usize| usize::from(!below(j));
    let mut n_blocked: usize = (-2..=2).map(|d| blocked(wrap(0, d, n_w))).sum();
    for i in 0..n_w {
        let own = v_smooth[i] - v[i] <= relax_tolerance(params, v_smooth[i], 0.0, 0.0);
        pass[i] = ties[i] > 0 && n_blocked == 0 && own;
        n_blocked -= blocked(wrap(i, -2, n_w));
        n_blocked += blocked(wrap(i, 3, n_w));
    }
    // Interpretation (15, beyond the paper): a window at or beside one that held a confirmed
    // obstacle last scan passes when its maximum is within RELAX-OBST's tolerance of that
    // obstacle's range (the paper's locality in time: "located at around φ at time t + T").
    if params.hold_obstacles && history.obst_prev.len() >= n_w {
        // (from the few held windows to their neighbours, not from every window)
        for (j, &held) in history.obst_prev[..n_w].iter().enumerate() {
            if held <= 0.0 {
                continue;
            }
            for d in [-1, 0, 1] {
                let i = wrap(j, d, n_w);
                let c1 = history.c_prev1.get(i).copied().unwrap_or(0.0);
                let c2 = history.c_prev2.get(i).copied().unwrap_or(0.0);
                let near = (v[i] - held).abs() < relax_tolerance(params, v[i], c1, c2);
                // (branch-free: whether a neighbour already passes is not predictable)
                pass[i] |= (ties[i] > 0) & near;
            }
        }
    }
    // Interpretation (2, DESIGN): δ/2 at i±1, δ/4 at i±2, per candidate return, own window not raised.
    let (half, quarter) = (params.delta / 2.0, params.delta / 4.0);
    for i in 0..n_w {
        if pass[i] {
            let k = ties[i] as f32;
            for (d, raise) in [(-2, quarter), (-1, half), (1, half), (2, quarter)] {
                t_k[wrap(i, d, n_w)] += raise * k;
            }
        }
    }

    // R_c: the maxima of the windows that pass (branch-free: they interleave at random in grass)
    let mut count = 0;
    for (slot, &w) in rc.iter_mut().zip(&scan.windows[..ne]) {
        let ok = pass.get(w as usize).copied().unwrap_or(false);
        count += usize::from(ok & (*slot > 0.0));
        *slot = keep_if(*slot, ok);
    }
    count
}
