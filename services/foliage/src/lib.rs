//! # mimnav-foliage — real-time foliage discrimination for a planar ladar scan
//!
//! A std-only implementation of the classifier of *"Foliage discrimination using a rotating
//! ladar"* (`seeds/foliage-discrimination-rotating-ladar.txt`, the Urbie robot paper), as restated in
//! `DESIGN.md` §8. Every return of a planar scan is classified as foliage or not; the returns that
//! are not foliage and survive the pruning are *obstacles*, they raise the `alarm` flag and give the
//! nearest obstacle range per sector (`R_s`).
//!
//! The paper's routine `CLASSIFY(A, R)` is the pipeline run by [`Classifier::classify`]:
//!
//! | paper routine            | function here             | output                                   |
//! |--------------------------|---------------------------|------------------------------------------|
//! | `FIND-LOW-FREQ`          | [`find_low_freq`]         | `v`, `dv`, `nad2v` per window            |
//! | `GET-OBST-CANDIDATES`    | [`get_obst_candidates`]   | `R_c` (candidates), thresholds `T_k`     |
//! | `RELAX-OBST`             | [`relax_obst`]            | `R_c` grown to smooth neighbours         |
//! | `REMOVE-NEW-OBST`        | [`remove_new_obst`]       | `R_f` ⊆ `R_c` (seen in the last 2 scans) |
//! | `REMOVE-THIN-OBST`       | [`remove_thin_obst`]      | `R_f` without isolated hits              |
//! | `CROP-RANGE`             | [`crop_range`]            | `R_f` within `[d_min, d_max]`            |
//! | `UPDATE-AND-ARCHIVE`     | [`update_and_archive`]    | `alarm`, `R_s`, evidence `C_k` archived  |
//!
//! The temporal state (thresholds `T_{k-1}`, `T_{k-2}` and evidence `C_{k-1}`, `C_{k-2}`, one value
//! per angular window) lives in [`History`]. Windows are defined by absolute angle, so they are the
//! same from one scan to the next: window `i = ⌊(angle + π) / α⌋`, `n_windows = ⌈2π / α⌉`.
//!
//! ## Input
//!
//! A scan is two slices, `angles` (radians, nominally in `(-π, π]`) and `ranges` (metres,
//! `0` = no return), in firing order. The order of the angles does not matter for the windows (each
//! return is binned by its own angle), so a clockwise sweep whose angles decrease is handled as well
//! as an increasing one. The return neighbourhoods `r-2 … r+2` (`RELAX-OBST`) and the `W_s` window
//! (`REMOVE-THIN-OBST`) follow the order in the slice and wrap around its ends.
//!
//! ## Interpretations
//!
//! The paper's pseudo-code is OCR-damaged. Where `DESIGN.md` marks an interpretation it is followed;
//! the other readings chosen here are marked `// Interpretation:` next to the code. All of them:
//!
//! 1. **Threshold carry-over** (DESIGN): `T_k(i) = K1 + max(T_{k-1}(i), T_{k-2}(i)) / 2`
//!    (`GET-OBST-CANDIDATES` lines 2–3). The archived `T_k` is the one *after* the raises made by this
//!    scan's candidates, so windows near obstacles keep a higher threshold. The paper does not give
//!    the initial thresholds; it says the robot starts in free space (§3), so [`Classifier::new`] and
//!    [`Classifier::reset`] start from the free-space fixed point `T_{k-1} = T_{k-2} = 2·K1` of the
//!    carry-over. Starting from zero would halve the first scan's threshold (`K1`): partly hidden or
//!    noisy obstacles would then often yield no candidate on the first scan and, lacking evidence,
//!    could not be confirmed on the second.
//! 2. **Threshold raise** (DESIGN): a new candidate in window `i` raises `T_k(i±1)` by `δ/2` and
//!    `T_k(i±2)` by `δ/4` (lines 13–15); its own window is not raised. The raise is applied once per
//!    candidate *return*, as in the paper's per-return loop, so tied window maxima raise it more.
//! 3. **Candidate condition** (DESIGN): return `r` in window `i` becomes a candidate when
//!    `R(r) = v(i) > 0` and `nad2v(j) < T_k(j)` for every `j ∈ i-2 … i+2` (each window against its own
//!    threshold; the paper's "`nad2v` is smaller than all the thresholds within a vicinity of 2",
//!    read element by element, which keeps its "together with its four closest neighbours, it spans
//!    a low frequency region"). All returns tied at the window maximum qualify. A consequence of
//!    this reading: with a raise neighbourhood (`±2`) no wider than the test neighbourhood (`±2`), a
//!    raise can never unblock a window within the same scan (the raised window's `nad2v` was
//!    already below its threshold), so the paper's "repeat until nothing changes" loop reaches its
//!    fixed point after one pass, which is how it is computed (proof in [`get_obst_candidates`],
//!    checked against a literal transcription of the loop in the tests); the raises act on the
//!    following scans through the carry-over.
//! 4. **Wrap-around**: the paper loops `r = 3 … Ne-2` and `i = 1 … N_w-2`; here every window
//!    neighbourhood (`i±1`, `i±2`, `dv`, `nad2v`) wraps around the circle and every return
//!    neighbourhood wraps around the slice, so a full revolution has no seam at ±π. (For a partial
//!    scan, e.g. a 270° SICK, the two ends of the slice become neighbours; `RELAX-OBST` only joins
//!    them if their ranges agree, and the empty windows of the blind sector have `nad2v = 0`.)
//! 5. **RELAX-OBST tolerance**: `T = C · (a·R(r) + b)` with `C = 1 + K2 · (C_{k-1}(i) + C_{k-2}(i))`,
//!    where `r` is the non-candidate being evaluated and `i` its window (line 5–7); it is compared,
//!    strictly, with `|R(r) − R(r+j)|` for a candidate neighbour `r+j`, `j ∈ {±1, ±2}`. A return
//!    with no range never becomes a candidate. Run as a worklist; same fixed point as the passes.
//! 6. **REMOVE-NEW-OBST neighbourhood**: a candidate in window `i` is kept when `C_{k-1}(j) > 0` or
//!    `C_{k-2}(j) > 0` for some `j ∈ i-2 … i+2` (the OCR shows a product over five indices around
//!    the return; the windows `i±2` match the neighbourhood of `GET-OBST-CANDIDATES`).
//! 7. **REMOVE-THIN-OBST count**: a return survives when at least `O_s` of the `2⌊W_s/2⌋+1` returns
//!    centred on it — itself included, as in the paper's `k = -d … d` loop — are obstacles, counted
//!    on the copy taken before this routine (no cascade). If the scan is shorter than that window,
//!    the whole scan is the window.
//! 8. **CROP-RANGE** keeps the closed interval `[d_min, d_max]`.
//! 9. **UPDATE-AND-ARCHIVE** (DESIGN): `C_k(i) = K3` where window `i` holds a candidate of `R_c`
//!    (not the pruned `R_f`); `alarm` and `R_s` come from the pruned `R_f`. An empty sector reports
//!    `f32::INFINITY` (the paper used 0).
//! 10. **Forget rounding**: the bracket in line 16, `C_{k-1} − [(C_k + C_{k-1}) / 2]`, is read as a
//!     ceiling. With exact halving the evidence of a vanished obstacle would never reach 0 (and
//!     lines 17–18, "never below 0", would be dead code), contradicting the paper's "the evidence of
//!     having seen it before has expired"; with a floor it would stall at 1. With the ceiling,
//!     `K3 = 25` expires after 5 scans without the obstacle (25 → 12 → 6 → 3 → 1 → 0), and the
//!     clamp at 0 is live for fractional values.
//! 11. **Units**: ranges and `b` are metres (the paper's `b = 12.3` is millimetres); `a`, `K1`, `δ`
//!     (`nad2v` is dimensionless), `K2` and `K3` are unit-free, so `K2·K3` keeps the paper's
//!     relaxation gain.
//! 12. **Order of pruning** is the paper's: `REMOVE-NEW` → `REMOVE-THIN` → `CROP-RANGE`, so obstacle
//!     returns beyond `d_max` still count as neighbours in `REMOVE-THIN-OBST`.
//! 13. **Input sanitation** (not in the paper): a range that is NaN, infinite, zero or negative, or a
//!     return whose angle is not finite, is "no return". Angles outside `(-π, π]` are wrapped onto the
//!     circle. If `angles` and `ranges` differ in length, only the first `min(len)` returns are used
//!     (the classes slice has that length). An empty scan is a scan without returns: it advances the
//!     temporal state (thresholds and evidence decay) and never alarms.
//! 14. **Window count**: `n_windows = ⌈2π/α⌉`, except that a remainder smaller than 0.1 % of `α`
//!     (rounding of `α` itself, e.g. `1°` in `f32`) does not create an extra sliver window; likewise
//!     for sectors.
//! 15. **Held obstacles** (beyond the paper; `hold_obstacles`, on by default): a window `i` passes
//!     `GET-OBST-CANDIDATES`, whatever its neighbours' `nad2v`, when its maximum `v(i)` is within
//!     `RELAX-OBST`'s tolerance of `R`, the farthest confirmed obstacle range (`R_f`) of the
//!     previous scan in window `i`, `i-1` or `i+1` (the paper's locality in time: an obstacle
//!     found at `φ` "will be located at around `φ`" one scan later; driving past it, its bearing
//!     drifts by up to half a window per scan). A trunk behind grass was lost in about one scan
//!     in 14 when blades broke the seven smooth windows the paper's test needs; with this, in the
//!     simulated evaluation, 99.6 % of those scans alarm instead of 92–93 %, and grass alone
//!     still never alarms (nothing is held before an alarm). Holding window `i` alone, as a first
//!     version did, lost the edge windows of an obstacle whose bearing drifted.
//! 16. **Filled notches** (beyond the paper; `fill_notches`, on by default): after the max filter, a
//!     window whose maximum is nearer than both neighbours' takes the nearer neighbour's maximum
//!     when the two windows on each side agree (`i-2` with `i-1`, `i-1` with `i+1`, `i+1` with
//!     `i+2`, each within `RELAX-OBST`'s tolerance without evidence). Blades in front of a surface
//!     can only shorten a window; a window whose every beam met a blade broke the 7 smooth
//!     windows of an obstacle coming into range behind grass, whose first alarm came 7.7 scans
//!     late on average while driving. A filled window never yields a candidate itself. See
//!     [`fill_notches`].
//! 17. **Carried scans** (beyond the paper; `carry_scans`, 2 by default, with
//!     [`Classifier::classify_moved`] and the sensor's [`Motion`] from odometry): the window maxima
//!     of the last `carry_scans` scans, moved into this scan's frame, join this scan's in the max
//!     filter before `FIND-LOW-FREQ`'s differences (and before the notches are filled), once the
//!     sensor has moved `carry_min_travel_m` from where they were taken. The paper's argument for
//!     the max filter — "the largest return of the set is likely to belong to the obstacle if any
//!     of the beams hit the obstacle" — holds for beams from several viewpoints as well: behind
//!     grass, each window then has the beams of three scans instead of one to reach the obstacle.
//!     Only this scan's own returns become candidates: a window passes `GET-OBST-CANDIDATES` when
//!     its own maximum (filled as in 16) is within `RELAX-OBST`'s tolerance without evidence of the
//!     merged one, so a window whose own beams all met blades yields no candidate and nothing old is
//!     ever reported. A carried maximum is placed at its window's centre angle (at most half a
//!     window off). Standing still nothing is carried: from the same place, the earlier scans add
//!     no view, and in the tests' sharp-edged grass band their maxima lined up along its edge (137
//!     false alarms in 200 scans with 2 carried scans, 1 without). Driving toward trunks hidden in
//!     grass in the simulated evaluation, the share of scans alarmed went from 92–94 % to 98–99 %.
//!     Its price is a grass strip that stops every beam, uniformly, before a sharp far edge, which
//!     no simulated or Beer–Lambert grass does: driving toward one 1 m deep and 1 m away, 6–18 %
//!     of the scans alarmed instead of 0–2 % (see docs/commands.md).
//!
//! ## Allocation and cost
//!
//! [`Classifier`] owns every buffer. The per-window buffers are allocated in [`Classifier::new`]; the
//! per-return buffers grow on the first scan of a given size and are reused afterwards, so
//! `classify()` does not allocate for scans no larger than one it has already seen. Every routine is
//! `O(Ne + N_w)`: `GET-OBST-CANDIDATES`'s "repeat until nothing changes" loop provably ends after
//! one pass, and `RELAX-OBST`'s is a worklist in which each return enters at most once. The
//! per-return loops are written to keep data-dependent branches few (candidates and foliage
//! interleave at random in grass, so such branches are mispredicted).

