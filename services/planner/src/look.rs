//! Going to look at suspected glass (issue 22, item 3: "may move so that a suspected pane gets
//! seen").
//!
//! A pane returns light only where a beam meets it within a few degrees of normal incidence, so
//! the mapper shows where a pane has been seen and draws its line on, as *suspected glass*,
//! where it has not. A stretch of the line is cleared (an opening) only where a beam within
//! `mapper.glass_normal_deg` of normal passed it: at the foot of the perpendicular from the
//! sensor, a strip `2·d·tan(glass_normal_deg)` wide at distance `d` (7 cm at 1 m). The route may
//! cross suspected glass at a cost, and leads the robot to the cheapest stretch; but a robot
//! that stands or circles in front of it moves the foot of the perpendicular hardly at all, and
//! the stretch stays suspected — the robot's commonest end before an unfaced door.
//!
//! What sweeps the foot along the line is driving *beside* it. So when the robot has made no
//! progress along its route for a while and the route leads into suspected glass close ahead,
//! [`stretch_at`] fits the line through the suspected and glass cells there and
//! [`look_target`] picks a point beside it, past the stretch's end, at the robot's own distance
//! from the line: driving there, the robot faces the whole stretch squarely once. Then the map
//! says glass or opening, and the route goes on or goes round. A look at a door ends as soon as
//! the door is seen whole ([`Stretch::whole_m`]): the suspected stretch it was sent past runs
//! on beyond the door's far edge, as the pane's line drawn on.

use mimnav_shared::grid::GridSpec;
use mimnav_shared::topics::cell_class;

use crate::route::Route;

/// A stretch of suspected glass as a line in the robot frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stretch {
    /// A point on the line: where the route meets the suspected glass, m.
    pub point: (f64, f64),
    /// Unit vector along the line.
    pub dir: (f64, f64),
    /// The suspected cells' extent along `dir`, from `point`, m (`from_m` ≤ 0 ≤ `to_m`).
    pub from_m: f64,
    /// See `from_m`.
    pub to_m: f64,
    /// The free width of the widest gap of free cells the line has next to the suspected ones,
    /// m (0: none; see [`Stretch::opening`]).
    pub seen_m: f64,
    /// The free width of the widest such gap with seen glass at both ends, none suspected: a
    /// door seen whole, edge to edge (0: none).
    pub whole_m: f64,
}

impl Stretch {
    /// The line has a gap of free cells next to the suspected ones: an opening seen in part
    /// (the mapper clears a pane's line only where a beam crossed it squarely, so the rest of
    /// a door the robot faced stays suspected), not a pane never faced at all.
    pub fn opening(&self) -> bool {
        self.seen_m > 0.0
    }

    /// Worth a look: with `openings_only`, a door seen in part whose seen gap is still
    /// narrower than `wide_m` (what the footprint needs); else any suspected stretch.
    pub fn worth_a_look(&self, openings_only: bool, wide_m: f64) -> bool {
        !openings_only || (self.opening() && self.seen_m < wide_m)
    }
}

/// Follows the route downhill from the robot (the map's centre) in steps of a map cell for up
/// to `within_m`, and returns the suspected-glass cell the route leads into: the nearest one
/// within `touch_m` of where the descent stops short of the goal. (Leaving a cell where the
/// footprint would touch suspected glass costs `planner.route_suspect_weight` more per metre,
/// so the route's lengths rise into that band before they fall beyond it: the descent stops at
/// its edge.) None when the way runs `within_m` or reaches the goal first, or stops with no
/// suspected glass near.
pub fn route_meets_suspected(
    route: &Route,
    classes: &[u8],
    grid: GridSpec,
    within_m: f64,
    touch_m: f64,
) -> Option<(f64, f64)> {
    if classes.len() != grid.len() {
        return None;
    }
    let step = f64::from(grid.cell_m).max(0.02);
    let (mut x, mut y) = (0.0f64, 0.0f64);
    let mut here = route.value(0.0, 0.0);
    if !here.is_finite() {
        return None;
    }
    let mut walked = 0.0;
    while walked < within_m {
        // the lowest of 16 directions a step away
        let mut best = (here, x, y);
        for k in 0..16 {
            let a = f64::from(k) * std::f64::consts::PI / 8.0;
            let (nx, ny) = (x + step * a.cos(), y + step * a.sin());
            let v = route.value(nx as f32, ny as f32);
            if v < best.0 {
                best = (v, nx, ny);
            }
        }
        if best.0 >= here {
            if here < step as f32 {
                return None;
            }
            return nearest_suspected(classes, grid, (x, y), touch_m);
        }
        (here, x, y) = best;
        walked += step;
    }
    None
}

