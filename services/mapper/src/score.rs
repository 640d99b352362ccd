//! Scoring a map against ground truth: precision, recall and F-score per class.
//!
//! The protocol (what a cell counts as):
//! - only cells within `range_m` of the sensor are scored;
//! - a map cell of class c is a true positive when the truth has c within one cell of it (the
//!   grid discretises thin panes and surfaces; either side of a border is right), else a false
//!   positive;
//! - a truth cell of class c with no c in the map within one cell is a false negative when the
//!   mapper saw it: for solid and passable, when the map found returns there (it called the cell
//!   something else); for glass, which returns light only near normal incidence, whenever the map
//!   does not call the cell unknown. Cells no return and no beam reached cannot be scored.

use mimnav_shared::grid::GridSpec;
use mimnav_shared::topics::cell_class;

/// Counts for one class.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ClassScore {
    /// True positives.
    pub tp: u64,
    /// False positives.
    pub fp: u64,
    /// False negatives.
    pub fn_: u64,
}

impl ClassScore {
    /// tp / (tp + fp); 1 with nothing claimed.
    pub fn precision(&self) -> f64 {
        if self.tp + self.fp == 0 {
            1.0
        } else {
            self.tp as f64 / (self.tp + self.fp) as f64
        }
    }

    /// tp / (tp + fn); 1 with nothing to find.
    pub fn recall(&self) -> f64 {
        if self.tp + self.fn_ == 0 {
            1.0
        } else {
            self.tp as f64 / (self.tp + self.fn_) as f64
        }
    }

    /// Harmonic mean of precision and recall.
    pub fn f_score(&self) -> f64 {
        let (p, r) = (self.precision(), self.recall());
        if p + r == 0.0 {
            0.0
        } else {
            2.0 * p * r / (p + r)
        }
    }

    /// True when the class never occurred (in the map or the truth).
    pub fn is_empty(&self) -> bool {
        self.tp + self.fp + self.fn_ == 0
    }

    fn add(&mut self, o: &ClassScore) {
        self.tp += o.tp;
        self.fp += o.fp;
        self.fn_ += o.fn_;
    }
}

/// Counts for the three classes that matter.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MapScore {
    /// Solid obstacles.
    pub solid: ClassScore,
    /// Passable obstacles (grass, curtains).
    pub passable: ClassScore,
    /// Glass.
    pub glass: ClassScore,
}

impl MapScore {
    /// Adds another revolution's counts.
    pub fn add(&mut self, o: &MapScore) {
        self.solid.add(&o.solid);
        self.passable.add(&o.passable);
        self.glass.add(&o.glass);
    }
}

/// Whether `class` occurs in the 3 × 3 neighbourhood of (r, c).
fn near(cells: &[u8], grid: GridSpec, r: usize, c: usize, class: u8) -> bool {
    let n = grid.cells;
    for rr in r.saturating_sub(1)..=(r + 1).min(n - 1) {
        for cc in c.saturating_sub(1)..=(c + 1).min(n - 1) {
            if cells[grid.index(rr, cc)] == class {
                return true;
            }
        }
    }
    false
}

/// Scores one map against the truth of the same instant (see the module docs).
pub fn score(map: &[u8], truth: &[u8], grid: GridSpec, range_m: f32) -> MapScore {
    score_excluding(map, truth, grid, range_m, None)
}

/// [`score`], leaving out the cells `exclude` marks (neither right nor wrong).
pub fn score_excluding(
    map: &[u8],
    truth: &[u8],
    grid: GridSpec,
    range_m: f32,
    exclude: Option<&[bool]>,
) -> MapScore {
    // suspected glass is scored as the glass it is drawn as (the robot keeps off both)
    let glass_only: Vec<u8>;
    let map = if map.contains(&cell_class::SUSPECTED_GLASS) {
        glass_only = map
            .iter()
            .map(|&m| match m {
                cell_class::SUSPECTED_GLASS => cell_class::GLASS,
                m => m,
            })
            .collect();
        &glass_only[..]
    } else {
        map
    };
    let mut s = MapScore::default();
    for r in 0..grid.cells {
        for c in 0..grid.cells {
            let (x, y) = grid.center_of(r, c);
            if x.hypot(y) > range_m {
                continue;
            }
            let i = grid.index(r, c);
            if exclude.is_some_and(|e| e[i]) {
                continue;
            }
            let m = map[i];
            let t = truth[i];
            for (class, cs) in [
                (cell_class::SOLID, &mut s.solid),
                (cell_class::PASSABLE, &mut s.passable),
                (cell_class::GLASS, &mut s.glass),
            ] {
                if m == class {
                    if near(truth, grid, r, c, class) {
                        cs.tp += 1;
                    } else {
                        cs.fp += 1;
                    }
                } else if t == class && !near(map, grid, r, c, class) {
                    let seen = match class {
                        cell_class::GLASS => m != cell_class::UNKNOWN,
                        _ => matches!(
                            m,
                            cell_class::SOLID | cell_class::PASSABLE | cell_class::GLASS
                        ),
                    };
                    if seen {
                        cs.fn_ += 1;
                    }
                }
            }
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_with_one_cell_of_tolerance() {
        let grid = GridSpec {
            cells: 10,
            cell_m: 1.0,
        };
        let mut truth = vec![cell_class::FREE; 100];
        let mut map = vec![cell_class::FREE; 100];
        truth[grid.index(5, 5)] = cell_class::SOLID;
        map[grid.index(5, 6)] = cell_class::SOLID; // one cell off: right
        map[grid.index(1, 1)] = cell_class::SOLID; // nothing there: wrong
        truth[grid.index(7, 2)] = cell_class::PASSABLE;
        map[grid.index(7, 2)] = cell_class::SOLID; // seen, misclassified: a passable miss
        truth[grid.index(2, 7)] = cell_class::GLASS; // map says free: a glass miss
        truth[grid.index(8, 8)] = cell_class::GLASS;
        map[grid.index(8, 8)] = cell_class::UNKNOWN; // not seen: not scored
        let s = score(&map, &truth, grid, 100.0);
        assert_eq!(
            s.solid,
            ClassScore {
                tp: 1,
                fp: 2,
                fn_: 0
            }
        );
        assert_eq!(
            s.passable,
            ClassScore {
                tp: 0,
                fp: 0,
                fn_: 1
            }
        );
        assert_eq!(
            s.glass,
            ClassScore {
                tp: 0,
                fp: 0,
                fn_: 1
            }
        );
        assert!((s.solid.precision() - 1.0 / 3.0).abs() < 1e-9);
        assert_eq!(s.solid.recall(), 1.0);
    }
}
