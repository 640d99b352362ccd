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

use std::collections::VecDeque;

use crate::motion::contact;
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
    /// Grid centres tested.
    pub tested: usize,
}

/// Whether a robot of `radius_m` can drive from `scene`'s start to within `goal_tolerance_m` of
/// its goal without contact, on a grid of `cell_m` (see the module doc).
pub fn reach(scene: &Scene, radius_m: f64, goal_tolerance_m: f64, cell_m: f64) -> Reach {
    let start = [scene.start[0], scene.start[1]];
    let goal = scene.goal;
    if contact(scene, start[0], start[1], radius_m).is_some() {
        return Reach {
            reachable: false,
            start_blocked: true,
            tested: 1,
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
    let margin = 2.0 * radius_m + 4.0 * cell_m + 0.1;
    let cell = cell_m.max(1e-3);
    // grid indices relative to the start's cell, i = (x − start) / cell
    let i0 = ((x0 - margin - start[0]) / cell).floor() as i64;
    let i1 = ((x1 + margin - start[0]) / cell).ceil() as i64;
    let j0 = ((y0 - margin - start[1]) / cell).floor() as i64;
    let j1 = ((y1 + margin - start[1]) / cell).ceil() as i64;
    let (w, h) = ((i1 - i0 + 1) as usize, (j1 - j0 + 1) as usize);
    // 0 untested, 1 free and queued, 2 blocked
    let mut state = vec![0u8; w * h];
    let at = |i: i64, j: i64| (j - j0) as usize * w + (i - i0) as usize;
    let centre = |i: i64, j: i64| [start[0] + i as f64 * cell, start[1] + j as f64 * cell];
    let mut queue = VecDeque::new();
    state[at(0, 0)] = 1;
    queue.push_back((0i64, 0i64));
    let mut tested = 1;
    while let Some((i, j)) = queue.pop_front() {
        let p = centre(i, j);
        if (p[0] - goal[0]).hypot(p[1] - goal[1]) <= goal_tolerance_m {
            return Reach {
                reachable: true,
                start_blocked: false,
                tested,
            };
        }
        for (di, dj) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
            let (ni, nj) = (i + di, j + dj);
            if ni < i0 || ni > i1 || nj < j0 || nj > j1 {
                continue;
            }
            let k = at(ni, nj);
            if state[k] != 0 {
                continue;
            }
            tested += 1;
            let q = centre(ni, nj);
            if contact(scene, q[0], q[1], radius_m).is_some() {
                state[k] = 2;
            } else {
                state[k] = 1;
                queue.push_back((ni, nj));
            }
        }
    }
    Reach {
        reachable: false,
        start_blocked: false,
        tested,
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

    #[test]
    fn a_start_touching_something_is_reported() {
        let r = reach(&gap_world(2.0, ""), 1.5, 0.3, CELL_M);
        assert!(r.start_blocked && !r.reachable);
    }
}
