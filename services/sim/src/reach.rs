//! Ground-truth reachability: can a robot of a given radius get from a scene's start onto its
//! goal circle without touching anything?
//!
//! "Touching" is exactly what ends a simulated episode: [`crate::motion::contact`], the
//! simulator's own collision test (a blocking object — wall, pillar, glass, bush, trunk, rock —
//! closer to the robot's centre than its radius; grass and curtains do not block). The robot is a
//! circle turning on the spot, so the question is whether the start and the goal circle
//! (`sim.goal_tolerance_m`, where the simulator ends an episode as reached) are connected in the
//! free space of the robot's centre. It is answered by a flood fill over the centres of a fine
//! grid anchored at the start, testing each centre with `contact` as it is reached.
//!
//! The grid makes the answer exact to a cell: a passage wider than the robot by more than one
//! cell (default [`CELL_M`], 2 cm) is found; one narrower than the robot never is. The world
//! need not be closed: the fill runs over the extent of the objects plus a margin wide enough for
//! the robot to go round all of them.
//!
//! A body that is not round (Spot's 1.1 × 0.5 m rectangle) depends on its heading: [`reach_by`]
//! fills poses (x, y, heading) instead, with the body's own contact test as a closure, and tests
//! it only where the heading matters (between the body's half width and its enclosing radius
//! from the nearest object).

use std::collections::VecDeque;

use crate::geometry::footprint_distance;
use mimnav_shared::config::Body;
use mimnav_shared::pose::pose2;

use crate::motion::{OUTLINE_SPACING_M, body_contact, contact};
use crate::world::Scene;

/// Default grid spacing, m.
pub const CELL_M: f64 = 0.02;

/// What the flood fill found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reach {
    /// The goal circle can be reached from the start.
    pub reachable: bool,
    /// The start itself touches an object.
    pub start_blocked: bool,
    /// Poses tested.
    pub tested: usize,
    /// The grid spacing the fill ran at, m: the one asked for, or coarser when the world is too
    /// large for [`MAX_POSES`] at that spacing.
    pub cell_m: f64,
    /// The fill ran at a coarser spacing than asked, the world being too large for
    /// [`MAX_POSES`] at that one.
    pub coarsened: bool,
}

/// Most poses (grid cells × headings) the fill keeps a bit for: 2³⁰, 128 MB (and, with several
/// headings, a 4-byte clearance per cell, at most 60 MB at [`BODY_HEADINGS`]). A world whose
/// extent needs more at the spacing asked for is filled at a coarser one, reported in
/// [`Reach::cell_m`] (a world spans at most 2 km, [`crate::world::WORLD_EXTENT_M`]).
pub const MAX_POSES: f64 = (1u64 << 30) as f64;

/// The robot's footprint as the flood fill needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Footprint {
    /// A pose whose centre is closer than this to a blocking object always touches it (a
    /// circle's radius; a rectangle's half width), m.
    pub inner_m: f64,
    /// A pose whose centre is at least this far from every blocking object never touches one
    /// (a circle's radius; a rectangle's enclosing radius), m.
    pub outer_m: f64,
    /// Headings tested, evenly spaced from the start's: 1 for a round robot (the heading does
    /// not matter); for a rectangle, e.g. 72 (5° apart).
    pub headings: usize,
}

/// Whether a round robot of `radius_m` can drive from `scene`'s start to within
/// `goal_tolerance_m` of its goal without contact, on a grid of `cell_m`: [`reach_by`] with the
/// simulator's [`contact`].
pub fn reach(scene: &Scene, radius_m: f64, goal_tolerance_m: f64, cell_m: f64) -> Reach {
    let round = Footprint {
        inner_m: radius_m,
        outer_m: radius_m,
        headings: 1,
    };
    reach_by(scene, round, goal_tolerance_m, cell_m, |x, y, _| {
        contact(scene, x, y, radius_m).is_some()
    })
}