#![forbid(unsafe_code)]
#![warn(missing_docs)]

use std::f32::consts::{PI, TAU};

use mimnav_shared::config::Invalid;
/// The classifier's parameters are the `[foliage]` section of the stack's config, defined (with
/// their defaults, the paper's values and their checks) in `mimnav_shared::config::foliage`.
pub use mimnav_shared::config::foliage::{FoliageParams, MAX_CARRY_SCANS, bin_count};
use mimnav_shared::pose::{Pose2, Pose2Ext};

pub mod step;

/// Per-return classes reported in [`Verdict::classes`].
pub mod class {
    /// No usable return (range 0, negative, NaN or infinite, or a non-finite angle).
    pub const NO_RETURN: u8 = 0;
    /// A return that never became an obstacle candidate: foliage (drivable).
    pub const FOLIAGE: u8 = 1;
    /// A candidate that survived all pruning: a confirmed obstacle.
    pub const OBSTACLE: u8 = 2;
    /// A candidate removed by `REMOVE-NEW-OBST`, `REMOVE-THIN-OBST` or `CROP-RANGE`.
    pub const PRUNED: u8 = 3;
}

/// Marker for a return that belongs to no window / sector (its angle is not finite).
pub const NO_BIN: u32 = u32::MAX;

// ---------------------------------------------------------------------------------------------
// Binning and input preparation
// ---------------------------------------------------------------------------------------------

