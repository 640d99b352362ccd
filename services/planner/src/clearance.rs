//! The footprint clearance: the distance from every cell to the nearest solid or glass cell, by
//! a two-pass chamfer transform. The dynamic window tests its rollouts against it ([`crate::dwa`])
//! and the route search finds where the footprint fits with it on the coarse grid
//! ([`crate::route`]); both import it from here, so neither imports the other for it.

use mimnav_shared::grid::GridSpec;
use mimnav_shared::topics::cell_class;

/// Distance to the nearest solid or glass cell, m, over a square window of the map around the
/// robot (two-pass chamfer transform, capped). Only the window the dynamic window's rollouts can
/// reach is computed; obstacles beyond its edge do not count, so the window must reach past the
/// rollouts by the distance that matters (the footprint and margin).
#[derive(Debug, Clone, Default)]
pub struct Clearance {
    /// First row and column of the window.
    lo: usize,
    /// Side of the window, cells.
    side: usize,
    /// Map side, cells.
    cells: usize,
    data: Vec<f32>,
}

impl Clearance {
    /// Computes the clearance of the cells within `half_m` of the map's centre (the robot),
    /// capped at `cap_m`.
    pub fn compute(&mut self, classes: &[u8], grid: GridSpec, half_m: f32, cap_m: f32) {
        self.compute_glass_nearer(classes, grid, half_m, cap_m, 0.0);
    }

    /// [`Clearance::compute`] with glass and suspected glass counted `glass_nearer_m` nearer
    /// than they are (their cells start the transform at −`glass_nearer_m`): a footprint test
    /// with a margin this much smaller then still keeps the full margin from glass.
    pub fn compute_glass_nearer(
        &mut self,
        classes: &[u8],
        grid: GridSpec,
        half_m: f32,
        cap_m: f32,
        glass_nearer_m: f32,
    ) {
        let n = grid.cells;
        let half = ((half_m / grid.cell_m).ceil().max(1.0) as usize).min(n / 2);
        let lo = n / 2 - half;
        let side = (2 * half).min(n - lo);
        self.lo = lo;
        self.side = side;
        self.cells = n;
        self.data.clear();
        if classes.len() < grid.len() || side == 0 {
            self.side = 0;
            return;
        }
        for r in lo..lo + side {
            self.data.extend(
                classes[r * n + lo..r * n + lo + side]
                    .iter()
                    .map(|&c| match c {
                        c if cell_class::is_glass(c) => -glass_nearer_m,
                        c if cell_class::blocks(c) => 0.0,
                        _ => cap_m,
                    }),
            );
        }
        chamfer(&mut self.data, side, grid.cell_m);
    }

    /// The clearance of map cell (r, c), m; 0 outside the window (never drive there).
    #[inline]
    pub fn at(&self, r: usize, c: usize) -> f32 {
        let (r, c) = (r.wrapping_sub(self.lo), c.wrapping_sub(self.lo));
        if r < self.side && c < self.side {
            self.data[r * self.side + c]
        } else {
            0.0
        }
    }
}

/// Distance from every cell to the nearest solid or glass cell over the whole map, m, capped at
/// `cap_m` (row-major, as the map).
pub fn clearance(classes: &[u8], grid: GridSpec, cap_m: f32, out: &mut Vec<f32>) {
    out.clear();
    out.extend(
        classes
            .iter()
            .map(|&c| if cell_class::blocks(c) { 0.0 } else { cap_m }),
    );
    if out.len() == grid.len() {
        chamfer(out, grid.cells, grid.cell_m);
    }
}

/// The two-pass chamfer distance transform of a `side` × `side` buffer holding 0 at obstacles
/// and the cap elsewhere; `g` is the cell size.
pub(crate) fn chamfer(out: &mut [f32], n: usize, g: f32) {
    let diag = g * std::f32::consts::SQRT_2;
    if n == 0 || out.len() < n * n {
        return;
    }
    // Forward pass, row by row: first the three neighbours of the row above (independent of
    // each other, so the compiler can vectorise), then the left neighbour, which runs along the
    // row; the result is the same as the cell-by-cell pass. The backward pass mirrors it.
    {
        let first = &mut out[..n];
        for c in 1..n {
            first[c] = lesser(first[c], first[c - 1] + g);
        }
    }
    for r in 1..n {
        let (above, rest) = out.split_at_mut(r * n);
        let prev = &above[(r - 1) * n..];
        let cur = &mut rest[..n];
        rows_min(cur, prev, g, diag);
        for c in 1..n {
            cur[c] = lesser(cur[c], cur[c - 1] + g);
        }
    }
    {
        let last = &mut out[(n - 1) * n..];
        for c in (0..n - 1).rev() {
            last[c] = lesser(last[c], last[c + 1] + g);
        }
    }
    for r in (0..n - 1).rev() {
        let (head, below) = out.split_at_mut((r + 1) * n);
        let next = &below[..n];
        let cur = &mut head[r * n..];
        rows_min(cur, next, g, diag);
        for c in (0..n - 1).rev() {
            cur[c] = lesser(cur[c], cur[c + 1] + g);
        }
    }
}

