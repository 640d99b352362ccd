//! The planner's last check before it plans (issue 23 item 3): the goal in the robot frame must
//! be finite. Odometry and goals are refused on arrival when a number is not finite
//! ([`crate::pilot::Pilot::odom`], [`crate::pilot::Pilot::goal`]), but two finite ones can still
//! overflow on the way (a pose at 1e308 m, a goal at −1e308 m): the dynamic window would then
//! score every motion NaN and pick an extreme one. A finite goal can also be too far for the
//! planner's single-precision route: at 8e28 m every cell's length rounds to the same number,
//! and the route's bucket index overflowed (found by the proptest in `tests/non_finite.rs`).
//! Such a goal is not planned towards; the robot stops with
//! [`crate::pilot::Stale::GoalOutOfRange`].

use mimnav_shared::pose::{Pose2, Pose2Ext};

/// The farthest goal the planner drives towards, m. The route's lengths are `f32`: at 100 km
/// their resolution is 8 mm, still far finer than a coarse cell.
pub const MAX_GOAL_M: f64 = 100_000.0;

/// The goal `(x, y)` (odometry frame) seen from `pose`, when every number on the way is finite
/// and the goal is within [`MAX_GOAL_M`].
pub fn goal_in_robot_frame(pose: &Pose2, x: f64, y: f64) -> Option<(f64, f64)> {
    if !(pose.is_finite() && x.is_finite() && y.is_finite()) {
        return None;
    }
    let (gx, gy) = pose.to_local(x, y);
    (gx.is_finite() && gy.is_finite() && gx.hypot(gy) <= MAX_GOAL_M).then_some((gx, gy))
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
        // finite, but beyond what the route resolves
        assert!(goal_in_robot_frame(&here, 1.0, 2.0 + 0.9 * MAX_GOAL_M).is_some());
        assert_eq!(goal_in_robot_frame(&here, 1.0, 7.9e28), None);
    }
}
