//! What the planner is set by: `[planner]`, the robot of `[robot]` (footprint, motion limits,
//! the command's validity) and the passable cost of `[mapper]`, held as the config has them.
//! The values the planner needs in other units are methods here, written once.

use mimnav_mapper::config::MapperConfig;
use mimnav_shared::config::{Disc, RobotProfile, seconds_ns};

use crate::config::PlannerConfig;

/// How far the disc cover of a rectangular body may reach beyond its long sides, m: the cover
/// then reaches about 0.15 m beyond a 0.5 m wide body's front and back (see
/// [`mimnav_shared::config::Body::discs`]), which only makes the robot stop that much earlier
/// head-on; narrow passages are passed on the sides, where 3 cm is lost.
pub const BODY_COVER_SIDE_M: f64 = 0.03;

/// How far apart the dynamic window tests a rectangular body's outline where its disc cover
/// comes too close, m; each point keeps half this more than `planner.margin_m`.
pub const OUTLINE_SPACING_M: f64 = 0.08;

/// Everything the planner and the service's step around it ([`crate::pilot`]) are set by.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannerParams {
    /// `[planner]`: inflation, the dynamic window, the route, the freshness rules.
    pub planner: PlannerConfig,
    /// `[robot]`: the body (`radius_m`, or `length_m` × `width_m`), the motion limits the dynamic window samples
    /// within, and how long a command stays valid.
    pub robot: RobotProfile,
    /// The planning cost of a passable cell, 0–255, as the mapper writes it
    /// (`mapper.passable_cost`, [`MapperConfig::passable_cell_cost`]).
    pub passable_cost: u8,
}

impl PlannerParams {
    /// Half the narrowest gap the robot is routed through, with the margin kept on each side:
    /// the body's half width (its radius, if round) and `planner.margin_m`, m.
    pub fn footprint_m(&self) -> f64 {
        self.robot.body().half_width_m() + self.planner.margin_m
    }

    /// The room beyond the footprint a long body needs to turn in place: its enclosing radius
    /// less its half width (0 for a round robot), or `planner.route_berth_m` if more, m. The route prefers places with it
    /// ([`crate::route::RouteParams::swing_m`]).
    pub fn swing_m(&self) -> f64 {
        let body = self.robot.body();
        (body.enclosing_radius_m() - body.half_width_m())
            .max(self.planner.route_berth_m)
            .max(0.0)
    }

    /// How far a long body's route keeps from a free end of a wall or pane where there is room
    /// (`planner.route_end_m`; 0 for a round robot), m. A round body's sensor at its centre
    /// faces a pane squarely at the very point where the body would first touch it (the foot of
    /// the perpendicular); a rectangle's corner reaches a pane's line ahead of that point, so
    /// past a wall's end, where a pane may go on unseen, a long body can touch glass it never
    /// faced.
    pub fn end_m(&self) -> f64 {
        match self.robot.body() {
            mimnav_shared::config::Body::Rectangle { .. } => self.planner.route_end_m,
            _ => 0.0,
        }
    }

    /// The discs the dynamic window checks along every rollout: a cover of the body (one disc
    /// of `radius_m` for a round robot; for a rectangle, discs along the heading reaching at
    /// most [`BODY_COVER_SIDE_M`] beyond its long sides), each to be kept `planner.margin_m`
    /// from solid and glass cells.
    pub fn footprint_discs(&self) -> Vec<Disc> {
        self.robot.body().discs(BODY_COVER_SIDE_M)
    }

    /// Points of a rectangular body's outline [`OUTLINE_SPACING_M`] apart, in the body's frame
    /// (none for a round body).
    pub fn outline(&self) -> Vec<[f64; 2]> {
        self.robot.body().outline(OUTLINE_SPACING_M)
    }

    /// The route search's settings (`planner.route_*`), settling the lengths within
    /// `settle_within_m` of the robot.
    pub fn route_params(&self, settle_within_m: f32) -> crate::route::RouteParams {
        let p = &self.planner;
        crate::route::RouteParams {
            cell_m: p.route_cell_m as f32,
            radius_m: self.footprint_m() as f32,
            cost_weight: p.route_cost_weight as f32,
            swing_m: self.swing_m() as f32,
            swing_weight: p.route_swing_weight as f32,
            suspect_weight: p.route_suspect_weight as f32,
            end_m: self.end_m() as f32,
            settle_within_m,
        }
    }

    /// How far from the robot a rollout's footprint can reach: the top speed over the horizon,
    /// the body's enclosing radius (the end discs of its cover, if farther) and the margin, m.
    pub fn reach_m(&self) -> f64 {
        let body = self
            .footprint_discs()
            .iter()
            .map(|d| d.x_m.abs() + d.radius_m)
            .fold(self.robot.body().enclosing_radius_m(), f64::max);
        self.robot.max_linear_mps * self.planner.horizon_s + body + self.planner.margin_m
    }

    /// A map older than this is stale (`planner.map_max_age_s`), ns.
    pub fn map_max_age_ns(&self) -> u64 {
        seconds_ns(self.planner.map_max_age_s)
    }

