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
//! Stopping (issue 23, item 9). The children never outlive the demo: each is started with a
//! parent-death signal (SIGTERM, see [`crate::procs`]), so even a SIGKILL of the demo ends them
//! and the simulated robot with them. They run in process groups of their own, so a Ctrl-C on the
//! terminal reaches the demo alone, which stops them in an order that halts the robot first: on
//! SIGINT or SIGTERM (and on any error) it stops the planner, commands zero velocity on `cmd_vel`
//! itself and waits (up to [`HALT_WITHIN`]) until the odometry shows the robot at rest, then
//! stops the simulator, then the driver, mapper and classifier, and waits for each.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use mimnav_config::Config;
use mimnav_mapper::render::{self, Marks, render_map};
use mimnav_shared::config::toml_quote;
use mimnav_shared::grid::GridSpec;
use mimnav_shared::ipc::{self, PrivateDomain};
use mimnav_shared::pose::{Pose2Ext, pose2};
use mimnav_shared::topics::{
    Goal, MapHeader, Odometry, VelocityCommand, command_flags, command_status,
};
use mimnav_sim::world::WorldFile;

use crate::procs::{Options, Service, service_binary};

/// How long the demo waits, once interrupted, for the odometry to show the robot at rest before
/// it stops the simulator anyway.
pub const HALT_WITHIN: Duration = Duration::from_secs(3);
/// How long a child has to end after SIGTERM before it is killed.
const STOP_GRACE: Duration = Duration::from_secs(2);
/// Below these speeds (m/s, rad/s) the robot is at rest.
const AT_REST: (f32, f32) = (1e-3, 1e-3);

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
    /// The SCHED_FIFO priority of the driver, mapper, foliage classifier and planner
    /// (`latency.realtime_priority`; 0: the normal scheduler). Without the right to use it
    /// (root, CAP_SYS_NICE or RLIMIT_RTPRIO), each service warns and runs normally.
    #[arg(long, value_name = "N", default_value_t = 10, value_parser = clap::value_parser!(i32).range(0..=99))]
    realtime_priority: i32,
}

/// Percentile `q` (0–1) of sorted values.
fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

/// A loopback UDP port nobody uses right now.
fn free_port() -> Result<u16> {
    let s = std::net::UdpSocket::bind("127.0.0.1:0").context("cannot find a free UDP port")?;
    Ok(s.local_addr()
        .context("cannot find a free UDP port")?
        .port())
}

