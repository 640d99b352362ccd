//! A long body's way out of a place the dynamic window cannot leave: a search over poses
//! (x, y, heading) for a sequence of straight moves forward and back and turns on the spot.
//!
//! The dynamic window rolls out arcs of one (v, ω) over its horizon, so it never plans a
//! motion that first goes away from the goal: a long body that has come past a door in the
//! side of a corridor too narrow to turn in where it stands — close to the door's wall, its
//! corners swinging into it — is held there, and backing straight out along the corridor
//! brings it back to the same place (Spot in the generated glass corridors, issue 22 item 4:
//! the body's real footprint). The search here is the hybrid A* of path planners for
//! car-like robots, reduced to what a body that turns on the spot needs: poses on a lattice
//! of `step_m` cells and [`HEADINGS`] headings, each reached continuously (a move keeps its
//! pose's exact position), moves of `step_m` forward or back along the heading and turns of
//! one heading step, each pose tested with the body's outline against the clearance (every
//! point of it at least `need_m` from the nearest solid or glass cell, or no nearer than the
//! body already is where it stands). It is guided by the route's length to the goal
//! ([`crate::route::Route::value`], the A* heuristic) and ends at the first pose the route
//! counts `gain_m` nearer the goal where the body has room to turn on the spot (its centre
//! `turn_room_m` from every obstacle), or at the goal.
//!
//! A move is short enough that no cell can pass through the outline between two poses tested:
//! a point entering the body by less than `need_m` is caught at the next pose's outline, and
//! no point of the body moves more than `2 need_m` in one move ([`Settings::checked`]).

use mimnav_shared::grid::GridSpec;

use crate::clearance::Clearance;

/// Headings of the lattice, a full turn: 11.25° a step, which moves the corners of a
/// 1.1 × 0.5 m body by 12 cm.
pub const HEADINGS: usize = 32;

/// A plan ends headed the route's way: this many straight moves on from its end are free ...
const AHEAD_STEPS: usize = 3;
/// ... and take the route's length down by at least this share of their length (the heading
/// within about 35° of the way where the route's length is a metre a metre).
const AHEAD_FALL: f64 = 0.8;

/// Beyond the route's length from the start, what a pose the route knows no way from is taken
/// to be from the goal, m (such poses are passed through, never ended at).
const UNKNOWN_M: f32 = 10.0;

/// One move of a plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Move {
    /// `step_m` forward along the heading.
    Forward,
    /// `step_m` back.
    Back,
    /// One heading step counter-clockwise, on the spot.
    Left,
    /// One heading step clockwise, on the spot.
    Right,
}

impl Move {
    const ALL: [Move; 4] = [Move::Forward, Move::Back, Move::Left, Move::Right];

    fn straight(self) -> bool {
        matches!(self, Move::Forward | Move::Back)
    }

    /// Forward and back, left and right.
    pub fn opposes(self, other: Move) -> bool {
        matches!(
            (self, other),
            (Move::Forward, Move::Back)
                | (Move::Back, Move::Forward)
                | (Move::Left, Move::Right)
                | (Move::Right, Move::Left)
        )
    }
}

/// How the search runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// The lattice's cell and a straight move's length, m.
    pub step_m: f64,
    /// How far from the start the search goes, m (the poses' centres).
    pub radius_m: f64,
    /// A turn's cost per radian, in metres of driving.
    pub turn_m_per_rad: f64,
    /// A change between forward and back (a cusp) costs this, m.
    pub cusp_m: f64,
    /// Done at the first pose this much nearer the goal by the route, m.
    pub gain_m: f64,
    /// The least clearance of every point of the outline, m.
    pub need_m: f64,
    /// A plan ends where the body's centre is at least this far from every obstacle (room to
    /// turn on the spot), m.
    pub turn_room_m: f64,
    /// Poses expanded at most.
    pub max_expanded: usize,
}

impl Settings {
    /// True when no point of a body with this enclosing radius moves more than twice
    /// `need_m` in one move, so that no cell can slip into the body between two tested poses.
    pub fn checked(&self, enclosing_radius_m: f64) -> bool {
        let turn = enclosing_radius_m * std::f64::consts::TAU / HEADINGS as f64;
        self.step_m.max(turn) <= 2.0 * self.need_m && self.step_m > 0.0
    }
}