/// Headings a rectangular body is tested at by [`reach_body`]: 5° apart.
pub const BODY_HEADINGS: usize = 72;
/// Grid spacing of [`reach_body`] for a rectangular body, m.
pub const BODY_CELL_M: f64 = 0.03;

/// Whether the robot's `body` can drive from `scene`'s start onto the goal circle without
/// contact, by the simulator's own test for that body ([`crate::motion::body_contact`]): a round
/// body by [`reach`] (exact to [`CELL_M`]); a rectangle over poses by [`reach_by`], exact to
/// [`BODY_CELL_M`] and half of 360° / [`BODY_HEADINGS`] (Spot's 1.1 m body turned 2.5° off a
/// gap's axis is 5 cm wider across it).
pub fn reach_body(scene: &Scene, body: &Body, goal_tolerance_m: f64) -> Reach {
    match *body {
        Body::Round(r) => reach(scene, r, goal_tolerance_m, CELL_M),
        Body::Rectangle { .. } => {
            let footprint = Footprint {
                inner_m: body.half_width_m(),
                // body_contact calls a contact up to half its outline spacing early
                outer_m: body.enclosing_radius_m() + 0.5 * OUTLINE_SPACING_M,
                headings: BODY_HEADINGS,
            };
            reach_by(
                scene,
                footprint,
                goal_tolerance_m,
                BODY_CELL_M,
                |x, y, yaw| body_contact(scene, &pose2(x, y, yaw), body).is_some(),
            )
        }
    }
}