/// The centre of the suspected-glass cell nearest `at` within `radius_m`.
fn nearest_suspected(
    classes: &[u8],
    grid: GridSpec,
    at: (f64, f64),
    radius_m: f64,
) -> Option<(f64, f64)> {
    let (r0, c0) = clamp_cell(grid, at.0 - radius_m, at.1 - radius_m)?;
    let (r1, c1) = clamp_cell(grid, at.0 + radius_m, at.1 + radius_m)?;
    let mut best: Option<(f64, (f64, f64))> = None;
    for r in r0.min(r1)..=r0.max(r1) {
        for c in c0.min(c1)..=c0.max(c1) {
            if classes[grid.index(r, c)] != cell_class::SUSPECTED_GLASS {
                continue;
            }
            let (x, y) = grid.center_of(r, c);
            let (x, y) = (f64::from(x), f64::from(y));
            let d = (x - at.0).hypot(y - at.1);
            if d <= radius_m && best.is_none_or(|b| d < b.0) {
                best = Some((d, (x, y)));
            }
        }
    }
    best.map(|b| b.1)
}

/// The line through the glass and suspected-glass cells within `radius_m` of `at` (their
/// principal axis), and the extent of the suspected ones along it. None with fewer than three
/// such cells or no clear direction (a blob rather than a line).
pub fn stretch_at(
    classes: &[u8],
    grid: GridSpec,
    at: (f64, f64),
    radius_m: f64,
) -> Option<Stretch> {
    if classes.len() != grid.len() {
        return None;
    }
    let mut pts: Vec<(f64, f64, bool)> = Vec::new();
    let (x0, y0) = (at.0 - radius_m, at.1 - radius_m);
    let (x1, y1) = (at.0 + radius_m, at.1 + radius_m);
    let (Some((r0, c0)), Some((r1, c1))) = (clamp_cell(grid, x0, y0), clamp_cell(grid, x1, y1))
    else {
        return None;
    };
    for r in r0.min(r1)..=r0.max(r1) {
        for c in c0.min(c1)..=c0.max(c1) {
            let class = classes[grid.index(r, c)];
            if !cell_class::is_glass(class) {
                continue;
            }
            let (x, y) = grid.center_of(r, c);
            let (x, y) = (f64::from(x), f64::from(y));
            if (x - at.0).hypot(y - at.1) <= radius_m {
                pts.push((x, y, class == cell_class::SUSPECTED_GLASS));
            }
        }
    }
    if pts.len() < 3 {
        return None;
    }
    let n = pts.len() as f64;
    let (mx, my) = pts
        .iter()
        .fold((0.0, 0.0), |(a, b), p| (a + p.0 / n, b + p.1 / n));
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in &pts {
        let (dx, dy) = (p.0 - mx, p.1 - my);
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
    }
    // the principal axis of the 2 × 2 covariance, and how much more it holds than the other
    let tr = sxx + syy;
    let det = sxx * syy - sxy * sxy;
    let disc = (tr * tr / 4.0 - det).max(0.0).sqrt();
    let (l1, l2) = (tr / 2.0 + disc, tr / 2.0 - disc);
    if l1 <= 0.0 || l2 > 0.25 * l1 {
        return None;
    }
    let a = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let dir = (a.cos(), a.sin());
    let along = |p: &(f64, f64, bool)| (p.0 - at.0) * dir.0 + (p.1 - at.1) * dir.1;
    let (mut from_m, mut to_m) = (0.0f64, 0.0f64);
    for p in pts.iter().filter(|p| p.2) {
        let s = along(p);
        from_m = from_m.min(s);
        to_m = to_m.max(s);
    }
    let (seen_m, whole_m) = seen_gap(classes, grid, &pts, (mx, my), dir);
    Some(Stretch {
        point: at,
        dir,
        from_m,
        to_m,
        seen_m,
        whole_m,
    })
}