/// A plan: the moves in order, each with the pose it ends at (robot frame at the search's start:
/// x, y m, heading rad).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Plan {
    /// The moves and the poses they end at.
    pub moves: Vec<(Move, [f64; 3])>,
    /// The route's length to the goal at the last pose, m.
    pub to_go_m: f64,
}

/// The search's buffers, kept between searches.
#[derive(Debug, Clone, Default)]
pub struct Scratch {
    /// Per lattice state: the cost to reach it (∞ unreached).
    cost: Vec<f32>,
    /// Per state: its pose (x, y) where reached, its parent and the move from it.
    pose: Vec<(f32, f32)>,
    parent: Vec<(u32, u8)>,
    /// Per state: the last straight move on the way to it.
    gear: Vec<Option<Move>>,
    /// Per state: 0 untested, 1 free, 2 blocked.
    free: Vec<u8>,
    heap: std::collections::BinaryHeap<Entry>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Entry {
    f: f32,
    g: f32,
    state: u32,
}

impl Eq for Entry {}

impl Ord for Entry {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        // a min-heap on f, then on the state (deterministic ties)
        (other.f.total_cmp(&self.f)).then(other.state.cmp(&self.state))
    }
}

impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

/// The least clearance of the outline (body frame) at `pose` (robot frame: x, y m, heading
/// rad), m; 0 where a point of it is off the clearance's window.
pub fn least_clearance(
    outline: &[[f64; 2]],
    grid: GridSpec,
    clear: &Clearance,
    pose: [f64; 3],
) -> f64 {
    let [x, y, th] = pose;
    let (sn, cs) = th.sin_cos();
    outline
        .iter()
        .map(|&[bx, by]| {
            grid.cell_of(
                (x + cs * bx - sn * by) as f32,
                (y + sn * bx + cs * by) as f32,
            )
            .map_or(0.0, |(r, c)| f64::from(clear.at(r, c)))
        })
        .fold(f64::INFINITY, f64::min)
}

