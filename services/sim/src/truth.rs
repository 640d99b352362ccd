//! Ground truth: the class of every map cell around the robot, in the robot frame, from the
//! scene's objects. A cell takes the class of the most important object whose footprint comes
//! within half a cell of its centre (a curtain: plus the sway of its strands): solid before glass
//! before passable; every other cell is free.

use mimnav_shared::grid::GridSpec;
use mimnav_shared::topics::cell_class;

use mimnav_shared::pose::{Pose2, Pose2Ext};

use crate::geometry::footprint_distance;
use crate::world::Scene;

fn rank(class: u8) -> u8 {
    match class {
        cell_class::SOLID => 3,
        cell_class::GLASS => 2,
        cell_class::PASSABLE => 1,
        _ => 0,
    }
}

/// Fills `out` (resized to the grid) with the true class of every cell of `grid` around `pose`.
pub fn truth_grid(scene: &Scene, pose: &Pose2, grid: GridSpec, out: &mut Vec<u8>) {
    out.clear();
    out.resize(grid.len(), cell_class::FREE);
    let half = f64::from(grid.cell_m) * 0.5;
    let extent = f64::from(grid.half_extent_m());
    for obj in &scene.objects {
        let (centre, radius) = obj.bound;
        // the object's bounding circle in the robot frame
        let (rx, ry) = pose.to_local(centre[0], centre[1]);
        let reach = radius + half + obj.truth_margin_m;
        if rx + reach < -extent
            || rx - reach > extent
            || ry + reach < -extent
            || ry - reach > extent
        {
            continue;
        }
        let cell = |v: f64| {
            ((v + extent) / f64::from(grid.cell_m))
                .floor()
                .clamp(0.0, grid.cells as f64 - 1.0) as usize
        };
        let (r0, r1) = (cell(rx - reach), cell(rx + reach));
        let (c0, c1) = (cell(ry - reach), cell(ry + reach));
        let new_rank = rank(obj.class);
        for r in r0..=r1 {
            for col in c0..=c1 {
                let i = grid.index(r, col);
                if rank(out[i]) >= new_rank {
                    continue;
                }
                let (x, y) = grid.center_of(r, col);
                let (wx, wy) = pose.to_fixed(f64::from(x), f64::from(y));
                // a hair over half a cell, so a sheet lying exactly on a cell border marks the
                // cells on both sides rather than neither
                if footprint_distance(&obj.shape, [wx, wy]) <= half + obj.truth_margin_m + 1e-6 {
                    out[i] = obj.class;
                }
            }
        }
    }
}
