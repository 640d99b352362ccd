//! The planner service's step: everything between receiving its topics and publishing `cmd_vel`,
//! without IPC and without reading a clock (every call is given `now`, monotonic ns).
//!
//! The service (`main.rs`), `mimnav eval` and the lock-step runner all drive this type, so the
//! fail-safe rules below are the ones every figure measures:
//!
//! - **no goal** (none received, or older than `planner.goal_max_age_s`): zero velocity,
//!   [`command_status::NO_GOAL`];
//! - **stale input**: odometry missing or older than `planner.odom_max_age_s`, or no map for
//!   `planner.map_max_age_s` (the service's deadline on `map/plan` and its 100 ms tick ask
//!   [`Pilot::on_silence`]), or a map whose header does not describe its payload: zero
//!   velocity, [`command_status::STALE_INPUT`], with the reason in [`Decision::stale`];
//! - **non-finite input is refused** where it arrives ([`Pilot::odom`], [`Pilot::goal`]): it never
//!   replaces the last good message, so it ages into stale input instead of steering;
//! - **goal reached**: within the goal's tolerance, zero velocity;
//! - **blocked**: no feasible motion, or a planner result that is not finite: zero velocity;
//! - **command expiry**: every command is valid for `robot.command_validity_s` from when it is
//!   sent ([`Pilot::command`]); a base stops once `valid_until_mono_ns` passes;
//! - **foliage**: the obstacles of a verdict no older than `planner.foliage_max_age_s` are solid
//!   for the planner (DESIGN §8); an older verdict is ignored, and its alarm flag with it.

use mimnav_shared::config::Body;
use mimnav_shared::grid::GridSpec;
use mimnav_shared::hop::Hop;
use mimnav_shared::pose::{NonFiniteOdometry, check_odometry, odom_pose};
use mimnav_shared::topics::{
    FoliageHeader, FoliageReturn, Goal, MapHeader, Odometry, VelocityCommand, cell_class,
    command_flags, command_status, foliage_class, goal_flags,
};

use crate::dwa::DwaOutcome;
use crate::{Planner, PlannerParams, confirm_obstacles};

/// Why the robot is stopped for stale input.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stale {
    /// No odometry received yet (or only non-finite odometry).
    NoOdometry,
    /// The last good odometry is older than `planner.odom_max_age_s`.
    OldOdometry,
    /// No map on `map/plan` for `planner.map_max_age_s`.
    NoMap,
    /// A map whose header does not match its payload (cell count, cell size).
    BadMap,
    /// The goal in the robot frame is not finite (odometry or goal so large the numbers
    /// overflow) or is farther than [`crate::guard::MAX_GOAL_M`] ([`crate::guard`]).
    GoalOutOfRange,
}

impl Stale {
    /// What to tell a person.
    pub fn reason(self) -> &'static str {
        match self {
            Stale::NoOdometry => "no odometry",
            Stale::OldOdometry => "odometry older than planner.odom_max_age_s",
            Stale::NoMap => "no map on map/plan for planner.map_max_age_s",
            Stale::BadMap => "a map whose header does not match its cells",
            Stale::GoalOutOfRange => {
                "the goal in the robot frame is not finite or is over 100 km away"
            }
        }
    }
}

/// What the pilot decided: the velocity to command and why.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decision {
    /// Forward speed, m/s (finite).
    pub v: f64,
    /// Turn rate, rad/s (finite).
    pub omega: f64,
    /// [`command_status`].
    pub status: u8,
    /// [`command_flags`].
    pub flags: u8,
    /// With [`command_status::STALE_INPUT`]: what is stale.
    pub stale: Option<Stale>,
    /// The map's revolution: its sensor stamp and sequence number (0 without a map).
    pub source_stamp_ns: u64,
    /// See `source_stamp_ns`.
    pub source_seq: u64,
}

impl Decision {
    fn stop(status: u8, flags: u8, stale: Option<Stale>, map: Option<&MapHeader>) -> Decision {
        Decision {
            v: 0.0,
            omega: 0.0,
            status,
            flags,
            stale,
            source_stamp_ns: map.map_or(0, |h| h.stamp_ns),
            source_seq: map.map_or(0, |h| h.source_seq),
        }
    }

    /// Driving at (v, ω) with `flags`, planned on the map of `header`.
    fn drive(v: f64, omega: f64, flags: u8, header: &MapHeader) -> Decision {
        Decision {
            v,
            omega,
            status: command_status::DRIVING,
            flags,
            stale: None,
            source_stamp_ns: header.stamp_ns,
            source_seq: header.source_seq,
        }
    }

    /// One line for a person (and systemd's `STATUS=`).
    pub fn describe(&self) -> String {
        let what = match self.status {
            command_status::DRIVING => "driving".to_string(),
            command_status::GOAL_REACHED => "goal reached: zero velocity".to_string(),
            command_status::BLOCKED if self.flags & command_flags::NO_ROUTE != 0 => {
                "blocked (no route to the goal on the map): zero velocity".to_string()
            }
            command_status::BLOCKED if self.flags & command_flags::BACKING_OUT != 0 => {
                "blocked (held still, and backing out brought it no nearer the goal): zero velocity"
                    .to_string()
            }
            command_status::BLOCKED => "blocked (no feasible motion): zero velocity".to_string(),
            command_status::NO_GOAL => "no goal: zero velocity".to_string(),
            command_status::STALE_INPUT => format!(
                "stale input ({}): zero velocity",
                self.stale.map_or("?", Stale::reason)
            ),
            s => format!("status {s}"),
        };
        let driving = self.status == command_status::DRIVING;
        let what = if driving && self.flags & command_flags::NO_ROUTE != 0 {
            what + " slowly: no route to the goal on the map"
        } else {
            what
        };
        let what = if driving && self.flags & command_flags::BACKING_OUT != 0 {
            what + " back: backing out"
        } else {
            what
        };
        let what = if driving && self.flags & command_flags::TIGHT != 0 {
            what + " squeezing through (planner.tight_margin_m)"
        } else {
            what
        };
        let what = if driving && self.flags & command_flags::MANEUVERING != 0 {
            what + " on a searched way out (moves and turns on the spot)"
        } else {
            what
        };
        let what = if driving && self.flags & command_flags::LOOKING != 0 {
            what + " beside suspected glass, to see it"
        } else {
            what
        };
        if self.flags & command_flags::FOLIAGE_ALARM != 0 {
            what + "; foliage alarm"
        } else {
            what
        }
    }
}