/// Bin of an angle: `⌊(angle + π) / bin_rad⌋`, the angle first wrapped onto `[-π, π)` so that
/// `π` and `-π` share bin 0. `None` for a non-finite angle or no bins.
pub fn angle_bin(angle: f32, bin_rad: f32, n_bins: usize) -> Option<u32> {
    if bin_rad.is_nan() || bin_rad <= 0.0 {
        return None;
    }
    bin_with_inverse(angle, 1.0 / bin_rad, n_bins)
}

/// [`angle_bin`] with the reciprocal of the bin width precomputed (one multiply per return).
#[inline]
fn bin_with_inverse(angle: f32, inv_bin: f32, n_bins: usize) -> Option<u32> {
    if !angle.is_finite() || n_bins == 0 || !(inv_bin.is_finite() && inv_bin > 0.0) {
        return None;
    }
    let mut t = angle + PI;
    if !(0.0..TAU).contains(&t) {
        // Rare: only angles outside [-π, π) need the (slow, libm) remainder.
        t = t.rem_euclid(TAU);
    }
    // t ≥ 0, so the cast floors; it saturates on overflow and the min() keeps it in range.
    let idx = ((t * inv_bin) as usize).min(n_bins - 1);
    Some(idx as u32)
}

/// A range as the classifier sees it: NaN, ±∞, 0 and negative values are "no return" (0).
pub fn sanitize_range(range: f32) -> f32 {
    if range.is_finite() && range > 0.0 {
        range
    } else {
        0.0
    }
}

