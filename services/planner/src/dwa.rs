//! The dynamic window approach on the planning map (equation 12 of
//! `mim-lidar-intensity-navigation.txt`).
//!
//! Velocity pairs (v, ω) are sampled in the window the acceleration limits allow within one
//! control period of the current velocity; each is rolled forward over the horizon from the robot
//! (at the map's centre, heading along x). A trajectory whose footprint — the robot's body,
//! oriented along the rollout's heading at every step: a disc for a round robot, a rectangle
//! for one with `robot.length_m` × `robot.width_m` — comes within `planner.margin_m` of a solid
//! or glass cell is infeasible. A rectangle is tested in three tiers, each exact enough to
//! decide when it passes: the centre's clearance against the body's reach, then a cover of
//! discs along the heading ([`PlannerParams::footprint_discs`], a superset of the body), then
//! the outline, walked side by side in steps as long as the clearance allows (a point with
//! clearance c proves every point within c − need of it clear, so beside a wall the walk takes
//! [`OUTLINE_SPACING_M`] steps and elsewhere it strides) — so the exact test runs only beside
//! obstacles, where the discs' bulge would otherwise keep the body from a door or a turn it can
//! make (beyond the paper: narrow
//! passages stay open without ever grazing a wall); the others are scored by goal progress, speed and the obstacle
//! cost summed along them on the planning map (eq. 12), and the cheapest wins.
//!
//! A body already inside its margin somewhere (a door it barely fits, a late detection) may
//! come down to `planner.inside_margin_share` of the margin, and drives forward no faster than
//! `planner.inside_margin_mps` until it is out of it — while the map has a route to the goal.
//! Creeping on without one (the map may be wrong, or the world impassable), every point of the
//! body keeps the whole margin: a body already inside it is held, and the pilot's
//! `planner.no_route_stop_s` ends the wait.
//!
//! A long body whose window reaches standing still also rolls out turns on the spot first
//! (`planner.turn_first`): in place to a heading up to half a turn away, then straight on.
//! An arc's score is the route's length at its nearest, so a turn in place gains nothing within
//! the horizon and the fastest arc that loses nothing wins: beside a door in a corridor's side
//! Spot drove on past it. Such a plan wins only [`TURN_FIRST_GAIN_M`] nearer the goal than the
//! best arc (issue 22, glass corridors).
//!
//! The clearance is a cell centre's, and a cell stands for anything within it, so a body close
//! to a cell can sweep into what the cell holds while every cell its outline passes keeps its
//! clearance: a long body turning swings its ends sideways, and a round body's centre moves
//! within its cell along a bush. So the solid and glass cells just beside the body are also
//! tested one by one ([`Clearance::set_guard`]): no rollout brings a cell's centre nearer than
//! [`guard_m`] (half its diagonal and a centimetre; a round body [`round_guard_m`], half a
//! cell), or nearer than it already is.

use mimnav_shared::grid::GridSpec;

use crate::clearance::Clearance;
use crate::params::{OUTLINE_SPACING_M, PlannerParams};
use crate::route::Route;

/// What the search decided.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DwaOutcome {
    /// Drive at (v, ω).
    Drive {
        /// Speed, m/s.
        v: f64,
        /// Turn rate, rad/s.
        omega: f64,
        /// The winning score (lower is better).
        score: f64,
        /// False when the route knew no way from the robot to the goal: goal progress was the
        /// straight-line distance and the speed at most `planner.glass_slow_mps`.
        routed: bool,
        /// How much nearer the goal the winning rollout comes at its nearest, m (by the route,
        /// or the straight line without one): 0 for one that only leads away.
        gain_m: f64,
    },
    /// No sampled trajectory is feasible: stop.
    Blocked,
}

impl DwaOutcome {
    /// True for the outcomes that command a stop.
    pub fn is_stop(&self) -> bool {
        !matches!(self, DwaOutcome::Drive { .. })
    }
}

/// Searches the dynamic window from the current velocity (v0, ω0) towards `goal` (robot frame,
/// m) on the planning `cost` (0–255 per cell) with the footprint clearance `clear`.
///
/// Goal progress is the distance still to go along `route` (see [`crate::route`]) where it knows
/// one from the robot's place, and the straight-line distance otherwise (the paper's eq. 12).
#[allow(clippy::too_many_arguments)]
pub fn plan(
    p: &PlannerParams,
    grid: GridSpec,
    cost: &[u8],
    clear: &Clearance,
    v0: f64,
    omega0: f64,
    goal: (f64, f64),
    route: Option<&Route>,
) -> DwaOutcome {
    plan_capped_turning(
        p,
        grid,
        cost,
        clear,
        (v0, omega0),
        (f64::INFINITY, f64::INFINITY),
        goal,
        route,
    )
}

/// A rollout turns, for the speed caps of [`plan_capped_turning`], above this rate, rad/s: its
/// heading leaves a pane's direction by more than ~15° within a second.
pub const TURNING_RPS: f64 = 0.25;

/// [`plan`] with the speeds sampled no higher than a cap (m/s; the window still starts from the
/// current speed, so a robot faster than the cap slows at its deceleration limit): the first of
/// `(straight, turning)` for the rollouts that keep their heading (|ω| ≤ [`TURNING_RPS`]), the
/// second for those that turn ([`crate::glass_speed_caps`]; the same cap twice caps every
/// rollout alike). A `route` that knows no way from the robot's place to the goal is not used:
/// progress is the straight-line distance and the speed at most `planner.glass_slow_mps`
/// (`DwaOutcome::Drive::routed` false; [`crate::pilot`] stops after `planner.no_route_stop_s`).
/// One whose way leads off the map ([`Route::beyond`]) is followed, `routed` still false, and
/// with `planner.beyond_as_route` at the speeds of a route.
#[allow(clippy::too_many_arguments)]
pub fn plan_capped_turning(
    p: &PlannerParams,
    grid: GridSpec,
    cost: &[u8],
    clear: &Clearance,
    v0_omega0: (f64, f64),
    (speed_cap, turning_cap): (f64, f64),
    goal: (f64, f64),
    route: Option<&Route>,
) -> DwaOutcome {
    let gear = Gear::Forward;
    let prune = true;
    search(
        p,
        grid,
        cost,
        clear,
        v0_omega0,
        (speed_cap.max(turning_cap), turning_cap),
        goal,
        route,
        gear,
        prune,
    )
}

