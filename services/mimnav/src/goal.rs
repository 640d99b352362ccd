//! `mimnav goal X Y`: sends a navigation goal (odometry frame) to the running stack.

use std::io::Write as _;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::Result;
use mimnav_config::Config;
use mimnav_shared::ipc;
use mimnav_shared::topics::Goal;

/// Arguments of `mimnav goal`.
#[derive(Debug, clap::Args)]
pub struct GoalArgs {
    /// x in the odometry frame, m.
    #[arg(allow_negative_numbers = true)]
    x: f64,
    /// y in the odometry frame, m.
    #[arg(allow_negative_numbers = true)]
    y: f64,
    /// The goal counts as reached within this distance, m.
    #[arg(long, default_value_t = 0.3)]
    tolerance: f64,
}

/// Refuses a goal the planner would refuse (issue 23 item 3): x and y finite, the tolerance
/// finite and above 0, each named with the value given.
fn check(args: &GoalArgs) -> Result<()> {
    for (name, v) in [("X", args.x), ("Y", args.y)] {
        anyhow::ensure!(v.is_finite(), "goal {name} = {v}: must be a finite number");
    }
    anyhow::ensure!(
        args.tolerance.is_finite() && args.tolerance > 0.0,
        "--tolerance {}: must be a finite number above 0",
        args.tolerance
    );
    Ok(())
}

/// Publishes the goal (twice, 200 ms apart, so a planner that is just connecting gets it too).
pub fn run(config: &Config, args: &GoalArgs) -> Result<ExitCode> {
    check(args)?;
    let node = ipc::node(config, "mimnav-goal")?;
    let publisher = ipc::goal_publisher(&node)?;
    let goal = Goal {
        seq: ipc::realtime_ns(),
        stamp_mono_ns: ipc::monotonic_ns(),
        x: args.x,
        y: args.y,
        tolerance_m: args.tolerance,
        ..Goal::default()
    };
    let mut delivered = publisher.publish(goal)?;
    let _ = node.wait(Duration::from_millis(200));
    delivered = delivered.max(publisher.publish(goal)?);
    if delivered == 0 {
        let _ = writeln!(
            std::io::stderr(),
            "mimnav: no planner is listening on {} (root path {}, prefix {})",
            mimnav_shared::topics::GOAL,
            config.iceoryx2.global.root_path(),
            config.iceoryx2.global.prefix
        );
        return Ok(ExitCode::from(1));
    }
    outln!(
        "goal ({}, {}) sent, tolerance {} m",
        args.x,
        args.y,
        args.tolerance
    )?;
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 23 item 3: `mimnav goal nan 0` or `--tolerance inf` is refused before anything is
    /// sent, naming the value.
    #[test]
    fn issue23_3_non_finite_values_accepted_a_non_finite_goal_is_refused() {
        let args = |x: f64, y: f64, tolerance: f64| GoalArgs { x, y, tolerance };
        assert!(check(&args(1.0, -2.0, 0.3)).is_ok());
        for (a, says) in [
            (args(f64::NAN, 0.0, 0.3), "goal X = NaN"),
            (args(0.0, f64::NEG_INFINITY, 0.3), "goal Y = -inf"),
            (args(0.0, 0.0, f64::INFINITY), "--tolerance inf"),
            (args(0.0, 0.0, f64::NAN), "--tolerance NaN"),
            (args(0.0, 0.0, 0.0), "--tolerance 0"),
        ] {
            let e = check(&a).expect_err(says).to_string();
            assert!(e.contains(says), "{e}");
        }
    }
}
