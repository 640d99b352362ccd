//! `mimnav demo`: the whole stack as separate processes, driving a simulated robot from its start
//! to its goal.
//!
//! The simulator streams the VLP-16's UDP packets to the driver over loopback in real time, as a
//! real sensor would; the driver, the mapper, the foliage classifier and the planner run as their
//! own processes and talk
//! over iceoryx2 in a private domain (they never meet a stack already running on the machine);
//! the simulator drives the robot by the planner's `cmd_vel`. The demo sends the world's goal,
//! follows the episode with a progress bar, measures the latency from each revolution's last
//! packet to the command planned from it (from the messages' own sequence numbers and
//! monotonic timestamps), writes the last map with the driven path as a PNG and prints the
//! figures. Exit status: 0 when the goal was reached, 3 on contact or timeout, 130 when
//! interrupted.
//!
//! Stopping (issue 23, item 9): the children never outlive the demo, and on SIGINT or SIGTERM
//! (and on any error) the robot is halted first ([`crate::stack`]).

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Result;
use mimnav_mapper::render::{Marks, render_map_with_legend};
use mimnav_shared::config::toml_quote;
use mimnav_shared::grid::GridSpec;
use mimnav_shared::ipc;
use mimnav_shared::pose::{Pose2Ext, pose2};
use mimnav_shared::topics::{Goal, MapHeader, VelocityCommand, command_flags, command_status};

use crate::stack::{self, Resolved, Stack};

/// Removes a folder of the demo's own when dropped.
struct RemoveDir(PathBuf);

impl Drop for RemoveDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Arguments of `mimnav demo`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Stopping: Ctrl-C (SIGINT) or SIGTERM stops the robot first: the demo stops the planner, \
commands zero velocity on cmd_vel, waits up to 3 s until the odometry shows the robot at rest \
(and prints where it stopped), then stops the simulator and the other services and waits for \
them; exit status 130. The services never outlive the demo: should it be killed (SIGKILL), the \
kernel sends each of them SIGTERM (a parent-death signal) and they end cleanly.

Exit status: 0 goal reached, 3 contact or timeout, 130 interrupted, 1 error.")]
pub struct DemoArgs {
    /// The world (default: sim.world of the config).
    #[arg(long, value_name = "FILE")]
    world: Option<PathBuf>,
    /// The robot profile: spot or turtlebot2 (default: the config's).
    #[arg(long, value_name = "NAME")]
    robot: Option<String>,
    /// Seed of the simulation (default: sim.seed).
    #[arg(long)]
    seed: Option<u64>,
    /// Where to write the map with the driven path.
    #[arg(long, value_name = "PNG", default_value = "mimnav-demo.png")]
    out: PathBuf,
    /// The services' log filter (`log.level`); their messages come to this terminal's stderr.
    /// `debug` shows each revolution's timing per hop.
    #[arg(long, value_name = "FILTER", default_value = "warn")]
    log: String,
    /// The SCHED_FIFO priority of the driver (`latency.realtime_priority`; 0: the normal
    /// scheduler); the planner, mapper, foliage classifier and simulator run 1, 2, 3 and 4 below.
    /// Without the right to use it (root, CAP_SYS_NICE or RLIMIT_RTPRIO), each service warns
    /// and runs normally.
    #[arg(long, value_name = "N", default_value_t = 10, value_parser = clap::value_parser!(i32).range(0..=99))]
    realtime_priority: i32,
    /// The robot's base: `ideal` (the simulator follows cmd_vel and publishes odom) or
    /// `kobuki` (the Turtlebot 2's: a simulated Kobuki on a pseudo-terminal speaking the base's
    /// serial protocol, driven by mimnav-kobuki, whose odometry from the encoders and gyro the
    /// stack uses; the demo prints its error against the simulator's true position).
    #[arg(long, value_enum, default_value = "ideal")]
    base: Base,
    /// Also run the Foxglove live view (`mimnav-view`) on 127.0.0.1:PORT, so a viewer can watch
    /// the demo (ws://127.0.0.1:PORT) and the latency can be measured with one attached
    /// (`bench/view-latency.sh`).
    #[arg(long, value_name = "PORT")]
    view: Option<u16>,
}

