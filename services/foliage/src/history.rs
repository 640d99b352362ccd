//! The temporal state carried from scan to scan ([`History`]): thresholds and evidence per window,
//! and the obstacles held (interpretation 15).

use crate::bits::wrap;

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
    /// none: what [`FoliageParams::hold_obstacles`](crate::FoliageParams::hold_obstacles) holds.
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
    /// `T = K1 + T/2`. This is what [`Classifier::new`](crate::Classifier::new) and [`Classifier::reset`](crate::Classifier::reset) start from.
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
