//! A curtain's free end, kept off as a pane's end is (issue 22).
//!
//! A string curtain is passable, so the body may touch it; a wall beside a door is solid, so the
//! body keeps `planner.margin_m` from its end. A curtain that ends in free floor is the case
//! between: where its line goes on unseen, the jamb of its door may be a frameless pane. Such a
//! pane returns light only to a beam that meets it squarely, i.e. only where the foot of the
//! sensor's perpendicular on the line lies on it; a robot crossing the line through the curtain
//! at a slant keeps that foot on the curtain, never sees the pane, and its round body sweeps the
//! pane's end within its radius before the sensor reaches the line (`curtain s100 i14` of the
//! tune worlds, docs/evaluation.md). [`curtain_ends`] finds the cells where a thin line of
//! passable cells ends with nothing on its far side; the planner draws them as suspected glass, so
//! the body keeps its margin from them as from a wall's end, and the rest of the curtain stays
//! passable.

use mimnav_shared::grid::GridSpec;
use mimnav_shared::topics::cell_class;

use crate::route::Side;

/// The square rings around a cell on which [`curtain_ends`] reads the line it ends, from the
/// nearest to the farthest, m: a curtain's strings leave a ragged band 0.1–0.2 m thick in the map,
/// so its direction is read beyond that, and out to where a tuft of grass has ended.
const LINE_M: (f32, f32) = (0.25, 0.6);

/// Most cells the line may have on one ring of [`LINE_M`]: a band up to 0.2 m thick crossing a
/// ring at a slant has up to about eight; the edge of a field of grass has many more.
const THIN_CELLS: u32 = 8;

/// How far a cell's offset may point back from the line's direction (the cosine of the angle
/// between them) and still be beside the end rather than beyond it.
const BEYOND_COS: f32 = -0.3;

/// Cells of a row [`curtain_ends`] tests for a string at once before it reads them one by one.
const CHUNK: usize = 16;

/// Most passable or solid neighbours a line's end cell has (of eight); a cell inside a field of
/// grass has more, and is passed over before any ring is read.
const END_NEIGHBOURS: u32 = 5;

/// Pushes into `out` the index of every passable (or solid: the mapper calls a curtain's tip solid
/// now and then) cell from `behind_m` behind the map's centre (the robot) to `within_m` ahead of it
/// and `within_m` to each side, that is the free end of a thin straight line of mostly passable
/// cells:
/// - on each ring of [`LINE_M`] around it the passable and solid cells (unknown counts as free)
///   are at most [`THIN_CELLS`], at least half of them passable, with no glass or suspected
///   glass, and lie to one side ([`Side`], as a wall's end does), the same side on every ring:
///   the line it ends;
/// - nearer than that, no glass, and nothing passable or solid beyond it (against the line's
///   direction): the band's last cells, ragged as it is.
///
/// A curtain that ends at a wall, a pane or a post is no free end (the jamb is on the far side);
/// nor is a wall's end (no strings), nor a cell inside a field of grass or at its edge.
pub fn curtain_ends(
    classes: &[u8],
    grid: GridSpec,
    (behind_m, within_m): (f32, f32),
    out: &mut Vec<usize>,
) {
    out.clear();
    // NaN fails both range tests
    if classes.len() != grid.len()
        || grid.is_empty()
        || !(f32::MIN_POSITIVE..=f32::MAX).contains(&within_m)
        || !(0.0..=within_m).contains(&behind_m)
    {
        return;
    }
    let (Some((r0, c0)), Some((r1, c1))) = (
        grid.cell_of(-behind_m, -within_m),
        grid.cell_of(within_m, within_m),
    ) else {
        return;
    };
    let cells_out = |m: f32| (m / grid.cell_m).round().max(2.0) as isize;
    let (first, far) = (cells_out(LINE_M.0), cells_out(LINE_M.1));
    let n = grid.cells as isize;
    // the rings must lie within the map
    let (lo, hi) = (far as usize, (n - far).max(0) as usize);
    let rows = r0.min(r1).max(lo)..r0.max(r1).saturating_add(1).min(hi);
    let cols = c0.min(c1).max(lo)..c0.max(c1).saturating_add(1).min(hi);
    let w = grid.cells;
    // the neighbours' offsets in opposite pairs, the row's own first (the same cache line)
    let around = [1, w, w + 1, w - 1];
    for r in rows {
        let row = &classes[grid.index(r, 0)..grid.index(r, 0) + w];
        // most of a map is free floor: a run of CHUNK cells without a string is passed over
        // whole (a test the compiler makes on many cells at a time)
        for start in cols.clone().step_by(CHUNK) {
            let end = (start + CHUNK).min(cols.end);
            if !row[start..end]
                .iter()
                .fold(false, |any, &cl| any | strings(cl))
            {
                continue;
            }
            for c in start..end {
                let i = grid.index(r, c);
                let cl = classes[i];
                if !strings(cl) {
                    continue;
                }
                // a wall's cell (no string beside it), a cell inside a field of grass (more than
                // END_NEIGHBOURS strings around it) and one a line runs through (strings on two
                // opposite sides) are passed over before any ring is read
                let (mut neighbours, mut passable) = (0, cl == cell_class::PASSABLE);
                let through = around.iter().any(|&d| {
                    let (a, b) = (classes[i - d], classes[i + d]);
                    neighbours += u32::from(strings(a)) + u32::from(strings(b));
                    passable |= a == cell_class::PASSABLE || b == cell_class::PASSABLE;
                    strings(a) && strings(b)
                });
                if through || !passable || neighbours > END_NEIGHBOURS {
                    continue;
                }
                let (r, c) = (r as isize, c as isize);
                let class_at = |dr: isize, dc: isize| classes[((r + dr) * n + c + dc) as usize];
                if is_free_end(first, far, class_at) {
                    out.push(i);
                }
            }
        }
    }
}