/// `mimnav demo --base`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Base {
    /// The simulator follows cmd_vel and publishes odom.
    Ideal,
    /// A simulated Kobuki on a pty, driven by mimnav-kobuki.
    Kobuki,
}

/// The latency from a revolution's last packet to its `cmd_vel` (issue 27), as the demo and
/// the soak measure it: each map's revolution and the arrival of its last packet (the map's
/// `rx_mono_ns`), matched with the command planned on it; a command for want of fresh input is
/// not counted.
#[derive(Debug, Default)]
pub(crate) struct CmdLatency {
    /// The last maps' revolutions and their last packets' arrival.
    arrived: VecDeque<(u64, u64)>,
    ms: Vec<f64>,
}

impl CmdLatency {
    /// A map of revolution `source_seq`, whose last packet arrived at `rx_mono_ns`.
    pub(crate) fn map(&mut self, source_seq: u64, rx_mono_ns: u64) {
        self.arrived.push_back((source_seq, rx_mono_ns));
        if self.arrived.len() > 64 {
            self.arrived.pop_front();
        }
    }

    /// A command: its latency counted when its map was seen.
    pub(crate) fn command(&mut self, c: &VelocityCommand) {
        if let Some(&(_, rx)) = self.arrived.iter().find(|(seq, _)| *seq == c.source_seq)
            && c.status != command_status::STALE_INPUT
            && rx > 0
        {
            self.ms
                .push(c.stamp_mono_ns.saturating_sub(rx) as f64 / 1e6);
        }
    }

    /// The percentiles over every command counted.
    pub(crate) fn summary(&self) -> Latency {
        let mut ms = self.ms.clone();
        ms.sort_by(f64::total_cmp);
        Latency {
            revolutions: ms.len(),
            p50: percentile(&ms, 0.5),
            p99: percentile(&ms, 0.99),
            max: ms.last().copied().unwrap_or(f64::NAN),
        }
    }
}

/// Percentiles of [`CmdLatency`], ms.
#[derive(Debug, serde::Serialize)]
pub(crate) struct Latency {
    pub(crate) revolutions: usize,
    pub(crate) p50: f64,
    pub(crate) p99: f64,
    pub(crate) max: f64,
}

/// Percentile `q` (0–1) of sorted values.
fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