/// The free width of the widest gap the line through `centre` along `dir` has between two of
/// its glass or suspected cells `pts` (at least one of them suspected), at least two cells long,
/// whose cells on the line are all free: seen open, not unknown and not a frame (0: none); and
/// of the widest such gap between two glass cells, neither of them suspected.
fn seen_gap(
    classes: &[u8],
    grid: GridSpec,
    pts: &[(f64, f64, bool)],
    centre: (f64, f64),
    dir: (f64, f64),
) -> (f64, f64) {
    let cell = f64::from(grid.cell_m);
    // the cells on the line (within a cell and a half of it), by their place along it
    let mut on: Vec<(f64, bool)> = pts
        .iter()
        .filter_map(|p| {
            let (dx, dy) = (p.0 - centre.0, p.1 - centre.1);
            let across = (-dir.1 * dx + dir.0 * dy).abs();
            (across <= 1.5 * cell).then_some((dx * dir.0 + dy * dir.1, p.2))
        })
        .collect();
    on.sort_by(|a, b| a.0.total_cmp(&b.0));
    let free = on.windows(2).filter(|w| {
        let ((a, _), (b, _)) = (w[0], w[1]);
        // a diagonal line's neighbouring cells lie up to √2 cells apart along it
        if b - a < 2.5 * cell {
            return false;
        }
        // the gap's inside, a cell clear of the cells at its ends
        let (a, b) = (a + cell, b - cell);
        let steps = ((b - a) / (0.5 * cell)).ceil().max(1.0) as usize;
        (0..=steps).all(|k| {
            let s = a + (b - a) * k as f64 / steps as f64;
            let (x, y) = (centre.0 + s * dir.0, centre.1 + s * dir.1);
            grid.cell_of(x as f32, y as f32)
                .is_some_and(|(r, c)| classes[grid.index(r, c)] == cell_class::FREE)
        })
    });
    // the free width: between the cells' edges, not their centres
    free.fold((0.0, 0.0), |(seen, whole), w| {
        let width = w[1].0 - w[0].0 - cell;
        if w[0].1 || w[1].1 {
            (seen.max(width), whole)
        } else {
            (seen, whole.max(width))
        }
    })
}

/// The map cell nearest (x, y), for a window that reaches past the map's edge.
fn clamp_cell(grid: GridSpec, x: f64, y: f64) -> Option<(usize, usize)> {
    let h = f64::from(grid.half_extent_m()) - 0.5 * f64::from(grid.cell_m);
    grid.cell_of(x.clamp(-h, h) as f32, y.clamp(-h, h) as f32)
}