/// A prepared scan: sanitized ranges and the window and sector of every return, all of length `Ne`.
#[derive(Debug, Clone, Copy)]
pub struct Scan<'a> {
    /// `R(r)`, metres; 0 = no return.
    pub ranges: &'a [f32],
    /// Window of each return ([`NO_BIN`] when its angle is not finite).
    pub windows: &'a [u32],
    /// Sector of each return ([`NO_BIN`] when its angle is not finite).
    pub sectors: &'a [u32],
}

impl Scan<'_> {
    /// `Ne`, the number of returns (the shortest of the three slices).
    pub fn len(&self) -> usize {
        self.ranges
            .len()
            .min(self.windows.len())
            .min(self.sectors.len())
    }

    /// True when the scan has no returns at all.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Fills the per-return buffers of a [`Scan`] from raw input (interpretation 13): uses the first
/// `min(angles.len(), ranges.len())` returns, sanitizes the ranges, bins each return into its window
/// and sector. The output vectors are cleared and refilled (no allocation once large enough).
pub fn prepare_scan(
    angles: &[f32],
    ranges: &[f32],
    params: &FoliageParams,
    ranges_out: &mut Vec<f32>,
    windows_out: &mut Vec<u32>,
    sectors_out: &mut Vec<u32>,
) {
    let n = angles.len().min(ranges.len());
    let (n_w, n_s) = (params.n_windows(), params.n_sectors());
    let (inv_w, inv_s) = (1.0 / params.window_rad, 1.0 / params.sector_rad);
    ranges_out.clear();
    ranges_out.resize(n, 0.0);
    windows_out.clear();
    windows_out.resize(n, NO_BIN);
    sectors_out.clear();
    sectors_out.resize(n, NO_BIN);
    // the checks of `bin_with_inverse` that do not depend on the angle, made once
    let usable = |inv: f32, n_bins: usize| n_bins > 0 && inv.is_finite() && inv > 0.0;
    if !(usable(inv_w, n_w) && usable(inv_s, n_s)) {
        return; // no bins: every return is "no return"
    }
    // Bin counts come from `bin_count` (at most 10⁹), so the bins fit in u32 and the saturating
    // `as u32` followed by the `min` gives the same bin as `bin_with_inverse`'s `as usize`.
    let (last_w, last_s) = ((n_w - 1) as u32, (n_s - 1) as u32);
    let outs = ranges_out
        .iter_mut()
        .zip(windows_out.iter_mut())
        .zip(sectors_out.iter_mut());
    for ((&a, &r), ((ro, wo), so)) in angles[..n].iter().zip(&ranges[..n]).zip(outs) {
        // Interpretation (13): a non-finite angle or range, or a range ≤ 0, is "no return".
        if !a.is_finite() {
            continue;
        }
        // `bin_with_inverse` for both bin widths, sharing the wrapped angle
        let mut t = a + PI;
        if !(0.0..TAU).contains(&t) {
            // Rare: only angles outside [-π, π) need the (slow, libm) remainder.
            t = t.rem_euclid(TAU);
        }
        *ro = keep_if(r, r.is_finite() & (r > 0.0)); // `sanitize_range`, branch-free
        *wo = ((t * inv_w) as u32).min(last_w);
        *so = ((t * inv_s) as u32).min(last_s);
    }
}