/// An input refused because it cannot be acted on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Refused {
    /// Odometry with a non-finite pose or velocity.
    #[error(transparent)]
    Odometry(#[from] NonFiniteOdometry),
    /// A goal with a non-finite position or a tolerance that is not finite and ≥ 0.
    #[error("a goal with a non-finite position or a bad tolerance (seq {0}): ignored")]
    Goal(u64),
}

/// The latest foliage verdict: its header and its obstacle returns (bearing, range).
#[derive(Debug, Default)]
struct Foliage {
    header: Option<FoliageHeader>,
    obstacles: Vec<(f32, f32)>,
}

/// The planner service's state between messages: the latest odometry, goal and foliage verdict,
/// when the last map came, and the planner with its buffers.
#[derive(Debug)]
pub struct Pilot {
    planner: Planner,
    odom: Option<Odometry>,
    goal: Option<Goal>,
    foliage: Foliage,
    last_map_ns: Option<u64>,
    classes: Vec<u8>,
    seq: u64,
    /// Since when the map has held no route to the goal (monotonic ns), and how the way off
    /// the map ([`crate::route::Route::beyond`]) shortened meanwhile: one it leads along keeps
    /// the creep going.
    no_route: Progress,
    map_hop: Hop,
    /// Backing out: see [`BackOut`].
    back_out: BackOut,
    /// A long body's way out: see [`Maneuvering`].
    maneuver: Maneuvering,
    /// Going to look at suspected glass: see [`Look`].
    look: Look,
    /// The solids and glass of past maps, for the route beyond the map.
    memory: crate::memory::Memory,
    /// Squeezing through: see [`Tight`].
    tight: Tight,
    /// Suspected glass given up: see [`GiveUp`].
    given_up: GiveUp,
}

/// Below these speeds (m/s, rad/s) a command holds the robot (nearly) still: a long body that
/// cannot turn away creeps ever slower towards what holds it.
const STILL: (f64, f64) = (0.03, 0.05);

/// A long body counts as led away ([`crate::config::PlannerConfig::still_gain_m`]) only
/// farther than this from the goal by the route, m.
const AWAY_FAR_M: f64 = 1.0;

/// A body led away counts as beside a pane with this many glass or suspected-glass cells ...
const AWAY_PANE_CELLS: usize = 6;
/// ... within this distance of its centre, m.
const AWAY_PANE_M: f64 = 1.2;
/// A body led away counts as in a corridor with this many blocking cells on each side ...
const AWAY_SIDE_CELLS: usize = 3;
/// ... within this distance of its axis, m ...
const AWAY_SIDE_M: f64 = 1.0;
/// ... and this far ahead of or behind its centre, m.
const AWAY_SIDE_ALONG_M: f64 = 0.6;

/// How far behind the body the route is looked at for a way shorter than where it stands, m.
const AWAY_LOOK_M: f32 = 0.5;
/// A body led only away searches a way out at once, and after a search that found none no
/// sooner than this again (a search that finds none spends its whole budget, some 20 ms), ns.
const AWAY_SEARCH_EVERY_NS: u64 = 1_000_000_000;
/// How long a body led only away follows a way out found for it when `planner.maneuver_s`
/// does not say (0: a body held still backs out), ns.
const AWAY_MANEUVER_NS: u64 = 20_000_000_000;
/// A body led only away that has come back within this of where it last followed a way out
/// drives on as planned: the way out led it back the same way (an office, `office s1400 i9`), m.
const AWAY_AGAIN_M: f64 = 1.0;
/// A body led only away drives on past what it came for when its plan turns slower than this
/// share of its top turn rate.
const AWAY_TURN_SHARE: f64 = 0.25;
/// Whether a way out's first straight move is back.
fn first_straight_backs(plan: &crate::maneuver::Plan) -> bool {
    use crate::maneuver::Move;
    plan.moves
        .iter()
        .find(|(m, _)| matches!(m, Move::Forward | Move::Back))
        .is_some_and(|(m, _)| *m == Move::Back)
}

/// How many moves of a way out make its backing: every move before its first forward one, when
/// a back move is among them (so the turns on the spot after the last back move), else none.
fn backing_moves(plan: &crate::maneuver::Plan) -> usize {
    use crate::maneuver::Move;
    let first_forward = (plan.moves.iter())
        .position(|(m, _)| *m == Move::Forward)
        .unwrap_or(plan.moves.len());
    let backs = plan.moves[..first_forward]
        .iter()
        .any(|(m, _)| *m == Move::Back);
    if backs { first_forward } else { 0 }
}

/// How far a way out backs before its first forward move, m (the straight line from its start
/// to where the backing ends: moves are `step_m` each, turns on the spot move nothing).
fn backing_m(plan: &crate::maneuver::Plan) -> f64 {
    let n = backing_moves(plan);
    plan.moves[..n]
        .last()
        .map_or(0.0, |(_, [x, y, _])| x.hypot(*y))
}

/// Nearer the goal by this much (m, straight line) is progress: the backing-out tries start
/// again from none.
const PROGRESS_M: f64 = 0.5;

/// The robot held still by the dynamic window, and backing out of it.
#[derive(Debug, Clone, Copy)]
struct BackOut {
    /// Since when every plan held the robot still (monotonic ns).
    still_since: Option<u64>,
    /// Backing out until then (monotonic ns).
    until: Option<u64>,
    /// Tries since the robot last got `PROGRESS_M` nearer the goal.
    tries: u32,
    /// The distance to the goal then, m.
    progress_ref_m: f64,
    /// When a search for a way out found none for a body led only away (monotonic ns): the
    /// next is tried [`AWAY_SEARCH_EVERY_NS`] later at the soonest.
    away_failed: Option<u64>,
    /// Where (odometry frame) the last way out was found for a body led only away: it is not
    /// searched again within [`AWAY_AGAIN_M`] of there.
    away_at: Option<(f64, f64)>,
}

/// A long body following a way out ([`crate::maneuver`]): its moves with the poses they end
/// at, in the odometry frame, followed in order; searched anew from where the robot stands
/// when a map shows one of the poses left blocked.
#[derive(Debug, Clone, Default)]
struct Maneuvering {
    /// Until then at most (monotonic ns); `None`: not maneuvering.
    until: Option<u64>,
    /// The moves and the poses they end at (odometry frame: x, y m, heading rad).
    moves: Vec<(crate::maneuver::Move, [f64; 3])>,
    /// The first move not yet done.
    next: usize,
    /// Only the way's backing is followed (`planner.away_window_after_back`), a way searched
    /// anew included: the window drives the rest.
    backing_only: bool,
}