/// Backing out (see [`crate::pilot`]): the dynamic window with speeds from
/// `-planner.recovery_mps` to just below 0, every trajectory checked against the map as forward
/// ones are, and the one scored best that leaves the body clearest of obstacles at its end,
/// goal progress counting less ([`BACK_OUT_CLEARANCE_WEIGHT`]) and the ground given up counting
/// for it ([`BACK_OUT_DISTANCE_WEIGHT`]: room to come in again). A long body parallel to glass or
/// a wall it has come too close to cannot turn away (its corners swing into it) and may not go
/// on (the way converges): standing still is then all the forward window allows.
#[allow(clippy::too_many_arguments)]
pub fn back_out(
    p: &PlannerParams,
    grid: GridSpec,
    cost: &[u8],
    clear: &Clearance,
    v0_omega0: (f64, f64),
    goal: (f64, f64),
    route: Option<&Route>,
) -> DwaOutcome {
    let gear = Gear::Reverse;
    search(
        p,
        grid,
        cost,
        clear,
        v0_omega0,
        (f64::INFINITY, f64::INFINITY),
        goal,
        route,
        gear,
        true,
    )
}

/// How near the body may bring the centre of a solid or glass cell beside it, m: half the
/// cell's diagonal (what the cell holds may lie anywhere in it) and a centimetre. A cell already
/// nearer may come no nearer.
pub fn guard_m(grid: GridSpec) -> f64 {
    0.5 * std::f64::consts::SQRT_2 * f64::from(grid.cell_m) + 0.01
}

/// How near a round body may bring the centre of a solid or glass cell beside it, m: half a
/// cell. Its centre test keeps the margin from every cell, and the guard only stops the body
/// creeping nearer along cells that keep their clearance; at [`guard_m`] it held the Turtlebot 2
/// among scenario 4's grass for 20 s (a contact after, Table I 9 of 10) and before gaps of
/// 0.52–0.54 m, a cell wider than its body (stop 72).
pub fn round_guard_m(grid: GridSpec) -> f64 {
    0.5 * f64::from(grid.cell_m)
}

/// Backing out, a metre of clearance gained for the body is worth this many metres of goal
/// progress.
pub const BACK_OUT_CLEARANCE_WEIGHT: f64 = 3.0;

/// Backing out, a metre backed is worth this many metres of goal progress. Backing straight out
/// of a passage gains the body no clearance at its discs, and scored on the route alone the
/// slowest reverse won: Spot, wedged turned 8° in the mouth of a corridor 1.13 m wide, backed
/// 3 cm a try and never came in again straighter (issue 22, stop 61).
pub const BACK_OUT_DISTANCE_WEIGHT: f64 = 5.0;

/// Headings a half turn holds for a long body's turns on the spot first (`planner.turn_first`):
/// 11.25° apart, the first tried 22.5° away (less, an arc turns as far).
pub const TURN_FIRST_HEADINGS: usize = 16;

/// A turn on the spot first must come this much nearer the goal than the best arc, m.
pub const TURN_FIRST_GAIN_M: f64 = 0.1;

/// Which speeds the window samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Gear {
    Forward,
    Reverse,
}

/// Where a rollout has got to.
#[derive(Debug, Clone, Copy)]
struct Rollout {
    x: f64,
    y: f64,
    hc: f64,
    hs: f64,
    /// Steps of the horizon rolled.
    k: usize,
    obstacle: f64,
    /// The least route length met so far.
    closest: f64,
    /// Off the map or at the goal: nothing more to roll.
    ended: bool,
}

