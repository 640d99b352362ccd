//! Obstacle inflation (equations 8–10 of `mim-lidar-intensity-navigation.txt`) and the planning
//! map (equation 11).
//!
//! The adaptive kernel K is e × e with ones on the line through its centre along the goal
//! direction (eq. 8), thickened by `padding` cells either side (eq. 9). Dilating the solid and
//! glass cells with it (eq. 10) stretches obstacles along the goal axis — towards the robot that
//! approaches them — and barely sideways, so a door or a gap between trees across the robot's
//! way stays open where an all-ones kernel (uniform inflation, the paper's ablation) closes it.
//! *Interpretation:* the inflated cost fades from 1 at the obstacle to 0.5 at the kernel's edge,
//! so the planner prefers to keep away without treating the margin as a wall.

use mimnav_shared::grid::GridSpec;
use mimnav_shared::topics::cell_class;

/// How obstacles are inflated: `planner.inflation`.
pub use crate::config::Inflation;

/// A kernel: the offsets (row, column) of its ones and their cost.
#[derive(Debug, Clone, PartialEq)]
pub struct Kernel {
    /// Side e, cells (odd).
    pub size: usize,
    /// (Δrow, Δcol, cost 0–255) of each one.
    pub taps: Vec<(i32, i32, u8)>,
}

impl Kernel {
    /// The adaptive kernel (eq. 8–9) for a goal direction `angle` (rad, robot frame:
    /// counter-clockwise from x forward; rows run along x, columns along y).
    pub fn adaptive(size: usize, padding: usize, angle: f64) -> Kernel {
        let h = (size / 2) as i32;
        let (s, c) = angle.sin_cos();
        let mut taps = Vec::new();
        for dr in -h..=h {
            for dc in -h..=h {
                // distance of the cell from the line through the centre along (c, s)
                let (x, y) = (f64::from(dr), f64::from(dc));
                let across = (x * s - y * c).abs();
                if across <= padding as f64 + 0.5 {
                    taps.push((dr, dc, fade(dr, dc, h)));
                }
            }
        }
        Kernel {
            size: 2 * h as usize + 1,
            taps,
        }
    }

    /// The all-ones kernel.
    pub fn uniform(size: usize) -> Kernel {
        let h = (size / 2) as i32;
        let mut taps = Vec::new();
        for dr in -h..=h {
            for dc in -h..=h {
                taps.push((dr, dc, fade(dr, dc, h)));
            }
        }
        Kernel {
            size: 2 * h as usize + 1,
            taps,
        }
    }

    /// Whether (Δrow, Δcol) is one of the kernel's ones.
    pub fn contains(&self, dr: i32, dc: i32) -> bool {
        self.taps.iter().any(|t| t.0 == dr && t.1 == dc)
    }
}

fn fade(dr: i32, dc: i32, h: i32) -> u8 {
    let d = f64::from(dr * dr + dc * dc).sqrt() / f64::from(h.max(1));
    (255.0 * (1.0 - 0.5 * d.min(1.0))).round() as u8
}

/// Kernels cached per quantised goal angle.
#[derive(Debug)]
pub struct KernelCache {
    size: usize,
    padding: usize,
    bins: usize,
    cache: Vec<Option<Kernel>>,
    uniform: Kernel,
}

impl KernelCache {
    /// Kernels of side `size` and `padding`, for goal angles quantised to `bins` steps a turn.
    pub fn new(size: usize, padding: usize, bins: usize) -> Self {
        KernelCache {
            size,
            padding,
            bins: bins.max(1),
            cache: vec![None; bins.max(1)],
            uniform: Kernel::uniform(size),
        }
    }

