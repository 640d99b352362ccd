//! `[robot]`: the robot profile (`config/robots/NAME.toml`).

use serde::{Deserialize, Serialize};

use super::check::{Checks, Invalid};

/// A robot: footprint, sensor mounting and motion limits (`config/robots/NAME.toml`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RobotProfile {
    /// Profile name.
    pub name: String,
    /// Radius of the circle that encloses the footprint, metres.
    pub radius_m: f64,
    /// Height of the lidar's optical centre above the ground, metres.
    pub sensor_height_m: f64,
    /// Height of the robot's top above the ground, metres.
    pub height_m: f64,
    /// Largest forward speed, m/s.
    pub max_linear_mps: f64,
    /// Largest turn rate, rad/s.
    pub max_angular_rps: f64,
    /// Largest linear acceleration, m/s².
    pub max_linear_accel: f64,
    /// Largest angular acceleration, rad/s².
    pub max_angular_accel: f64,
    /// How long a velocity command stays valid on the base, seconds.
    pub command_validity_s: f64,
    /// Where the lidar sits on the robot (`[robot.mount]`; its height is `sensor_height_m`).
    pub mount: crate::pose::LidarMount,
}

impl Default for RobotProfile {
    /// The Turtlebot 2 (DESIGN §4).
    fn default() -> Self {
        RobotProfile {
            name: "turtlebot2".into(),
            radius_m: 0.20,
            sensor_height_m: 0.5,
            height_m: 0.6,
            max_linear_mps: 0.5,
            max_angular_rps: 1.5,
            max_linear_accel: 0.6,
            max_angular_accel: 3.0,
            command_validity_s: 0.5,
            mount: crate::pose::LidarMount::default(),
        }
    }
}

impl RobotProfile {
    /// Checks every key of `[robot]`: each value refused names its key and what is allowed.
    pub fn validate(&self) -> Result<(), Invalid> {
        let mut r = Checks::default();
        r.check("robot.radius_m", self.radius_m, 0.05, 3.0);
        r.check("robot.sensor_height_m", self.sensor_height_m, 0.05, 3.0);
        r.check("robot.height_m", self.height_m, 0.05, 3.0);
        r.check("robot.max_linear_mps", self.max_linear_mps, 0.01, 5.0);
        r.check("robot.max_angular_rps", self.max_angular_rps, 0.01, 10.0);
        r.check("robot.max_linear_accel", self.max_linear_accel, 0.01, 20.0);
        r.check(
            "robot.max_angular_accel",
            self.max_angular_accel,
            0.01,
            50.0,
        );
        r.check(
            "robot.command_validity_s",
            self.command_validity_s,
            0.01,
            10.0,
        );
        r.merge(self.mount.validate());
        r.finish()
    }
}