/// A maneuver's straight move is done this near its end (m), a turn this near its heading
/// (rad).
const MOVE_DONE: (f64, f64) = (0.02, 0.03);
/// A maneuver's straight moves hold their heading turning this much per radian off it, 1/s.
const HOLD_GAIN: f64 = 1.0;

impl Maneuvering {
    /// Takes `plan` (robot frame at `pose`) as the way to follow.
    fn follow(&mut self, plan: &crate::maneuver::Plan, pose: &mimnav_shared::pose::Pose2) {
        use mimnav_shared::pose::Pose2Ext as _;
        let n = if self.backing_only {
            backing_moves(plan)
        } else {
            plan.moves.len()
        };
        self.moves.clear();
        self.moves
            .extend(plan.moves[..n].iter().map(|&(mv, [x, y, th])| {
                let (fx, fy) = pose.to_fixed(x, y);
                (mv, [fx, fy, crate::maneuver::wrap(pose.yaw() + th)])
            }));
        self.next = 0;
    }

    /// Moves on past the moves done at `pose`; the move to make, with the pose it ends at.
    fn current(
        &mut self,
        pose: &mimnav_shared::pose::Pose2,
    ) -> Option<(crate::maneuver::Move, [f64; 3])> {
        use crate::maneuver::Move;
        use mimnav_shared::pose::Pose2Ext as _;
        while let Some(&(mv, [x, y, th])) = self.moves.get(self.next) {
            let along = (pose.x() - x) * th.cos() + (pose.y() - y) * th.sin();
            let off = crate::maneuver::wrap(th - pose.yaw());
            let done = match mv {
                Move::Forward => along >= -MOVE_DONE.0,
                Move::Back => along <= MOVE_DONE.0,
                Move::Left => off <= MOVE_DONE.1,
                Move::Right => off >= -MOVE_DONE.1,
            };
            if !done {
                return Some((mv, [x, y, th]));
            }
            self.next += 1;
        }
        None
    }
}

/// A route this much longer than the shortest it has been is a changed map (a wall seen late),
/// not a robot going nowhere: squeezing's wait for progress starts again from it, m.
const ROUTE_CHANGED_M: f64 = 1.0;

/// Progress along the route: its length to the goal when it last fell by [`PROGRESS_M`], and
/// since when. Looking and squeezing both start after a while without it.
#[derive(Debug, Clone, Copy)]
struct Progress {
    best_m: f64,
    /// Monotonic ns.
    since: Option<u64>,
}

impl Default for Progress {
    fn default() -> Self {
        Progress {
            best_m: f64::INFINITY,
            since: None,
        }
    }
}

impl Progress {
    /// Takes the route's length at `now` (infinite: no route); a route `changed_m` longer than
    /// the best starts the wait again from it. True when the route made progress.
    fn see(&mut self, route_m: f64, now: u64, changed_m: f64) -> bool {
        let progress = route_m.is_finite()
            && (route_m < self.best_m - PROGRESS_M || route_m > self.best_m + changed_m);
        if progress {
            (self.best_m, self.since) = (route_m, Some(now));
        }
        self.since.get_or_insert(now);
        progress
    }

    /// How long the route has made no progress at `now`, ns.
    fn stalled_ns(&self, now: u64) -> u64 {
        self.since.map_or(0, |s| now.saturating_sub(s))
    }

    /// Starts the wait again at `now`.
    fn restart(&mut self, now: u64) {
        self.since = Some(now);
    }
}

/// Suspected glass given up (`planner.give_up_after_s`): where the route ran into it while
/// leading no nearer the goal for that long, in the odometry frame, each until a time.
#[derive(Debug, Clone, Default)]
struct GiveUp {
    progress: Progress,
    /// (x, y, until monotonic ns).
    spots: Vec<(f64, f64, u64)>,
}

/// At most this many stretches are given up at once; the oldest goes first.
const GIVE_UP_MAX: usize = 8;

/// Squeezing through (`planner.tight_after_s`): the route has led the robot no nearer the goal
/// for that long, so it plans with `planner.tight_margin_m` for `planner.tight_s`.
#[derive(Debug, Clone, Copy, Default)]
struct Tight {
    progress: Progress,
    /// Squeezing until then (monotonic ns).
    until: Option<u64>,
}

impl Tight {
    /// Whether the plan at `now` squeezes through.
    fn on(&self, now: u64) -> bool {
        self.until.is_some_and(|u| now < u)
    }

    /// Takes the route's length to the goal after a plan at `now` (infinite: no route): starts
    /// a squeeze after `after` ns without progress, lasting `lasts` ns, and after one a new
    /// wait.
    fn see(&mut self, route_m: f64, now: u64, after: u64, lasts: u64) {
        if after == 0 {
            return;
        }
        self.progress.see(route_m, now, ROUTE_CHANGED_M);
        match self.until {
            Some(u) if now >= u => {
                self.until = None;
                self.progress.restart(now);
            }
            None if self.progress.stalled_ns(now) >= after => {
                self.until = Some(now.saturating_add(lasts));
            }
            _ => {}
        }
    }
}

/// How far ahead along its route the robot looks for suspected glass it leads into, m.
const LOOK_WITHIN_M: f64 = 2.0;
/// The radius within which the pane's line is fitted around where the route meets it, m.
const LOOK_RADIUS_M: f64 = 1.5;
/// How far past the suspected stretch's end a look drives, m.
const LOOK_OVERSHOOT_M: f64 = 0.3;
/// A look is over within this distance of its target, m.
const LOOK_ARRIVED_M: f64 = 0.25;
/// The farthest from the pane's line a look drives, m; the nearest is the footprint and this
/// much more.
const LOOK_FAR_M: f64 = 1.5;
const LOOK_NEAR_EXTRA_M: f64 = 0.3;

/// Going to look at suspected glass the route leads into ([`crate::look`]).
#[derive(Debug, Clone, Copy, Default)]
struct Look {
    progress: Progress,
    /// The look under way: its target in the odometry frame, and when it ends at the latest.
    target: Option<(f64, f64)>,
    until: u64,
    /// Where the route met the stretch looked at (odometry frame).
    at: Option<(f64, f64)>,
    /// Looks since the route last fell by [`PROGRESS_M`].
    tries: u32,
}

impl Default for BackOut {
    fn default() -> Self {
        BackOut {
            still_since: None,
            until: None,
            tries: 0,
            progress_ref_m: f64::INFINITY,
            away_failed: None,
            away_at: None,
        }
    }
}

