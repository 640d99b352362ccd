//! The footprint clearance: the distance from every cell to the nearest solid or glass cell, by
//! a two-pass chamfer transform. The dynamic window tests its rollouts against it ([`crate::dwa`])
//! and the route search finds where the footprint fits with it on the coarse grid
//! ([`crate::route`]); both import it from here, so neither imports the other for it.

use mimnav_shared::config::Body;
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
    /// Solid and glass cells beside a rectangular body (robot frame, m) and how far their
    /// centres are from it now: see [`Clearance::set_guard`].
    guard: Vec<(f64, f64, f64)>,
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

    /// Keeps the solid and glass cells of `classes` whose centres lie within `within_m` of
    /// `body` (at the map's centre, heading along x) but not under it, with that distance: the
    /// cells a rollout must not bring the body nearer ([`Clearance::guard`]). The clearance is
    /// a cell centre's and a cell stands for anything within it, so beside a body already
    /// inside its margin a corner can sweep into what a cell holds while every cell it passes
    /// keeps its clearance (Spot, turning beside a bush and beside a pane on impassable
    /// worlds; the Turtlebot 2, squeezing along a bush on an impassable hedge).
    pub fn set_guard(&mut self, classes: &[u8], grid: GridSpec, body: &Body, within_m: f64) {
        self.guard.clear();
        let reach = (body.enclosing_radius_m() + within_m) as f32;
        let (Some((r0, c0)), Some((r1, c1))) =
            (grid.cell_of(-reach, -reach), grid.cell_of(reach, reach))
        else {
            return;
        };
        if classes.len() < grid.len() {
            return;
        }
        for r in r0.min(r1)..=r0.max(r1) {
            for c in c0.min(c1)..=c0.max(c1) {
                if !cell_class::blocks(classes[grid.index(r, c)]) {
                    continue;
                }
                let (x, y) = grid.center_of(r, c);
                let (x, y) = (f64::from(x), f64::from(y));
                let d = body.signed_distance(x, y);
                // under the body: a mapping error ([`crate::Planner::plan_as`] frees it)
                if (0.0..within_m).contains(&d) {
                    self.guard.push((x, y, d));
                }
            }
        }
    }

    /// The cells [`Clearance::set_guard`] kept: (x, y, distance from the body now).
    pub fn guard(&self) -> &[(f64, f64, f64)] {
        &self.guard
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
///
/// Cell by cell, the forward pass takes each cell's least of itself, the three cells above it
/// (+ `g` straight, + `g`·√2 diagonally) and the cell before it in its row (+ `g`); the
/// backward pass mirrors it from the last cell. The cell before is a chain along the row, an
/// add and a min after the other, so taken a row at a time a pass waits on that chain at every
/// cell. Here [`ROWS`] rows go together, each two columns behind the one it takes from (whose
/// cells it needs up to one column ahead, by then final), so their chains overlap: 1.6–1.8×
/// faster on the planner's windows (1.05–1.4× where another VM's thread shares the core and its
/// execution units). Every cell takes the same operations in the same order as row by
/// row, so the result is the same to the bit (a property test holds it to the row-by-row
/// pass).
pub(crate) fn chamfer(out: &mut [f32], n: usize, g: f32) {
    if n < TOGETHER_FROM {
        chamfer_by_rows(out, n, g);
    } else {
        chamfer_together(out, n, g);
    }
}

/// [`chamfer`] with [`ROWS`] rows together, whatever the side.
fn chamfer_together(out: &mut [f32], n: usize, g: f32) {
    let diag = g * std::f32::consts::SQRT_2;
    if n == 0 || out.len() < n * n {
        return;
    }
    let out = &mut out[..n * n];
    // forward: the first row has only the cell before each, then rows 1.. in groups
    for c in 1..n {
        out[c] = lesser(out[c], out[c - 1] + g);
    }
    let mut r = 1;
    while r < n {
        let rows = ROWS.min(n - r);
        pass::<false>(out, n, r, rows, g, diag);
        r += rows;
    }
    // backward: the last row from its end, then the rows above it in groups, upwards
    let last = (n - 1) * n;
    for c in (0..n - 1).rev() {
        out[last + c] = lesser(out[last + c], out[last + c + 1] + g);
    }
    let mut left = n - 1;
    while left > 0 {
        let rows = ROWS.min(left);
        pass::<true>(out, n, left - 1, rows, g, diag);
        left -= rows;
    }
}

/// [`chamfer`] a row at a time: on a grid narrower than [`TOGETHER_FROM`] cells, where rows
/// going together gain nothing (the groups' ends are too much of each row); and the reference
/// the rows together must equal to the bit.
fn chamfer_by_rows(out: &mut [f32], n: usize, g: f32) {
    let diag = g * std::f32::consts::SQRT_2;
    if n == 0 || out.len() < n * n {
        return;
    }
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

/// Rows the chamfer's passes take together.
const ROWS: usize = 4;

/// The least side of a grid whose chamfer passes take [`ROWS`] rows together: at 40 cells (the
/// route's coarse grid) they are 1.2–1.5× slower than a row at a time, at 100 1.6–1.8×
/// faster.
const TOGETHER_FROM: usize = 64;

/// `rows` rows of one pass starting at row `r0` and going down the buffer (forward) or up it
/// (`BACK`), the row `i` from the first `2i` columns behind it.
#[inline(always)]
fn pass<const BACK: bool>(out: &mut [f32], n: usize, r0: usize, rows: usize, g: f32, diag: f32) {
    let lag = 2 * (rows - 1);
    let row = |i: usize| if BACK { r0 - i } else { r0 + i };
    let edge = |out: &mut [f32], t: usize| {
        for i in 0..rows {
            if let Some(k) = t.checked_sub(2 * i).filter(|&k| k < n) {
                edge_cell::<BACK>(out, n, row(i) * n, k, g, diag);
            }
        }
    };
    if rows < ROWS || n <= lag + 2 {
        for t in 0..n + lag {
            edge(out, t);
        }
        return;
    }
    // the steps where every row's cell is away from the row's ends
    for t in 0..=lag {
        edge(out, t);
    }
    // the group's rows and the row the pass comes from, top to bottom
    let top = if BACK { r0 + 1 - ROWS } else { r0 - 1 };
    let (_, rest) = out.split_at_mut(top * n);
    let (r1, rest) = rest.split_at_mut(n);
    let (r2, rest) = rest.split_at_mut(n);
    let (r3, rest) = rest.split_at_mut(n);
    let (r4, rest) = rest.split_at_mut(n);
    let r5 = &mut rest[..n];
    if BACK {
        // from r5, the row below the group, up to r1
        for t in lag + 1..n - 1 {
            let c = n - 1 - t;
            inner_cell::<true>(r5, r4, c, g, diag);
            inner_cell::<true>(r4, r3, c + 2, g, diag);
            inner_cell::<true>(r3, r2, c + 4, g, diag);
            inner_cell::<true>(r2, r1, c + 6, g, diag);
        }
    } else {
        for t in lag + 1..n - 1 {
            inner_cell::<false>(r1, r2, t, g, diag);
            inner_cell::<false>(r2, r3, t - 2, g, diag);
            inner_cell::<false>(r3, r4, t - 4, g, diag);
            inner_cell::<false>(r4, r5, t - 6, g, diag);
        }
    }
    for t in n - 1..n + lag {
        edge(out, t);
    }
}

/// A cell away from its row's ends (`0 < c < n − 1`): `from` is the row the pass comes from
/// (above it forward, below it backward).
#[inline(always)]
fn inner_cell<const BACK: bool>(from: &[f32], row: &mut [f32], c: usize, g: f32, diag: f32) {
    let mut v = lesser(row[c], from[c] + g);
    v = lesser(v, from[c - 1] + diag);
    v = lesser(v, from[c + 1] + diag);
    let before = if BACK { row[c + 1] } else { row[c - 1] };
    row[c] = lesser(v, before + g);
}

/// The `k`-th cell of a pass in the row starting at `at` (column `k` forward, `n − 1 − k`
/// backward), in the order the row-by-row pass took them: straight across, the column before,
/// the column after, then the cell before in the row.
#[inline(always)]
fn edge_cell<const BACK: bool>(out: &mut [f32], n: usize, at: usize, k: usize, g: f32, diag: f32) {
    let c = if BACK { n - 1 - k } else { k };
    let i = at + c;
    let f = if BACK { i + n } else { i - n };
    let mut v = lesser(out[i], out[f] + g);
    if c > 0 {
        v = lesser(v, out[f - 1] + diag);
    }
    if c + 1 < n {
        v = lesser(v, out[f + 1] + diag);
    }
    if k > 0 {
        let before = if BACK { out[i + 1] } else { out[i - 1] };
        v = lesser(v, before + g);
    }
    out[i] = v;
}

/// The smaller of `a` and `b`, as one `minss`/`minps` instruction (no NaN rules: there are no
/// NaNs here), so the row loops vectorise.
#[inline(always)]
fn lesser(a: f32, b: f32) -> f32 {
    if b < a { b } else { a }
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

    proptest::proptest! {
        #[test]
        fn the_rows_together_give_the_row_by_row_transform_to_the_bit(
            n in 0usize..100,
            seed in proptest::prelude::any::<u64>(),
            density in 0u32..40,
            g in 0.01f32..0.5,
        ) {
            // obstacles (0, and glass counted nearer: −0.1, or −0 when not nearer), the cap
            // elsewhere
            let mut state = seed;
            let cells: Vec<f32> = (0..n * n)
                .map(|_| {
                    state = state
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    match (state >> 33) % 100 {
                        x if x < u64::from(density) / 3 => -0.1,
                        x if x < 2 * u64::from(density) / 3 => -0.0,
                        x if x < u64::from(density) => 0.0,
                        _ => 5.0,
                    }
                })
                .collect();
            let (mut together, mut by_rows) = (cells.clone(), cells);
            chamfer_together(&mut together, n, g);
            chamfer_by_rows(&mut by_rows, n, g);
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            proptest::prop_assert_eq!(bits(&together), bits(&by_rows));
        }
    }

    #[test]
    fn the_guard_keeps_the_cells_just_beside_a_body_and_not_those_under_it() {
        let body = Body::Rectangle {
            length_m: 1.1,
            width_m: 0.5,
        };
        // a wall along the body's right side 4 cm off it, a stray return under it, a post
        // 0.3 m ahead of its nose
        let (grid, classes) = map(|x, y| {
            let wall = (y + 0.29).abs() < 0.02 && x.abs() < 0.3;
            let under = x.abs() < 0.03 && y.abs() < 0.03;
            let post = (x - 0.85).abs() < 0.03 && y.abs() < 0.03;
            match wall || under || post {
                true => cell_class::SOLID,
                false => cell_class::FREE,
            }
        });
        let mut clear = Clearance::default();
        clear.set_guard(&classes, grid, &body, 0.1);
        let guard = clear.guard();
        assert!(!guard.is_empty());
        for &(x, y, d) in guard {
            assert!((0.0..0.1).contains(&d), "({x}, {y}) {d}");
            assert!(y < -0.25, "only the wall: ({x}, {y}) {d}");
            assert!((body.signed_distance(x, y) - d).abs() < 1e-12);
        }
        // every wall cell is kept
        let wall_cells = (classes.iter().enumerate())
            .filter(|&(i, &c)| {
                let (x, y) = grid.center_of(i / grid.cells, i % grid.cells);
                c == cell_class::SOLID && y < -0.2 && x.abs() < 0.3
            })
            .count();
        assert_eq!(guard.len(), wall_cells);
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
