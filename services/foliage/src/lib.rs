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
//! | paper routine            | function here             | module         | output                                   |
//! |--------------------------|---------------------------|----------------|------------------------------------------|
//! | `FIND-LOW-FREQ`          | [`find_low_freq`]         | `low_freq`     | `v`, `dv`, `nad2v` per window            |
//! | `GET-OBST-CANDIDATES`    | [`get_obst_candidates`]   | `candidates`   | `R_c` (candidates), thresholds `T_k`     |
//! | `RELAX-OBST`             | [`relax_obst`]            | `relax`        | `R_c` grown to smooth neighbours         |
//! | `REMOVE-NEW-OBST`        | [`remove_new_obst`]       | `prune`        | `R_f` ⊆ `R_c` (seen in the last 2 scans) |
//! | `REMOVE-THIN-OBST`       | [`remove_thin_obst`]      | `prune`        | `R_f` without isolated hits              |
//! | `CROP-RANGE`             | [`crop_range`]            | `prune`        | `R_f` within `[d_min, d_max]`            |
//! | `UPDATE-AND-ARCHIVE`     | [`update_and_archive`]    | `archive`      | `alarm`, `R_s`, evidence `C_k` archived  |
//!
//! The other modules: `bins` (windows and sectors of the returns, the prepared [`Scan`]), `history`
//! (the temporal state), `carry` (the carried scans of interpretation 17 and the sensor's
//! [`Motion`]), `classifier` ([`Classifier`], the routines in order) and `bits` (the wrapped
//! neighbour index and the branch-free selects they share). Every public item is re-exported
//! here.
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

/// The classifier's parameters are the `[foliage]` section of the stack's config, defined here
/// with their defaults, the paper's values and their checks.
pub mod config;
pub use config::{FoliageParams, MAX_CARRY_SCANS, ScanSource, bin_count};

// One module per routine of the paper (see the table above); the public API is re-exported here,
// so every item keeps its path `mimnav_foliage::…`.
mod archive;
mod bins;
mod bits;
mod candidates;
mod carry;
mod classifier;
mod history;
mod low_freq;
mod prune;
mod relax;
// The synthetic scenes of the unit tests, public (and hidden from the docs) so that the `scan`
// bench times the classifier on the same scenes instead of a copy of the simulator.
#[doc(hidden)]
pub mod scene;
pub mod step;

pub use archive::{evidence_step, update_and_archive};
pub use bins::{NO_BIN, Scan, angle_bin, prepare_scan, sanitize_range};
pub use candidates::{WindowWork, carry_threshold, get_obst_candidates};
pub use carry::{Motion, fast_atan2};
pub use classifier::{Classifier, Verdict};
pub use history::History;
pub use low_freq::{LowFreq, fill_notches, find_low_freq};
pub use prune::{crop_range, remove_new_obst, remove_thin_obst};
pub use relax::{RelaxWork, relax_obst, relax_tolerance};

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

#[cfg(test)]
mod tests;
