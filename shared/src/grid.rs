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
        let h = self.half_extent_m();
        // one reciprocal, which the compiler hoists out of a caller's loop: no division per point
        let inv = 1.0 / self.cell_m;
        let r = (x + h) * inv;
        let c = (y + h) * inv;
        let n = self.cells as f32;
        // truncation is the floor for the non-negative values that pass the test (and NaN fails)
        (r >= 0.0 && c >= 0.0 && r < n && c < n).then_some((r as usize, c as usize))
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
}