/// `(i + d) mod n` for `n > 0` (every caller guarantees it); no division in the common case
/// `|d| ≤ n`.
// Interpretation (4): window and return neighbourhoods wrap (the paper stops 2 short of each end).
#[inline]
fn wrap(i: usize, d: isize, n: usize) -> usize {
    let n = n as isize;
    let j = i as isize + d;
    if (0..n).contains(&j) {
        j as usize
    } else if (-n..0).contains(&j) {
        (j + n) as usize
    } else if (n..2 * n).contains(&j) {
        (j - n) as usize
    } else {
        j.rem_euclid(n) as usize
    }
}

/// `if keep { x } else { 0.0 }` computed on the bits, so that it stays branch-free: the compiler
/// turns a float select feeding a store into a branch, mispredicted where candidates and foliage
/// interleave at random (grass).
#[inline]
fn keep_if(x: f32, keep: bool) -> f32 {
    f32::from_bits(x.to_bits() & u32::from(keep).wrapping_neg())
}

/// `if cond { a } else { b }` on the bits (branch-free, see [`keep_if`]); exact for every value.
#[inline]
fn select(cond: bool, a: f32, b: f32) -> f32 {
    let m = u32::from(cond).wrapping_neg();
    f32::from_bits((a.to_bits() & m) | (b.to_bits() & !m))
}

// ---------------------------------------------------------------------------------------------
// Temporal state
// ---------------------------------------------------------------------------------------------

/// The state carried from scan to scan, one value per window: thresholds `T_{k-1}`, `T_{k-2}`
/// (`GET-OBST-CANDIDATES`) and evidence `C_{k-1}`, `C_{k-2}` (`RELAX-OBST`, `REMOVE-NEW-OBST`,
/// `UPDATE-AND-ARCHIVE`).
#[derive(Debug, Clone, PartialEq)]
pub struct History {
    /// `T_{k-1}(i)`, the thresholds of the previous scan (after its raises).
    pub t_prev1: Vec<f32>,
    /// `T_{k-2}(i)`.
    pub t_prev2: Vec<f32>,
    /// `C_{k-1}(i)`, the evidence after the previous scan's update.
    pub c_prev1: Vec<f32>,
    /// `C_{k-2}(i)`.
    pub c_prev2: Vec<f32>,
    /// The farthest confirmed obstacle range (`R_f`) per window in the previous scan, 0 where
    /// none: what [`FoliageParams::hold_obstacles`] holds.
    pub obst_prev: Vec<f32>,
}

impl History {
    /// All-zero state for `n_windows` windows.
    pub fn new(n_windows: usize) -> Self {
        Self {
            t_prev1: vec![0.0; n_windows],
            t_prev2: vec![0.0; n_windows],
            c_prev1: vec![0.0; n_windows],
            c_prev2: vec![0.0; n_windows],
            obst_prev: vec![0.0; n_windows],
        }
    }

    /// Number of windows (the shortest of the four arrays).
    pub fn n_windows(&self) -> usize {
        self.t_prev1
            .len()
            .min(self.t_prev2.len())
            .min(self.c_prev1.len())
            .min(self.c_prev2.len())
            .min(self.obst_prev.len())
    }

    /// The state of a robot that has been in free space for a long time (interpretation 1): no
    /// evidence, and both previous thresholds at the fixed point `2·K1` of the carry-over
    /// `T = K1 + T/2`. This is what [`Classifier::new`] and [`Classifier::reset`] start from.
    // Interpretation (1): the paper gives no initial thresholds; it starts the robot in free space.
    pub fn free_space(n_windows: usize, k1: f32) -> Self {
        let mut h = Self::new(n_windows);
        h.reset_free_space(k1);
        h
    }

    /// Forgets everything (all thresholds and evidence back to 0), keeping the allocation.
    pub fn reset(&mut self) {
        self.t_prev1.fill(0.0);
        self.t_prev2.fill(0.0);
        self.c_prev1.fill(0.0);
        self.c_prev2.fill(0.0);
        self.obst_prev.fill(0.0);
    }

    /// Back to [`History::free_space`]: evidence 0, thresholds `2·K1`; keeps the allocation.
    pub fn reset_free_space(&mut self, k1: f32) {
        self.reset();
        self.t_prev1.fill(2.0 * k1);
        self.t_prev2.fill(2.0 * k1);
    }

