//! `[map]`: the robot-centred grid.

use serde::Deserialize;

use super::check::{Checks, Invalid};

/// The robot-centred map grid (`[map]`), shared by the mapper, the planner and the simulator's
/// ground truth.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MapConfig {
    /// Cells per side (n).
    pub cells: usize,
    /// Cell size, metres (g).
    pub cell_m: f64,
}

impl Default for MapConfig {
    fn default() -> Self {
        MapConfig {
            cells: 200,
            cell_m: 0.05,
        }
    }
}

impl MapConfig {
    /// The grid.
    pub fn grid(&self) -> crate::grid::GridSpec {
        crate::grid::GridSpec {
            cells: self.cells,
            cell_m: self.cell_m as f32,
        }
    }

    /// Checks every key of `[map]`: each value refused names its key and what is allowed.
    pub fn validate(&self) -> Result<(), Invalid> {
        let mut r = Checks::default();
        r.check("map.cells", self.cells as f64, 10.0, 2000.0);
        r.check("map.cell_m", self.cell_m, 0.01, 1.0);
        r.finish()
    }
}