/// Runs the demo.
pub fn run(config_path: Option<&Path>, sets: &[String], args: &DemoArgs) -> Result<ExitCode> {
    let (robot, world) = (args.robot.as_deref(), args.world.as_deref());
    // the simulated Kobuki's pty, reached through a symlink of the demo's own
    let kobuki_dir = (args.base == Base::Kobuki)
        .then(|| std::env::temp_dir().join(format!("mimnav-demo-kobuki-{}", std::process::id())));
    let mut extra = Vec::new();
    if let Some(dir) = &kobuki_dir {
        std::fs::create_dir_all(dir)?;
        let link = toml_quote(&dir.join("kobuki").display().to_string());
        extra.extend([
            format!("sim.base={}", toml_quote("kobuki")),
            format!("sim.kobuki_link={link}"),
            format!("kobuki.device={link}"),
            "kobuki.reconnect_s=0.1".to_string(),
        ]);
    }
    let _remove = kobuki_dir.as_ref().map(|d| RemoveDir(d.clone()));
    let Resolved {
        config,
        sets,
        world_path,
        world,
    } = stack::resolve(config_path, sets, robot, &extra, world)?;
    if args.base == Base::Kobuki && config.robot.name != "turtlebot2" {
        anyhow::bail!(
            "--base kobuki: the Kobuki is the Turtlebot 2's base, and the robot is {} (add --robot turtlebot2)",
            config.robot.name
        );
    }
    // the Kobuki's odometry starts where the robot stands; the simulator's is the world's frame
    let start = pose2(world.start[0], world.start[1], world.start[2].to_radians());
    let odom_of = |x: f64, y: f64| match args.base {
        Base::Kobuki => start.to_local(x, y),
        Base::Ideal => (x, y),
    };
    let goal_odom = odom_of(world.goal[0], world.goal[1]);
    let stack = Stack::new(
        "demo",
        &config,
        config_path,
        &sets,
        &args.log,
        args.realtime_priority,
    )?;
    let (local, data_port) = (stack.local.clone(), stack.data_port);
    let node = ipc::node(&local, "mimnav-demo")?;
    let plans = ipc::plan_subscriber(&node)?;
    let commands = ipc::cmd_vel_subscriber(&node)?;
    let odom = ipc::odom_subscriber(&node)?;
    let goal_pub = ipc::goal_publisher(&node)?;
    // the demo's own stop command, sent once the planner is stopped (see `Children::halt_robot`)
    let stop_pub = ipc::cmd_vel_publisher(&node)?;

    let _ = outln!(
        "{}: from ({:.1}, {:.1}) to ({:.1}, {:.1}) with a {} ({} m radius); driver, mapper, foliage classifier and planner as processes, the simulator streaming UDP to 127.0.0.1:{data_port}",
        world.name,
        world.start[0],
        world.start[1],
        world.goal[0],
        world.goal[1],
        config.robot.name,
        config.robot.radius_m
    );
    let mut children = stack.start_services()?;
    if let Some(port) = args.view {
        stack.start_view(&mut children, port)?;
    }
    if !children.wait_for_planner(&node, &commands)? {
        // nothing moves yet: dropping the children stops them
        return Ok(ExitCode::from(130));
    }
    let goal = Goal {
        seq: 0,
        stamp_mono_ns: ipc::monotonic_ns(),
        x: goal_odom.0,
        y: goal_odom.1,
        tolerance_m: config.sim.goal_tolerance_m,
        ..Goal::default()
    };
    goal_pub.publish(goal)?;

    let mut sim_args = vec!["--world".into(), world_path.display().to_string()];
    sim_args.push("--json".into());
    if let Some(s) = args.seed {
        sim_args.extend(["--seed".into(), s.to_string()]);
    }
    stack.start_sim(&mut children, &sim_args)?;
    let started = Instant::now();

    let bar = indicatif::ProgressBar::new_spinner();
    bar.set_style(
        indicatif::ProgressStyle::with_template("{elapsed_precise} {spinner} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    let mut latency = CmdLatency::default();
    let mut mapper_ms = Vec::new();
    let (mut maps, mut cmds, mut blocked, mut stale) = (0u64, 0u64, 0u64, 0u64);
    let mut alarmed = 0u64;
    let mut last_map: Option<(MapHeader, Vec<u8>)> = None;
    let mut path: Vec<(f64, f64)> = Vec::new();
    let mut last_odom: Option<(f64, f64)> = None;
    let mut goal_seen = false;
    let mut interrupted = false;
    loop {
        if children.sim_exited() {
            break;
        }
        if !ipc::sleep(&node, Duration::from_millis(5)) {
            // SIGINT or SIGTERM: only the demo got it (the children have groups of their own)
            interrupted = true;
            break;
        }
        while let Some(sample) = plans.receive()? {
            let h = *sample.user_header();
            latency.map(h.source_seq, h.rx_mono_ns);
            mapper_ms.push(f64::from(h.processing_us) / 1e3);
            let classes: Vec<u8> = sample.payload().iter().map(|c| c.class).collect();
            drop(sample);
            last_map = Some((h, classes));
            maps += 1;
        }
        while let Some(c) = commands.receive()? {
            cmds += 1;
            alarmed += u64::from(c.flags & command_flags::FOLIAGE_ALARM != 0);
            match c.status {
                command_status::BLOCKED => blocked += 1,
                command_status::STALE_INPUT => stale += 1,
                command_status::NO_GOAL if !goal_seen => {
                    // the goal went out before the planner listened: again
                    goal_pub.publish(Goal {
                        stamp_mono_ns: ipc::monotonic_ns(),
                        ..goal
                    })?;
                }
                _ => {}
            }
            if c.status == command_status::DRIVING || c.status == command_status::GOAL_REACHED {
                goal_seen = true;
            }
            latency.command(&c);
        }
        if let Some(o) = odom.latest()? {
            last_odom = Some((o.x, o.y));
            if path
                .last()
                .is_none_or(|p| (p.0 - o.x).hypot(p.1 - o.y) > 0.02)
            {
                path.push((o.x, o.y));
            }
            bar.set_message(format!(
                "at ({:.2}, {:.2}), {:.2} m to the goal, v {:.2} m/s ω {:.2} rad/s; {maps} maps, {cmds} commands",
                o.x,
                o.y,
                (goal_odom.0 - o.x).hypot(goal_odom.1 - o.y),
                o.v,
                o.omega
            ));
        }
    }
    bar.finish_and_clear();
    let halted = interrupted.then(|| children.halt_robot(&node, &stop_pub, &odom));
    let (status, summary) = children.stop_sim();
    let wall_s = started.elapsed().as_secs_f64();
    children.stop_rest();
    if let Some(h) = &halted {
        let _ = outln!("{}", h.describe());
    }
    // the simulator's summary line (`mimnav-sim --json`); a run cut short may have printed none
    let ended: Option<mimnav_sim::Summary> = summary
        .lines()
        .rev()
        .find_map(|l| serde_json::from_str(l).ok());
    let outcome = ended.as_ref().map_or("unknown", |e| e.outcome.as_str());
    let num = |f: fn(&mimnav_sim::Summary) -> f64| ended.as_ref().map_or(f64::NAN, f);

    if let Some((h, classes)) = &last_map {
        let grid = GridSpec {
            cells: h.cells as usize,
            cell_m: h.cell_m,
        };
        let robot = pose2(h.x, h.y, h.yaw);
        let to_robot = |x: f64, y: f64| robot.to_local(x, y);
        let img = render_map_with_legend(
            grid,
            classes,
            &[],
            &Marks {
                robot_radius_m: config.robot.radius_m,
                body_m: crate::snapshot::body_of(&config),
                goal: Some(to_robot(goal_odom.0, goal_odom.1)),
                path: path.iter().map(|p| to_robot(p.0, p.1)).collect(),
            },
            &format!("{}: map {}", world.name, h.seq),
        );
        crate::snapshot::write_png(&args.out, &img)?;
    }
    let latency = latency.summary();
    mapper_ms.sort_by(f64::total_cmp);
    let _ = outln!(
        "{}: {outcome} after {:.1} s simulated ({wall_s:.1} s wall); driven {:.2} m, straight line {:.2} m (ratio {:.2})",
        world.name,
        num(|e| e.time_s),
        num(|e| e.path_length_m),
        num(|e| e.straight_m),
        num(|e| e.path_length_m / e.straight_m)
    );
    let _ = outln!(
        "{maps} maps, {cmds} commands ({blocked} blocked, {stale} stale input, {alarmed} with the foliage alarm); latency from a revolution's last packet to its cmd_vel over {} revolutions: p50 {:.2} ms, p99 {:.2} ms, max {:.2} ms",
        latency.revolutions,
        latency.p50,
        latency.p99,
        latency.max
    );
    let _ = outln!(
        "of which the mapper's own processing per revolution: p50 {:.2} ms, p99 {:.2} ms, max {:.2} ms",
        percentile(&mapper_ms, 0.5),
        percentile(&mapper_ms, 0.99),
        mapper_ms.last().copied().unwrap_or(f64::NAN)
    );
    if args.base == Base::Kobuki {
        // the odometry mimnav-kobuki published from the base's encoders and gyro, in the world
        match (last_odom, &ended) {
            (Some((x, y)), Some(e)) => {
                let (wx, wy) = start.to_fixed(x, y);
                let _ = outln!(
                    "odometry from the Kobuki's encoders and gyro (mimnav-kobuki) at the end: ({wx:.3}, {wy:.3}); the simulator's true position ({:.3}, {:.3}): error {:.3} m after {:.2} m driven",
                    e.x,
                    e.y,
                    (wx - e.x).hypot(wy - e.y),
                    e.path_length_m
                );
            }
            _ => _ = outln!("no odometry from the Kobuki to compare"),
        }
    }
    if last_map.is_some() {
        let _ = outln!(
            "wrote {} (the last map, robot at the centre heading up, driven path in cyan)",
            args.out.display()
        );
    } else {
        let _ = outln!("no map arrived: nothing written to {}", args.out.display());
    }
    if interrupted {
        return Ok(ExitCode::from(130));
    }
    Ok(match (outcome, status.is_some_and(|s| s.success())) {
        ("goal_reached", true) => ExitCode::SUCCESS,
        _ => ExitCode::from(3),
    })
}