impl Pilot {
    /// A pilot planning with `params`, under its freshness rules (`planner.*_max_age_s`,
    /// `planner.use_foliage`) and command validity (`robot.command_validity_s`).
    pub fn new(params: PlannerParams) -> Self {
        Pilot {
            planner: Planner::new(params),
            odom: None,
            goal: None,
            foliage: Foliage::default(),
            last_map_ns: None,
            classes: Vec::new(),
            seq: 0,
            no_route: Progress::default(),
            map_hop: Hop::new(),
            back_out: BackOut::default(),
            maneuver: Maneuvering::default(),
            look: Look::default(),
            memory: crate::memory::Memory::default(),
            tight: Tight::default(),
            given_up: GiveUp::default(),
        }
    }

    /// The settings: the planner's and the rules'.
    pub fn params(&self) -> &PlannerParams {
        self.planner.params()
    }

    /// The planner (its last cost map and route).
    pub fn planner(&self) -> &Planner {
        &self.planner
    }

    /// The map the last plan used: the mapper's classes with the foliage obstacles made solid.
    pub fn classes(&self) -> &[u8] {
        &self.classes
    }

    /// The latest good goal.
    pub fn current_goal(&self) -> Option<&Goal> {
        self.goal.as_ref()
    }

    /// Commands numbered so far.
    pub fn commands(&self) -> u64 {
        self.seq
    }

    /// The maps taken from `map/plan` and those that never reached the planner (gaps in their
    /// sequence: overwritten in the subscriber's buffer while it was busy).
    pub fn map_hop(&self) -> &Hop {
        &self.map_hop
    }

    /// Takes the latest odometry; refuses (and keeps the previous one) when a number is not
    /// finite.
    pub fn odom(&mut self, o: &Odometry) -> Result<(), Refused> {
        check_odometry(o)?;
        self.odom = Some(*o);
        Ok(())
    }

    /// Takes a new goal; refuses (and keeps the previous one) when a number is not finite or the
    /// tolerance is negative. A stop request ([`goal_flags::STOP`], issue 25) drops the goal:
    /// zero velocity (status `NO_GOAL`) until a new goal comes.
    pub fn goal(&mut self, g: &Goal) -> Result<(), Refused> {
        if g.flags & goal_flags::STOP != 0 {
            self.goal = None;
            self.no_route = Progress::default();
            self.back_out = BackOut::default();
            self.maneuver = Maneuvering::default();
            self.look = Look::default();
            self.tight = Tight::default();
            self.given_up = GiveUp::default();
            return Ok(());
        }
        if !(g.x.is_finite() && g.y.is_finite() && g.tolerance_m.is_finite()) || g.tolerance_m < 0.0
        {
            return Err(Refused::Goal(g.seq));
        }
        self.goal = Some(*g);
        // a new goal may have a route: its own time to find one, its own tries to back out
        self.no_route = Progress::default();
        self.back_out = BackOut::default();
        self.maneuver = Maneuvering::default();
        self.look = Look::default();
        self.tight = Tight::default();
        self.given_up = GiveUp::default();
        Ok(())
    }

    /// Takes the latest foliage verdict (its obstacle returns; non-finite ones are skipped when
    /// they are drawn).
    pub fn foliage(&mut self, header: &FoliageHeader, returns: &[FoliageReturn]) {
        self.foliage.header = Some(*header);
        self.foliage.obstacles.clear();
        self.foliage.obstacles.extend(
            (returns.iter())
                .filter(|r| r.class == foliage_class::OBSTACLE)
                .map(|r| (r.angle_rad, r.range_m)),
        );
    }

    /// Plans on a map that arrived at `now`: `classes` are its cells' classes in order.
    pub fn on_map(
        &mut self,
        header: &MapHeader,
        classes: impl IntoIterator<Item = u8>,
        now: u64,
    ) -> Decision {
        self.map_hop.see(header.seq);
        self.classes.clear();
        self.classes.extend(classes);
        let grid = GridSpec {
            cells: header.cells as usize,
            cell_m: header.cell_m,
        };
        if grid.is_empty()
            || !(header.cell_m.is_finite() && header.cell_m > 0.0)
            || grid.len() != self.classes.len()
        {
            // not counted as a map: a silent mapper and a broken one stop the robot alike
            return Decision::stop(
                command_status::STALE_INPUT,
                0,
                Some(Stale::BadMap),
                Some(header),
            );
        }
        self.last_map_ns = Some(now);
        let p = self.planner.params();
        let (goal_max_age_ns, odom_max_age_ns) = (p.goal_max_age_ns(), p.odom_max_age_ns());
        let (use_foliage, foliage_max_age_ns) = (p.planner.use_foliage, p.foliage_max_age_ns());
        if goal_max_age_ns > 0
            && (self.goal).is_some_and(|g| now.saturating_sub(g.stamp_mono_ns) > goal_max_age_ns)
        {
            self.goal = None;
        }
        let Some(goal) = self.goal else {
            return Decision::stop(command_status::NO_GOAL, 0, None, Some(header));
        };
        let odom = match self.odom {
            None => {
                return Decision::stop(
                    command_status::STALE_INPUT,
                    0,
                    Some(Stale::NoOdometry),
                    Some(header),
                );
            }
            Some(o) if now.saturating_sub(o.rx_mono_ns) > odom_max_age_ns => {
                return Decision::stop(
                    command_status::STALE_INPUT,
                    0,
                    Some(Stale::OldOdometry),
                    Some(header),
                );
            }
            Some(o) => o,
        };
        // refused on arrival when not finite
        let Some(pose) = odom_pose(&odom) else {
            return Decision::stop(
                command_status::STALE_INPUT,
                0,
                Some(Stale::NoOdometry),
                Some(header),
            );
        };
        let Some((gx, gy)) = crate::guard::goal_in_robot_frame(&pose, goal.x, goal.y) else {
            return Decision::stop(
                command_status::STALE_INPUT,
                0,
                Some(Stale::GoalOutOfRange),
                Some(header),
            );
        };
        if gx.hypot(gy) <= goal.tolerance_m.max(0.01) {
            return Decision::stop(command_status::GOAL_REACHED, 0, None, Some(header));
        }
        // obstacles the foliage classifier confirms are solid (a trunk hidden in grass)
        let mut flags = 0;
        if use_foliage
            && let Some(fh) = &self.foliage.header
            && now.saturating_sub(fh.rx_mono_ns) <= foliage_max_age_ns
        {
            if fh.alarm != 0 {
                flags |= command_flags::FOLIAGE_ALARM;
            }
            confirm_obstacles(
                &mut self.classes,
                grid,
                self.foliage.obstacles.iter().copied(),
            );
        }
        self.draw_given_up(&pose, now);
        self.remember(grid, &pose, (goal.x, goal.y), (gx, gy), now);
        let (v0, omega0) = (f64::from(odom.v), f64::from(odom.omega));
        if let Some(d) = self.backing_out(grid, (v0, omega0), (gx, gy), now, flags, header) {
            return d;
        }
        if let Some(d) = self.maneuvering(grid, &pose, (v0, omega0), (gx, gy), now, flags, header) {
            return d;
        }
        if let Some(d) = self.looking(grid, &pose, (v0, omega0), now, flags, header) {
            return d;
        }
        let mode = if self.tight.on(now) {
            flags |= command_flags::TIGHT;
            crate::Mode::Tight
        } else {
            crate::Mode::Forward
        };
        let outcome = (self.planner).plan_as(mode, &self.classes, grid, (v0, omega0), (gx, gy));
        let (after, lasts) = (self.params().tight_after_ns(), self.params().tight_ns());
        // progress by the straight line where no route is searched (the paper's DWA)
        let route_m = if self.params().planner.route_cell_m > 0.0 {
            f64::from(self.planner.route().value(0.0, 0.0))
        } else {
            gx.hypot(gy)
        };
        self.tight.see(route_m, now, after, lasts);
        self.give_up(grid, &pose, route_m, now);
        if let Some(d) = self.held_still(
            &outcome,
            grid,
            &pose,
            (v0, omega0),
            (gx, gy),
            now,
            flags,
            header,
        ) {
            return d;
        }
        if let Some(d) = self.start_look(grid, &pose, (v0, omega0), now, flags, header) {
            return d;
        }
        match outcome {
            DwaOutcome::Drive {
                v, omega, routed, ..
            } if v.is_finite() && omega.is_finite() => {
                // no route on the map: creep on (off the map where a way leads there, else by
                // the straight line) for `planner.no_route_stop_s` (the map may be wrong: a
                // pane's unseen stretch drawn across the only opening), then stop
                let mut flags = flags;
                if routed {
                    self.no_route = Progress::default();
                } else {
                    flags |= command_flags::NO_ROUTE;
                    // with `planner.beyond_as_route`, a way off the map the robot gets on
                    // along (its length falling by 0.5 m) starts the time again; with none
                    // (an infinite length), or one that no longer shortens, it runs out
                    let route_m = if self.params().planner.beyond_as_route {
                        route_m
                    } else {
                        f64::INFINITY
                    };
                    self.no_route.see(route_m, now, f64::INFINITY);
                    if self.no_route.stalled_ns(now) >= self.params().no_route_stop_ns() {
                        return Decision::stop(command_status::BLOCKED, flags, None, Some(header));
                    }
                }
                Decision::drive(v, omega, flags, header)
            }
            _ => Decision::stop(command_status::BLOCKED, flags, None, Some(header)),
        }
    }