    /// Archives this scan's thresholds: `T_{k-2} ← T_{k-1}`, `T_{k-1} ← T_k`. `t_k` receives the old
    /// `T_{k-2}` buffer (to be overwritten next scan); no copy, no allocation.
    pub fn archive_thresholds(&mut self, t_k: &mut Vec<f32>) {
        std::mem::swap(&mut self.t_prev2, &mut self.t_prev1);
        std::mem::swap(&mut self.t_prev1, t_k);
    }

    /// `true` when window `i` or one of `i±1`, `i±2` (wrapped) has non-zero evidence in `C_{k-1}` or
    /// `C_{k-2}` — the test of `REMOVE-NEW-OBST` (interpretation 6).
    pub fn seen_near(&self, i: usize) -> bool {
        let n = self.n_windows();
        if n == 0 {
            return false;
        }
        let nz = |j: usize| self.c_prev1[j] > 0.0 || self.c_prev2[j] > 0.0;
        if i >= 2 && i + 2 < n {
            (i - 2..=i + 2).any(nz)
        } else {
            (-2..=2).any(|d| nz(wrap(i, d, n)))
        }
    }
}

// ---------------------------------------------------------------------------------------------
// FIND-LOW-FREQ
// ---------------------------------------------------------------------------------------------

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
fn max_filter(scan: Scan<'_>, n_windows: usize, out: &mut LowFreq) {
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
fn differences(out: &mut LowFreq) {
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
fn fill_notches_in(params: &FoliageParams, v: &mut [f32]) -> usize {
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

// ---------------------------------------------------------------------------------------------
// Carried scans (beyond the paper, interpretation 17)
// ---------------------------------------------------------------------------------------------

/// The sensor's motion from the previous scan to this one: this scan's sensor pose in the frame of
/// the previous scan's sensor (x forward, y left, θ counter-clockwise; REP-103), for
/// [`Classifier::classify_moved`].
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
struct Carry {
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
    fn with_windows(window_rad: f32, n_windows: usize) -> Self {
        let centre = |w: usize| -std::f64::consts::PI + (w as f64 + 0.5) * f64::from(window_rad);
        Self {
            cos: (0..n_windows).map(|w| centre(w).cos() as f32).collect(),
            sin: (0..n_windows).map(|w| centre(w).sin() as f32).collect(),
            ..Self::default()
        }
    }

    fn clear(&mut self) {
        self.spare.append(&mut self.scans);
    }

    /// Moves every carried scan by `m` into the new frame and writes, per window, the largest range
    /// of the maxima carried from scans taken at least `min_travel` away (0 where none). False
    /// when no scan qualified (`out` is then all 0).
    fn advance(&mut self, m: Motion, min_travel: f32, inv_w: f32, out: &mut Vec<f32>) -> bool {
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
    fn record(&mut self, v: &[f32], keep: usize) {
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

// ---------------------------------------------------------------------------------------------
// GET-OBST-CANDIDATES
// ---------------------------------------------------------------------------------------------

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
    ties: Vec<u32>,
    pass: Vec<bool>,
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
///   (update condition of line 11, interpretation 3). (In [`Classifier::classify_moved`] with
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
fn candidates_in(
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

// ---------------------------------------------------------------------------------------------
// RELAX-OBST
// ---------------------------------------------------------------------------------------------

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
    stack: Vec<u32>,
    can_join: Vec<u8>,
    tol: Vec<f32>,
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

// ---------------------------------------------------------------------------------------------
// Pruning: REMOVE-NEW-OBST, REMOVE-THIN-OBST, CROP-RANGE
// ---------------------------------------------------------------------------------------------

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
/// windows), so that [`Classifier::classify`]'s `REMOVE-NEW-OBST` looks the answer up per return.
fn seen_near_windows(history: &History, seen: &mut Vec<bool>) {
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

/// `REMOVE-THIN-OBST` then `CROP-RANGE` in one pass for [`Classifier::classify`]: `rf` from
/// `new`, the output of `REMOVE-NEW-OBST` (`0` or a positive range per return), with the results
/// of [`remove_thin_obst`] and [`crop_range`] run in that order (interpretations 7, 8, 12).
fn thin_and_crop(params: &FoliageParams, new: &[f32], rf: &mut Vec<f32>) {
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

// ---------------------------------------------------------------------------------------------
// UPDATE-AND-ARCHIVE
// ---------------------------------------------------------------------------------------------

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

// ---------------------------------------------------------------------------------------------
// Classifier
// ---------------------------------------------------------------------------------------------

/// Result of one [`Classifier::classify`] call; borrows the classifier's buffers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Verdict<'a> {
    /// `alarm`: at least one confirmed obstacle return in `[d_min, d_max]`.
    pub alarm: bool,
    /// `R_s`: nearest confirmed obstacle range per sector (sector `s` covers angles
    /// `[-π + s·sector, -π + (s+1)·sector)`), `f32::INFINITY` where none.
    pub nearest_per_sector: &'a [f32],
    /// Class of every return ([`class`]), in input order; length `min(angles.len(), ranges.len())`.
    pub classes: &'a [u8],
    /// Returns classed [`class::OBSTACLE`].
    pub obstacle_count: usize,
    /// Returns that were candidates (`R_c`, after `RELAX-OBST`): `OBSTACLE` + `PRUNED`.
    pub candidate_count: usize,
}

/// The foliage classifier: parameters, temporal state and every working buffer.
#[derive(Debug, Clone)]
pub struct Classifier {
    params: FoliageParams,
    n_windows: usize,
    history: History,
    low: LowFreq,
    t_k: Vec<f32>,
    c_k: Vec<f32>,
    work: WindowWork,
    ranges: Vec<f32>,
    windows: Vec<u32>,
    sectors: Vec<u32>,
    rc: Vec<f32>,
    rf: Vec<f32>,
    thin_copy: Vec<f32>,
    seen: Vec<bool>,
    relax_work: RelaxWork,
    classes: Vec<u8>,
    nearest: Vec<f32>,
    /// Interpretation 17: the earlier scans carried, this scan's own (filled) maxima, the raw
    /// ones, and the carried maxima per window.
    carry: Carry,
    v_own: Vec<f32>,
    v_raw: Vec<f32>,
    carry_max: Vec<f32>,
}

impl Classifier {
    /// A classifier with zeroed temporal state; fails if [`FoliageParams::validate`] does.
    pub fn new(params: FoliageParams) -> Result<Self, Invalid> {
        params.validate()?;
        let n_w = params.n_windows();
        let n_s = params.n_sectors();
        Ok(Self {
            params,
            n_windows: n_w,
            history: History::free_space(n_w, params.k1),
            low: LowFreq {
                v: Vec::with_capacity(n_w),
                dv: Vec::with_capacity(n_w),
                nad2v: Vec::with_capacity(n_w),
            },
            t_k: Vec::with_capacity(n_w),
            c_k: Vec::with_capacity(n_w),
            work: WindowWork::with_windows(n_w),
            ranges: Vec::new(),
            windows: Vec::new(),
            sectors: Vec::new(),
            rc: Vec::new(),
            rf: Vec::new(),
            thin_copy: Vec::new(),
            seen: Vec::with_capacity(n_w),
            relax_work: RelaxWork::default(),
            classes: Vec::new(),
            nearest: vec![f32::INFINITY; n_s],
            carry: Carry::with_windows(params.window_rad, n_w),
            v_own: Vec::with_capacity(n_w),
            v_raw: Vec::with_capacity(n_w),
            carry_max: Vec::with_capacity(n_w),
        })
    }

    /// Classifies one scan (`CLASSIFY(A, R)`) and advances the temporal state.
    ///
    /// `angles[r]` (radians) and `ranges[r]` (metres, 0 = no return) describe return `r` in firing
    /// order. If the slices differ in length only the first `min` returns are used. Never panics:
    /// non-finite, zero or negative ranges and non-finite angles are "no return"; an empty scan is a
    /// scan without returns (see interpretation 13).
    ///
    /// Without the sensor's motion no earlier scan is carried (interpretation 17): this is
    /// [`Classifier::classify_moved`] with `None`.
    pub fn classify(&mut self, angles: &[f32], ranges: &[f32]) -> Verdict<'_> {
        self.classify_moved(angles, ranges, None)
    }

    /// [`Classifier::classify`] knowing how the sensor moved since the previous scan
    /// (interpretation 17, [`FoliageParams::carry_scans`]): the window maxima of up to
    /// `carry_scans` earlier scans, moved into this scan's frame, join the max filter's
    /// smoothness test once the sensor has moved `carry_min_travel_m` from where they were taken.
    /// `None`, or an implausible motion ([`Motion::is_plausible`]: a jump or a non-finite value),
    /// drops every earlier scan; this scan is kept for the next.
    pub fn classify_moved(
        &mut self,
        angles: &[f32],
        ranges: &[f32],
        motion: Option<Motion>,
    ) -> Verdict<'_> {
        let p = self.params;
        prepare_scan(
            angles,
            ranges,
            &p,
            &mut self.ranges,
            &mut self.windows,
            &mut self.sectors,
        );
        let scan = Scan {
            ranges: &self.ranges,
            windows: &self.windows,
            sectors: &self.sectors,
        };
        let ne = scan.len();

        // FIND-LOW-FREQ, with the notches filled (interpretation 16) between its max filter and
        // its differences
        max_filter(scan, self.n_windows, &mut self.low);
        // Interpretation 17: the carried maxima join `v` for the differences; the candidates are
        // still this scan's own maxima (`v_own`), where they agree with the merged one.
        let carried = match motion.filter(|m| p.carry_scans > 0 && m.is_plausible()) {
            Some(m) => self.carry.advance(
                m,
                p.carry_min_travel_m,
                1.0 / p.window_rad,
                &mut self.carry_max,
            ),
            None => {
                self.carry.clear();
                false
            }
        };
        if p.carry_scans > 0 {
            self.v_raw.clone_from(&self.low.v);
        }
        if carried {
            self.v_own.clone_from(&self.low.v);
            for (v, &c) in self.low.v.iter_mut().zip(&self.carry_max) {
                *v = v.max(c);
            }
            if p.fill_notches {
                fill_notches_in(&p, &mut self.v_own);
            }
        }
        if p.fill_notches {
            fill_notches_in(&p, &mut self.low.v);
        }
        if !carried {
            self.v_own.clone_from(&self.low.v);
        }
        differences(&mut self.low);
        candidates_in(
            &p,
            scan,
            &self.v_own,
            &self.low,
            &self.history,
            &mut self.t_k,
            &mut self.rc,
            &mut self.work,
        );
        self.history.archive_thresholds(&mut self.t_k);
        relax_obst(&p, scan, &self.history, &mut self.rc, &mut self.relax_work);
        // Interpretation (12): the paper's pruning order, REMOVE-NEW → REMOVE-THIN → CROP-RANGE;
        // REMOVE-NEW-OBST writes the copy that REMOVE-THIN-OBST reads.
        seen_near_windows(&self.history, &mut self.seen);
        let new = &mut self.thin_copy;
        new.clear();
        new.extend(
            self.rc[..ne]
                .iter()
                .zip(&self.windows[..ne])
                .map(|(&c, &w)| {
                    // Interpretation (6), with the windows' answers made beforehand (branch-free).
                    let seen = self.seen.get(w as usize).copied().unwrap_or(false);
                    keep_if(c, (c > 0.0) & seen)
                }),
        );
        thin_and_crop(&p, new, &mut self.rf);
        let alarm = update_and_archive(
            &p,
            scan,
            &self.rc,
            &self.rf,
            &mut self.history,
            &mut self.c_k,
            &mut self.nearest,
        );
        if p.carry_scans > 0 {
            self.carry.record(&self.v_raw, p.carry_scans);
        }

        self.classes.clear();
        let (mut obstacles, mut candidates) = (0, 0);
        let per_return = self.rf[..ne]
            .iter()
            .zip(&self.rc[..ne])
            .zip(&self.ranges[..ne]);
        self.classes.extend(per_return.map(|((&f, &cand), &range)| {
            // (Branch-free: the classes interleave at random.) R_f ⊆ R_c ⊆ {R > 0}.
            let (is_obstacle, is_candidate) = (f > 0.0, cand > 0.0);
            obstacles += usize::from(is_obstacle);
            candidates += usize::from(is_candidate);
            let mut c = if range > 0.0 {
                class::FOLIAGE
            } else {
                class::NO_RETURN
            };
            c = if is_candidate { class::PRUNED } else { c };
            if is_obstacle { class::OBSTACLE } else { c }
        }));
        Verdict {
            alarm,
            nearest_per_sector: &self.nearest,
            classes: &self.classes,
            obstacle_count: obstacles,
            candidate_count: candidates,
        }
    }

    /// Forgets the temporal state, as after [`Classifier::new`]: evidence 0, thresholds at the
    /// free-space value `2·K1` ([`History::free_space`]).
    pub fn reset(&mut self) {
        self.history.reset_free_space(self.params.k1);
        self.carry.clear();
        self.nearest.fill(f32::INFINITY);
    }

    /// The parameters in use.
    pub fn params(&self) -> &FoliageParams {
        &self.params
    }

    /// The temporal state (`T_{k-1}`, `T_{k-2}`, `C_{k-1}`, `C_{k-2}` per window) after the last scan.
    pub fn history(&self) -> &History {
        &self.history
    }

    /// `v`, `dv`, `nad2v` of the last scan.
    pub fn low_freq(&self) -> &LowFreq {
        &self.low
    }

    /// `R_c` of the last scan (candidate range per return, 0 = not a candidate).
    pub fn candidates(&self) -> &[f32] {
        &self.rc
    }

    /// `R_f` of the last scan (obstacle range per return after pruning, 0 = not an obstacle).
    pub fn obstacles(&self) -> &[f32] {
        &self.rf
    }

    /// Number of angular windows `N_w`.
    pub fn n_windows(&self) -> usize {
        self.n_windows
    }
}

#[cfg(test)]
mod tests;
