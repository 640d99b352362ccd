//! Poses and frame transforms, on nalgebra: one 2-D pose type, [`Pose2`], for the robot in the
//! odometry frame, and one way to bring a point from a fixed frame into the robot's
//! ([`Pose2Ext::to_local`]) and back ([`Pose2Ext::to_fixed`]).
//!
//! Frames follow REP-103 / REP-105: x forward, y left, z up; metres and radians; the odometry
//! frame is fixed, the robot frame moves with the robot (DESIGN §4). Hot inner loops that move
//! thousands of points may keep a pose's sine and cosine in plain numbers; everything else goes
//! through this module.
//!
//! ```
//! use mimnav_shared::pose::{Pose2Ext, pose2};
//! // a robot at (1, 2) facing +y sees a goal at (1, 5) 3 m straight ahead
//! let robot = pose2(1.0, 2.0, std::f64::consts::FRAC_PI_2);
//! let (x, y) = robot.to_local(1.0, 5.0);
//! assert!((x - 3.0).abs() < 1e-12 && y.abs() < 1e-12);
//! ```

pub use nalgebra::{Isometry2, Isometry3, Point2, Point3, Translation3, UnitQuaternion, Vector2};

use crate::topics::Odometry;

/// A pose in the plane: position (m) and heading (rad, counter-clockwise from x). As a transform
/// it maps points of the posed frame (the robot's) into the frame it is given in (odometry).
pub type Pose2 = Isometry2<f64>;

/// The pose at `(x, y)` with heading `yaw`.
pub fn pose2(x: f64, y: f64, yaw: f64) -> Pose2 {
    Isometry2::new(Vector2::new(x, y), yaw)
}

/// The robot's pose an `odom` message gives, or `None` when a field is not finite.
pub fn odom_pose(odom: &Odometry) -> Option<Pose2> {
    (odom.x.is_finite() && odom.y.is_finite() && odom.yaw.is_finite())
        .then(|| pose2(odom.x, odom.y, odom.yaw))
}

/// Odometry with a number that is not finite: refused where it arrives, so it never steers and
/// never moves a memory (the last good message ages into stale odometry instead).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("odometry with a non-finite pose or velocity (seq {0}): ignored")]
pub struct NonFiniteOdometry(pub u64);

/// The robot's pose an `odom` message gives, when its pose and velocity are all finite.
pub fn check_odometry(odom: &Odometry) -> Result<Pose2, NonFiniteOdometry> {
    odom_pose(odom)
        .filter(|_| odom.v.is_finite() && odom.omega.is_finite())
        .ok_or(NonFiniteOdometry(odom.seq))
}

/// What every code path asks of a pose.
pub trait Pose2Ext {
    /// x, m.
    fn x(&self) -> f64;
    /// y, m.
    fn y(&self) -> f64;
    /// Heading in (−π, π], rad.
    fn yaw(&self) -> f64;
    /// A point given in the fixed frame, in this pose's frame (e.g. the goal in the robot frame).
    fn to_local(&self, x: f64, y: f64) -> (f64, f64);
    /// A point given in this pose's frame, in the fixed frame (the T of MIM equation 6).
    fn to_fixed(&self, x: f64, y: f64) -> (f64, f64);
    /// `other` seen from this pose: the motion from here to there, in this pose's frame.
    fn motion_to(&self, other: &Self) -> Self;
    /// All three numbers finite.
    fn is_finite(&self) -> bool;
}

impl Pose2Ext for Pose2 {
    fn x(&self) -> f64 {
        self.translation.x
    }

    fn y(&self) -> f64 {
        self.translation.y
    }

    fn yaw(&self) -> f64 {
        self.rotation.angle()
    }

    fn to_local(&self, x: f64, y: f64) -> (f64, f64) {
        let p = self.inverse_transform_point(&Point2::new(x, y));
        (p.x, p.y)
    }

    fn to_fixed(&self, x: f64, y: f64) -> (f64, f64) {
        let p = self.transform_point(&Point2::new(x, y));
        (p.x, p.y)
    }

    fn motion_to(&self, other: &Self) -> Self {
        self.inv_mul(other)
    }

    fn is_finite(&self) -> bool {
        self.translation.x.is_finite()
            && self.translation.y.is_finite()
            && self.rotation.re.is_finite()
            && self.rotation.im.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    #[test]
    fn to_local_and_to_fixed_are_inverse() {
        let p = pose2(-3.0, 4.5, 2.3);
        for &(x, y) in &[(0.0, 0.0), (1.0, -2.0), (100.0, 3.0)] {
            let (lx, ly) = p.to_local(x, y);
            let (fx, fy) = p.to_fixed(lx, ly);
            assert!((fx - x).abs() < 1e-9 && (fy - y).abs() < 1e-9, "{x} {y}");
        }
    }

    #[test]
    fn a_goal_behind_and_left_of_a_turned_robot() {
        // facing −x at the origin: a goal at (−1, −2) is 1 m ahead and 2 m to the left
        let (x, y) = pose2(0.0, 0.0, PI).to_local(-1.0, -2.0);
        assert!(
            (x - 1.0).abs() < 1e-12 && (y - 2.0).abs() < 1e-12,
            "{x} {y}"
        );
    }

    #[test]
    fn motion_to_is_the_second_pose_in_the_first_frame_and_wraps() {
        let a = pose2(1.0, 1.0, FRAC_PI_2);
        let b = pose2(1.0, 3.0, -PI + 0.1);
        let m = a.motion_to(&b);
        assert!((m.x() - 2.0).abs() < 1e-12 && m.y().abs() < 1e-12);
        // from +90° to −179.9°: a turn of +90.1°, not −269.9°
        assert!((m.yaw() - (FRAC_PI_2 + 0.1)).abs() < 1e-12, "{}", m.yaw());
    }

    #[test]
    fn non_finite_odometry_has_no_pose() {
        let o = Odometry {
            x: f64::NAN,
            ..Odometry::default()
        };
        assert!(odom_pose(&o).is_none());
        assert!(odom_pose(&Odometry::default()).is_some_and(|p| p.is_finite()));
        let fast = Odometry {
            seq: 4,
            v: f32::INFINITY,
            ..Odometry::default()
        };
        assert_eq!(check_odometry(&fast), Err(NonFiniteOdometry(4)));
        assert!(check_odometry(&Odometry::default()).is_ok());
    }
}