/// A cell a curtain leaves in the map: passable, or now and then solid at its tip.
fn strings(class: u8) -> bool {
    class == cell_class::PASSABLE || class == cell_class::SOLID
}

/// Calls `f` with the offsets of the square ring `k` cells around a cell (Chebyshev distance
/// `k`), each once, until it returns false; false when it did.
fn ring(k: isize, mut f: impl FnMut(isize, isize) -> bool) -> bool {
    for dc in -k..=k {
        if !f(-k, dc) || !f(k, dc) {
            return false;
        }
    }
    for dr in 1 - k..k {
        if !f(dr, -k) || !f(dr, k) {
            return false;
        }
    }
    true
}

/// The test of [`curtain_ends`] on one cell, `class(dr, dc)` the class at that offset, the
/// line's rings `first..=far` cells out.
fn is_free_end(first: isize, far: isize, class: impl Fn(isize, isize) -> u8) -> bool {
    let line = |k: isize| -> Option<(f32, f32)> {
        // a curtain's line: thin, mostly strings, no glass (given up at the first cell too many)
        let (mut side, mut passable) = (Side::default(), 0u32);
        let thin = ring(k, |dr, dc| {
            let cl = class(dr, dc);
            if cell_class::is_glass(cl) {
                return false;
            }
            if strings(cl) {
                side.add(dr, dc);
                if side.count > THIN_CELLS {
                    return false;
                }
                passable += u32::from(cl == cell_class::PASSABLE);
            }
            true
        });
        // all to one side, as a wall's end is
        side.one_way()
            .filter(|_| thin && 2 * passable >= side.count)
    };
    let Some(towards) = line(first) else {
        return false;
    };
    // the band's end: no glass near it, nothing beyond it (a post, a wall's end, more strings)
    for dr in -(first - 1)..first {
        for dc in -(first - 1)..first {
            let cl = class(dr, dc);
            if cell_class::is_glass(cl) {
                return false;
            }
            if (dr, dc) == (0, 0) || !strings(cl) {
                continue;
            }
            let len = ((dr * dr + dc * dc) as f32).sqrt();
            if (dr as f32 * towards.0 + dc as f32 * towards.1) / len < BEYOND_COS {
                return false;
            }
        }
    }
    ((first + 1)..=far)
        .all(|k| line(k).is_some_and(|dir| towards.0 * dir.0 + towards.1 * dir.1 >= 0.9))
}

#[cfg(test)]
mod tests {
    use super::*;

    const GRID: GridSpec = GridSpec {
        cells: 100,
        cell_m: 0.05,
    };

    /// A map with `class` on the cells (x, y) of the segment from `a` to `b` (robot frame, m).
    fn draw(classes: &mut [u8], a: (f32, f32), b: (f32, f32), class: u8) {
        let steps = ((b.0 - a.0).hypot(b.1 - a.1) / (GRID.cell_m / 4.0)).ceil() as usize;
        for i in 0..=steps {
            let t = i as f32 / steps.max(1) as f32;
            let (x, y) = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
            if let Some((r, c)) = GRID.cell_of(x, y) {
                classes[GRID.index(r, c)] = class;
            }
        }
    }

    fn ends(classes: &[u8]) -> Vec<(f32, f32)> {
        let mut out = Vec::new();
        curtain_ends(classes, GRID, (2.4, 2.4), &mut out);
        out.iter()
            .map(|&i| GRID.center_of(i / GRID.cells, i % GRID.cells))
            .collect()
    }

    fn near(found: &[(f32, f32)], at: (f32, f32)) -> bool {
        found
            .iter()
            .any(|&(x, y)| (x - at.0).hypot(y - at.1) <= 1.5 * GRID.cell_m)
    }

    #[test]
    fn a_ring_holds_each_cell_at_its_distance_once() {
        for k in 1..=12 {
            let mut cells = Vec::new();
            assert!(ring(k, |dr, dc| {
                cells.push((dr, dc));
                true
            }));
            assert_eq!(cells.len(), 8 * k as usize);
            assert!(cells.iter().all(|&(dr, dc)| dr.abs().max(dc.abs()) == k));
            cells.sort_unstable();
            cells.dedup();
            assert_eq!(cells.len(), 8 * k as usize);
        }
        // a visit that says stop ends the walk there
        let mut seen = 0;
        assert!(!ring(3, |_, _| {
            seen += 1;
            seen < 5
        }));
        assert_eq!(seen, 5);
    }

