//! Suspected glass no body could pass even if it were open (issue 22).
//!
//! The mapper draws a pane's line on as *suspected glass* where no beam has met it squarely, and
//! the route may cross suspected glass at a cost (`planner.route_suspect_weight`): it may be an
//! opening never faced. The route's grid is coarse (`planner.route_cell_m`, 0.25 m) and its
//! test optimistic by half a coarse cell, so that no door the footprint fits through is closed
//! there; but then a sliver of suspected glass between a pane's seen end and the wall it runs
//! into, or between a post and the glass beside it, is a way through for the route. It is not
//! one for the body: even open, the gap is narrower than the body and the margin it keeps. A
//! round body sweeping a shop front towards the side wall cannot bring the foot of its sensor's
//! perpendicular nearer the wall than its radius and margin, so the last stretch of the pane
//! stays suspected for good; the route, its coarse cells falling on or off that sliver as the
//! robot-centred map moves a cell, flipped between "through the corner" and "back along the
//! front" from one map to the next (`glass-storefront s900 i11`, tune: 15 s lost creeping in the
//! corner, 4–7 m jumps of the route's length between revolutions).
//!
//! [`too_narrow`] finds every suspected cell nearer a solid or glass cell than the body could
//! pass it (the dynamic window's own test, cell centre to cell centre); for a rectangular body
//! the planner hands them to the route as glass (a round body gained nothing by it on the tune
//! worlds and keeps its route; docs/evaluation.md, stop 68). The dynamic window treats suspected
//! glass as glass anyway, so nothing else changes.

use mimnav_shared::grid::GridSpec;
use mimnav_shared::topics::cell_class;

/// Pushes into `out` (cleared first) the index of every suspected-glass cell of `classes` with a
/// solid or glass cell (not suspected) within `need_m` of its centre: were the suspected glass an
/// opening, a body whose centre crossed it there would come nearer that cell than `need_m`.
pub fn too_narrow(classes: &[u8], grid: GridSpec, need_m: f64, out: &mut Vec<usize>) {
    out.clear();
    let n = grid.cells;
    if classes.len() < grid.len() || need_m <= 0.0 || grid.cell_m <= 0.0 {
        return;
    }
    // the offsets within the need, nearest first: a cell beside a pane's end stops at once
    let k = (need_m / f64::from(grid.cell_m)).floor() as isize;
    let limit = need_m / f64::from(grid.cell_m);
    let mut offsets: Vec<(isize, isize, f64)> = Vec::new();
    for dr in -k..=k {
        for dc in -k..=k {
            let d = (dr as f64).hypot(dc as f64);
            if d > 0.0 && d < limit {
                offsets.push((dr, dc, d));
            }
        }
    }
    offsets.sort_by(|a, b| a.2.total_cmp(&b.2));
    let seen = |c: u8| c == cell_class::SOLID || c == cell_class::GLASS;
    for (i, _) in (classes[..grid.len()].iter().enumerate())
        .filter(|&(_, &c)| c == cell_class::SUSPECTED_GLASS)
    {
        let (r, c) = ((i / n) as isize, (i % n) as isize);
        let near = offsets.iter().any(|&(dr, dc, _)| {
            let (rr, cc) = (r + dr, c + dc);
            rr >= 0
                && cc >= 0
                && (rr as usize) < n
                && (cc as usize) < n
                && seen(classes[rr as usize * n + cc as usize])
        });
        if near {
            out.push(i);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 10 m map of 5 cm cells with the class `f(x, y)` at each cell's centre.
    fn map(f: impl Fn(f32, f32) -> u8) -> (GridSpec, Vec<u8>) {
        crate::clearance::tests::map(f)
    }

    #[test]
    fn a_sliver_between_a_panes_end_and_a_wall_is_too_narrow_and_a_door_is_not() {
        // a pane's line at x = 1: glass for y < 0, suspected from 0 to 0.37 (a sliver), a wall
        // (solid, across the line) at y = 0.4; past the wall, suspected for 1.2 m, then glass
        let (grid, classes) = map(|x, y| {
            if (x - 1.0).abs() > 0.03 {
                if (y - 0.4).abs() < 0.03 && (0.5..1.5).contains(&x) {
                    return cell_class::SOLID;
                }
                return cell_class::FREE;
            }
            match y {
                y if y < 0.0 => cell_class::GLASS,
                y if y < 0.37 => cell_class::SUSPECTED_GLASS,
                y if y < 0.43 => cell_class::SOLID,
                y if y < 1.63 => cell_class::SUSPECTED_GLASS,
                _ => cell_class::GLASS,
            }
        });
        let mut out = Vec::new();
        too_narrow(&classes, grid, 0.25, &mut out);
        let at = |i: usize| grid.center_of(i / grid.cells, i % grid.cells);
        let suspected = |lo: f32, hi: f32| {
            (0..grid.len())
                .filter(|&i| classes[i] == cell_class::SUSPECTED_GLASS)
                .filter(|&i| (lo..hi).contains(&at(i).1))
                .count()
        };
        let closed =
            |lo: f32, hi: f32| out.iter().filter(|&&i| (lo..hi).contains(&at(i).1)).count();
        // the sliver, 0.37 m between glass and wall: every cell of it within 0.25 m of one
        assert!(suspected(0.0, 0.4) > 0);
        assert_eq!(closed(0.0, 0.4), suspected(0.0, 0.4));
        // the stretch past the wall, 1.2 m: its middle stays suspected, its ends are closed
        assert!(closed(0.4, 1.7) > 0);
        assert_eq!(closed(0.7, 1.35), 0, "{out:?}");
        assert!(
            out.iter()
                .all(|&i| classes[i] == cell_class::SUSPECTED_GLASS)
        );
        // a smaller body passes nearer: less is closed
        let mut less = Vec::new();
        too_narrow(&classes, grid, 0.1, &mut less);
        assert!(less.len() < out.len());
        // nothing suspected, nothing closed
        let (grid, plain) = map(|x, _| match (x - 1.0).abs() < 0.03 {
            true => cell_class::GLASS,
            false => cell_class::FREE,
        });
        too_narrow(&plain, grid, 0.25, &mut out);
        assert!(out.is_empty());
    }
}