    /// While backing out ([`BackOut::until`] not passed): the step back, or `None` when the time
    /// is up or no step back is feasible (then the robot plans forward again). Counts the
    /// progress towards the goal that resets the tries.
    #[allow(clippy::too_many_arguments)]
    fn backing_out(
        &mut self,
        grid: GridSpec,
        v0_omega0: (f64, f64),
        goal: (f64, f64),
        now: u64,
        flags: u8,
        header: &MapHeader,
    ) -> Option<Decision> {
        let b = &mut self.back_out;
        let to_goal = goal.0.hypot(goal.1);
        if to_goal < b.progress_ref_m - PROGRESS_M || b.progress_ref_m.is_infinite() {
            (b.progress_ref_m, b.tries) = (to_goal, 0);
        }
        let until = b.until?;
        if now >= until {
            b.until = None;
            return None;
        }
        self.step_back(grid, v0_omega0, goal, flags, header)
    }

    /// The route's way lies behind the body, away from the goal: more than [`AWAY_FAR_M`] from
    /// it (nearer, the goal itself bounds what a rollout can gain), and shorter [`AWAY_LOOK_M`]
    /// straight back or 45° to either side than where the body stands (ahead, driving on may
    /// show the way it could not gain on yet).
    fn route_lies_behind(&self) -> bool {
        let route = self.planner.route();
        let here = route.value(0.0, 0.0);
        let behind = [(-1.0f32, 0.0f32), (-0.707, 0.707), (-0.707, -0.707)]
            .iter()
            .map(|&(x, y)| route.value(AWAY_LOOK_M * x, AWAY_LOOK_M * y))
            .fold(f32::INFINITY, f32::min);
        f64::from(here) > AWAY_FAR_M && behind < here
    }

