//! What the planner is set by: `[planner]`, the robot of `[robot]` (footprint, motion limits,
//! the command's validity) and the passable cost of `[mapper]`, held as the config has them.
//! The values the planner needs in other units are methods here, written once.

use mimnav_mapper::config::MapperConfig;
use mimnav_shared::config::{RobotProfile, seconds_ns};

use crate::config::PlannerConfig;

/// Everything the planner and the service's step around it ([`crate::pilot`]) are set by.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannerParams {
    /// `[planner]`: inflation, the dynamic window, the route, the freshness rules.
    pub planner: PlannerConfig,
    /// `[robot]`: the footprint (`radius_m`), the motion limits the dynamic window samples
    /// within, and how long a command stays valid.
    pub robot: RobotProfile,
    /// The planning cost of a passable cell, 0–255, as the mapper writes it
    /// (`mapper.passable_cost`, [`MapperConfig::passable_cell_cost`]).
    pub passable_cost: u8,
}

impl PlannerParams {
    /// The distance kept from solid and glass cells: the footprint's radius and the margin, m.
    pub fn footprint_m(&self) -> f64 {
        self.robot.radius_m + self.planner.margin_m
    }

    /// How far from the robot a rollout's footprint can reach: the top speed over the horizon,
    /// the radius and the margin, m.
    pub fn reach_m(&self) -> f64 {
        self.robot.max_linear_mps * self.planner.horizon_s
            + self.robot.radius_m
            + self.planner.margin_m
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