    /// The kernel for `inflation` and a goal at `angle` (rad).
    pub fn get(&mut self, inflation: Inflation, angle: f64) -> Option<&Kernel> {
        match inflation {
            Inflation::None => None,
            Inflation::Uniform => Some(&self.uniform),
            Inflation::Adaptive => {
                // a line through the centre has the same kernel for θ and θ + π
                let turn = std::f64::consts::PI;
                let b = ((angle.rem_euclid(turn) / turn) * self.bins as f64).round() as usize
                    % self.bins;
                let q = b as f64 * turn / self.bins as f64;
                let (size, padding) = (self.size, self.padding);
                Some(self.cache[b].get_or_insert_with(|| Kernel::adaptive(size, padding, q)))
            }
        }
    }
}

/// Scratch of [`plan_cost`], kept between maps so that no map allocates.
#[derive(Debug, Default)]
pub struct Scratch {
    /// Per map cell: 255 at solid, glass and suspected glass, else 0.
    mask: Vec<u8>,
    /// The map rows holding at least [`DENSE_ROW`] of them: (row, the columns from the first
    /// to the last).
    rows: Vec<(usize, std::ops::Range<usize>)>,
    /// The padded index of each obstacle in the other rows.
    sparse: Vec<usize>,
}

/// A map row with at least this many obstacle cells is dilated a whole row per kernel one
/// (vectorised), one with fewer obstacle by obstacle: the two cost the same about here.
const DENSE_ROW: usize = 8;

/// Builds the planning cost (eq. 10–11): solid and glass cells cost 255, their inflation by
/// `kernel` fades from 255 to 128, passable cells cost `passable`, free and unknown 0. Returns the
/// cost per cell in `out`.
///
/// The dilation (eq. 10) goes over rows dense with obstacles tap by tap — for each of the
/// kernel's ones, every such row raises the row it lands on to that one's cost where its
/// obstacle mask is set, in passes the compiler vectorises — and over the rest obstacle by
/// obstacle: the same maxima in any order, so a field of grass with thousands of solid cells
/// costs little more than a corridor.
pub fn plan_cost(
    classes: &[u8],
    grid: GridSpec,
    kernel: Option<&Kernel>,
    passable: u8,
    out: &mut Vec<u8>,
    scratch: &mut Scratch,
) {
    let n = grid.cells;
    let classes = &classes[..classes.len().min(n * n)];
    // Work in a grid padded by the kernel's reach on every side, so a tap needs no bounds check,
    // then move the inner part to the front (every row moves towards the start, so in place).
    let reach = kernel.map_or(0, |k| {
        k.taps
            .iter()
            .map(|&(dr, dc, _)| dr.unsigned_abs().max(dc.unsigned_abs()) as usize)
            .max()
            .unwrap_or(0)
    });
    let w = n + 2 * reach;
    out.clear();
    out.resize(w * w, 0);
    let Scratch { mask, rows, sparse } = scratch;
    mask.clear();
    mask.resize(classes.len(), 0);
    rows.clear();
    sparse.clear();
    for (r, (row, mrow)) in classes.chunks(n).zip(mask.chunks_mut(n)).enumerate() {
        let base = (r + reach) * w + reach;
        // without a branch per cell (a map of grass mixes the classes unpredictably), and
        // counted in a pass of its own: with the count in it, this loop did not vectorise
        for ((&class, m), o) in row
            .iter()
            .zip(mrow.iter_mut())
            .zip(&mut out[base..base + n])
        {
            let obstacle = u8::from(class == cell_class::SOLID)
                | u8::from(class == cell_class::GLASS)
                | u8::from(class == cell_class::SUSPECTED_GLASS);
            *m = obstacle.wrapping_neg();
            *o = *m | (passable & u8::from(class == cell_class::PASSABLE).wrapping_neg());
        }
        let count: u32 = mrow.iter().map(|&m| u32::from(m & 1)).sum();
        if count as usize >= DENSE_ROW {
            let first = mrow.iter().position(|&m| m != 0).unwrap_or(0);
            let last = mrow.iter().rposition(|&m| m != 0).unwrap_or(0);
            rows.push((r, first..last + 1));
        } else if count > 0 {
            sparse.extend(
                mrow.iter()
                    .enumerate()
                    .filter(|&(_, &m)| m != 0)
                    .map(|(c, _)| base + c),
            );
        }
    }
    if let Some(k) = kernel {
        let wi = w as isize;
        for &i in sparse.iter() {
            for &(dr, dc, cost) in &k.taps {
                let j = (i as isize + dr as isize * wi + dc as isize) as usize;
                out[j] = out[j].max(cost);
            }
        }
        for &(dr, dc, cost) in &k.taps {
            for (r, span) in rows.iter() {
                let src = &mask[r * n + span.start..r * n + span.end];
                let at = ((r + reach) as isize + dr as isize) as usize * w
                    + (reach as isize + dc as isize) as usize
                    + span.start;
                dilate_span(&mut out[at..at + src.len()], src, cost);
            }
        }
    }
    if reach > 0 {
        for r in 0..n {
            let from = (r + reach) * w + reach;
            out.copy_within(from..from + n, r * n);
        }
    }
    out.truncate(classes.len());
}

