//! Binning and input preparation: every return's window and sector by absolute angle, and the
//! sanitized ranges (interpretations 13 and 14), the [`Scan`] the routines read.

use std::f32::consts::{PI, TAU};

use crate::FoliageParams;
use crate::bits::keep_if;

/// Marker for a return that belongs to no window / sector (its angle is not finite).
pub const NO_BIN: u32 = u32::MAX;

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