/// Runs the demo.
pub fn run(config_path: Option<&Path>, sets: &[String], args: &DemoArgs) -> Result<ExitCode> {
    let mut sets = sets.to_vec();
    if let Some(r) = &args.robot {
        sets.push(format!("robot.profile={}", toml_quote(r)));
    }
    let config = Config::resolve(config_path, &sets).map_err(|e| anyhow::anyhow!("{e}"))?;
    let world_path = args
        .world
        .clone()
        .unwrap_or_else(|| config.sim.world_path(&config.dir()));
    let world = WorldFile::load(&world_path)?;
    let domain = PrivateDomain::new("demo");
    let local = domain.apply(config.clone());
    let (data_port, position_port) = (free_port()?, free_port()?);

    let mut child_args: Vec<String> = Vec::new();
    if let Some(p) = config_path {
        child_args.extend(["--config".into(), p.display().to_string()]);
    }
    for s in &sets {
        child_args.extend(["--set".into(), s.clone()]);
    }
    child_args.extend(domain.set_args());
    for s in [
        format!("velodyne.input={}", toml_quote("udp")),
        format!("velodyne.bind_address={}", toml_quote("127.0.0.1")),
        format!("velodyne.data_port={data_port}"),
        format!("velodyne.position_port={position_port}"),
        format!("sim.udp_target={}", toml_quote("127.0.0.1")),
        format!("log.level={}", toml_quote(&args.log)),
        format!("latency.realtime_priority={}", args.realtime_priority),
    ] {
        child_args.extend(["--set".into(), s]);
    }

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
    // started from this (the main) thread: their parent-death signal is tied to it
    let own_group = Options {
        own_process_group: true,
        piped_stdout: false,
    };
    let mut children = Children::default();
    for name in [
        "mimnav-velodyne",
        "mimnav-mapper",
        "mimnav-foliage",
        "mimnav-planner",
    ] {
        let s = Service::start_with(&service_binary(name)?, &child_args, own_group)?;
        if name == "mimnav-planner" {
            children.planner = Some(s);
        } else {
            children.others.push(s);
        }
    }
    // the planner is up when it speaks (a stale-input stop every 100 ms while no map comes)
    let until = Instant::now() + Duration::from_secs(10);
    loop {
        if commands.receive()?.is_some() {
            break;
        }
        if let Some((name, status)) = children.exited_early() {
            bail!("{name} exited at start ({status}); see its messages above");
        }
        if Instant::now() > until {
            bail!("the planner did not publish on cmd_vel within 10 s");
        }
        if !ipc::sleep(&node, Duration::from_millis(20)) {
            // nothing moves yet: dropping the children stops them
            return Ok(ExitCode::from(130));
        }
    }
    let goal = Goal {
        seq: 0,
        stamp_mono_ns: ipc::monotonic_ns(),
        x: world.goal[0],
        y: world.goal[1],
        tolerance_m: config.sim.goal_tolerance_m,
    };
    goal_pub.publish(goal)?;

    let mut sim_args = child_args.clone();
    sim_args.extend(["--world".into(), world_path.display().to_string()]);
    sim_args.push("--json".into());
    if let Some(s) = args.seed {
        sim_args.extend(["--seed".into(), s.to_string()]);
    }
    children.sim = Some(Service::start_with(
        &service_binary("mimnav-sim")?,
        &sim_args,
        Options {
            piped_stdout: true,
            ..own_group
        },
    )?);
    let started = Instant::now();

    let bar = indicatif::ProgressBar::new_spinner();
    bar.set_style(
        indicatif::ProgressStyle::with_template("{elapsed_precise} {spinner} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    // revolution sequence → its last packet's receive time (from the map header)
    let mut received: VecDeque<(u64, u64)> = VecDeque::new();
    let mut latencies_ms = Vec::new();
    let mut mapper_ms = Vec::new();
    let (mut maps, mut cmds, mut blocked, mut stale) = (0u64, 0u64, 0u64, 0u64);
    let mut alarmed = 0u64;
    let mut last_map: Option<(MapHeader, Vec<u8>)> = None;
    let mut path: Vec<(f64, f64)> = Vec::new();
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
            received.push_back((h.source_seq, h.rx_mono_ns));
            mapper_ms.push(f64::from(h.processing_us) / 1e3);
            if received.len() > 64 {
                received.pop_front();
            }
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
            if let Some(&(_, rx)) = received.iter().find(|(seq, _)| *seq == c.source_seq)
                && c.status != command_status::STALE_INPUT
                && rx > 0
            {
                latencies_ms.push(c.stamp_mono_ns.saturating_sub(rx) as f64 / 1e6);
            }
        }
        if let Some(o) = odom.latest()? {
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
                (world.goal[0] - o.x).hypot(world.goal[1] - o.y),
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
        let mut img = render_map(
            grid,
            classes,
            &[],
            &Marks {
                robot_radius_m: config.robot.radius_m,
                goal: Some(to_robot(world.goal[0], world.goal[1])),
            },
        );
        for w in path.windows(2) {
            let (a, b) = (to_robot(w[0].0, w[0].1), to_robot(w[1].0, w[1].1));
            img.line(
                render::pixel(grid, a.0, a.1),
                render::pixel(grid, b.0, b.1),
                [0, 200, 255],
            );
        }
        crate::snapshot::write_png(&args.out, &img)?;
    }
    latencies_ms.sort_by(f64::total_cmp);
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
        latencies_ms.len(),
        percentile(&latencies_ms, 0.5),
        percentile(&latencies_ms, 0.99),
        latencies_ms.last().copied().unwrap_or(f64::NAN)
    );
    let _ = outln!(
        "of which the mapper's own processing per revolution: p50 {:.2} ms, p99 {:.2} ms, max {:.2} ms",
        percentile(&mapper_ms, 0.5),
        percentile(&mapper_ms, 0.99),
        mapper_ms.last().copied().unwrap_or(f64::NAN)
    );
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

/// The demo's children. They stop in the order that halts the robot first — the planner, the
/// simulator, then the rest — also when this value is dropped on an error.
#[derive(Default)]
struct Children {
    // dropped in declaration order
    planner: Option<Service>,
    sim: Option<Service>,
    others: Vec<Service>,
}

/// How the robot came to rest after an interruption.
struct Halted {
    /// The last odometry received after the stop command went out.
    last: Option<Odometry>,
    /// It showed the robot at rest.
    at_rest: bool,
    /// From the start of the halt (the signal) to the odometry at rest, or to giving up.
    after: Duration,
}

impl Halted {
    fn describe(&self) -> String {
        let secs = self.after.as_secs_f64();
        match (self.at_rest, &self.last) {
            (true, Some(o)) => format!(
                "interrupted: the robot stopped at ({:.2}, {:.2}) {secs:.2} s after the signal \
                 (planner stopped, zero velocity commanded); services stopped",
                o.x, o.y
            ),
            (false, Some(o)) => format!(
                "interrupted: the robot was not at rest {secs:.2} s after the signal \
                 (v {:.2} m/s, ω {:.2} rad/s at ({:.2}, {:.2})); the simulator was stopped anyway",
                o.v, o.omega, o.x, o.y
            ),
            (_, None) => format!(
                "interrupted: no odometry within {secs:.2} s of the signal; the simulator was \
                 stopped anyway"
            ),
        }
    }
}

impl Children {
    /// A service that has exited, with its status (while starting, none should have).
    fn exited_early(&mut self) -> Option<(String, std::process::ExitStatus)> {
        self.planner
            .iter_mut()
            .chain(self.others.iter_mut())
            .find_map(|s| s.exited().map(|e| (s.name().to_string(), e)))
    }

    /// The simulator has exited (or was never started).
    fn sim_exited(&mut self) -> bool {
        self.sim.as_mut().is_none_or(|s| s.exited().is_some())
    }

    /// Stops the planner (no more driving commands), then commands zero velocity on `cmd_vel`
    /// every 100 ms until the odometry, published after the first of them, shows the robot at
    /// rest, or [`HALT_WITHIN`] passes, or a second signal comes.
    fn halt_robot(
        &mut self,
        node: &iceoryx2::prelude::Node<ipc::Svc>,
        stop: &ipc::ValuePublisher<VelocityCommand>,
        odom: &ipc::ValueSubscriber<Odometry>,
    ) -> Halted {
        let began = Instant::now();
        if let Some(mut planner) = self.planner.take() {
            planner.stop(STOP_GRACE);
        }
        let first_stop_ns = ipc::monotonic_ns();
        let (mut seq, mut next_stop, mut last) = (0u64, began, None);
        loop {
            let now = Instant::now();
            if now >= next_stop {
                let cmd = VelocityCommand {
                    seq,
                    stamp_mono_ns: ipc::monotonic_ns(),
                    status: command_status::NO_GOAL,
                    ..VelocityCommand::default()
                };
                if let Err(e) = stop.publish(cmd) {
                    tracing::warn!("cannot command the robot to stop: {e}");
                }
                (seq, next_stop) = (seq + 1, now + Duration::from_millis(100));
            }
            while let Ok(Some(o)) = odom.receive() {
                if o.rx_mono_ns < first_stop_ns {
                    continue;
                }
                last = Some(o);
                if o.v.abs() < AT_REST.0 && o.omega.abs() < AT_REST.1 {
                    return Halted {
                        last,
                        at_rest: true,
                        after: began.elapsed(),
                    };
                }
            }
            if self.sim_exited()
                || began.elapsed() > HALT_WITHIN
                || !ipc::sleep(node, Duration::from_millis(5))
            {
                return Halted {
                    last,
                    at_rest: false,
                    after: began.elapsed(),
                };
            }
        }
    }

    /// Stops the simulator (if it still runs) and returns its exit status and its stdout.
    fn stop_sim(&mut self) -> (Option<std::process::ExitStatus>, String) {
        match self.sim.as_mut() {
            Some(sim) => (sim.stop(STOP_GRACE), sim.read_stdout()),
            None => (None, String::new()),
        }
    }

    /// Stops the planner, then the driver, mapper and classifier together, and waits for each.
    fn stop_rest(&mut self) {
        if let Some(planner) = self.planner.as_mut() {
            planner.stop(STOP_GRACE);
        }
        for s in &mut self.others {
            s.terminate();
        }
        for s in &mut self.others {
            s.stop(STOP_GRACE);
        }
    }
}

impl Drop for Children {
    fn drop(&mut self) {
        // an early return or an error: the same order, without the stop command
        if let Some(mut sim) = self.sim.take() {
            if let Some(planner) = self.planner.as_mut() {
                planner.stop(STOP_GRACE);
            }
            sim.stop(STOP_GRACE);
        }
        self.stop_rest();
    }
}
