//! Issue 23 item 3: the planner never publishes a non-finite command and never commands motion
//! from a non-finite pose or goal: it stops, with a status saying why.

use mimnav_planner::PlannerParams;
use mimnav_planner::pilot::Pilot;
use mimnav_shared::topics::{Goal, MapHeader, Odometry, cell_class, command_status};
use proptest::prelude::*;

const S: u64 = 1_000_000_000;

fn header() -> MapHeader {
    MapHeader {
        seq: 1,
        source_seq: 1,
        stamp_ns: S,
        cells: 100,
        cell_m: 0.1,
        layers: 4,
        ..MapHeader::default()
    }
}

fn free() -> Vec<u8> {
    vec![cell_class::FREE; 100 * 100]
}

/// Any number a message can carry: ordinary, huge, or not finite.
fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -50.0f64..50.0,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
        1 => Just(f64::MAX),
        1 => Just(-f64::MAX),
        1 => prop::num::f64::ANY,
    ]
}

fn any_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -1.0f32..1.0,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => prop::num::f32::ANY,
    ]
}

/// Issue 23 item 3: with a NaN start the planner turned at −1.5 rad/s for the whole episode.
/// Whatever pose and goal arrive, a command is finite and within the robot's limits, and the
/// robot is driven only from a finite pose towards a finite goal.
#[test]
fn issue23_3_non_finite_values_accepted_the_planner_never_commands_from_them() {
    let params = PlannerParams::default();
    let (v_max, w_max) = (
        params.robot.max_linear_mps as f32,
        params.robot.max_angular_rps as f32,
    );
    proptest!(ProptestConfig::with_cases(300), |(
        pose in (any_f64(), any_f64(), any_f64()),
        vel in (any_f32(), any_f32()),
        goal in (any_f64(), any_f64(), any_f64()),
    )| {
        let t = 10 * S;
        let mut p = Pilot::new(params.clone());
        let odom = Odometry {
            seq: 1,
            stamp_ns: t,
            rx_mono_ns: t,
            x: pose.0,
            y: pose.1,
            yaw: pose.2,
            v: vel.0,
            omega: vel.1,
        };
        let odom_taken = p.odom(&odom).is_ok();
        let goal = Goal { seq: 1, stamp_mono_ns: t, x: goal.0, y: goal.1, tolerance_m: goal.2.abs(), ..Goal::default() };
        let goal_taken = p.goal(&goal).is_ok();
        let d = p.on_map(&header(), free(), t);
        let cmd = p.command(&d, t);
        prop_assert!(cmd.v.is_finite() && cmd.omega.is_finite(), "{:?}", cmd);
        // within the limits when the robot is (from faster, the window may keep some speed)
        if vel.0.abs() <= v_max && vel.1.abs() <= w_max {
            prop_assert!(cmd.v.abs() <= v_max + 1e-6 && cmd.omega.abs() <= w_max + 1e-6, "{:?}", cmd);
        }
        let finite_in = [odom.x, odom.y, odom.yaw, goal.x, goal.y, goal.tolerance_m]
            .iter()
            .all(|v| v.is_finite())
            && odom.v.is_finite()
            && odom.omega.is_finite();
        if !finite_in {
            // refused where it arrived: no motion
            prop_assert!(!(odom_taken && goal_taken));
            prop_assert_eq!((cmd.v, cmd.omega), (0.0, 0.0));
            prop_assert!(cmd.status != command_status::DRIVING);
        }
        if cmd.status == command_status::DRIVING {
            // the goal in the robot frame was finite: nothing overflowed on the way
            let (dx, dy) = (goal.x - odom.x, goal.y - odom.y);
            prop_assert!(dx.is_finite() && dy.is_finite(), "{:?} {:?}", odom, goal);
        }
    });
}

/// Issue 23 item 3: finite odometry and a finite goal whose difference overflows stop the robot
/// with a status that says so, instead of the dynamic window picking an extreme turn.
#[test]
fn issue23_3_non_finite_values_accepted_an_overflowing_goal_stops_with_a_status() {
    let t = 10 * S;
    let mut p = Pilot::new(PlannerParams::default());
    let odom = Odometry {
        seq: 1,
        stamp_ns: t,
        rx_mono_ns: t,
        y: f64::MAX,
        ..Odometry::default()
    };
    p.odom(&odom).expect("finite odometry is taken");
    let goal = Goal {
        seq: 1,
        stamp_mono_ns: t,
        x: 0.0,
        y: -f64::MAX,
        tolerance_m: 0.3,
        ..Goal::default()
    };
    p.goal(&goal).expect("a finite goal is taken");
    let d = p.on_map(&header(), free(), t);
    assert_eq!(d.stale, Some(mimnav_planner::pilot::Stale::GoalOutOfRange));
    assert_eq!(
        (d.status, d.v, d.omega),
        (command_status::STALE_INPUT, 0.0, 0.0)
    );
    assert!(
        d.describe()
            .contains("goal in the robot frame is not finite"),
        "{}",
        d.describe()
    );
}