/// The smaller of `a` and `b`, as one `minss`/`minps` instruction (no NaN rules: there are no
/// NaNs here), so the row loops vectorise.
#[inline(always)]
fn lesser(a: f32, b: f32) -> f32 {
    if b < a { b } else { a }
}

/// `cur[c] = min(cur[c], other[c] + g, other[c ± 1] + diag)`: the neighbours in the row above or
/// below.
#[inline]
fn rows_min(cur: &mut [f32], other: &[f32], g: f32, diag: f32) {
    let n = cur.len().min(other.len());
    if n == 1 {
        cur[0] = lesser(cur[0], other[0] + g);
        return;
    }
    cur[0] = lesser(lesser(cur[0], other[0] + g), other[1] + diag);
    for ((c, w), o) in cur[1..n - 1]
        .iter_mut()
        .zip(other[..n - 2].iter().zip(&other[2..n]))
        .zip(&other[1..n - 1])
    {
        *c = lesser(lesser(lesser(*c, o + g), w.0 + diag), w.1 + diag);
    }
    cur[n - 1] = lesser(lesser(cur[n - 1], other[n - 1] + g), other[n - 2] + diag);
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A 10 m map of 5 cm cells with the class `f(x, y)` at each cell's centre.
    pub(crate) fn map(f: impl Fn(f32, f32) -> u8) -> (GridSpec, Vec<u8>) {
        let grid = GridSpec {
            cells: 200,
            cell_m: 0.05,
        };
        let classes = (0..grid.len())
            .map(|i| {
                let (x, y) = grid.center_of(i / grid.cells, i % grid.cells);
                f(x, y)
            })
            .collect();
        (grid, classes)
    }

    #[test]
    fn clearance_measures_the_distance_to_the_nearest_wall() {
        let (grid, classes) = map(|x, _| {
            if (x - 1.0).abs() < 0.03 {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        let mut clear = Vec::new();
        clearance(&classes, grid, 5.0, &mut clear);
        let at = |x: f32, y: f32| {
            let (r, c) = grid.cell_of(x, y).expect("inside");
            clear[grid.index(r, c)]
        };
        assert!((at(0.5, 0.0) - 0.5).abs() < 0.06, "{}", at(0.5, 0.0));
        assert_eq!(at(1.01, 0.0), 0.0);
    }

    #[test]
    fn the_window_agrees_with_the_whole_map_inside_and_is_zero_outside() {
        let (grid, classes) = map(|x, y| {
            if (x - 1.0).abs() < 0.03 || (y + 2.0).abs() < 0.03 {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        let mut full = Vec::new();
        clearance(&classes, grid, 5.0, &mut full);
        let mut window = Clearance::default();
        window.compute(&classes, grid, 1.5, 5.0);
        for r in 0..grid.cells {
            for c in 0..grid.cells {
                let (x, y) = grid.center_of(r, c);
                let w = window.at(r, c);
                if x.abs() < 1.45 && y.abs() < 1.45 {
                    // obstacles beyond the window are not seen: equal up to what reaches in
                    let f = full[grid.index(r, c)];
                    assert!(
                        w >= f - 1e-5 && (f > 0.4 || (w - f).abs() < 1e-5),
                        "{r},{c}: {w} {f}"
                    );
                } else if x.abs() > 1.55 || y.abs() > 1.55 {
                    assert_eq!(w, 0.0);
                }
            }
        }
    }

    #[test]
    fn clearance_is_within_the_chamfer_bound_of_the_true_distance() {
        // scattered obstacle cells from a fixed LCG; brute force against the transform
        let grid = GridSpec {
            cells: 60,
            cell_m: 0.05,
        };
        let mut state = 12345u64;
        let mut classes = vec![cell_class::FREE; grid.len()];
        for _ in 0..25 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            classes[(state >> 33) as usize % grid.len()] = cell_class::SOLID;
        }
        classes[grid.index(0, 59)] = cell_class::GLASS;
        let mut clear = Vec::new();
        clearance(&classes, grid, 5.0, &mut clear);
        let obstacles: Vec<(f32, f32)> = (0..grid.len())
            .filter(|&i| classes[i] != cell_class::FREE)
            .map(|i| grid.center_of(i / grid.cells, i % grid.cells))
            .collect();
        for (i, &got) in clear.iter().enumerate() {
            let (x, y) = grid.center_of(i / grid.cells, i % grid.cells);
            let truth = obstacles
                .iter()
                .map(|&(ox, oy)| (x - ox).hypot(y - oy))
                .fold(f32::INFINITY, f32::min);
            assert!(
                got >= truth - 1e-4 && got <= truth * 1.09 + 1e-4,
                "cell {i}: {got} against {truth}"
            );
        }
    }
}
