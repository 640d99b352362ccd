//! `[planner]`: obstacle inflation and the dynamic window.

use serde::Deserialize;

use mimnav_shared::config::{Checks, Invalid};

/// How the planner inflates obstacles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Inflation {
    /// The paper's adaptive kernel along the goal direction.
    Adaptive,
    /// An all-ones e × e kernel (the ablation).
    Uniform,
    /// No inflation.
    None,
}

/// The planner (`[planner]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlannerConfig {
    /// `adaptive`, `uniform` or `none`.
    pub inflation: Inflation,
    /// Side e of the inflation kernel, cells (odd).
    pub kernel_cells: usize,
    /// Thickness of the adaptive kernel's line either side, cells.
    pub padding_cells: usize,
    /// Goal directions the adaptive kernels are cached for, a half turn.
    pub kernel_angles: usize,
    /// Time the window's accelerations apply over (the control period), s.
    pub window_s: f64,
    /// Rollout step, s.
    pub dt_s: f64,
    /// Rollout horizon, s.
    pub horizon_s: f64,
    /// Speed samples.
    pub v_samples: usize,
    /// Turn-rate samples.
    pub omega_samples: usize,
    /// Weight of the remaining distance to the goal, per metre.
    pub goal_weight: f64,
    /// Weight of driving slower than the top speed, per m/s.
    pub speed_weight: f64,
    /// Weight of the obstacle cost summed along a trajectory (each cell 0–1).
    pub obstacle_weight: f64,
    /// Distance kept from solid and glass cells beyond the robot's radius, m. At least a cell:
    /// the clearance is measured between cell centres, so it overstates the distance to a
    /// surface by up to half a cell's diagonal, and a surface seen obliquely fills its outermost
    /// cells last.
    pub margin_m: f64,
    /// A body already nearer an obstacle than `margin_m` at some point of its outline (in a door
    /// it barely fits, or after a late detection) may come down to this share of the margin
    /// anywhere along a trajectory; nearer than that already, no nearer than it is (0–1).
    pub inside_margin_share: f64,
    /// Top speed forward while some point of the body's outline is nearer a solid or glass
    /// cell than `margin_m`, m/s (0: not limited). The dynamic window brakes to it as fast as
    /// the robot's acceleration allows.
    pub inside_margin_mps: f64,
    /// Coarse cell of the route search around obstacles, m (0: straight-line goal progress, as
    /// in the paper).
    pub route_cell_m: f64,
    /// Extra route cost per unit of planning cost.
    pub route_cost_weight: f64,
    /// A long body (Spot) needs room beyond its half width to turn: its enclosing radius less
    /// its half width. A metre of route nearer an obstacle than that costs up to this many
    /// metres more, in proportion to the shortfall, so the route keeps the body where it can
    /// still turn (0: no preference; a round robot has none).
    pub route_swing_weight: f64,
    /// Room beyond the footprint the route prefers to keep from obstacles for any robot, m:
    /// where it exceeds a long body's room to turn it takes its place, so a round robot's
    /// route, too, keeps off walls and glass where there is room (charged at
    /// `route_swing_weight`). 0: only a long body's room to turn.
    pub route_berth_m: f64,
    /// A long body keeps this far from a solid's or a pane's free end — a wall or pane ending
    /// in open floor, the mouth of a corridor, the jamb of a door — where there is room: a
    /// metre of route nearer costs up to `route_swing_weight` metres more, in proportion to the
    /// shortfall, m (0: no preference; a round robot has none). A pane may go on from that end
    /// unseen, and a long body turning round the end swings its nose across the pane's line
    /// before its sensor has faced any of it.
    pub route_end_m: f64,
    /// Suspected glass — a pane's line drawn on where the pane was not seen, which may be an
    /// opening never faced — does not close the route: a metre of route where the footprint
    /// would touch it costs this many metres more, so the route leads there only when no
    /// cheaper way is known, and the robot goes to face it (0: it closes the route like glass).
    pub route_suspect_weight: f64,
    /// The route remembers the solids, glass and suspected glass of past maps this far from the
    /// robot (on a 0.5 m lattice in the odometry frame) and leads round them beyond the local
    /// map, where it otherwise assumes the world open; a place the map covers is what the map
    /// shows, m (0: no memory).
    pub route_memory_m: f64,
    /// ... for this long after a map last showed them, s.
    pub route_memory_s: f64,
    /// Obstacles the foliage classifier confirms are solid for the planner (false: ignore it).
    pub use_foliage: bool,
    /// When the map holds no route to the goal for the robot's body, the planner drives on by
    /// the straight-line distance (the paper's DWA) no faster than `glass_slow_mps`, with the
    /// `no route` flag, for this long; then it stops with the `blocked` status, s (0: at once).
    /// A way off the map: see `beyond_as_route`.
    pub no_route_stop_s: f64,
    /// A way off the map the route leads along (the goal on the map, the way round it beyond:
    /// a partition's opening left behind) is driven as a route: at the speeds beside glass, not
    /// crept at `glass_slow_mps`, and the `blocked` stop comes `no_route_stop_s` after the
    /// robot last got 0.5 m nearer the goal along it, not after that long in all (false: crept
    /// and stopped as with no way at all).
    pub beyond_as_route: bool,
    /// Top speed with glass at the body's edge, m/s: near glass the planner drives no faster
    /// than this, rising to the robot's top speed at `glass_slow_within_m` (a pane is seen only
    /// where a beam meets it squarely, so its unseen parts appear late).
    pub glass_slow_mps: f64,
    /// Distance from the body (its enclosing circle) to the nearest glass cell ahead at which
    /// the speed limit near glass ends, m (0: no limit).
    pub glass_slow_within_m: f64,
    /// A solid wall's free end ahead (the mouth of a corridor, a door's jamb in a wall: a pane
    /// may go on from it unseen) limits a long body's speed as glass does (a round body faces a
    /// pane where it would first touch it). On the tune worlds, two episode seeds, Spot 99 →
    /// 101 of 140, contacts 20 → 11, no family lower (docs/glass.md).
    pub glass_slow_ends: bool,
    /// A round body: a pane running along the heading (within about 15°) beside the body's
    /// lane does not limit the speed: driving straight on, the body passes it, and the part not
    /// yet seen goes on along the same line (a pane across the way still does). A robot
    /// searching a partition for its opening sweeps the pane faster. Only motions that keep
    /// their heading are exempt ([`crate::dwa::TURNING_RPS`]); a turning one keeps the cap. A
    /// long body keeps it always: past a pane at speed, it reaches the door at the pane's end
    /// too fast to square up to it. On since stop 64: the Turtlebot 2's tune worlds 285 → 294
    /// of 320 and its report worlds 350 → 355 of 400, no contact more; Spot's tune worlds lost
    /// (123 → 120 of 160) (docs/evaluation.md).
    pub glass_slow_beside: bool,
    /// A curtain's free end — a thin straight line of passable cells ending in free floor with
    /// nothing beyond it within 0.6 m — is drawn as suspected glass for planning, so the body keeps
    /// `margin_m` from it as from a wall's end: the door's jamb there may be a frameless pane,
    /// seen only square on, which a body crossing the curtain at a slant sweeps unseen
    /// ([`crate::jamb`]). Every body since stop 60 (a round one since stop 53): while the
    /// mapper called a curtain's lone strands solid, Spot, marking the end as well, came back
    /// to cross at a worse slant, its corner sweeping the line beyond the end (two contacts more
    /// on the tune worlds); with `mapper.lone_solid_passable` it crosses (docs/evaluation.md).
    pub curtain_ends: bool,
    /// A robot held still by the dynamic window (every motion but standing still infeasible —
    /// a long body beside glass or a wall it cannot turn away from) for this long backs out, s
    /// (0: never).
    pub recovery_after_s: f64,
    /// How long one backing out lasts, s.
    pub recovery_s: f64,
    /// Top speed backing out, m/s (the dynamic window samples speeds from minus this to 0, each
    /// trajectory checked against the map as forward ones are).
    pub recovery_mps: f64,
    /// Backing-out tries without the robot getting `0.5 m` nearer the goal, after which it stops
    /// with the `blocked` status.
    pub recovery_max: u32,
    /// A long body held still as [`recovery_after_s`](Self::recovery_after_s) says first
    /// searches for a way out by straight moves forward and back and turns on the spot
    /// ([`crate::maneuver`]) and follows it, at `recovery_mps` and half its top turn rate, for
    /// at most this long a try (a try as a backing out is, counted in `recovery_max`); backing
    /// out as before where the search finds none, s (0, the default: never — measured on the
    /// tune worlds it changed no total, docs/glass.md; a round body never needs it).
    pub maneuver_s: f64,
    /// A long body whose best forward plan drives on (at least 0.03 m/s, turning slower than a
    /// quarter of its top rate) and comes less than this much nearer the goal by the route,
    /// while the route is shorter 0.5 m behind it than where it stands and the goal is more
    /// than 1 m away (every rollout leads away: a door in the side of a corridor it is driving
    /// past, seen open only behind it), beside a pane and between two sides (a glass corridor:
    /// a door in glass is seen open only abeam, and the body has no room to turn; elsewhere the
    /// window's own turn is quicker), is searched a way out by moves and turns on the spot
    /// at once ([`crate::maneuver`]) and follows it (for `maneuver_s`, or 20 s where that is
    /// 0; a try as a backing out is) where its first straight move is back (one going on
    /// forward the window drives itself, faster); where none is found it drives on as planned,
    /// searched again no sooner than 1 s later, and never again within 1 m of where it last
    /// followed one, m (0: never; a round body never, it turns on the spot).
    pub still_gain_m: f64,
    /// A way out found for a body led only away ([`still_gain_m`](Self::still_gain_m)) is
    /// followed only where its backing, the back moves before its first forward one, is at most
    /// this long: a door just passed lies about a body's length behind, and a way that backs
    /// farther costs more time at backing speed than the window needs to find the way on, m
    /// (0: no bound).
    pub away_back_max_m: f64,
    /// A way out followed for a body led only away hands back to the dynamic window once its
    /// backing and the turns on the spot after it are done, instead of following the rest at
    /// backing speed (false: the whole way is followed).
    pub away_window_after_back: bool,
    /// A long body also weighs turning on the spot first: rollouts that turn in place to a
    /// heading up to half a turn away, at the top turn rate, then drive straight on for the
    /// rest of the horizon; one wins (the command: stand and turn) only where no arc of the
    /// window comes as near the goal. An arc cannot show the way into a door in a corridor's
    /// side too narrow for the body to turn into on the move (false: arcs only; a round body
    /// never, its arcs turn within its own circle).
    pub turn_first: bool,
    /// A robot whose route has led it no nearer the goal for this long, the route running into
    /// suspected glass close ahead, goes to look at it: it drives beside the pane's line past
    /// the suspected stretch's end, so its beams meet the whole stretch squarely (issue 22,
    /// item 3; [`crate::look`]), s (0: never).
    pub look_after_s: f64,
    /// How long one look lasts at most, s (it ends sooner at its target, or once the door it
    /// looks at is seen whole: [`crate::look::Stretch::whole_m`]).
    pub look_s: f64,
    /// Look only at an opening seen in part: suspected glass on a line with a seen gap of free
    /// cells beside it (a door faced off its middle). Off: at any suspected glass the route
    /// runs into.
    pub look_openings_only: bool,
    /// A robot whose route has led it no nearer the goal (by `0.5 m`) for this long plans with
    /// `tight_margin_m` from solids instead of `margin_m` (glass keeps `margin_m`) for
    /// `tight_s` (flag `tight`): a gap the body fits through with less than the margin on each
    /// side — a hedge's, a door's — is otherwise a place it circles before until its time runs
    /// out, s (0: never). A round body only ([`crate::PlannerParams::tight_after_ns`]).
    pub tight_after_s: f64,
    /// The distance kept from solid and glass cells beyond the body while squeezing through
    /// (`tight_after_s`), m; at most `margin_m`.
    pub tight_margin_m: f64,
    /// How long one squeeze lasts, s.
    pub tight_s: f64,
    /// Looks without the robot getting `0.5 m` nearer the goal along its route, after which it
    /// looks no more.
    pub look_max: u32,
    /// A robot whose route has led it no nearer the goal (by `0.5 m`) for this long, the route
    /// running into suspected glass close ahead, gives that stretch up: the route does not
    /// cross the suspected glass within `give_up_radius_m` of where it met it for `give_up_s`,
    /// so it turns to another way (with none on the map, off the map: `no_route_stop_s`). A
    /// stretch the body cannot get square in front of — the last of a partition
    /// where it meets a wall — is otherwise where the robot stands until its time runs out, s
    /// (0: never).
    pub give_up_after_s: f64,
    /// How far from where the route met it a given-up stretch reaches, m.
    pub give_up_radius_m: f64,
    /// How long a stretch stays given up, s.
    pub give_up_s: f64,
    /// A foliage verdict older than this is ignored, s.
    pub foliage_max_age_s: f64,
    /// A map older than this is stale: zero velocity, s.
    pub map_max_age_s: f64,
    /// Odometry older than this is stale: zero velocity, s.
    pub odom_max_age_s: f64,
    /// A goal older than this is dropped (0: never), s.
    pub goal_max_age_s: f64,
}

