//! The planner's last check before it plans (issue 23 item 3): the goal in the robot frame must
//! be finite. Odometry and goals are refused on arrival when a number is not finite
//! ([`crate::pilot::Pilot::odom`], [`crate::pilot::Pilot::goal`]), but two finite ones can still
//! overflow on the way (a pose at 1e308 m, a goal at −1e308 m): the dynamic window would then
//! score every motion NaN and pick an extreme one. Such a goal is not planned towards; the robot
//! stops with [`crate::pilot::Stale::GoalNotFinite`].

use mimnav_shared::pose::{Pose2, Pose2Ext};

/// The goal `(x, y)` (odometry frame) seen from `pose`, when every number on the way is finite.
pub fn goal_in_robot_frame(pose: &Pose2, x: f64, y: f64) -> Option<(f64, f64)> {
    if !(pose.is_finite() && x.is_finite() && y.is_finite()) {
        return None;
    }
    let (gx, gy) = pose.to_local(x, y);
    (gx.is_finite() && gy.is_finite() && gx.hypot(gy).is_finite()).then_some((gx, gy))
}

#[cfg(test)]
mod tests {
    use super::*;
    use mimnav_shared::pose::pose2;

    #[test]
    fn issue23_3_non_finite_values_accepted_an_overflowing_goal_is_refused() {
        let here = pose2(1.0, 2.0, 0.5);
        assert!(goal_in_robot_frame(&here, 4.0, 6.0).is_some());
        assert_eq!(goal_in_robot_frame(&here, f64::NAN, 0.0), None);
        assert_eq!(goal_in_robot_frame(&here, 0.0, f64::INFINITY), None);
        assert_eq!(
            goal_in_robot_frame(&pose2(0.0, f64::MAX, 0.0), 0.0, -f64::MAX),
            None
        );
        assert_eq!(
            goal_in_robot_frame(&pose2(f64::NAN, 0.0, 0.0), 1.0, 1.0),
            None
        );
    }
}
