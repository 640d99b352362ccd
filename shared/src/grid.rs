//! The map grid convention every process shares: an n × n grid of g-metre cells centred on the
//! sensor, in the robot frame (x forward, y left). Row r grows with x, column c with y; cells are
//! stored row-major (`r * n + c`).

/// Size and resolution of a robot-centred grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridSpec {
    /// Cells per side.
    pub cells: usize,
    /// Cell size, metres.
    pub cell_m: f32,
}

impl GridSpec {
    /// Half the grid's side, metres.
    pub fn half_extent_m(&self) -> f32 {
        self.cells as f32 * self.cell_m * 0.5
    }

    /// The cell holding robot-frame point (x, y), if inside the grid.
    #[inline]
    pub fn cell_of(&self, x: f32, y: f32) -> Option<(usize, usize)> {
        self.locator().cell_of(x, y)
    }

    /// What [`cell_of`](Self::cell_of) computes from the grid, computed once: for a loop over
    /// many points (the same cells, bit for bit).
    #[inline]
    pub fn locator(&self) -> Locator {
        Locator {
            half_m: self.half_extent_m(),
            // one reciprocal: no division per point
            inv_cell: 1.0 / self.cell_m,
            // (a grid wider than a u32 counts cannot be allocated; the bound keeps the
            // conversion in `cell_of` sound regardless)
            cells_f: self.cells.min(u32::MAX as usize) as f32,
            cells: self.cells,
        }
    }
    /// Robot-frame centre of cell (r, c).
    #[inline]
    pub fn center_of(&self, r: usize, c: usize) -> (f32, f32) {
        let h = self.half_extent_m();
        (
            (r as f32 + 0.5) * self.cell_m - h,
            (c as f32 + 0.5) * self.cell_m - h,
        )
    }

    /// Row-major index of (r, c).
    #[inline]
    pub fn index(&self, r: usize, c: usize) -> usize {
        r * self.cells + c
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.cells * self.cells
    }

    /// True for a grid without cells.
    pub fn is_empty(&self) -> bool {
        self.cells == 0
    }
}

/// A grid's cell look-up with its constants computed ([`GridSpec::locator`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Locator {
    half_m: f32,
    inv_cell: f32,
    cells_f: f32,
    cells: usize,
}

impl Locator {
    /// The cell holding robot-frame point (x, y), if inside the grid: [`GridSpec::cell_of`].
    #[inline]
    pub fn cell_of(&self, x: f32, y: f32) -> Option<(usize, usize)> {
        let r = (x + self.half_m) * self.inv_cell;
        let c = (y + self.half_m) * self.inv_cell;
        let n = self.cells_f;
        // truncation is the floor for the non-negative values that pass the test (and NaN fails)
        // (one branch, not four: whether a far return falls on the grid is hard to predict)
        if (r >= 0.0) & (c >= 0.0) & (r < n) & (c < n) {
            // SAFETY: r and c are finite and in [0, n) with n ≤ 2^32, so they truncate to a
            // u32 (a saturating `as` costs the caller's hottest loops a tenth of their
            // instructions)
            Some(unsafe {
                (
                    r.to_int_unchecked::<u32>() as usize,
                    c.to_int_unchecked::<u32>() as usize,
                )
            })
        } else {
            None
        }
    }

    /// The row-major index of the cell holding (x, y), if inside the grid.
    #[inline]
    pub fn index_of(&self, x: f32, y: f32) -> Option<usize> {
        self.cell_of(x, y).map(|(r, c)| r * self.cells + c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_and_centres_agree() {
        let g = GridSpec {
            cells: 200,
            cell_m: 0.05,
        };
        assert_eq!(g.cell_of(0.0, 0.0), Some((100, 100)));
        assert_eq!(g.cell_of(-5.0, -5.0), Some((0, 0)));
        assert_eq!(g.cell_of(5.0, 0.0), None);
        assert_eq!(g.cell_of(4.999, 4.999), Some((199, 199)));
        let (x, y) = g.center_of(120, 80);
        assert_eq!(g.cell_of(x, y), Some((120, 80)));
        assert!(
            (x - 1.025).abs() < 1e-5 && (y + 0.975).abs() < 1e-5,
            "{x} {y}"
        );
    }

    /// `cell_of` converts without the saturating checks: it must still be the floor, inside
    /// the grid only, for any number at all.
    #[test]
    fn a_cell_is_the_floor_of_any_point_inside_and_none_outside() {
        let g = GridSpec {
            cells: 200,
            cell_m: 0.05,
        };
        let reference = |x: f32, y: f32| {
            let h = g.half_extent_m();
            let (r, c) = (((x + h) * (1.0 / g.cell_m)), ((y + h) * (1.0 / g.cell_m)));
            let n = g.cells as f32;
            let inside = |a: f32| a.is_finite() && a.floor() >= 0.0 && a.floor() < n;
            (inside(r) && inside(c)).then(|| (r.floor() as usize, c.floor() as usize))
        };
        let mut some: Vec<f32> = vec![
            0.0,
            -0.0,
            5.0,
            -5.0,
            4.999_999,
            -5.000_001,
            1e-30,
            -1e-30,
            1e30,
            -1e30,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::EPSILON,
        ];
        // and a spread over and beyond the grid (a fixed generator: the same every run)
        let mut s = 0x2545_f491u32;
        for _ in 0..20_000 {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            some.push((s as f32 / u32::MAX as f32 - 0.5) * 12.0);
        }
        for (i, &x) in some.iter().enumerate() {
            let y = some[(i * 7 + 3) % some.len()];
            assert_eq!(g.cell_of(x, y), reference(x, y), "({x}, {y})");
            assert_eq!(
                g.locator().index_of(x, y),
                reference(x, y).map(|(r, c)| g.index(r, c)),
                "({x}, {y})"
            );
        }
    }
}