impl Default for PlannerConfig {
    fn default() -> Self {
        PlannerConfig {
            inflation: Inflation::Adaptive,
            kernel_cells: 13,
            padding_cells: 1,
            kernel_angles: 36,
            window_s: 0.5,
            dt_s: 0.1,
            horizon_s: 3.5,
            v_samples: 11,
            omega_samples: 21,
            goal_weight: 5.0,
            speed_weight: 0.1,
            obstacle_weight: 1.0,
            margin_m: 0.1,
            inside_margin_share: 0.5,
            inside_margin_mps: 0.4,
            route_cell_m: 0.25,
            route_cost_weight: 1.0,
            route_swing_weight: 4.0,
            route_berth_m: 0.0,
            route_end_m: 0.0,
            route_suspect_weight: 10.0,
            route_memory_m: 15.0,
            route_memory_s: 120.0,
            use_foliage: true,
            no_route_stop_s: 20.0,
            beyond_as_route: true,
            glass_slow_mps: 0.2,
            glass_slow_within_m: 1.0,
            glass_slow_ends: true,
            glass_slow_beside: true,
            curtain_ends: true,
            recovery_after_s: 1.5,
            recovery_s: 2.0,
            recovery_mps: 0.15,
            recovery_max: 4,
            maneuver_s: 0.0,
            still_gain_m: 0.1,
            away_back_max_m: 2.0,
            away_window_after_back: false,
            turn_first: true,
            look_after_s: 3.0,
            look_s: 8.0,
            look_openings_only: true,
            look_max: 4,
            give_up_after_s: 12.0,
            give_up_radius_m: 1.0,
            give_up_s: 60.0,
            tight_after_s: 3.0,
            tight_margin_m: 0.05,
            tight_s: 10.0,
            foliage_max_age_s: 0.3,
            map_max_age_s: 0.15,
            odom_max_age_s: 0.5,
            goal_max_age_s: 0.0,
        }
    }
}