    #[test]
    fn a_curtain_ending_in_free_floor_has_that_end_and_only_it_found() {
        // a slanted curtain from a wall's end to free floor, as in `curtain s100 i14`
        let mut classes = vec![cell_class::FREE; GRID.len()];
        draw(&mut classes, (-1.5, -2.0), (-0.3, -0.6), cell_class::SOLID);
        draw(
            &mut classes,
            (-0.3, -0.6),
            (0.6, 0.45),
            cell_class::PASSABLE,
        );
        let found = ends(&classes);
        assert!(near(&found, (0.6, 0.45)), "{found:?}");
        // nothing along the curtain, and nothing at the end that meets the wall
        assert!(
            found.iter().all(|&(x, y)| (x - 0.6).hypot(y - 0.45) < 0.15),
            "{found:?}"
        );
    }

    #[test]
    fn a_ragged_band_of_strings_has_its_tip_found_and_not_its_inside() {
        // a curtain as the map shows it: a band 0.15 m thick, with holes, slanted
        let mut classes = vec![cell_class::FREE; GRID.len()];
        for w in [-0.05f32, 0.0, 0.05, 0.08] {
            draw(
                &mut classes,
                (-1.2 + w, -1.5),
                (0.5 + w, 0.2),
                cell_class::PASSABLE,
            );
        }
        for i in (0..GRID.len()).step_by(7) {
            if classes[i] == cell_class::PASSABLE {
                classes[i] = cell_class::FREE;
            }
        }
        let found = ends(&classes);
        // both tips, and only cells within 0.15 m of one
        let tips = [(0.52, 0.2), (-1.2, -1.5)];
        assert!(tips.iter().all(|&t| near(&found, t)), "{found:?}");
        assert!(
            found
                .iter()
                .all(|&(x, y)| tips.iter().any(|t| (x - t.0).hypot(y - t.1) < 0.15)),
            "{found:?}"
        );
    }

    #[test]
    fn a_curtain_between_walls_a_field_of_grass_and_a_short_tuft_have_no_free_end() {
        let mut classes = vec![cell_class::FREE; GRID.len()];
        // a curtain filling a door between two walls
        draw(&mut classes, (1.0, -2.0), (1.0, -0.5), cell_class::SOLID);
        draw(&mut classes, (1.0, -0.5), (1.0, 0.5), cell_class::PASSABLE);
        draw(&mut classes, (1.0, 0.5), (1.0, 2.0), cell_class::SOLID);
        // a field of grass behind the robot
        for x in 0..20 {
            let x = -1.8 + x as f32 * 0.05;
            draw(&mut classes, (x, -1.5), (x, 1.5), cell_class::PASSABLE);
        }
        // a tuft 0.3 m long in free floor
        draw(&mut classes, (0.2, 1.2), (0.2, 1.5), cell_class::PASSABLE);
        assert_eq!(ends(&classes), Vec::<(f32, f32)>::new());
    }

    #[test]
    fn a_curtain_ending_at_a_pane_or_with_a_post_beside_its_end_has_no_free_end() {
        let mut classes = vec![cell_class::FREE; GRID.len()];
        draw(&mut classes, (1.0, -1.0), (1.0, 0.0), cell_class::PASSABLE);
        draw(&mut classes, (1.0, 0.0), (1.0, 1.0), cell_class::GLASS);
        draw(
            &mut classes,
            (-1.0, -1.0),
            (-1.0, 0.0),
            cell_class::PASSABLE,
        );
        draw(&mut classes, (-1.0, 0.2), (-1.0, 0.25), cell_class::SOLID);
        let found = ends(&classes);
        // the curtains' other ends are free; the ends at the pane and at the post are not (the
        // post's far side is the line's free end now, and the post may be kept off as glass)
        assert!(
            near(&found, (1.0, -1.0)) && near(&found, (-1.0, -1.0)),
            "{found:?}"
        );
        assert!(
            found.iter().all(|&(_, y)| !(-0.8..0.2).contains(&y)),
            "{found:?}"
        );
    }

    #[test]
    fn nothing_is_found_beyond_the_window_or_on_a_map_of_the_wrong_size() {
        let mut classes = vec![cell_class::FREE; GRID.len()];
        draw(&mut classes, (1.0, -1.0), (1.0, 0.0), cell_class::PASSABLE);
        let mut out = vec![7];
        curtain_ends(&classes, GRID, (0.5, 0.5), &mut out);
        assert!(out.is_empty());
        curtain_ends(&classes, GRID, (2.4, 2.4), &mut out);
        assert!(!out.is_empty());
        // the curtain lies ahead: a window that ends at the robot has nothing
        curtain_ends(&classes, GRID, (2.4, 0.0), &mut out);
        assert!(out.is_empty());
        curtain_ends(&classes[1..], GRID, (2.4, 2.4), &mut out);
        assert!(out.is_empty());
        curtain_ends(&classes, GRID, (0.0, f32::NAN), &mut out);
        assert!(out.is_empty());
        curtain_ends(&classes, GRID, (3.0, 2.4), &mut out);
        assert!(out.is_empty());
    }
}
