//! The helpers every routine shares: the wrapped neighbour index (interpretation 4) and the
//! branch-free selects on a float's bits.

/// `(i + d) mod n` for `n > 0` (every caller guarantees it); no division in the common case
/// `|d| ≤ n`.
// Interpretation (4): window and return neighbourhoods wrap (the paper stops 2 short of each end).
#[inline]
pub(crate) fn wrap(i: usize, d: isize, n: usize) -> usize {
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
pub(crate) fn keep_if(x: f32, keep: bool) -> f32 {
    f32::from_bits(x.to_bits() & u32::from(keep).wrapping_neg())
}

/// `if cond { a } else { b }` on the bits (branch-free, see [`keep_if`]); exact for every value.
#[inline]
pub(crate) fn select(cond: bool, a: f32, b: f32) -> f32 {
    let m = u32::from(cond).wrapping_neg();
    f32::from_bits((a.to_bits() & m) | (b.to_bits() & !m))
}