/// Where to drive to sweep `s` with the foot of the perpendicular: beside the line, on the
/// robot's side, at the robot's own distance from it (kept within `min_d`–`max_d`), and
/// `overshoot` past the stretch's end in the direction `sign` (+1 along `dir`, −1 against it).
pub fn look_target(s: &Stretch, sign: f64, min_d: f64, max_d: f64, overshoot: f64) -> (f64, f64) {
    // the robot is at the origin: its offset from the line, along the line's normal
    let (nx, ny) = (-s.dir.1, s.dir.0);
    let off = -(s.point.0 * nx + s.point.1 * ny);
    let side = if off < 0.0 { -1.0 } else { 1.0 };
    let d = off.abs().clamp(min_d, max_d.max(min_d));
    let end = if sign >= 0.0 {
        s.to_m + overshoot
    } else {
        s.from_m - overshoot
    };
    (
        s.point.0 + end * s.dir.0 + side * d * nx,
        s.point.1 + end * s.dir.1 + side * d * ny,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::route::RouteParams;

    fn grid() -> GridSpec {
        GridSpec {
            cells: 100,
            cell_m: 0.1,
        }
    }

    /// A pane across the map 2 m ahead (x = 2), seen as glass but for a suspected stretch
    /// 1.2 m wide around y = 0.5.
    fn pane() -> Vec<u8> {
        let g = grid();
        let mut classes = vec![cell_class::FREE; g.len()];
        for k in -50..50 {
            let y = k as f32 * 0.1 + 0.05;
            if let Some((r, c)) = g.cell_of(2.05, y) {
                classes[g.index(r, c)] = if (-0.1..1.1).contains(&y) {
                    cell_class::SUSPECTED_GLASS
                } else {
                    cell_class::GLASS
                };
            }
        }
        classes
    }

    fn route_to(classes: &[u8], goal: (f32, f32)) -> Route {
        let mut route = Route::default();
        let cost = vec![0u8; classes.len()];
        route.build(
            &RouteParams {
                cell_m: 0.2,
                radius_m: 0.3,
                cost_weight: 1.0,
                swing_m: 0.0,
                swing_weight: 0.0,
                suspect_weight: 10.0,
                end_m: 0.0,
                settle_within_m: 0.0,
            },
            grid(),
            classes,
            &cost,
            goal,
        );
        route
    }

    #[test]
    fn the_route_through_an_unfaced_door_meets_it_and_the_sweep_runs_beside_it() {
        let classes = pane();
        let route = route_to(&classes, (4.0, 0.5));
        let at = route_meets_suspected(&route, &classes, grid(), 3.0, 0.6).expect("meets it");
        assert!((at.0 - 2.0).abs() < 0.15, "{at:?}");
        assert!((-0.1..1.1).contains(&at.1), "{at:?}");
        let s = stretch_at(&classes, grid(), at, 1.5).expect("a line");
        // along y, the suspected cells from -0.05 to 1.05
        assert!(s.dir.0.abs() < 0.05, "{s:?}");
        let ends = [at.1 + s.from_m * s.dir.1, at.1 + s.to_m * s.dir.1];
        let (lo, hi) = (ends[0].min(ends[1]), ends[0].max(ends[1]));
        assert!(
            (lo + 0.05).abs() < 0.11 && (hi - 1.05).abs() < 0.11,
            "{lo} {hi}"
        );
        // beside the line on the robot's side at its distance (2 m, kept to 1.5 m), past the end
        let t = look_target(&s, 1.0, 0.6, 1.5, 0.3);
        let t2 = look_target(&s, -1.0, 0.6, 1.5, 0.3);
        for t in [t, t2] {
            assert!((t.0 - 0.55).abs() < 0.1, "{t:?}");
        }
        let (ylo, yhi) = (t.1.min(t2.1), t.1.max(t2.1));
        assert!(ylo < -0.3 && yhi > 1.3, "{ylo} {yhi}");
    }

    #[test]
    fn a_route_through_the_open_or_past_seen_glass_meets_nothing() {
        let g = grid();
        let free = vec![cell_class::FREE; g.len()];
        let route = route_to(&free, (4.0, 0.0));
        assert_eq!(route_meets_suspected(&route, &free, g, 3.0, 0.6), None);
        // the same pane all seen, with a door at y = 3: the route goes round, meeting no
        // suspected glass
        let mut classes = pane();
        for c in classes.iter_mut() {
            if *c == cell_class::SUSPECTED_GLASS {
                *c = cell_class::GLASS;
            }
        }
        for k in 25..35 {
            if let Some((r, c)) = g.cell_of(2.05, k as f32 * 0.1 + 0.05) {
                classes[g.index(r, c)] = cell_class::FREE;
            }
        }
        let route = route_to(&classes, (4.0, 0.0));
        assert!(route.value(0.0, 0.0).is_finite());
        assert_eq!(route_meets_suspected(&route, &classes, g, 4.0, 0.6), None);
    }

    #[test]
    fn a_door_seen_in_part_is_an_opening_and_an_unfaced_one_is_not() {
        let g = grid();
        let classes = pane();
        let at = (2.05, 0.45);
        // suspected from y = -0.05 to 1.05, glass either side: never faced
        let s = stretch_at(&classes, g, at, 1.5).expect("a line");
        assert!(!s.opening(), "{s:?}");
        // the middle of the door seen open (free), the rest still suspected: an opening
        let mut seen = classes.clone();
        for k in 3..7 {
            if let Some((r, c)) = g.cell_of(2.05, k as f32 * 0.1 + 0.05) {
                seen[g.index(r, c)] = cell_class::FREE;
            }
        }
        let door = stretch_at(&seen, g, at, 1.5).expect("a line");
        // four free cells between the suspected ones
        assert!(
            door.opening() && (door.seen_m - 0.4).abs() < 0.01,
            "{door:?}"
        );
        // looked at while that gap is narrower than the footprint needs, not once it is wider
        assert!(door.worth_a_look(true, 0.6) && !door.worth_a_look(true, 0.35));
        assert!(!s.worth_a_look(true, 0.6) && s.worth_a_look(false, 0.6));
        // a one-cell gap is the line's own raggedness, not an opening
        let mut ragged = classes.clone();
        if let Some((r, c)) = g.cell_of(2.05, 0.45) {
            ragged[g.index(r, c)] = cell_class::FREE;
        }
        assert!(!stretch_at(&ragged, g, at, 1.5).expect("a line").opening());
        // a gap not seen (unknown) or closed by a frame (solid) is none either
        for class in [cell_class::UNKNOWN, cell_class::SOLID] {
            let mut other = seen.clone();
            for k in 3..7 {
                if let Some((r, c)) = g.cell_of(2.05, k as f32 * 0.1 + 0.05) {
                    other[g.index(r, c)] = class;
                }
            }
            assert!(!stretch_at(&other, g, at, 1.5).expect("a line").opening());
        }
        // a gap between two glass stretches, no suspected glass beside it: a door already seen
        let mut glass = seen.clone();
        for c in glass.iter_mut() {
            if *c == cell_class::SUSPECTED_GLASS {
                *c = cell_class::GLASS;
            }
        }
        let whole = stretch_at(&glass, g, at, 1.5).expect("a line");
        assert!(!whole.opening(), "{whole:?}");
        // ... seen whole, edge to edge, which a door seen in part is not
        assert!((whole.whole_m - 0.4).abs() < 0.01, "{whole:?}");
        assert_eq!(door.whole_m, 0.0, "{door:?}");
    }

    #[test]
    fn a_diagonal_line_is_no_gap_but_a_door_in_it_is() {
        // a pane at 35° through (2, 0), suspected, its cells as the mapper draws them
        let g = grid();
        let mut classes = vec![cell_class::FREE; g.len()];
        let (dx, dy) = (35f64.to_radians().cos(), 35f64.to_radians().sin());
        let mark = |classes: &mut Vec<u8>, t: f64, class: u8| {
            if let Some((r, c)) = g.cell_of((2.0 + t * dy) as f32, (t * dx) as f32) {
                classes[g.index(r, c)] = class;
            }
        };
        for k in -150..150 {
            mark(
                &mut classes,
                f64::from(k) * 0.01,
                cell_class::SUSPECTED_GLASS,
            );
        }
        let at = (2.0, 0.0);
        assert!(!stretch_at(&classes, g, at, 1.5).expect("a line").opening());
        for k in -20..20 {
            mark(&mut classes, f64::from(k) * 0.01, cell_class::FREE);
        }
        assert!(
            stretch_at(&classes, g, (2.0 + 0.5 * dy, 0.5 * dx), 1.5)
                .expect("a line")
                .opening()
        );
    }

    #[test]
    fn a_blob_is_no_line() {
        let g = grid();
        let mut classes = vec![cell_class::FREE; g.len()];
        for dr in 0..4 {
            for dc in 0..4 {
                classes[g.index(60 + dr, 50 + dc)] = cell_class::SUSPECTED_GLASS;
            }
        }
        let (x, y) = g.center_of(61, 51);
        assert_eq!(
            stretch_at(&classes, g, (f64::from(x), f64::from(y)), 1.0),
            None
        );
    }
}