    /// After a forward plan: when it held the robot still for `planner.recovery_after_s`, the
    /// first step of backing out (or, after `planner.recovery_max` tries without progress, the
    /// `blocked` stop); `None` to send the plan as it is.
    #[allow(clippy::too_many_arguments)]
    fn held_still(
        &mut self,
        outcome: &DwaOutcome,
        grid: GridSpec,
        pose: &mimnav_shared::pose::Pose2,
        v0_omega0: (f64, f64),
        goal: (f64, f64),
        now: u64,
        flags: u8,
        header: &MapHeader,
    ) -> Option<Decision> {
        let (after, lasts) = (
            self.params().recovery_after_ns(),
            self.params().recovery_ns(),
        );
        let max_tries = self.params().planner.recovery_max;
        // a long body led only away from the goal (every rollout that gains nothing) is held
        // as surely as one stopped: driving on, it passes the door it came for
        let still_gain_m = self.params().planner.still_gain_m;
        let away = still_gain_m > 0.0
            && !matches!(self.params().robot.body(), Body::Round(_))
            && matches!(*outcome, DwaOutcome::Drive { routed: true, gain_m, .. }
                if gain_m < still_gain_m)
            && self.route_lies_behind()
            && beside_a_pane(&self.classes, grid)
            && between_two_sides(&self.classes, grid);
        let maneuver_ns = self.params().maneuver_ns();
        if away {
            // a body whose plan drives on (forward, nearly straight) is searched a way out at
            // once, and it stands only to follow one found: where none is it drives on as
            // planned. A plan that turns (at its start, headed away) turns towards the goal on
            // its own — a maneuver found from there backed it towards the goal at backing
            // speed — and one that stops is held still as any is
            let max_turn = self.params().robot.max_angular_rps;
            let back_max_m = self.params().planner.away_back_max_m;
            let window_after = self.params().planner.away_window_after_back;
            let follow_ns = if maneuver_ns > 0 {
                maneuver_ns
            } else {
                AWAY_MANEUVER_NS
            };
            let b = &mut self.back_out;
            let searched_lately = b
                .away_failed
                .is_some_and(|t| now.saturating_sub(t) < AWAY_SEARCH_EVERY_NS);
            let driving_on = matches!(*outcome, DwaOutcome::Drive { v, omega, .. }
                if v >= STILL.0 && omega.abs() < AWAY_TURN_SHARE * max_turn);
            let (x, y) = {
                use mimnav_shared::pose::Pose2Ext as _;
                (pose.x(), pose.y())
            };
            let been_here = b
                .away_at
                .is_some_and(|(ax, ay)| (x - ax).hypot(y - ay) < AWAY_AGAIN_M);
            if driving_on && b.tries < max_tries && !searched_lately && !been_here {
                // only a way that first backs (the window never plans one): the rest of a way
                // that goes on forward the window drives itself, faster (office s1400 i9)
                match self.planner.maneuver(grid, None) {
                    Some(plan)
                        if first_straight_backs(&plan)
                            && (back_max_m <= 0.0 || backing_m(&plan) <= back_max_m) =>
                    {
                        b.still_since = None;
                        b.tries += 1;
                        b.away_at = Some((x, y));
                        let until = now.saturating_add(follow_ns);
                        self.maneuver.backing_only = window_after;
                        if let Some(d) = self.start_maneuver(&plan, pose, until, flags, header) {
                            return Some(d);
                        }
                    }
                    _ => b.away_failed = Some(now),
                }
            }
        }
        let still = matches!(*outcome, DwaOutcome::Drive { v, omega, .. }
            if v.abs() < STILL.0 && omega.abs() < STILL.1);
        let b = &mut self.back_out;
        if !still || after == 0 {
            b.still_since = None;
            return None;
        }
        let since = *b.still_since.get_or_insert(now);
        if now.saturating_sub(since) < after {
            return None;
        }
        if b.tries >= max_tries {
            // the tries spent: `blocked` for as long as every plan holds the robot still (the
            // wait not started again, so the status does not fall back to `driving` between
            // stops); a plan that moves it, progress or a new goal ends it
            let flags = flags | command_flags::BACKING_OUT;
            return Some(Decision::stop(
                command_status::BLOCKED,
                flags,
                None,
                Some(header),
            ));
        }
        b.still_since = None;
        b.tries += 1;
        // a long body: a way out by moves and turns on the spot first, searched on this map
        self.maneuver.backing_only = false;
        if maneuver_ns > 0
            && let Some(plan) = self.planner.maneuver(grid, None)
            && let Some(d) =
                self.start_maneuver(&plan, pose, now.saturating_add(maneuver_ns), flags, header)
        {
            return Some(d);
        }
        self.back_out.until = Some(now.saturating_add(lasts));
        self.step_back(grid, v0_omega0, goal, flags, header)
    }

    /// Follows `plan` until `until` (monotonic ns): its first step, or `None` when it has none.
    fn start_maneuver(
        &mut self,
        plan: &crate::maneuver::Plan,
        pose: &mimnav_shared::pose::Pose2,
        until: u64,
        flags: u8,
        header: &MapHeader,
    ) -> Option<Decision> {
        self.maneuver.follow(plan, pose);
        self.maneuver.until = Some(until);
        self.maneuver_step(pose, flags, header)
    }

    /// While following a way out ([`Maneuvering::until`] not passed): the next move, or `None`
    /// (and the maneuver ends) when every move is done, the time is up, or a pose left is
    /// blocked on this map and no way is found any more from where the robot stands.
    #[allow(clippy::too_many_arguments)]
    fn maneuvering(
        &mut self,
        grid: GridSpec,
        pose: &mimnav_shared::pose::Pose2,
        v0_omega0: (f64, f64),
        goal: (f64, f64),
        now: u64,
        flags: u8,
        header: &MapHeader,
    ) -> Option<Decision> {
        let until = self.maneuver.until?;
        if now >= until || self.maneuver.current(pose).is_none() {
            self.maneuver = Maneuvering::default();
            return None;
        }
        // this map's clearance and route; the poses left, still free on it?
        let _ = (self.planner).plan_as(crate::Mode::Forward, &self.classes, grid, v0_omega0, goal);
        let m = &self.maneuver;
        let left = m.moves[m.next..].iter().filter_map(|&(_, [x, y, th])| {
            let (lx, ly) = crate::guard::goal_in_robot_frame(pose, x, y)?;
            use mimnav_shared::pose::Pose2Ext as _;
            Some([lx, ly, crate::maneuver::wrap(th - pose.yaw())])
        });
        let left: Vec<[f64; 3]> = left.collect();
        if left.len() != m.moves.len() - m.next || !self.planner.maneuver_holds(grid, left) {
            let doing = self.maneuver.current(pose).map(|c| c.0);
            let Some(plan) = self.planner.maneuver(grid, doing) else {
                self.maneuver = Maneuvering::default();
                return None;
            };
            self.maneuver.follow(&plan, pose);
        }
        let d = self.maneuver_step(pose, flags, header);
        if d.is_none() {
            self.maneuver = Maneuvering::default();
        }
        d
    }

    /// The command for the way out's move at `pose`: forward or back at
    /// `planner.recovery_mps` holding the move's heading, or a turn on the spot
    /// ([`crate::maneuver_turn_rps`]); `None` when every move is done.
    fn maneuver_step(
        &mut self,
        pose: &mimnav_shared::pose::Pose2,
        flags: u8,
        header: &MapHeader,
    ) -> Option<Decision> {
        use crate::maneuver::Move;
        use mimnav_shared::pose::Pose2Ext as _;
        let (speed, turn) = (
            self.params().planner.recovery_mps,
            crate::maneuver_turn_rps(self.params()),
        );
        let (mv, [_, _, th]) = self.maneuver.current(pose)?;
        let hold = (HOLD_GAIN * crate::maneuver::wrap(th - pose.yaw())).clamp(-turn, turn);
        let (v, omega) = match mv {
            Move::Forward => (speed, hold),
            Move::Back => (-speed, hold),
            Move::Left => (0.0, turn),
            Move::Right => (0.0, -turn),
        };
        Some(Decision::drive(
            v,
            omega,
            flags | command_flags::MANEUVERING,
            header,
        ))
    }