    /// Odometry older than this is stale (`planner.odom_max_age_s`), ns.
    pub fn odom_max_age_ns(&self) -> u64 {
        seconds_ns(self.planner.odom_max_age_s)
    }

    /// A goal older than this is dropped; 0: never (`planner.goal_max_age_s`), ns.
    pub fn goal_max_age_ns(&self) -> u64 {
        seconds_ns(self.planner.goal_max_age_s)
    }

    /// A foliage verdict older than this is ignored (`planner.foliage_max_age_s`), ns.
    pub fn foliage_max_age_ns(&self) -> u64 {
        seconds_ns(self.planner.foliage_max_age_s)
    }

    /// How long the planner creeps with no route before it stops (`planner.no_route_stop_s`), ns.
    pub fn no_route_stop_ns(&self) -> u64 {
        seconds_ns(self.planner.no_route_stop_s)
    }

    /// How long the route may lead no nearer the goal before the robot goes to look at
    /// suspected glass (`planner.look_after_s`; 0: never), ns.
    pub fn look_after_ns(&self) -> u64 {
        seconds_ns(self.planner.look_after_s)
    }

    /// How long the route may lead no nearer the goal before the robot squeezes through with
    /// `planner.tight_margin_m` (`planner.tight_after_s`; 0: never), ns. A round body only: a
    /// long one's corners swing as it turns in a gap, and on the tune worlds Spot squeezing
    /// touched three impassable hedges instead of one and gained no hedge (docs/glass.md).
    pub fn tight_after_ns(&self) -> u64 {
        match self.robot.body() {
            mimnav_shared::config::Body::Round(_) => seconds_ns(self.planner.tight_after_s),
            mimnav_shared::config::Body::Rectangle { .. } => 0,
        }
    }

    /// How long one squeeze lasts (`planner.tight_s`), ns.
    pub fn tight_ns(&self) -> u64 {
        seconds_ns(self.planner.tight_s)
    }

    /// The least clearance from a solid or glass cell at which the body's centre can cross a
    /// line, m: its half width and the least margin it ever keeps — `inside_margin_share` of
    /// `planner.margin_m` (a body already inside its margin), or `planner.tight_margin_m` for a
    /// round body that squeezes. Suspected glass nearer than this to a solid or glass cell is no
    /// way through even if it is open ([`crate::narrow`]).
    pub fn pass_need_m(&self) -> f64 {
        let p = &self.planner;
        let mut margin = p.inside_margin_share.clamp(0.0, 1.0) * p.margin_m;
        if self.tight_after_ns() > 0 {
            margin = margin.min(p.tight_margin_m);
        }
        self.robot.body().half_width_m() + margin.max(0.0)
    }

    /// These settings squeezing through: `planner.margin_m` replaced by
    /// `planner.tight_margin_m`.
    pub fn tight(&self) -> PlannerParams {
        let mut p = self.clone();
        p.planner.margin_m = self.planner.tight_margin_m;
        p
    }

    /// How long the route may lead no nearer the goal before the suspected glass it runs into
    /// is given up (`planner.give_up_after_s`; 0: never), ns.
    pub fn give_up_after_ns(&self) -> u64 {
        seconds_ns(self.planner.give_up_after_s)
    }

    /// How long a stretch stays given up (`planner.give_up_s`), ns.
    pub fn give_up_ns(&self) -> u64 {
        seconds_ns(self.planner.give_up_s)
    }

    /// How long the route remembers what a map showed (`planner.route_memory_s`), ns.
    pub fn route_memory_ns(&self) -> u64 {
        seconds_ns(self.planner.route_memory_s)
    }

    /// How long one look lasts at most (`planner.look_s`), ns.
    pub fn look_ns(&self) -> u64 {
        seconds_ns(self.planner.look_s)
    }

    /// How long the robot is held still before it backs out (`planner.recovery_after_s`), ns.
    pub fn recovery_after_ns(&self) -> u64 {
        seconds_ns(self.planner.recovery_after_s)
    }

    /// How long one backing out lasts (`planner.recovery_s`), ns.
    pub fn recovery_ns(&self) -> u64 {
        seconds_ns(self.planner.recovery_s)
    }

    /// How long one maneuver lasts at most (`planner.maneuver_s`), ns.
    pub fn maneuver_ns(&self) -> u64 {
        seconds_ns(self.planner.maneuver_s)
    }

    /// How long a command is valid after it is sent (`robot.command_validity_s`), ns.
    pub fn command_validity_ns(&self) -> u64 {
        seconds_ns(self.robot.command_validity_s)
    }
}

impl Default for PlannerParams {
    /// The documented defaults: a Turtlebot 2 with the authors' starting point (DESIGN §7).
    /// `mimnav_config::Config::planner_params` builds a file's.
    fn default() -> Self {
        PlannerParams {
            planner: PlannerConfig::default(),
            robot: RobotProfile::default(),
            passable_cost: MapperConfig::default().passable_cell_cost(),
        }
    }
}