/// Whether the start and the goal circle are connected in the free poses (x, y, heading) of a
/// robot whose contact test is `blocked(x, y, yaw)` — the simulator's own (for a rectangular
/// body, its body contact at that pose). With one heading the search is over positions only and
/// `blocked` decides every one. With several, a position closer than `footprint.inner_m` to a
/// blocking object is blocked at every heading and one at least `footprint.outer_m` from all is
/// free at every heading, and `blocked` decides only between the two. A robot that turns on the
/// spot and drives forward and back can follow any path through free poses, so connectivity is
/// the answer; the grid makes it exact to a cell and half a heading step.
pub fn reach_by(
    scene: &Scene,
    footprint: Footprint,
    goal_tolerance_m: f64,
    cell_m: f64,
    blocked: impl Fn(f64, f64, f64) -> bool,
) -> Reach {
    let start = [scene.start[0], scene.start[1]];
    let yaw0 = scene.start[2];
    let goal = scene.goal;
    let k_n = footprint.headings.max(1);
    if blocked(start[0], start[1], yaw0) {
        return Reach {
            reachable: false,
            start_blocked: true,
            tested: 1,
            cell_m,
            coarsened: false,
        };
    }
    // the extent: objects, start and goal, and room to go round them all
    let (mut x0, mut y0, mut x1, mut y1) = (start[0], start[1], start[0], start[1]);
    let mut grow = |x: f64, y: f64, r: f64| {
        x0 = x0.min(x - r);
        y0 = y0.min(y - r);
        x1 = x1.max(x + r);
        y1 = y1.max(y + r);
    };
    grow(goal[0], goal[1], goal_tolerance_m);
    for o in &scene.objects {
        grow(o.bound.0[0], o.bound.0[1], o.bound.1);
    }
    let asked = cell_m.max(1e-3);
    let mut cell = asked;
    let mut margin = 2.0 * footprint.outer_m + 4.0 * cell + 0.1;
    // bounded: a world too large for the grid at this spacing is filled at a coarser one
    let poses = |cell: f64, margin: f64| {
        ((x1 - x0 + 2.0 * margin) / cell + 2.0)
            * ((y1 - y0 + 2.0 * margin) / cell + 2.0)
            * k_n as f64
    };
    // NaN (a non-finite extent) never fits
    let fits = |cell: f64, margin: f64| poses(cell, margin) <= MAX_POSES;
    while !fits(cell, margin) && cell < 1e3 {
        cell *= 1.25;
        margin = 2.0 * footprint.outer_m + 4.0 * cell + 0.1;
    }
    if !fits(cell, margin) {
        // only a non-finite extent gets here (a scene not from a checked world file)
        return Reach {
            reachable: false,
            start_blocked: false,
            tested: 0,
            cell_m: cell,
            coarsened: true,
        };
    }
    // grid indices relative to the start's cell, i = (x − start) / cell
    let i0 = ((x0 - margin - start[0]) / cell).floor() as i64;
    let i1 = ((x1 + margin - start[0]) / cell).ceil() as i64;
    let j0 = ((y0 - margin - start[1]) / cell).floor() as i64;
    let j1 = ((y1 + margin - start[1]) / cell).ceil() as i64;
    let (w, h) = ((i1 - i0 + 1) as usize, (j1 - j0 + 1) as usize);
    // one bit per pose: reached (free and queued) or found blocked
    let mut seen = vec![0u64; (w * h * k_n).div_ceil(64)];
    let at = |i: i64, j: i64, k: usize| ((j - j0) as usize * w + (i - i0) as usize) * k_n + k;
    let centre = |i: i64, j: i64| [start[0] + i as f64 * cell, start[1] + j as f64 * cell];
    let yaw = |k: usize| yaw0 + std::f64::consts::TAU * k as f64 / k_n as f64;
    // with several headings: the clearance of each position, NaN until needed
    let mut clearance = if k_n > 1 {
        vec![f32::NAN; w * h]
    } else {
        Vec::new()
    };
    let mut clear_at = |i: i64, j: i64| -> f64 {
        let c = &mut clearance[(j - j0) as usize * w + (i - i0) as usize];
        if c.is_nan() {
            let p = centre(i, j);
            *c = scene
                .objects
                .iter()
                .filter(|o| o.blocks)
                .filter(|o| {
                    (o.bound.0[0] - p[0]).hypot(o.bound.0[1] - p[1])
                        <= o.bound.1 + footprint.outer_m
                })
                .map(|o| footprint_distance(&o.shape, p))
                .fold(f64::INFINITY, f64::min) as f32;
        }
        f64::from(*c)
    };
    let mut mark = |k: usize| {
        let (word, bit) = (k / 64, k % 64);
        let was = seen[word] >> bit & 1 == 1;
        seen[word] |= 1 << bit;
        was
    };
    let mut queue = VecDeque::new();
    mark(at(0, 0, 0));
    queue.push_back((0i64, 0i64, 0usize));
    let mut tested = 1;
    while let Some((i, j, k)) = queue.pop_front() {
        let p = centre(i, j);
        if (p[0] - goal[0]).hypot(p[1] - goal[1]) <= goal_tolerance_m {
            return Reach {
                reachable: true,
                start_blocked: false,
                tested,
                cell_m: cell,
                coarsened: cell > asked,
            };
        }
        let turns = if k_n > 1 {
            [(0, 0, 1), (0, 0, k_n - 1)]
        } else {
            [(0, 0, 0); 2]
        };
        for (di, dj, dk) in [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0)]
            .into_iter()
            .chain(turns.into_iter().filter(|t| t.2 != 0))
        {
            let (ni, nj, nk) = (i + di, j + dj, (k + dk) % k_n);
            if ni < i0 || ni > i1 || nj < j0 || nj > j1 || mark(at(ni, nj, nk)) {
                continue;
            }
            tested += 1;
            let q = centre(ni, nj);
            let free = if k_n == 1 {
                !blocked(q[0], q[1], yaw(nk))
            } else {
                let d = clear_at(ni, nj);
                d >= footprint.outer_m || (d >= footprint.inner_m && !blocked(q[0], q[1], yaw(nk)))
            };
            if free {
                queue.push_back((ni, nj, nk));
            }
        }
    }
    Reach {
        reachable: false,
        start_blocked: false,
        tested,
        cell_m: cell,
        coarsened: cell > asked,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::WorldFile;

    /// A closed room split at x = 3 by a wall with a gap `gap` wide (between the walls' ends),
    /// with `extra` objects inside the gap.
    fn gap_world(gap: f64, extra: &str) -> Scene {
        let text = format!(
            "name = 'gap'\nstart = [0.0, 0.0, 0.0]\ngoal = [6.0, 0.0]\ntime_limit_s = 10.0\n\
             [[wall]]\nfrom = [-1.0, -3.0]\nto = [8.0, -3.0]\n\
             [[wall]]\nfrom = [-1.0, 3.0]\nto = [8.0, 3.0]\n\
             [[wall]]\nfrom = [-1.0, -3.0]\nto = [-1.0, 3.0]\n\
             [[wall]]\nfrom = [8.0, -3.0]\nto = [8.0, 3.0]\n\
             [[wall]]\nfrom = [3.0, -3.0]\nto = [3.0, {a}]\n\
             [[wall]]\nfrom = [3.0, {b}]\nto = [3.0, 3.0]\n{extra}",
            a = 1.0 - gap / 2.0,
            b = 1.0 + gap / 2.0
        );
        WorldFile::parse(&text, "gap").expect("valid").compile()
    }

    #[test]
    fn a_gap_narrower_than_the_robot_is_impassable_a_wider_one_passable() {
        for radius in [0.2, 0.6] {
            let narrow = reach(&gap_world(2.0 * radius - 0.03, ""), radius, 0.3, CELL_M);
            assert!(
                !narrow.reachable && !narrow.start_blocked,
                "{radius}: {narrow:?}"
            );
            let wide = reach(&gap_world(2.0 * radius + 0.03, ""), radius, 0.3, CELL_M);
            assert!(wide.reachable, "{radius}: {wide:?}");
        }
    }

    #[test]
    fn curtains_and_grass_are_passable_glass_and_rocks_are_not() {
        let curtain = "[[curtain]]\nfrom = [3.0, 0.0]\nto = [3.0, 2.0]\n";
        assert!(reach(&gap_world(2.0, curtain), 0.6, 0.3, CELL_M).reachable);
        let grass = "[[grass]]\ncenter = [3.0, 1.0]\nsize = [1.0, 2.0]\n";
        assert!(reach(&gap_world(2.0, grass), 0.6, 0.3, CELL_M).reachable);
        let glass = "[[glass]]\nfrom = [3.0, 0.0]\nto = [3.0, 2.0]\n";
        assert!(!reach(&gap_world(2.0, glass), 0.2, 0.3, CELL_M).reachable);
        let rock = "[[rock]]\ncenter = [3.0, 1.0]\nradius = 0.5\n";
        // 0.5 m each side of the rock: a Turtlebot passes, Spot does not
        assert!(reach(&gap_world(2.0, rock), 0.2, 0.3, CELL_M).reachable);
        assert!(!reach(&gap_world(2.0, rock), 0.6, 0.3, CELL_M).reachable);
    }

    #[test]
    fn an_open_world_is_gone_round() {
        // a wall across the way, open at both ends: round it
        let text = "name = 'w'\nstart = [0.0, 0.0, 0.0]\ngoal = [6.0, 0.0]\ntime_limit_s = 10.0\n\
                    [[wall]]\nfrom = [3.0, -2.0]\nto = [3.0, 2.0]\n";
        let scene = WorldFile::parse(text, "w").expect("valid").compile();
        assert!(reach(&scene, 0.6, 0.3, 0.02).reachable);
    }

    /// A `length` × `width` rectangle at (x, y, yaw) touches a blocking object: any point of
    /// its outline (5 cm apart) within 1 cm of one — a stand-in for the simulator's body test.
    fn rectangle(scene: &Scene, length: f64, width: f64) -> impl Fn(f64, f64, f64) -> bool + '_ {
        let mut outline = Vec::new();
        let (hl, hw) = (length / 2.0, width / 2.0);
        let n = |l: f64| (l / 0.05).ceil() as usize;
        for s in 0..=n(length) {
            let x = -hl + length * s as f64 / n(length) as f64;
            outline.push([x, -hw]);
            outline.push([x, hw]);
        }
        for s in 0..=n(width) {
            let y = -hw + width * s as f64 / n(width) as f64;
            outline.push([-hl, y]);
            outline.push([hl, y]);
        }
        move |x, y, yaw| {
            let (s, c) = yaw.sin_cos();
            scene.objects.iter().filter(|o| o.blocks).any(|o| {
                outline.iter().any(|p| {
                    let q = [x + c * p[0] - s * p[1], y + s * p[0] + c * p[1]];
                    footprint_distance(&o.shape, q) < 0.01
                })
            })
        }
    }

    /// A small room 3 m across split at x = 1 by a wall with a gap `gap` wide about y = 0; the
    /// robot starts facing across the room (it must turn to pass).
    fn small_gap_world(gap: f64) -> Scene {
        let text = format!(
            "name = 'gap'\nstart = [0.0, 0.0, 90.0]\ngoal = [2.2, 0.0]\ntime_limit_s = 10.0\n\
             [[wall]]\nfrom = [-1.0, -1.5]\nto = [3.2, -1.5]\n\
             [[wall]]\nfrom = [-1.0, 1.5]\nto = [3.2, 1.5]\n\
             [[wall]]\nfrom = [-1.0, -1.5]\nto = [-1.0, 1.5]\n\
             [[wall]]\nfrom = [3.2, -1.5]\nto = [3.2, 1.5]\n\
             [[wall]]\nfrom = [1.0, -1.5]\nto = [1.0, {a}]\n\
             [[wall]]\nfrom = [1.0, {b}]\nto = [1.0, 1.5]\n",
            a = -gap / 2.0,
            b = gap / 2.0
        );
        WorldFile::parse(&text, "gap").expect("valid").compile()
    }

    #[test]
    fn a_rectangle_passes_lengthwise_through_a_gap_its_enclosing_circle_would_not() {
        // Spot's body, 1.1 × 0.5 m: enclosing radius 0.60 m, half width 0.25 m
        let body = Footprint {
            inner_m: 0.25,
            outer_m: 0.605,
            headings: 36,
        };
        for (gap, passable) in [(0.62, true), (0.45, false)] {
            let scene = small_gap_world(gap);
            let r = reach_by(&scene, body, 0.3, 0.04, rectangle(&scene, 1.1, 0.5));
            assert_eq!(r.reachable, passable, "gap {gap}: {r:?}");
            assert!(
                !reach(&scene, 0.6, 0.3, 0.04).reachable,
                "the circle: {gap}"
            );
        }
        // a body longer than the room is wide does not fit at the start, facing across it
        let scene = small_gap_world(0.62);
        let r = reach_by(&scene, body, 0.3, 0.04, rectangle(&scene, 3.1, 0.5));
        assert!(r.start_blocked, "a 3.1 m body at the start: {r:?}");
    }

    #[test]
    fn reach_body_uses_the_simulators_body_test() {
        let spot = Body::Rectangle {
            length_m: 1.1,
            width_m: 0.5,
        };
        for (gap, passable) in [(0.62, true), (0.45, false)] {
            let r = reach_body(&small_gap_world(gap), &spot, 0.3);
            assert_eq!(r.reachable, passable, "gap {gap}: {r:?}");
        }
        // a round body is the circle
        assert!(!reach_body(&small_gap_world(0.62), &Body::Round(0.32), 0.3).reachable);
        assert!(reach_body(&small_gap_world(0.62), &Body::Round(0.29), 0.3).reachable);
    }

    #[test]
    fn a_start_touching_something_is_reported() {
        let r = reach(&gap_world(2.0, ""), 1.5, 0.3, CELL_M);
        assert!(r.start_blocked && !r.reachable);
    }
}