    /// Where the last plan's route runs into suspected glass within [`LOOK_WITHIN_M`] ahead
    /// (robot frame; [`crate::look::route_meets_suspected`]): what a look sweeps and what is
    /// given up.
    fn suspected_ahead(&self, grid: GridSpec) -> Option<(f64, f64)> {
        // the band of extra cost the route charges beside suspected glass reaches the footprint
        // and half a coarse cell from it, measured from coarse cells' centres
        let touch = self.params().footprint_m() + 2.0 * self.params().planner.route_cell_m;
        let route = self.planner.route();
        crate::look::route_meets_suspected(route, &self.classes, grid, LOOK_WITHIN_M, touch)
    }

    /// Takes this map into the route's memory and hands the planner the lengths to the goal
    /// (odometry frame; `local` the same in the robot frame) beyond the map
    /// (`planner.route_memory_m`; [`crate::memory`]).
    fn remember(
        &mut self,
        grid: GridSpec,
        pose: &mimnav_shared::pose::Pose2,
        goal: (f64, f64),
        local: (f64, f64),
        now: u64,
    ) {
        let p = self.params();
        let (radius_m, keep_ns) = (p.planner.route_memory_m, p.route_memory_ns());
        let suspect_weight = p.planner.route_suspect_weight as f32;
        if radius_m <= 0.0 || p.planner.route_cell_m <= 0.0 {
            self.planner.set_beyond(None);
            return;
        }
        let m = &mut self.memory;
        m.take_in(pose, &self.classes, grid, now, keep_ns, radius_m);
        let local = (local.0 as f32, local.1 as f32);
        let budget = crate::memory::SEARCH_CELLS_PER_MAP;
        // the field reaches past the map's corners, so every border cell has a length or is
        // known to have no way (a `route_memory_m` below the map's half diagonal would leave
        // border cells outside it, taken for cells with no way)
        let corner_m = f64::from(grid.half_extent_m()) * std::f64::consts::SQRT_2;
        let field_m = radius_m.max(corner_m + crate::memory::CELL_M);
        let beyond = m.beyond(pose, goal, local, now, field_m, suspect_weight, budget);
        self.planner.set_beyond(beyond);
    }

    /// Hands the planner the stretches given up and still held, in the robot frame; drops the
    /// expired ones.
    fn draw_given_up(&mut self, pose: &mimnav_shared::pose::Pose2, now: u64) {
        let radius = self.params().planner.give_up_radius_m as f32;
        let g = &mut self.given_up;
        g.spots.retain(|s| now < s.2);
        let discs = (g.spots.iter())
            .filter_map(|&(x, y, _)| crate::guard::goal_in_robot_frame(pose, x, y))
            .map(|(x, y)| (x as f32, y as f32, radius));
        self.planner.set_given_up(discs);
    }

    /// After a forward plan: when the route has led no nearer the goal for
    /// `planner.give_up_after_s` and runs into suspected glass close ahead, gives that stretch
    /// up for `planner.give_up_s` (from the next map on).
    fn give_up(
        &mut self,
        grid: GridSpec,
        pose: &mimnav_shared::pose::Pose2,
        route_m: f64,
        now: u64,
    ) {
        let after = self.params().give_up_after_ns();
        if after == 0 {
            return;
        }
        let g = &mut self.given_up;
        // the route's length flips when a stretch is crossable in one map and not the next: only
        // a shorter route is progress
        if g.progress.see(route_m, now, f64::INFINITY) || g.progress.stalled_ns(now) < after {
            return;
        }
        let Some(at) = self.suspected_ahead(grid) else {
            return;
        };
        use mimnav_shared::pose::Pose2Ext as _;
        let (x, y) = pose.to_fixed(at.0, at.1);
        let until = now.saturating_add(self.params().give_up_ns());
        let g = &mut self.given_up;
        if g.spots.len() >= GIVE_UP_MAX {
            g.spots.remove(0);
        }
        g.spots.push((x, y, until));
        // the way changes: its length from now on is the measure
        g.progress = Progress::default();
        g.progress.restart(now);
    }

    /// While a look is under way: the step towards its target, or `None` once it is reached,
    /// its time is up, or no step towards it is feasible (then the robot plans for its goal
    /// again).
    #[allow(clippy::too_many_arguments)]
    fn looking(
        &mut self,
        grid: GridSpec,
        pose: &mimnav_shared::pose::Pose2,
        (v0, omega0): (f64, f64),
        now: u64,
        flags: u8,
        header: &MapHeader,
    ) -> Option<Decision> {
        let target = self.look.target?;
        let local = crate::guard::goal_in_robot_frame(pose, target.0, target.1);
        // the door has been seen whole, edge to edge, and wide enough: what the look went to see
        // (the route now goes through it); the suspected stretch beyond it, which the look's
        // target lies past, is the pane's line drawn on past the door's far edge
        let wide = self.door_wide_m(grid);
        let seen = self.look.at.is_some_and(|(ax, ay)| {
            crate::guard::goal_in_robot_frame(pose, ax, ay)
                .and_then(|at| crate::look::stretch_at(&self.classes, grid, at, LOOK_RADIUS_M))
                .is_some_and(|s| s.whole_m >= wide)
        });
        let Some((tx, ty)) =
            local.filter(|t| !seen && now < self.look.until && t.0.hypot(t.1) > LOOK_ARRIVED_M)
        else {
            self.look.target = None;
            return None;
        };
        match self.planner.plan(&self.classes, grid, v0, omega0, (tx, ty)) {
            DwaOutcome::Drive {
                v, omega, routed, ..
            } if v.is_finite() && omega.is_finite() && routed => Some(Decision::drive(
                v,
                omega,
                flags | command_flags::LOOKING,
                header,
            )),
            _ => {
                self.look.target = None;
                None
            }
        }
    }

    /// The seen gap a door needs for the footprint (twice its half width and margin, and a
    /// cell): a look starts only at a narrower one and ends once the door is seen whole this wide.
    fn door_wide_m(&self, grid: GridSpec) -> f64 {
        2.0 * self.params().footprint_m() + f64::from(grid.cell_m)
    }

