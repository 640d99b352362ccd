//! `mimnav goal X Y`: sends a navigation goal (odometry frame) to the running stack.

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

/// Publishes the goal (twice, 200 ms apart, so a planner that is just connecting gets it too).
pub fn run(config: &Config, args: &GoalArgs) -> Result<ExitCode> {
    if !(args.x.is_finite() && args.y.is_finite() && args.tolerance > 0.0) {
        anyhow::bail!("the goal must be finite and the tolerance above 0");
    }
    let node = ipc::node(config, "mimnav-goal")?;
    let publisher = ipc::goal_publisher(&node)?;
    let goal = Goal {
        seq: ipc::realtime_ns(),
        stamp_mono_ns: ipc::monotonic_ns(),
        x: args.x,
        y: args.y,
        tolerance_m: args.tolerance,
    };
    let mut delivered = publisher.publish(goal)?;
    let _ = node.wait(Duration::from_millis(200));
    delivered = delivered.max(publisher.publish(goal)?);
    if delivered == 0 {
        eprintln!(
            "mimnav: no planner is listening on {} (root path {}, prefix {})",
            mimnav_shared::topics::GOAL,
            config.iceoryx2.global.root_path(),
            config.iceoryx2.global.prefix
        );
        return Ok(ExitCode::from(1));
    }
    println!(
        "goal ({}, {}) sent, tolerance {} m",
        args.x, args.y, args.tolerance
    );
    Ok(ExitCode::SUCCESS)
}