impl PlannerConfig {
    /// Checks every key of `[planner]`: each value refused names its key and what is allowed.
    pub fn validate(&self) -> Result<(), Invalid> {
        let mut r = Checks::default();
        r.check("planner.kernel_cells", self.kernel_cells as f64, 1.0, 101.0);
        r.require(
            self.kernel_cells % 2 == 1,
            "planner.kernel_cells",
            format!("planner.kernel_cells = {} must be odd", self.kernel_cells),
        );
        r.check(
            "planner.padding_cells",
            self.padding_cells as f64,
            0.0,
            20.0,
        );
        r.check(
            "planner.kernel_angles",
            self.kernel_angles as f64,
            1.0,
            3600.0,
        );
        r.check("planner.window_s", self.window_s, 0.01, 5.0);
        r.check("planner.dt_s", self.dt_s, 0.01, 1.0);
        r.check("planner.horizon_s", self.horizon_s, 0.1, 20.0);
        r.check("planner.v_samples", self.v_samples as f64, 1.0, 200.0);
        r.check(
            "planner.omega_samples",
            self.omega_samples as f64,
            1.0,
            400.0,
        );
        r.check("planner.goal_weight", self.goal_weight, 0.0, 1000.0);
        r.check("planner.speed_weight", self.speed_weight, 0.0, 1000.0);
        r.check("planner.obstacle_weight", self.obstacle_weight, 0.0, 1000.0);
        r.check("planner.margin_m", self.margin_m, 0.0, 2.0);
        r.check(
            "planner.inside_margin_share",
            self.inside_margin_share,
            0.0,
            1.0,
        );
        r.check(
            "planner.inside_margin_mps",
            self.inside_margin_mps,
            0.0,
            10.0,
        );
        r.check("planner.route_cell_m", self.route_cell_m, 0.0, 2.0);
        r.check(
            "planner.route_cost_weight",
            self.route_cost_weight,
            0.0,
            100.0,
        );
        r.check(
            "planner.route_swing_weight",
            self.route_swing_weight,
            0.0,
            100.0,
        );
        r.check("planner.route_berth_m", self.route_berth_m, 0.0, 2.0);
        r.check("planner.route_end_m", self.route_end_m, 0.0, 3.0);
        r.check(
            "planner.route_suspect_weight",
            self.route_suspect_weight,
            0.0,
            1000.0,
        );
        r.check("planner.route_memory_m", self.route_memory_m, 0.0, 100.0);
        r.check("planner.route_memory_s", self.route_memory_s, 0.0, 3600.0);
        r.check("planner.glass_slow_mps", self.glass_slow_mps, 0.01, 10.0);
        r.check("planner.no_route_stop_s", self.no_route_stop_s, 0.0, 3600.0);
        r.check(
            "planner.glass_slow_within_m",
            self.glass_slow_within_m,
            0.0,
            10.0,
        );
        r.check("planner.recovery_after_s", self.recovery_after_s, 0.0, 60.0);
        r.check("planner.look_after_s", self.look_after_s, 0.0, 60.0);
        r.check("planner.look_s", self.look_s, 0.5, 60.0);
        r.check("planner.look_max", f64::from(self.look_max), 0.0, 100.0);
        r.check("planner.give_up_after_s", self.give_up_after_s, 0.0, 600.0);
        r.check("planner.give_up_radius_m", self.give_up_radius_m, 0.0, 5.0);
        r.check("planner.give_up_s", self.give_up_s, 0.0, 3600.0);
        r.check("planner.tight_after_s", self.tight_after_s, 0.0, 600.0);
        r.check("planner.tight_margin_m", self.tight_margin_m, 0.0, 2.0);
        r.require(
            self.tight_margin_m <= self.margin_m,
            "planner.tight_margin_m",
            format!(
                "planner.tight_margin_m = {} must be at most planner.margin_m = {}",
                self.tight_margin_m, self.margin_m
            ),
        );
        r.check("planner.tight_s", self.tight_s, 0.1, 600.0);
        r.check("planner.recovery_s", self.recovery_s, 0.1, 60.0);
        r.check("planner.recovery_mps", self.recovery_mps, 0.01, 2.0);
        r.check(
            "planner.recovery_max",
            f64::from(self.recovery_max),
            0.0,
            100.0,
        );
        r.check("planner.maneuver_s", self.maneuver_s, 0.0, 600.0);
        r.check("planner.still_gain_m", self.still_gain_m, 0.0, 5.0);
        r.check("planner.away_back_max_m", self.away_back_max_m, 0.0, 10.0);
        r.check(
            "planner.foliage_max_age_s",
            self.foliage_max_age_s,
            0.01,
            60.0,
        );
        r.check("planner.map_max_age_s", self.map_max_age_s, 0.01, 60.0);
        r.check("planner.odom_max_age_s", self.odom_max_age_s, 0.01, 60.0);
        r.check("planner.goal_max_age_s", self.goal_max_age_s, 0.0, 86400.0);
        r.finish()
    }
}