    /// After a forward plan: when the route has led no nearer the goal for
    /// `planner.look_after_s` and runs into suspected glass close ahead, the first step of a
    /// look beside it ([`crate::look`]); `None` to send the plan as it is.
    #[allow(clippy::too_many_arguments)]
    fn start_look(
        &mut self,
        grid: GridSpec,
        pose: &mimnav_shared::pose::Pose2,
        v0_omega0: (f64, f64),
        now: u64,
        flags: u8,
        header: &MapHeader,
    ) -> Option<Decision> {
        let after = self.params().look_after_ns();
        if after == 0 {
            return None;
        }
        let (max_tries, footprint) = (self.params().planner.look_max, self.params().footprint_m());
        let route_m = f64::from(self.planner.route().value(0.0, 0.0));
        let l = &mut self.look;
        // a look keeps waiting however much longer the route grows
        if l.progress.see(route_m, now, f64::INFINITY) {
            l.tries = 0;
            return None;
        }
        if l.progress.stalled_ns(now) < after || l.tries >= max_tries {
            return None;
        }
        let at = self.suspected_ahead(grid)?;
        // a door seen in part, its seen gap still too narrow for the footprint
        let (only, wide) = (
            self.params().planner.look_openings_only,
            self.door_wide_m(grid),
        );
        let s = crate::look::stretch_at(&self.classes, grid, at, LOOK_RADIUS_M)
            .filter(|s| s.worth_a_look(only, wide))?;
        // first towards the stretch's end farther from the robot's own foot on the line, then
        // back and forth
        let foot = -(s.point.0 * s.dir.0 + s.point.1 * s.dir.1);
        let first = if s.to_m - foot >= foot - s.from_m {
            1.0
        } else {
            -1.0
        };
        let look_ns = self.params().look_ns();
        let l = &mut self.look;
        let sign = if l.tries.is_multiple_of(2) {
            first
        } else {
            -first
        };
        let (tx, ty) = crate::look::look_target(
            &s,
            sign,
            footprint + LOOK_NEAR_EXTRA_M,
            LOOK_FAR_M,
            LOOK_OVERSHOOT_M,
        );
        use mimnav_shared::pose::Pose2Ext as _;
        l.target = Some(pose.to_fixed(tx, ty));
        l.at = Some(pose.to_fixed(at.0, at.1));
        l.until = now.saturating_add(look_ns);
        l.tries += 1;
        l.progress.restart(now);
        self.looking(grid, pose, v0_omega0, now, flags, header)
    }

    /// One step back, or `None` (and backing out ends) when none is feasible.
    fn step_back(
        &mut self,
        grid: GridSpec,
        (v0, omega0): (f64, f64),
        goal: (f64, f64),
        flags: u8,
        header: &MapHeader,
    ) -> Option<Decision> {
        match self.planner.back_out(&self.classes, grid, v0, omega0, goal) {
            DwaOutcome::Drive { v, omega, .. } if v.is_finite() && omega.is_finite() => {
                let flags = flags | command_flags::BACKING_OUT;
                Some(Decision::drive(v, omega, flags, header))
            }
            _ => {
                self.back_out.until = None;
                None
            }
        }
    }

    /// Between maps (a missed deadline on `map/plan`, or the periodic tick): the stop to send
    /// when no map came for `planner.map_max_age_s` (or `deadline_missed`), else nothing.
    pub fn on_silence(&self, now: u64, deadline_missed: bool) -> Option<Decision> {
        let silent = deadline_missed
            || self
                .last_map_ns
                .is_none_or(|t| now.saturating_sub(t) > self.params().map_max_age_ns());
        silent.then(|| Decision::stop(command_status::STALE_INPUT, 0, Some(Stale::NoMap), None))
    }

    /// The message for `decision`, sent at `sent` (monotonic ns): numbered, valid until
    /// `sent + robot.command_validity_s`, and never carrying a non-finite number.
    pub fn command(&mut self, decision: &Decision, sent: u64) -> VelocityCommand {
        let finite = decision.v.is_finite() && decision.omega.is_finite();
        let cmd = VelocityCommand {
            seq: self.seq,
            stamp_mono_ns: sent,
            source_stamp_ns: decision.source_stamp_ns,
            source_seq: decision.source_seq,
            valid_until_mono_ns: sent.saturating_add(self.params().command_validity_ns()),
            v: if finite { decision.v as f32 } else { 0.0 },
            omega: if finite { decision.omega as f32 } else { 0.0 },
            status: if finite {
                decision.status
            } else {
                command_status::BLOCKED
            },
            flags: decision.flags,
            reserved: [0; 6],
        };
        self.seq += 1;
        cmd
    }
}

/// The cells of `grid` (robot frame: x ahead, y to the left) within `reach_m` of the body's
/// centre on each axis, with their classes from `classes` (row-major, as the plan's).
fn cells_near(
    classes: &[u8],
    grid: GridSpec,
    reach_m: f64,
) -> impl Iterator<Item = (f64, f64, u8)> + '_ {
    let n = grid.cells;
    let reach = (reach_m / f64::from(grid.cell_m)).ceil() as usize;
    let (lo, hi) = ((n / 2).saturating_sub(reach), (n / 2 + reach).min(n));
    (lo..hi).flat_map(move |r| {
        (lo..hi).filter_map(move |c| {
            let (x, y) = grid.center_of(r, c);
            let class = *classes.get(r * n + c)?;
            Some((f64::from(x), f64::from(y), class))
        })
    })
}

/// A pane's line (glass or suspected glass) runs beside the body: [`AWAY_PANE_CELLS`] such
/// cells within [`AWAY_PANE_M`] of its centre. A door in a pane is seen open only as the sensor
/// comes abeam of it, so a body led away there has just passed one; a door in a wall or a
/// curtain is seen from afar.
fn beside_a_pane(classes: &[u8], grid: GridSpec) -> bool {
    cells_near(classes, grid, AWAY_PANE_M)
        .filter(|&(x, y, class)| x.hypot(y) <= AWAY_PANE_M && cell_class::is_glass(class))
        .count()
        >= AWAY_PANE_CELLS
}

/// The body stands between two sides: [`AWAY_SIDE_CELLS`] blocking cells (solid, glass or
/// suspected glass) to its left and as many to its right, within [`AWAY_SIDE_M`] of its axis
/// and [`AWAY_SIDE_ALONG_M`] of its centre along it. A corridor, where a long body has no room
/// to turn into a door it passed; beside a shop front, open on its other side, the window's
/// own turn is quicker than a way out backed at recovery speed.
fn between_two_sides(classes: &[u8], grid: GridSpec) -> bool {
    let (mut left, mut right) = (0, 0);
    for (x, y, class) in cells_near(classes, grid, AWAY_SIDE_M) {
        if x.abs() <= AWAY_SIDE_ALONG_M && y.abs() <= AWAY_SIDE_M && cell_class::blocks(class) {
            if y > 0.0 {
                left += 1;
            } else {
                right += 1;
            }
        }
    }
    left >= AWAY_SIDE_CELLS && right >= AWAY_SIDE_CELLS
}

#[cfg(test)]
mod tests;