impl Rollout {
    fn start(to_go: f64) -> Rollout {
        Rollout {
            x: 0.0,
            y: 0.0,
            hc: 1.0,
            hs: 0.0,
            k: 0,
            obstacle: 0.0,
            closest: to_go,
            ended: false,
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn search(
    p: &PlannerParams,
    grid: GridSpec,
    cost: &[u8],
    clear: &Clearance,
    (v0, omega0): (f64, f64),
    (speed_cap, turning_cap): (f64, f64),
    goal: (f64, f64),
    route: Option<&Route>,
    gear: Gear,
    prune: bool,
) -> DwaOutcome {
    let (robot, pl) = (&p.robot, &p.planner);
    let routed = route.filter(|r| r.value(0.0, 0.0).is_finite());
    let mut speed_cap = speed_cap;
    // no way to the goal on the map: the one beyond it when there is one, else the straight line
    let lost = route.is_some() && routed.is_none_or(Route::beyond);
    // a way off the map is driven at the speeds of a route with `planner.beyond_as_route`
    if lost && !(routed.is_some() && pl.beyond_as_route) {
        // the map closes every way: drive on towards what is not on the map yet, or by the
        // straight line (the paper's DWA), no faster than beside glass — the way is open only
        // if the map is wrong or it lies beyond the map
        speed_cap = speed_cap.min(pl.glass_slow_mps);
    }
    let route = routed;
    let to_go = |x: f64, y: f64| match route {
        Some(r) => f64::from(r.value(x as f32, y as f32)),
        None => (goal.0 - x).hypot(goal.1 - y),
    };
    let (max_v, max_omega) = (robot.max_linear_mps, robot.max_angular_rps);
    let (max_accel, max_alpha) = (robot.max_linear_accel, robot.max_angular_accel);
    // never above the top speed, even when the odometry reports more (a base overshooting, or
    // a wrong `max_linear_mps`): the window's slowest is then the top speed
    let (v_lo, v_hi) = match gear {
        Gear::Forward => {
            let v_lo = (v0 - max_accel * pl.window_s).max(0.0).min(max_v);
            let v_hi = (v0 + max_accel * pl.window_s)
                .min(max_v)
                .min(speed_cap)
                .max(v_lo);
            (v_lo, v_hi)
        }
        // moving back, never standing still
        Gear::Reverse => {
            let back = pl.recovery_mps.min(max_v);
            let v_lo = (v0 - max_accel * pl.window_s).max(-back);
            let v_hi = (v0 + max_accel * pl.window_s).min(-0.2 * back);
            if v_lo > v_hi {
                return DwaOutcome::Blocked;
            }
            (v_lo, v_hi)
        }
    };
    let w_lo = (omega0 - max_alpha * pl.window_s).max(-max_omega);
    let w_hi = (omega0 + max_alpha * pl.window_s).min(max_omega);
    let dt_s = pl.dt_s;
    let steps = (pl.horizon_s / dt_s).ceil().max(1.0) as usize;
    let start_to_go = to_go(0.0, 0.0);
    // The clearance where the robot stands, at a point of its body; none off the map or in an
    // obstacle cell, where it can only be blocked.
    let start_clear = |x: f64, y: f64| {
        grid.cell_of(x as f32, y as f32)
            .map(|(r, c)| f64::from(clear.at(r, c)))
            .filter(|&c| c > 0.0)
    };
    // Each disc of the body's cover: its offset along the heading and the clearance it needs.
    // Closer than the footprint and margin already (a late detection, or a cell misjudged
    // solid): motions that get no closer still are allowed, so the robot can move away instead
    // of freezing.
    let mut discs: Vec<(f64, f64)> = Vec::new();
    for d in p.footprint_discs() {
        let Some(start) = start_clear(d.x_m, 0.0) else {
            return DwaOutcome::Blocked;
        };
        // creeping on without a route, the whole margin (see `outline_need`)
        let need = d.radius_m + pl.margin_m;
        discs.push((d.x_m, if lost { need } else { need.min(start) }));
    }
    // a centre this clear leaves every disc clear (a cell of slack for the grid's steps)
    let centre_enough = discs
        .iter()
        .map(|&(x, need)| x.abs() + need)
        .fold(0.0, f64::max)
        + f64::from(grid.cell_m);
    let round = discs.len() == 1 && discs[0].0 == 0.0;
    // the outline's points (body frame) and the clearance they need: the margin, and half the
    // spacing so that no point of the outline between two samples comes closer. A body already
    // inside the margin somewhere (in a door) may come down to `inside_margin_share` of the
    // margin anywhere: held point by point to "no closer than now", a jamb sliding along the
    // body's side made every motion but standing still infeasible, and Spot froze in the door
    let floor = pl.inside_margin_share * pl.margin_m + 0.5 * OUTLINE_SPACING_M;
    let mut closest = f64::INFINITY;
    for [bx, by] in p.outline() {
        let Some(start) = start_clear(bx, by) else {
            return DwaOutcome::Blocked;
        };
        closest = closest.min(start);
    }
    let full = pl.margin_m + 0.5 * OUTLINE_SPACING_M;
    // no route on the map (the world may be impassable): creeping on by the straight line keeps
    // the whole margin — inside it already, the body is blocked (a long body turning there
    // swung its end into a bush it was already inside the margin of, on impassable hedges)
    let outline_need = if closest >= full || lost {
        full
    } else if closest >= floor {
        floor
    } else {
        closest
    };
    // inside the margin (`closest < full`), forward no faster than `inside_margin_mps`: where a
    // body has come nearer an obstacle than its margin, the map's last cell is all that is left
    // between them, and a bush's outer leaves or a surface seen obliquely fill it late
    let v_hi = match gear {
        Gear::Forward if pl.inside_margin_mps > 0.0 && closest < full => {
            v_hi.min(pl.inside_margin_mps).max(v_lo)
        }
        _ => v_hi,
    };
    let sides = p.robot.body().sides();
    let cell_m = f64::from(grid.cell_m);
    // Walks each side: a point with clearance c ≥ need proves the next c − need of the side
    // clear, and the spacing's half in `need` covers the step beyond that.
    let outline_too_close = |x: f64, y: f64, hc: f64, hs: f64| {
        sides.iter().any(|side| {
            let mut t = 0.0;
            while t <= side.len_m {
                let [bx, by] = side.at(t);
                let (wx, wy) = (x + hc * bx - hs * by, y + hs * bx + hc * by);
                let c = grid
                    .cell_of(wx as f32, wy as f32)
                    .map_or(f64::INFINITY, |(r, c)| f64::from(clear.at(r, c)));
                if c < outline_need {
                    return true;
                }
                // a cell less: the clearance is a cell centre's, a point of it may be nearer
                t += (c - outline_need - cell_m).clamp(0.0, side.len_m) + OUTLINE_SPACING_M;
            }
            false
        })
    };
    // the cells beside the body: none may come nearer than `guard_at` (or than it is now)
    let guard = clear.guard();
    let guard_at = if round {
        round_guard_m(grid)
    } else {
        guard_m(grid)
    };
    let body = p.robot.body();
    let guarded = |x: f64, y: f64, hc: f64, hs: f64| {
        guard.iter().any(|&(gx, gy, now)| {
            let (dx, dy) = (gx - x, gy - y);
            body.signed_distance(hc * dx + hs * dy, -hs * dx + hc * dy) < now.min(guard_at) - 1e-3
        })
    };
    // a round body's centre this clear has every guarded cell beyond `guard_at`: the centre
    // lies within half a cell's diagonal of its cell's, and two cells cover that and the
    // chamfer transform's overestimate
    let round_guarded_within = body.enclosing_radius_m() + guard_at + 2.0 * cell_m;
    let too_close = |x: f64, y: f64, hc: f64, hs: f64| {
        discs.iter().any(|&(dx, need)| {
            grid.cell_of((x + hc * dx) as f32, (y + hs * dx) as f32)
                .is_some_and(|(r, c)| f64::from(clear.at(r, c)) < need)
        }) && outline_too_close(x, y, hc, hs)
    };
    let sample = |lo: f64, hi: f64, k: usize, n: usize| {
        if n <= 1 {
            0.5 * (lo + hi)
        } else {
            lo + (hi - lo) * k as f64 / (n - 1) as f64
        }
    };
    // Rolls (v, ω) on from `at` for `n` steps of the horizon (`at.k` counts them): false as soon
    // as a pose is infeasible. Leaving the map or reaching the goal ends the rollout feasible.
    let roll = |at: &mut Rollout, v: f64, w: f64, n: usize| -> bool {
        // the heading turns by w·dt a step: rotate (cos θ, sin θ) instead of calling sin and
        // cos each step
        let (turn_s, turn_c) = (w * dt_s).sin_cos();
        for _ in 0..n {
            if at.ended {
                break;
            }
            let k = at.k;
            at.k += 1;
            (at.hc, at.hs) = (
                at.hc * turn_c - at.hs * turn_s,
                at.hs * turn_c + at.hc * turn_s,
            );
            let (hc, hs) = (at.hc, at.hs);
            at.x += v * hc * dt_s;
            at.y += v * hs * dt_s;
            let (x, y) = (at.x, at.y);
            let Some((r, c)) = grid.cell_of(x as f32, y as f32) else {
                at.closest = at.closest.min(to_go(x, y));
                at.ended = true;
                break;
            };
            let i = grid.index(r, c);
            let centre_clear = f64::from(clear.at(r, c));
            if round {
                if centre_clear < discs[0].1
                    || centre_clear < round_guarded_within
                        && !guard.is_empty()
                        && guarded(x, y, hc, hs)
                {
                    return false;
                }
            } else if centre_clear < centre_enough && too_close(x, y, hc, hs)
                || !guard.is_empty() && guarded(x, y, hc, hs)
            {
                return false;
            }
            at.obstacle += f64::from(cost[i]) / 255.0;
            // progress every other step and at the end (the route is smooth; this halves the
            // planner's largest cost)
            if k % 2 == 1 || k + 1 == steps {
                at.closest = at.closest.min(to_go(x, y));
            }
            let (gx, gy) = (goal.0 - x, goal.1 - y);
            if gx * gx + gy * gy < 0.05 * 0.05 {
                at.closest = at.closest.min(to_go(x, y));
                at.ended = true;
                break;
            }
        }
        true
    };
    // A forward rollout's score can be bounded before it is rolled out: its goal progress is
    // no better than the least route length within its reach (|v| · the horizon), the speed
    // term is known, and the obstacle term is never negative. Speeds are taken fastest first,
    // so a good score comes early and slower speeds that cannot beat it are skipped. Ties go
    // to the sample the slowest-first order meets first, so the choice is the same as
    // rolling out every sample.
    let mut least = Vec::new();
    let horizon_m = |v: f64| v.abs() * dt_s * steps as f64 * (1.0 + 1e-6) + 1e-6;
    if let (Gear::Forward, Some(r)) = (gear, route) {
        r.least_within(
            r.rings_for(horizon_m(v_lo.abs().max(v_hi.abs()))),
            &mut least,
        );
    }
    let bound = |v: f64| {
        let least_to_go = match route {
            Some(r) => r.value_floor(&least, horizon_m(v)),
            // the straight line: no nearer than the goal's distance less the reach, nor 0
            None => (goal.0.hypot(goal.1) - horizon_m(v)).max(0.0) * (1.0 - 1e-9),
        };
        pl.goal_weight * least_to_go.min(start_to_go) + pl.speed_weight * (max_v - v)
    };
    let n_w = pl.omega_samples.max(1);
    // (v, ω, score, the sample's place in slowest-first order, its gain)
    let mut best: Option<(f64, f64, f64, usize, f64)> = None;
    for kv in (0..pl.v_samples.max(1)).rev() {
        let v = sample(v_lo, v_hi, kv, pl.v_samples);
        if prune && gear == Gear::Forward && best.is_some_and(|b| bound(v) > b.2) {
            continue;
        }
        for kw in 0..n_w {
            let w = sample(w_lo, w_hi, kw, pl.omega_samples);
            // a turning rollout's lane bends towards a pane beside the straight one (no slower
            // than the window allows, as for the straight cap; with the caps alike, every
            // sample the window holds, rounding and all)
            if gear == Gear::Forward
                && turning_cap < speed_cap
                && v > turning_cap.max(v_lo)
                && w.abs() > TURNING_RPS
            {
                continue;
            }
            let mut at = Rollout::start(start_to_go);
            if !roll(&mut at, v, w, steps) {
                continue;
            }
            let Rollout {
                x,
                y,
                hc,
                hs,
                obstacle,
                closest,
                ..
            } = at;
            let score = match gear {
                Gear::Forward => {
                    pl.goal_weight * closest
                        + pl.speed_weight * (max_v - v)
                        + pl.obstacle_weight * obstacle * dt_s
                }
                Gear::Reverse => {
                    // the body's slack at the end: the least of its discs' clearance beyond
                    // what each needs
                    let slack = (discs.iter())
                        .map(|&(dx, need)| {
                            grid.cell_of((x + hc * dx) as f32, (y + hs * dx) as f32)
                                .map_or(0.0, |(r, c)| f64::from(clear.at(r, c)) - need)
                        })
                        .fold(f64::INFINITY, f64::min);
                    let backed = v.abs() * dt_s * steps as f64;
                    pl.goal_weight
                        * (to_go(x, y)
                            - BACK_OUT_CLEARANCE_WEIGHT * slack
                            - BACK_OUT_DISTANCE_WEIGHT * backed)
                        + pl.obstacle_weight * obstacle * dt_s
                }
            };
            let place = kv * n_w + kw;
            if best.is_none_or(|b| score < b.2 || (score == b.2 && place < b.3)) {
                best = Some((v, w, score, place, start_to_go - closest));
            }
        }
    }
    // A long body whose arcs all come less than `TURN_FIRST_GAIN_M` nearer the goal (they lead
    // past a door beside it) may turn on the spot first (`planner.turn_first`): to each of
    // `TURN_FIRST_HEADINGS` a side at the top turn rate the window allows, then straight on at
    // the turning cap for what is left of the horizon (less the time lost getting up to speed).
    // It wins only by `TURN_FIRST_GAIN_M` of progress more: where an arc gains, turning on the
    // spot instead had Spot circling in an office, each turn's straight leg tried from a new
    // place.
    if gear == Gear::Forward && !round && pl.turn_first && v_lo == 0.0 {
        let v_go = max_v.min(turning_cap).min(speed_cap);
        let v_go = if pl.inside_margin_mps > 0.0 && closest < full {
            v_go.min(pl.inside_margin_mps)
        } else {
            v_go
        };
        let ramp_steps = (0.5 * v_go / max_accel / dt_s).ceil().min(steps as f64) as usize;
        // left, then right: each no slower than half the top turn rate the window allows
        for (w, side) in [(w_hi.min(max_omega), 1.0), (w_lo.max(-max_omega), -1.0)] {
            if w * side < 0.5 * max_omega || v_go <= 0.0 {
                continue;
            }
            let mut at = Rollout::start(start_to_go);
            let mut turned = 0;
            for j in 2..=TURN_FIRST_HEADINGS {
                let angle = std::f64::consts::PI * j as f64 / TURN_FIRST_HEADINGS as f64;
                let n_turn = (angle / (w.abs() * dt_s)).ceil() as usize;
                if n_turn.saturating_add(ramp_steps + 2) > steps {
                    break;
                }
                // the turn so far is shared by every heading beyond it
                if !roll(&mut at, 0.0, w, n_turn - turned) {
                    break;
                }
                turned = n_turn;
                let mut go = at;
                if !roll(&mut go, v_go, 0.0, steps - n_turn - ramp_steps) {
                    continue;
                }
                let score = pl.goal_weight * (go.closest + TURN_FIRST_GAIN_M)
                    + pl.speed_weight * max_v
                    + pl.obstacle_weight * go.obstacle * dt_s;
                if best.is_none_or(|b| score < b.2) {
                    best = Some((0.0, w, score, usize::MAX, start_to_go - go.closest));
                }
            }
        }
    }
    match best {
        Some((v, omega, score, _, gain_m)) => DwaOutcome::Drive {
            v,
            omega,
            score,
            routed: !lost,
            gain_m,
        },
        None => DwaOutcome::Blocked,
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::clearance::tests::map;
    use mimnav_shared::topics::cell_class;

    fn run(classes: &[u8], grid: GridSpec, v0: f64, goal: (f64, f64)) -> DwaOutcome {
        let mut clear = Clearance::default();
        clear.compute(classes, grid, 3.0, 5.0);
        let cost: Vec<u8> = classes
            .iter()
            .map(|&c| if c == cell_class::SOLID { 255 } else { 0 })
            .collect();
        let p = PlannerParams::default();
        let route = route_to(&p, grid, classes, &cost, goal);
        plan(&p, grid, &cost, &clear, v0, 0.0, goal, Some(&route))
    }

    /// The route to `goal` on 0.2 m cells, each metre's cost weighed once.
    fn route_to(
        p: &PlannerParams,
        grid: GridSpec,
        classes: &[u8],
        cost: &[u8],
        goal: (f64, f64),
    ) -> Route {
        let mut route = Route::default();
        route.build(
            &crate::route::RouteParams {
                cell_m: 0.2,
                cost_weight: 1.0,
                ..p.route_params(0.0)
            },
            grid,
            classes,
            cost,
            (goal.0 as f32, goal.1 as f32),
        );
        route
    }

    #[test]
    fn an_open_map_drives_straight_at_a_goal_ahead() {
        let (grid, classes) = map(|_, _| cell_class::FREE);
        match run(&classes, grid, 0.3, (4.0, 0.0)) {
            DwaOutcome::Drive { v, omega, .. } => {
                assert!(v > 0.4, "{v}");
                assert!(omega.abs() < 0.2, "{omega}");
            }
            o => panic!("{o:?}"),
        }
    }

    #[test]
    fn a_goal_to_the_left_turns_left() {
        let (grid, classes) = map(|_, _| cell_class::FREE);
        match run(&classes, grid, 0.0, (0.5, 3.0)) {
            DwaOutcome::Drive { omega, .. } => assert!(omega > 0.5, "{omega}"),
            o => panic!("{o:?}"),
        }
    }

    /// The speed caps of [`plan_capped_turning`]: a turning rollout no faster than its own cap,
    /// one that keeps its heading up to the other (a pane beside the lane, issue 22).
    #[test]
    fn a_turning_rollout_keeps_the_turning_cap_and_a_straight_one_the_other() {
        let (grid, classes) = map(|_, _| cell_class::FREE);
        let mut clear = Clearance::default();
        clear.compute(&classes, grid, 3.0, 5.0);
        let cost = vec![0u8; classes.len()];
        let p = PlannerParams::default();
        let drive = |goal: (f64, f64), caps: (f64, f64)| {
            let route = route_to(&p, grid, &classes, &cost, goal);
            match plan_capped_turning(
                &p,
                grid,
                &cost,
                &clear,
                (0.3, 0.0),
                caps,
                goal,
                Some(&route),
            ) {
                DwaOutcome::Drive { v, omega, .. } => (v, omega),
                o => panic!("{o:?}"),
            }
        };
        // a goal to the left: uncapped it turns at speed; with the turning cap it turns no
        // faster than the cap, or keeps its heading (faster)
        let free = drive((1.0, 2.5), (f64::INFINITY, f64::INFINITY));
        assert!(free.0 > 0.25 && free.1 > TURNING_RPS, "{free:?}");
        let capped = drive((1.0, 2.5), (f64::INFINITY, 0.2));
        assert!(
            capped.1.abs() <= TURNING_RPS || capped.0 <= 0.2 + 1e-9,
            "{capped:?}"
        );
        assert!(capped.1 > TURNING_RPS, "it still turns: {capped:?}");
        // a goal straight ahead: the turning cap does not hold it back
        let ahead = drive((4.0, 0.0), (f64::INFINITY, 0.2));
        assert!(ahead.0 > 0.4 && ahead.1.abs() <= TURNING_RPS, "{ahead:?}");
        // both caps alike: every rollout capped
        let both = drive((4.0, 0.0), (0.2, 0.2));
        assert!(both.0 <= 0.2 + 1e-9, "{both:?}");
    }

    #[test]
    fn a_wall_ahead_with_an_opening_on_the_left_is_driven_around() {
        // wall across at x = 1 m from y = -3 to y = 0.5; open beyond
        let (grid, classes) = map(|x, y| {
            if (x - 1.0).abs() < 0.05 && y < 0.5 {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        match run(&classes, grid, 0.2, (3.0, 0.0)) {
            o @ DwaOutcome::Drive { omega, .. } => assert!(omega > 0.2, "swerves left: {o:?}"),
            o => panic!("{o:?}"),
        }
    }

    #[test]
    fn boxed_in_at_speed_is_blocked() {
        // a ring of wall 0.35 m around a robot doing 0.5 m/s: it cannot slow below 0.2 m/s
        // within the window, and every such trajectory touches the ring
        let (grid, classes) = map(|x, y| {
            if (x.hypot(y) - 0.35).abs() < 0.05 {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        assert!(run(&classes, grid, 0.5, (3.0, 0.0)).is_stop());
    }

    #[test]
    fn inside_an_obstacle_is_blocked() {
        let (grid, classes) = map(|x, _| {
            if x.abs() < 0.03 {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        assert!(run(&classes, grid, 0.0, (-3.0, 0.0)).is_stop());
    }

    #[test]
    fn too_close_already_backs_off_without_getting_closer() {
        // a wall 0.1 m ahead (inside the 0.2 m footprint), the goal straight through it: the
        // robot may only turn or move away, never closer
        let (grid, classes) = map(|x, _| {
            if (x - 0.1).abs() < 0.03 {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        match run(&classes, grid, 0.0, (3.0, 0.0)) {
            DwaOutcome::Drive { v, omega, .. } => {
                assert!(v < 0.05 || omega.abs() > 0.5, "{v} {omega}")
            }
            DwaOutcome::Blocked => {}
        }
        // whatever it chose, its trajectory kept its distance: check the straight one is refused
        let (clear, cost) = open_cost(&classes, grid, 3.0);
        let mut straight = PlannerParams::default();
        straight.planner.omega_samples = 1;
        straight.robot.max_angular_rps = 0.0;
        match plan(&straight, grid, &cost, &clear, 0.3, 0.0, (3.0, 0.0), None) {
            DwaOutcome::Drive { v, .. } => assert!(v < 1e-9, "it stands: {v}"),
            DwaOutcome::Blocked => {}
        }
    }

    #[test]
    fn odometry_faster_than_the_limit_never_commands_above_it() {
        let (grid, classes) = map(|_, _| cell_class::FREE);
        for v0 in [0.51, 0.8, 5.0] {
            match run(&classes, grid, v0, (4.0, 0.0)) {
                DwaOutcome::Drive { v, .. } => assert!(v <= 0.5, "{v0} → {v}"),
                o => panic!("{o:?}"),
            }
        }
    }

    /// The clearance of `classes` out to `reach_m`, and a planning cost of zero everywhere.
    fn open_cost(classes: &[u8], grid: GridSpec, reach_m: f32) -> (Clearance, Vec<u8>) {
        let mut clear = Clearance::default();
        clear.compute(classes, grid, reach_m, 5.0);
        (clear, vec![0u8; grid.len()])
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(48))]
        /// Skipping the speeds whose bound cannot beat the best so far chooses exactly what
        /// rolling out every sample chooses (the same motion, the same score, bit for bit), on
        /// any map, from any velocity, towards any goal, with and without a route, for a round
        /// and a long body, forwards and backing out.
        #[test]
        fn skipping_speeds_by_their_bound_chooses_what_the_full_window_does(
            blobs in proptest::collection::vec((-4.5f32..4.5, -4.5f32..4.5, 0.05f32..0.8), 0..12),
            v0 in 0.0f64..0.8,
            w0 in -1.5f64..1.5,
            goal in (-8.0f64..8.0, -8.0f64..8.0),
            long in proptest::bool::ANY,
            routed in proptest::bool::ANY,
            reverse in proptest::bool::ANY,
        ) {
            let (grid, classes) = map(|x, y| {
                let hit = blobs.iter().any(|&(bx, by, r)| (x - bx).hypot(y - by) < r
                    && x.hypot(y) > 0.9);
                if hit { cell_class::SOLID } else { cell_class::FREE }
            });
            let p = if long { spot() } else { PlannerParams::default() };
            let mut clear = Clearance::default();
            clear.compute(&classes, grid, p.reach_m() as f32 + 0.1, 5.0);
            let cost: Vec<u8> = classes
                .iter()
                .map(|&c| if c == cell_class::SOLID { 255 } else { 0 })
                .collect();
            let mut route = Route::default();
            route.build(
                &p.route_params(p.reach_m() as f32),
                grid,
                &classes,
                &cost,
                (goal.0 as f32, goal.1 as f32),
            );
            let route = routed.then_some(&route);
            let gear = if reverse { Gear::Reverse } else { Gear::Forward };
            let run = |prune| search(
                &p, grid, &cost, &clear, (v0, w0), (f64::INFINITY, f64::INFINITY), goal, route,
                gear, prune,
            );
            let (all, pruned) = (run(false), run(true));
            let bits = |o: DwaOutcome| match o {
                DwaOutcome::Drive { v, omega, score, routed, gain_m } => {
                    Some((v.to_bits(), omega.to_bits(), score.to_bits(), routed, gain_m.to_bits()))
                }
                DwaOutcome::Blocked => None,
            };
            proptest::prop_assert_eq!(bits(all), bits(pruned), "{:?} vs {:?}", all, pruned);
        }
    }

    /// Spot's body as its profile gives it: 1.1 × 0.5 m (its enclosing circle: 0.6 m).
    pub(crate) fn spot() -> PlannerParams {
        let mut p = PlannerParams::default();
        p.robot.radius_m = 0.6;
        p.robot.length_m = 1.1;
        p.robot.width_m = 0.5;
        p.robot.max_linear_mps = 0.6;
        p
    }

    #[test]
    fn a_rectangular_body_drives_through_a_door_its_enclosing_circle_does_not_fit() {
        // a wall across x = 1.2 m with a 1 m door on the heading
        let (grid, classes) = map(|x, y| {
            if (x - 1.2).abs() < 0.05 && y.abs() > 0.5 {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        let (clear, cost) = open_cost(&classes, grid, 4.0);
        let straight = |mut p: PlannerParams| {
            p.planner.omega_samples = 1;
            p.robot.max_angular_rps = 0.0;
            plan(&p, grid, &cost, &clear, 0.5, 0.0, (4.0, 0.0), None)
        };
        match straight(spot()) {
            DwaOutcome::Drive { v, .. } => assert!(v > 0.45, "through the door: {v}"),
            o => panic!("the body fits the door: {o:?}"),
        }
        let mut round = spot();
        (round.robot.length_m, round.robot.width_m) = (0.0, 0.0);
        assert_eq!(straight(round), DwaOutcome::Blocked);
    }

    #[test]
    fn the_body_is_checked_along_each_rollouts_heading() {
        // a 1 m corridor: Spot fits lengthwise but cannot turn across it; a small round robot can
        let (grid, classes) = map(|_, y| {
            if y.abs() > 0.5 {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        let (clear, cost) = open_cost(&classes, grid, 4.0);
        let turn_in_place = |mut p: PlannerParams| {
            p.planner.v_samples = 1;
            p.planner.omega_samples = 1;
            p.robot.max_linear_accel = 0.01;
            p.robot.max_angular_accel = 0.01;
            p.robot.max_angular_rps = 1.0;
            plan(&p, grid, &cost, &clear, 0.0, 1.0, (0.0, 3.0), None)
        };
        assert_eq!(turn_in_place(spot()), DwaOutcome::Blocked);
        assert!(matches!(
            turn_in_place(PlannerParams::default()),
            DwaOutcome::Drive { .. }
        ));
        // heading along the corridor, the same body drives
        let mut ahead = spot();
        ahead.planner.omega_samples = 1;
        ahead.robot.max_angular_rps = 0.0;
        assert!(matches!(
            plan(&ahead, grid, &cost, &clear, 0.3, 0.0, (4.0, 0.0), None),
            DwaOutcome::Drive { v, .. } if v > 0.25
        ));
    }

    /// Issue 22 (glass corridors): a door in the side of a corridor, seen open only once Spot is
    /// beside it. The best arc of the window creeps round at a few cm/s and its rollout ends
    /// still in the corridor; turning on the spot first (`planner.turn_first`) and walking in
    /// comes at least `TURN_FIRST_GAIN_M` nearer, so Spot stands and turns towards the door.
    /// A round body's search is the arcs alone.
    #[test]
    fn a_long_body_beside_a_side_door_turns_on_the_spot_towards_it() {
        // a corridor 1.6 m wide along x, a 1.2 m door in its left wall beside the robot, the
        // goal in the room behind it
        let (grid, classes) = map(|x, y| {
            let left = (y - 0.825).abs() < 0.05 && x.abs() > 0.6;
            let right = (y + 0.825).abs() < 0.05;
            if left || right {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        let (clear, cost) = open_cost(&classes, grid, 4.0);
        let goal = (0.0, 2.5);
        let drive = |p: &PlannerParams| {
            let route = route_to(p, grid, &classes, &cost, goal);
            plan(p, grid, &cost, &clear, 0.3, 0.0, goal, Some(&route))
        };
        // Spot's own turn rate
        let mut first = spot();
        first.robot.max_angular_rps = 0.6;
        let mut arcs = first.clone();
        arcs.planner.turn_first = false;
        assert!(first.planner.turn_first, "on by default");
        let (
            DwaOutcome::Drive {
                gain_m: arc_gain, ..
            },
            DwaOutcome::Drive {
                v, omega, gain_m, ..
            },
        ) = (drive(&arcs), drive(&first))
        else {
            panic!("both drive: {:?} {:?}", drive(&arcs), drive(&first));
        };
        assert_eq!(v, 0.0, "stands to turn");
        assert!(omega > 0.3, "towards the door on the left: {omega}");
        assert!(
            gain_m > arc_gain + TURN_FIRST_GAIN_M,
            "{gain_m} against {arc_gain}"
        );
        // a round body of the same reach never turns first
        let mut round = first.clone();
        (
            round.robot.length_m,
            round.robot.width_m,
            round.robot.radius_m,
        ) = (0.0, 0.0, 0.25);
        assert!(matches!(drive(&round), DwaOutcome::Drive { v, .. } if v > 0.0));
    }

    /// Spot walked along a storefront that converged on its path until the only motion the
    /// window allowed was standing still (a 1.1 m body cannot turn away from a pane 0.16 m from
    /// its side: a corner swings into it). Backing out moves it back, on a trajectory the map
    /// allows, and leaves it clearer of the pane.
    #[test]
    fn a_long_body_held_still_beside_glass_backs_out() {
        // glass on the right converging on the heading (3° in), a wall across 0.2 m past the
        // nose; `behind`: and a wall across 0.2 m behind the tail
        let trap = |behind: bool| {
            map(|x, y| {
                let pane = y + 0.43 - 0.05 * x;
                if pane.abs() < 0.05 || (x - 0.8).abs() < 0.05 || behind && (x + 0.8).abs() < 0.05 {
                    cell_class::GLASS
                } else {
                    cell_class::FREE
                }
            })
        };
        let (grid, classes) = trap(false);
        let (clear, cost) = open_cost(&classes, grid, 4.0);
        let goal = (4.0, 0.0);
        match plan(&spot(), grid, &cost, &clear, 0.0, 0.0, goal, None) {
            DwaOutcome::Drive { v, omega, .. } => {
                assert!(
                    v.abs() < 0.01 && omega.abs() < 0.05,
                    "held still: {v} {omega}"
                )
            }
            o => panic!("{o:?}"),
        }
        match back_out(&spot(), grid, &cost, &clear, (0.0, 0.0), goal, None) {
            DwaOutcome::Drive { v, .. } => assert!(v < -0.02, "backs out: {v}"),
            o => panic!("{o:?}"),
        }
        // walled in behind as well: no step back
        let (grid, boxed) = trap(true);
        let (clear, cost) = open_cost(&boxed, grid, 4.0);
        assert_eq!(
            back_out(&spot(), grid, &cost, &clear, (0.0, 0.0), goal, None),
            DwaOutcome::Blocked
        );
    }

    /// Issue 22, stop 61: backing straight out of a narrow corridor gains the body no clearance
    /// at its discs, and scored on the way to the goal alone the slowest reverse won (Spot
    /// backed 3 cm a try, wedged in a corridor's mouth). It backs out at the recovery speed.
    #[test]
    fn a_long_body_backs_out_of_a_narrow_corridor_at_the_recovery_speed() {
        // glass 0.45 m either side of the heading from 2 m behind to 4 m ahead, the goal ahead
        // (by the straight line: a metre backed is a metre more to go)
        let side = |x: f32, y: f32| (y.abs() - 0.45).abs() < 0.03 && x > -2.0 && x < 4.0;
        let (grid, classes) = map(|x, y| match side(x, y) {
            true => cell_class::GLASS,
            false => cell_class::FREE,
        });
        let (clear, cost) = open_cost(&classes, grid, 4.0);
        let p = spot();
        match back_out(&p, grid, &cost, &clear, (0.0, 0.0), (4.0, 0.0), None) {
            DwaOutcome::Drive { v, omega, .. } => {
                let back = p.planner.recovery_mps;
                assert!(v <= -0.9 * back, "backs out at {v}, not {back}");
                assert!(omega.abs() < 0.1, "straight back along it: {omega}");
            }
            o => panic!("{o:?}"),
        }
    }

    #[test]
    fn a_body_in_a_door_at_a_slant_drives_on_with_a_jamb_beside_it() {
        // Spot half through a 1 m door, turned 27.5° to it (robot frame): the lower jamb
        // 0.115 m from its right side, inside the margin. Held point by point to "no closer
        // than now", the jamb sliding along its side made every motion but standing infeasible
        // (it froze there in the simulator).
        let (s, c) = 27.5f32.to_radians().sin_cos();
        let ray = |x0: f32, y0: f32, dx: f32, dy: f32, x: f32, y: f32| {
            let t = ((x - x0) * dx + (y - y0) * dy).max(0.0);
            (x - x0 - t * dx).hypot(y - y0 - t * dy)
        };
        let (grid, classes) = map(|x, y| {
            if ray(0.16, -0.365, -s, -c, x, y) < 0.05 || ray(0.62, 0.52, s, c, x, y) < 0.05 {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        let (clear, cost) = open_cost(&classes, grid, 4.0);
        match plan(&spot(), grid, &cost, &clear, 0.0, 0.0, (3.25, -3.1), None) {
            DwaOutcome::Drive { v, .. } => assert!(v > 0.05, "moves on: {v}"),
            o => panic!("{o:?}"),
        }
    }

    #[test]
    fn a_body_inside_its_margin_slows_to_inside_margin_mps() {
        // Spot driving along a wall on its right, at speed, the goal straight ahead: its speed
        // with the wall's cells at `y` (robot frame)
        let speed = |p: &PlannerParams, y: f32| {
            let (grid, classes) = map(|_, yy| match (yy - y).abs() < 0.03 {
                true => cell_class::SOLID,
                false => cell_class::FREE,
            });
            let (clear, cost) = open_cost(&classes, grid, 4.0);
            match plan(p, grid, &cost, &clear, 0.5, 0.0, (4.0, 0.0), None) {
                DwaOutcome::Drive { v, .. } => v,
                o => panic!("{o:?}"),
            }
        };
        // 0.07 m from its right side: inside the 0.1 m margin, above the half it may come to
        let inside = -0.345;
        let mut p = spot();
        p.planner.inside_margin_mps = 0.0;
        let free = speed(&p, inside);
        assert!(free > 0.35, "not limited: {free}");
        p.planner.inside_margin_mps = 0.2;
        let v = speed(&p, inside);
        assert!(v <= 0.2 + 1e-9 && v > 0.0, "{v}");
        // the same wall beyond the margin: not limited
        let beyond = speed(&p, -0.6);
        assert!(beyond > 0.35, "{beyond}");
    }

    #[test]
    fn a_long_body_never_brings_a_cell_beside_it_nearer_than_the_cell_can_hold() {
        // Spot creeping on with a bush's edge just off its rear left corner and the goal to its
        // right: turning right swings that corner into the bush. The clearance is a cell
        // centre's, so each cell the corner passes may keep its clearance while the corner
        // sweeps into what the cell holds; the guarded cells stop that.
        let p = spot();
        let body = p.robot.body();
        let blob = (-0.45f32, 0.38f32);
        let (grid, classes) = map(|x, y| match (x - blob.0).hypot(y - blob.1) < 0.1 {
            true => cell_class::SOLID,
            false => cell_class::FREE,
        });
        let solid: Vec<(f64, f64)> = (0..grid.cells)
            .flat_map(|r| (0..grid.cells).map(move |c| (r, c)))
            .filter(|&(r, c)| classes[grid.index(r, c)] == cell_class::SOLID)
            .map(|(r, c)| {
                let (x, y) = grid.center_of(r, c);
                (f64::from(x), f64::from(y))
            })
            .collect();
        let nearest = |x: f64, y: f64, hc: f64, hs: f64| {
            (solid.iter())
                .map(|&(sx, sy)| {
                    let (dx, dy) = (sx - x, sy - y);
                    body.signed_distance(hc * dx + hs * dy, -hs * dx + hc * dy)
                })
                .fold(f64::INFINITY, f64::min)
        };
        // the nearest a motion brings the blob over the horizon, rolled out as the window does
        let rolled = |v: f64, w: f64| {
            let dt = p.planner.dt_s;
            let (mut x, mut y, mut hc, mut hs) = (0.0f64, 0.0f64, 1.0f64, 0.0f64);
            let mut least = f64::INFINITY;
            for _ in 0..(p.planner.horizon_s / dt).ceil() as usize {
                let (s, c) = (w * dt).sin_cos();
                (hc, hs) = (hc * c - hs * s, hs * c + hc * s);
                x += v * hc * dt;
                y += v * hs * dt;
                least = least.min(nearest(x, y, hc, hs));
            }
            least
        };
        let now = nearest(0.0, 0.0, 1.0, 0.0);
        let goal = (-0.5, -3.0);
        let floor = now.min(guard_m(grid)) - 1e-3;
        let (mut clear, cost) = open_cost(&classes, grid, 4.0);
        let unguarded = match plan(&p, grid, &cost, &clear, 0.2, 0.0, goal, None) {
            DwaOutcome::Drive { v, omega, .. } => rolled(v, omega),
            o => panic!("{o:?}"),
        };
        assert!(
            unguarded < floor,
            "the clearance alone lets the corner in: {unguarded} (now {now})"
        );
        clear.set_guard(&classes, grid, &body, guard_m(grid) + 0.06);
        assert!(!clear.guard().is_empty());
        match plan(&p, grid, &cost, &clear, 0.2, 0.0, goal, None) {
            DwaOutcome::Drive { v, omega, .. } => {
                let least = rolled(v, omega);
                assert!(
                    least >= floor,
                    "({v}, {omega}) brings it to {least} (now {now})"
                );
            }
            DwaOutcome::Blocked => {}
        }
    }

    #[test]
    fn a_round_body_never_brings_a_cell_beside_it_nearer_than_the_cell_can_hold() {
        // The Turtlebot 2 driving straight on, a stray solid cell inside its edge beside it
        // (where it stands the clearance is that cell's, and only "no nearer than that" holds
        // it) and one cell of a bush ahead beside its path: the bush's cell keeps a clearance
        // above the stray's all the way, so the clearance alone lets the body pass it nearer
        // than `round_guard_m` (on an impassable hedge it grazed a bush so). Guarded, it never
        // does. Over cells at the body's side ahead, straight on only.
        // (a radius off the grid's half cells, so that the path passes a cell's centre within
        // `round_guard_m`)
        let mut p = PlannerParams::default();
        p.planner.omega_samples = 1;
        p.robot.max_angular_rps = 0.0;
        p.robot.radius_m = 0.21;
        let body = p.robot.body();
        let stray = (-0.025f32, -0.175);
        let (mut let_in, mut moved, mut tried) = (0, 0, 0);
        for k in 0..12 {
            for side in [0.0f32, 0.05] {
                let bush = (0.025 + 0.05 * k as f32, -0.225 - side);
                let (grid, classes) = map(|x, y| {
                    let near =
                        |(cx, cy): (f32, f32)| (x - cx).abs() < 0.03 && (y - cy).abs() < 0.03;
                    match near(stray) || near(bush) {
                        true => cell_class::SOLID,
                        false => cell_class::FREE,
                    }
                });
                let Some((br, bc)) = grid.cell_of(bush.0, bush.1) else {
                    continue;
                };
                let (bx, by) = grid.center_of(br, bc);
                let (bx, by) = (f64::from(bx), f64::from(by));
                let now = body.signed_distance(bx, by);
                if !(0.0..guard_m(grid) + 0.06).contains(&now) {
                    continue;
                }
                tried += 1;
                let floor = now.min(round_guard_m(grid)) - 1e-3;
                // the nearest the straight motion at v brings the bush's cell
                let nearest = |v: f64| {
                    let dt = p.planner.dt_s;
                    (1..=(p.planner.horizon_s / dt).ceil() as usize)
                        .map(|k| body.signed_distance(bx - v * dt * k as f64, by))
                        .fold(f64::INFINITY, f64::min)
                };
                let (mut clear, cost) = open_cost(&classes, grid, 4.0);
                if let DwaOutcome::Drive { v, .. } =
                    plan(&p, grid, &cost, &clear, 0.3, 0.0, (3.0, 0.0), None)
                {
                    let_in += usize::from(nearest(v) < floor);
                }
                clear.set_guard(&classes, grid, &body, guard_m(grid) + 0.06);
                if let DwaOutcome::Drive { v, .. } =
                    plan(&p, grid, &cost, &clear, 0.3, 0.0, (3.0, 0.0), None)
                {
                    moved += usize::from(v > 0.05);
                    let least = nearest(v);
                    assert!(
                        least >= floor,
                        "bush cell at ({bx}, {by}): {v} m/s brings it to {least} (now {now})"
                    );
                }
            }
        }
        assert!(
            let_in > 0,
            "the clearance alone never let the body in ({tried} tried)"
        );
        // and guarded, the body still drives on past the cells it passes far enough from
        assert!(moved > 0, "guarded, it never drove on ({tried} tried)");
    }

    #[test]
    fn creeping_on_without_a_route_keeps_the_whole_margin() {
        // Spot 7 cm from a wall on its right, inside its margin, the goal walled in ahead: the
        // map has no route to it. Routed (or with no route searched) the window lets the body
        // on along the wall inside its margin; lost, it keeps the whole margin, so it is held:
        // the world may be impassable (on impassable hedges Spot crept into a bush).
        let goal = (3.0, 0.0);
        let (grid, classes) = map(|x, y| {
            let ring = ((x - goal.0 as f32).hypot(y) - 0.6).abs() < 0.06;
            match (y + 0.345).abs() < 0.03 || ring {
                true => cell_class::SOLID,
                false => cell_class::FREE,
            }
        });
        let (clear, cost) = open_cost(&classes, grid, 4.0);
        let p = spot();
        let route = route_to(&p, grid, &classes, &cost, goal);
        // no way on the map: the lengths lead off it, driven as without a route
        assert!(route.beyond(), "the goal is walled in");
        assert!(matches!(
            plan(&p, grid, &cost, &clear, 0.2, 0.0, goal, None),
            DwaOutcome::Drive { v, .. } if v > 0.05
        ));
        assert_eq!(
            plan(&p, grid, &cost, &clear, 0.2, 0.0, goal, Some(&route)),
            DwaOutcome::Blocked
        );
    }
}
