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

/// Builds the planning cost (eq. 10–11): solid and glass cells cost 255, their inflation by
/// `kernel` fades from 255 to 128, passable cells cost `passable`, free and unknown 0. Returns the
/// cost per cell in `out`.
pub fn plan_cost(
    classes: &[u8],
    grid: GridSpec,
    kernel: Option<&Kernel>,
    passable: u8,
    out: &mut Vec<u8>,
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
    let wi = w as isize;
    for (r, row) in classes.chunks(n).enumerate() {
        let base = (r + reach) * w + reach;
        for (c, &class) in row.iter().enumerate() {
            let i = base + c;
            match class {
                cell_class::SOLID | cell_class::GLASS | cell_class::SUSPECTED_GLASS => {
                    out[i] = 255;
                    if let Some(k) = kernel {
                        for &(dr, dc, cost) in &k.taps {
                            let j = (i as isize + dr as isize * wi + dc as isize) as usize;
                            out[j] = out[j].max(cost);
                        }
                    }
                }
                cell_class::PASSABLE => out[i] = out[i].max(passable),
                _ => {}
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
        let mut cache = KernelCache::new(13, 1, 36);
        plan_cost(
            &classes,
            grid,
            cache.get(Inflation::Uniform, 0.0),
            51,
            &mut cost,
        );
        assert!(cost[door] > 0, "uniform inflation closes the door");
        plan_cost(
            &classes,
            grid,
            cache.get(Inflation::Adaptive, 0.0),
            51,
            &mut cost,
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
        plan_cost(&classes, grid, Some(&Kernel::uniform(5)), 51, &mut cost);
        assert_eq!(cost[grid.index(10, 10)], 51);
        assert_eq!(cost.iter().filter(|&&c| c > 0).count(), 1);
    }
}