/// Searches for a way from the robot (the map's centre, heading along x) to a pose the route
/// counts `s.gain_m` nearer the goal. `outline` is the body's outline (body frame, m; see
/// [`crate::PlannerParams::outline`]), `to_go` the route's length to the goal from a robot-frame
/// point (infinite where none). `None` when the start has no route, or no such pose is within
/// reach and the budget. `prev`: the move the robot is making, if it follows a plan already;
/// the opposite first move costs a cusp (no dithering between two plans of the same cost).
pub fn search(
    outline: &[[f64; 2]],
    grid: GridSpec,
    clear: &Clearance,
    to_go: impl Fn(f32, f32) -> f32,
    s: &Settings,
    prev: Option<Move>,
    scratch: &mut Scratch,
) -> Option<Plan> {
    let start_to_go = to_go(0.0, 0.0);
    if !start_to_go.is_finite() || outline.is_empty() || s.step_m <= 0.0 {
        return None;
    }
    let least = |x: f64, y: f64, th: f64| least_clearance(outline, grid, clear, [x, y, th]);
    // a body already nearer than the need somewhere may move without coming nearer still
    let need = s.need_m.min(least(0.0, 0.0, 0.0) - 1e-6);
    if need <= 0.0 {
        return None;
    }
    let half = (s.radius_m / s.step_m).ceil().max(1.0) as i64;
    let side = (2 * half + 1) as usize;
    let states = side * side * HEADINGS;
    scratch.cost.clear();
    scratch.cost.resize(states, f32::INFINITY);
    scratch.pose.clear();
    scratch.pose.resize(states, (0.0, 0.0));
    scratch.parent.clear();
    scratch.parent.resize(states, (u32::MAX, 0));
    scratch.gear.clear();
    scratch.gear.resize(states, None);
    scratch.free.clear();
    scratch.free.resize(states, 0);
    scratch.heap.clear();
    let index = |x: f64, y: f64, k: usize| -> Option<usize> {
        let (i, j) = (
            (x / s.step_m).round() as i64 + half,
            (y / s.step_m).round() as i64 + half,
        );
        ((0..side as i64).contains(&i) && (0..side as i64).contains(&j))
            .then(|| ((j as usize * side + i as usize) * HEADINGS) + k)
    };
    let heading = |k: usize| k as f64 * std::f64::consts::TAU / HEADINGS as f64;
    // the body can turn on the spot there: from such a pose the dynamic window goes on as it
    // likes (a pose merely headed the route's way was not enough: the route's length weighs
    // narrow places more than a metre a metre, and headings across the way passed for it)
    let room_to_turn = |x: f32, y: f32| {
        grid.cell_of(x, y)
            .is_some_and(|(r, c)| f64::from(clear.at(r, c)) >= s.turn_room_m)
    };
    // and is headed the route's way, with room to drive on: the dynamic window scores a
    // rollout that gets no nearer by its speed alone, so a body left across the way drives on
    // across it, not round into the way
    let heads_on = |x: f32, y: f32, th: f64, here: f32| {
        let (sn, cs) = th.sin_cos();
        let on = |d: f64| (f64::from(x) + d * cs, f64::from(y) + d * sn);
        let free = (1..=AHEAD_STEPS).all(|i| {
            let (ax, ay) = on(i as f64 * s.step_m);
            least(ax, ay, th) >= need
        });
        let (ax, ay) = on(AHEAD_STEPS as f64 * s.step_m);
        let fall = f64::from(here - to_go(ax as f32, ay as f32));
        free && fall >= AHEAD_FALL * AHEAD_STEPS as f64 * s.step_m
    };
    let start = index(0.0, 0.0, 0)?;
    scratch.cost[start] = 0.0;
    scratch.free[start] = 1;
    scratch.heap.push(Entry {
        f: start_to_go,
        g: 0.0,
        state: start as u32,
    });
    let target = start_to_go - s.gain_m as f32;
    let turn_cost = (s.turn_m_per_rad * std::f64::consts::TAU / HEADINGS as f64) as f32;
    let mut expanded = 0;
    while let Some(Entry { g, state, .. }) = scratch.heap.pop() {
        let st = state as usize;
        if g > scratch.cost[st] {
            continue;
        }
        let (x, y) = scratch.pose[st];
        let k = st % HEADINGS;
        let here = to_go(x, y);
        if st != start
            && (here <= 0.0
                || here <= target && room_to_turn(x, y) && heads_on(x, y, heading(k), here))
        {
            return Some(unwind(scratch, st, here));
        }
        expanded += 1;
        if expanded > s.max_expanded {
            return None;
        }
        for mv in Move::ALL {
            let (nx, ny, nk, step) = match mv {
                Move::Forward | Move::Back => {
                    let sign = if mv == Move::Forward { 1.0 } else { -1.0 };
                    let th = heading(k);
                    let (nx, ny) = (
                        f64::from(x) + sign * s.step_m * th.cos(),
                        f64::from(y) + sign * s.step_m * th.sin(),
                    );
                    (nx, ny, k, s.step_m as f32)
                }
                Move::Left => (f64::from(x), f64::from(y), (k + 1) % HEADINGS, turn_cost),
                Move::Right => (
                    f64::from(x),
                    f64::from(y),
                    (k + HEADINGS - 1) % HEADINGS,
                    turn_cost,
                ),
            };
            let Some(ns) = index(nx, ny, nk) else {
                continue;
            };
            // a cusp: forward after back or back after forward, turns between them or not
            let cusp = mv.straight() && scratch.gear[st].is_some_and(|g| g != mv);
            // from the start: undoing the move the robot is making costs a cusp
            let against = st == start && prev.is_some_and(|p| p.opposes(mv));
            let ng = g
                + step
                + if cusp || against {
                    s.cusp_m as f32
                } else {
                    0.0
                };
            if ng >= scratch.cost[ns] {
                continue;
            }
            if scratch.free[ns] == 0 {
                scratch.free[ns] = if least(nx, ny, heading(nk)) >= need {
                    1
                } else {
                    2
                };
            }
            if scratch.free[ns] != 1 {
                continue;
            }
            // where the route knows no way (beside a wall), far from the goal
            let h = to_go(nx as f32, ny as f32);
            let h = if h.is_finite() {
                h
            } else {
                start_to_go + UNKNOWN_M
            };

            scratch.cost[ns] = ng;
            scratch.pose[ns] = (nx as f32, ny as f32);
            scratch.parent[ns] = (state, mv as u8);
            scratch.gear[ns] = if mv.straight() {
                Some(mv)
            } else {
                scratch.gear[st]
            };
            scratch.heap.push(Entry {
                f: ng + h,
                g: ng,
                state: ns as u32,
            });
        }
    }
    None
}

/// An angle in (−π, π].
pub fn wrap(a: f64) -> f64 {
    let a = a.rem_euclid(std::f64::consts::TAU);
    if a > std::f64::consts::PI {
        a - std::f64::consts::TAU
    } else {
        a
    }
}