/// `out[i] = max(out[i], mask[i] & cost)` over a span, 16 cells at a time. A span's last
/// cells are taken as one more whole chunk that overlaps the one before it: taking a maximum
/// twice changes nothing, and no cell is then left to a scalar loop.
#[inline]
fn dilate_span(out: &mut [u8], mask: &[u8], cost: u8) {
    const W: usize = 16;
    let n = out.len().min(mask.len());
    if n < W {
        for (o, &m) in out[..n].iter_mut().zip(&mask[..n]) {
            *o = (*o).max(m & cost);
        }
        return;
    }
    let chunk = |o: &mut [u8], m: &[u8]| {
        // (both are always W long: the arrays let the compiler drop the bounds checks)
        let (o, m): (&mut [u8; W], &[u8; W]) = match (o.try_into(), m.try_into()) {
            (Ok(o), Ok(m)) => (o, m),
            _ => return,
        };
        for i in 0..W {
            o[i] = o[i].max(m[i] & cost);
        }
    };
    let mut i = 0;
    while i + W <= n {
        chunk(&mut out[i..i + W], &mask[i..i + W]);
        i += W;
    }
    if i < n {
        chunk(&mut out[n - W..n], &mask[n - W..n]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_kernel_lies_along_the_goal_direction() {
        // goal straight ahead (x, rows): a vertical bar through the centre
        let k = Kernel::adaptive(7, 0, 0.0);
        for dr in -3..=3 {
            assert!(k.contains(dr, 0), "row {dr}");
        }
        assert!(!k.contains(0, 1) && !k.contains(0, -2));
        assert_eq!(k.taps.len(), 7);
        // goal to the left (y, columns): a horizontal bar
        let k = Kernel::adaptive(7, 0, std::f64::consts::FRAC_PI_2);
        assert!(k.contains(0, 3) && k.contains(0, -3) && !k.contains(1, 0));
        // 45°: the diagonal
        let k = Kernel::adaptive(7, 0, std::f64::consts::FRAC_PI_4);
        assert!(k.contains(2, 2) && k.contains(-3, -3) && !k.contains(2, -2));
        // padding thickens it
        let k = Kernel::adaptive(7, 1, 0.0);
        assert!(k.contains(3, 1) && k.contains(-3, -1) && !k.contains(0, 2));
        assert_eq!(k.taps.len(), 21);
        assert_eq!(Kernel::uniform(7).taps.len(), 49);
    }

    #[test]
    fn adaptive_inflation_keeps_a_door_open_that_uniform_inflation_closes() {
        // a wall across the robot's way (along y at x = 2 m) with a 0.5 m door at y = 0
        let grid = GridSpec {
            cells: 100,
            cell_m: 0.05,
        };
        let mut classes = vec![cell_class::FREE; grid.len()];
        for k in -40..=40 {
            let y = k as f32 * 0.05;
            if y.abs() > 0.25 {
                let (r, c) = grid.cell_of(2.0, y).expect("inside");
                classes[grid.index(r, c)] = cell_class::SOLID;
            }
        }
        let door = grid
            .cell_of(2.0, 0.0)
            .map(|(r, c)| grid.index(r, c))
            .expect("inside");
        let mut cost = Vec::new();
        let mut scratch = Scratch::default();
        let mut cache = KernelCache::new(13, 1, 36);
        plan_cost(
            &classes,
            grid,
            cache.get(Inflation::Uniform, 0.0),
            51,
            &mut cost,
            &mut scratch,
        );
        assert!(cost[door] > 0, "uniform inflation closes the door");
        plan_cost(
            &classes,
            grid,
            cache.get(Inflation::Adaptive, 0.0),
            51,
            &mut cost,
            &mut scratch,
        );
        assert_eq!(
            cost[door], 0,
            "adaptive inflation along the goal keeps it open"
        );
        // and the wall grows towards the robot
        let before = grid
            .cell_of(1.8, 1.0)
            .map(|(r, c)| grid.index(r, c))
            .expect("inside");
        assert!(cost[before] >= 128);
    }

    #[test]
    fn passable_cells_get_a_small_cost_and_are_not_inflated() {
        let grid = GridSpec {
            cells: 20,
            cell_m: 0.1,
        };
        let mut classes = vec![cell_class::FREE; grid.len()];
        classes[grid.index(10, 10)] = cell_class::PASSABLE;
        let mut cost = Vec::new();
        plan_cost(
            &classes,
            grid,
            Some(&Kernel::uniform(5)),
            51,
            &mut cost,
            &mut Scratch::default(),
        );
        assert_eq!(cost[grid.index(10, 10)], 51);
        assert_eq!(cost.iter().filter(|&&c| c > 0).count(), 1);
    }

    /// Eq. 10 obstacle by obstacle, as written: each solid, glass or suspected-glass cell
    /// raises every cell its kernel's ones cover (inside the map) to their cost.
    fn reference(classes: &[u8], n: usize, kernel: Option<&Kernel>, passable: u8) -> Vec<u8> {
        let mut out = vec![0u8; classes.len()];
        for (i, &class) in classes.iter().enumerate() {
            let (r, c) = ((i / n) as i32, (i % n) as i32);
            match class {
                cell_class::SOLID | cell_class::GLASS | cell_class::SUSPECTED_GLASS => {
                    out[i] = 255;
                    for &(dr, dc, cost) in kernel.map_or(&[][..], |k| &k.taps[..]) {
                        let (rr, cc) = (r + dr, c + dc);
                        if (0..n as i32).contains(&rr) && (0..n as i32).contains(&cc) {
                            let j = rr as usize * n + cc as usize;
                            if let Some(o) = out.get_mut(j) {
                                *o = (*o).max(cost);
                            }
                        }
                    }
                }
                cell_class::PASSABLE => out[i] = out[i].max(passable),
                _ => {}
            }
        }
        out
    }

    proptest::proptest! {
        /// Row by row over the mask gives what obstacle by obstacle gives, for any map, kernel
        /// and goal direction — at the map's edges too.
        #[test]
        fn row_passes_give_eq_10_as_written(
            // rows past 32 cells: spans of several 16-cell chunks and an overlapping last one
            cells in proptest::collection::vec(0u8..6, 1..2400),
            side in 1usize..48,
            size in 1usize..10,
            padding in 0usize..3,
            angle in -4.0f64..4.0,
            which in 0u8..3,
            passable in 0u8..200,
        ) {
            let n = side.min(cells.len()).max(1);
            let classes: Vec<u8> = cells.iter().take(n * n).copied().collect();
            let grid = GridSpec { cells: n, cell_m: 0.1 };
            let kernel = match which {
                0 => None,
                1 => Some(Kernel::uniform(size)),
                _ => Some(Kernel::adaptive(size, padding, angle)),
            };
            let mut out = Vec::new();
            plan_cost(&classes, grid, kernel.as_ref(), passable, &mut out, &mut Scratch::default());
            proptest::prop_assert_eq!(out, reference(&classes, n, kernel.as_ref(), passable));
        }
    }
}