fn unwind(scratch: &Scratch, end: usize, to_go: f32) -> Plan {
    let mut moves = Vec::new();
    let mut st = end;
    while scratch.parent[st].0 != u32::MAX {
        let (parent, mv) = scratch.parent[st];
        let (x, y) = scratch.pose[st];
        let th = (st % HEADINGS) as f64 * std::f64::consts::TAU / HEADINGS as f64;
        moves.push((
            Move::ALL[usize::from(mv)],
            [f64::from(x), f64::from(y), wrap(th)],
        ));
        st = parent as usize;
    }
    moves.reverse();
    Plan {
        moves,
        to_go_m: f64::from(to_go),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Planner;
    use crate::clearance::tests::map;
    use crate::dwa::tests::spot;
    use mimnav_shared::topics::cell_class;

    /// A corridor 1.3 m wide along x, the robot 0.1 m off its axis towards the wall with the
    /// door, the door (0.8 m) behind the robot, the goal in the room beyond it.
    fn past_a_side_door() -> (mimnav_shared::grid::GridSpec, Vec<u8>, (f64, f64)) {
        let (grid, classes) = map(|x, y| {
            let wall = |d: f32| d.abs() < 0.05;
            let door = (-1.0..-0.2).contains(&x);
            if wall(y - 0.75) || wall(y + 0.55) && !door || wall(y + 3.5) || wall(x - 2.5) {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        (grid, classes, (-0.6, -2.3))
    }

    #[test]
    fn a_long_body_past_a_side_door_finds_its_way_in() {
        let (grid, classes, goal) = past_a_side_door();
        let mut planner = Planner::new(spot());
        let _ = planner.plan(&classes, grid, 0.0, 0.0, goal);
        let start_m = f64::from(planner.route().value(0.0, 0.0));
        let plan = planner.maneuver(grid, None).expect("a way in");
        assert!(plan.to_go_m <= start_m - crate::MANEUVER_GAIN_M, "{plan:?}");
        // it backs to the door and turns into it: the body ends in the room, past the wall
        let [x, y, _] = plan.moves.last().expect("moves").1;
        assert!(
            y < -0.6 && (-1.0..-0.2).contains(&x),
            "ends at ({x:.2}, {y:.2})"
        );
        assert!(plan.moves.iter().any(|m| m.0 == Move::Back));
        assert!(
            plan.moves
                .iter()
                .any(|m| matches!(m.0, Move::Left | Move::Right))
        );
        // every pose fits the body, and each is one move from the one before
        assert!(planner.maneuver_holds(grid, plan.moves.iter().map(|m| m.1)));
        let mut at = [0.0f64; 3];
        let turn = std::f64::consts::TAU / HEADINGS as f64;
        for &(mv, pose) in &plan.moves {
            let moved = (pose[0] - at[0]).hypot(pose[1] - at[1]);
            let turned = wrap(pose[2] - at[2]);
            match mv {
                Move::Forward | Move::Back => {
                    assert!((moved - 0.1).abs() < 1e-5 && turned.abs() < 1e-9, "{mv:?}")
                }
                Move::Left => assert!(moved < 1e-9 && (turned - turn).abs() < 1e-9),
                Move::Right => assert!(moved < 1e-9 && (turned + turn).abs() < 1e-9),
            }
            at = pose;
        }
    }

    #[test]
    fn no_way_out_a_round_body_or_moves_too_long_find_nothing() {
        let (grid, classes, goal) = past_a_side_door();
        // the door walled up: no route, so no way
        let closed: Vec<u8> = (0..grid.len())
            .map(|i| {
                let (_, y) = grid.center_of(i / grid.cells, i % grid.cells);
                if (y + 0.55).abs() < 0.05 {
                    cell_class::SOLID
                } else {
                    classes[i]
                }
            })
            .collect();
        let mut planner = Planner::new(spot());
        let _ = planner.plan(&closed, grid, 0.0, 0.0, goal);
        assert_eq!(planner.maneuver(grid, None), None);
        // a round body turns where it stands: never a maneuver
        let mut round = Planner::new(crate::PlannerParams::default());
        let _ = round.plan(&classes, grid, 0.0, 0.0, goal);
        assert_eq!(round.maneuver(grid, None), None);
        // a move that could carry a cell through the outline unseen is refused
        let mut s = crate::maneuver_settings(&spot());
        assert!(s.checked(0.604));
        s.step_m = 0.2;
        assert!(!s.checked(0.604));
    }
}
