//! `mimnav-planner`: the planner service.
//!
//! Wiring only: every map on `map/plan` is inflated towards the goal and searched with the
//! dynamic window, with the latest `odom` and `goal`; the result goes out on `cmd_vel`, valid for
//! `robot.command_validity_s`. Fail safe: without a goal, with stale odometry, with no map for
//! `planner.map_max_age_s`, or with no feasible motion, the command is zero velocity and its
//! status says why — also between maps: the map topic has a deadline of `map_max_age_s`, so a
//! silent mapper stops the robot within that time, and the stop is repeated every 100 ms. The
//! status also goes to systemd (`STATUS=`), which keeps the watchdog pinged from this loop.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Result;
use clap::Parser;
use iceoryx2::prelude::*;
use mimnav_planner::dwa::DwaOutcome;
use mimnav_planner::{Planner, PlannerParams, confirm_obstacles};
use mimnav_shared::cli::ServiceArgs;
use mimnav_shared::config::Config;
use mimnav_shared::faults::Faults;
use mimnav_shared::grid::GridSpec;
use mimnav_shared::ipc::{self, Listening, Svc};
use mimnav_shared::systemd::Notifier;
use mimnav_shared::topics::{
    FoliageHeader, Goal, Odometry, VelocityCommand, command_flags, command_status, foliage_class,
};

/// The planner: map/plan + odom + goal → cmd_vel.
#[derive(Debug, Parser)]
#[command(name = "mimnav-planner", version)]
struct Args {
    #[command(flatten)]
    service: ServiceArgs,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let config = match args.service.load_or_exit("mimnav-planner", &[]) {
        Ok(c) => c,
        Err(code) => return code,
    };
    mimnav_shared::logging::init(&config.log.level);
    // held until the service ends
    let _cpu_latency = mimnav_shared::realtime::apply(&config);
    mimnav_shared::cli::finish("mimnav-planner", run(&config).map(|()| ExitCode::SUCCESS))
}

/// Publishes commands, numbering them and logging when their status changes.
struct Commander {
    publisher: ipc::ValuePublisher<VelocityCommand>,
    seq: u64,
    last_status: u8,
    validity_ns: u64,
    /// [`command_flags`] of the commands sent.
    flags: u8,
    /// What a `stale input` status is about, for the status line.
    stale: &'static str,
    /// (status, flags, stale) the status line was last written for.
    shown: (u8, u8, &'static str),
    sd: Notifier,
    /// The last packet's receive time of the revolution the map being planned on came from
    /// (0: none, or already logged), and when that map arrived here, monotonic ns: the debug
    /// log's figures.
    map_rx_mono_ns: u64,
    map_received_mono_ns: u64,
}

impl Commander {
    #[allow(clippy::too_many_arguments)]
    fn send(
        &mut self,
        v: f64,
        omega: f64,
        status: u8,
        source_stamp_ns: u64,
        source_seq: u64,
        now: u64,
        faults: &mut Faults,
    ) {
        // stamped when it leaves, so the stack's latency includes the planning
        let now = ipc::monotonic_ns().max(now);
        if self.map_rx_mono_ns > 0 {
            tracing::debug!(
                source_seq,
                status,
                // from the revolution's last packet to this map's arrival here, and the planning
                waited_us = self
                    .map_received_mono_ns
                    .saturating_sub(self.map_rx_mono_ns)
                    / 1000,
                processing_us = now.saturating_sub(self.map_received_mono_ns) / 1000,
                "command"
            );
            // once per map: a later stale-input stop is not timed against it
            self.map_rx_mono_ns = 0;
        }
        let cmd = VelocityCommand {
            seq: self.seq,
            stamp_mono_ns: now,
            source_stamp_ns,
            source_seq,
            valid_until_mono_ns: now + self.validity_ns,
            v: v as f32,
            omega: omega as f32,
            status,
            flags: self.flags,
            reserved: [0; 6],
        };
        self.seq += 1;
        if let Err(e) = self.publisher.publish(cmd) {
            faults.record("publish_failed", Instant::now(), e);
        }
        if status != self.last_status {
            tracing::info!(status, v, omega, "command status changed");
            self.last_status = status;
        }
        let shown = (status, self.flags, self.stale);
        if shown != self.shown {
            self.shown = shown;
            let what = match status {
                command_status::DRIVING => "driving",
                command_status::GOAL_REACHED => "goal reached: zero velocity",
                command_status::BLOCKED => "blocked (no feasible motion): zero velocity",
                command_status::NO_GOAL => "no goal: zero velocity",
                _ => "",
            };
            let alarm = if self.flags & command_flags::FOLIAGE_ALARM != 0 {
                "; foliage alarm"
            } else {
                ""
            };
            let line = if status == command_status::STALE_INPUT {
                format!("stale input ({}): zero velocity{alarm}", self.stale)
            } else {
                format!("{what}{alarm}")
            };
            self.sd.status(&line);
        }
    }
}

fn run(config: &Config) -> Result<()> {
    let node = ipc::node(config, "planner")?;
    let plan_sub = ipc::plan_subscriber(&node)?;
    let odom_sub = ipc::odom_subscriber(&node)?;
    let goal_sub = ipc::goal_subscriber(&node)?;
    let foliage_sub = ipc::foliage_subscriber(&node)?;
    let cmd_pub = ipc::cmd_vel_publisher(&node)?;
    let p = &config.planner;
    let mut planner = Planner::new(PlannerParams::from_config(config));
    tracing::info!(inflation = ?p.inflation, "topics open: {}", mimnav_shared::topics::CMD_VEL);
    let waitset = WaitSetBuilder::new()
        .signal_handling_mode(SignalHandlingMode::HandleTerminationRequests)
        .create::<Svc>()
        .map_err(|e| anyhow::anyhow!("cannot create the WaitSet: {e:?}"))?;
    let sd = Notifier::from_env();
    // a missed deadline on the map is stale input at once, not at the next tick
    let plan_guard = waitset
        .attach_deadline(
            plan_sub.listener(),
            Duration::from_secs_f64(p.map_max_age_s),
        )
        .map_err(|e| anyhow::anyhow!("cannot wait on map/plan: {e:?}"))?;
    let _tick = waitset
        .attach_interval(Duration::from_millis(100).min(sd.tick()))
        .map_err(|e| anyhow::anyhow!("cannot attach an interval: {e:?}"))?;
    let validity_ns = (config.robot.command_validity_s * 1e9) as u64;
    let map_max_age_ns = (p.map_max_age_s * 1e9) as u64;
    let odom_max_age_ns = (p.odom_max_age_s * 1e9) as u64;
    let goal_max_age_ns = (p.goal_max_age_s * 1e9) as u64;
    let mut faults = Faults::new(Duration::from_secs(5));
    let (mut odom, mut goal): (Option<Odometry>, Option<Goal>) = (None, None);
    let mut last_map_mono = 0u64;
    let mut classes = Vec::new();
    // the latest foliage verdict: its header and its obstacle returns
    let mut foliage: Option<(FoliageHeader, Vec<(f32, f32)>)> = None;
    let foliage_max_age_ns = (p.foliage_max_age_s * 1e9) as u64;
    let mut commander = Commander {
        publisher: cmd_pub,
        seq: 0,
        last_status: u8::MAX,
        validity_ns,
        flags: 0,
        stale: "",
        shown: (u8::MAX, 0, ""),
        sd,
        map_rx_mono_ns: 0,
        map_received_mono_ns: 0,
    };
    commander.sd.ready("waiting for map/plan");
    let result = ipc::run_waitset(&waitset, |id| {
        commander.sd.alive(Instant::now());
        let now = ipc::monotonic_ns();
        let _ = (odom_sub.heard(), goal_sub.heard(), plan_sub.heard());
        loop {
            match foliage_sub.receive() {
                Ok(Some(sample)) => {
                    let obstacles = sample
                        .payload()
                        .iter()
                        .filter(|r| r.class == foliage_class::OBSTACLE)
                        .map(|r| (r.angle_rad, r.range_m))
                        .collect();
                    foliage = Some((*sample.user_header(), obstacles));
                }
                Ok(None) => break,
                Err(e) => {
                    faults.record("receive_failed", Instant::now(), e);
                    break;
                }
            }
        }
        if let Ok(Some(o)) = odom_sub.latest() {
            odom = Some(o);
        }
        match goal_sub.latest() {
            Ok(Some(g)) => {
                tracing::info!(x = g.x, y = g.y, seq = g.seq, "new goal");
                goal = Some(g);
            }
            Ok(None) => {}
            Err(e) => {
                faults.record("receive_failed", Instant::now(), e);
            }
        }
        let mut planned = false;
        while let Ok(Some(sample)) = plan_sub.receive() {
            let h = *sample.user_header();
            last_map_mono = now;
            commander.map_received_mono_ns = ipc::monotonic_ns();
            commander.map_rx_mono_ns = h.rx_mono_ns;
            classes.clear();
            classes.extend(sample.payload().iter().map(|c| c.class));
            drop(sample);
            planned = true;
            let grid = GridSpec {
                cells: h.cells as usize,
                cell_m: h.cell_m,
            };
            if goal_max_age_ns > 0
                && goal.is_some_and(|g| now.saturating_sub(g.stamp_mono_ns) > goal_max_age_ns)
            {
                goal = None;
            }
            let Some(g) = goal else {
                commander.send(
                    0.0,
                    0.0,
                    command_status::NO_GOAL,
                    h.stamp_ns,
                    h.source_seq,
                    now,
                    &mut faults,
                );
                continue;
            };
            let Some(o) = odom.filter(|o| now.saturating_sub(o.rx_mono_ns) <= odom_max_age_ns)
            else {
                faults.record(
                    "stale_odom",
                    Instant::now(),
                    "odometry is missing or stale: stopping",
                );
                commander.stale = if odom.is_some() {
                    "odometry older than planner.odom_max_age_s"
                } else {
                    "no odometry"
                };
                commander.send(
                    0.0,
                    0.0,
                    command_status::STALE_INPUT,
                    h.stamp_ns,
                    h.source_seq,
                    now,
                    &mut faults,
                );
                continue;
            };
            // the goal in the robot frame
            let (s, c) = o.yaw.sin_cos();
            let (dx, dy) = (g.x - o.x, g.y - o.y);
            let (gx, gy) = (c * dx + s * dy, -s * dx + c * dy);
            if gx.hypot(gy) <= g.tolerance_m.max(0.01) {
                commander.send(
                    0.0,
                    0.0,
                    command_status::GOAL_REACHED,
                    h.stamp_ns,
                    h.source_seq,
                    now,
                    &mut faults,
                );
                continue;
            }
            // obstacles the foliage classifier confirms are solid (a trunk hidden in grass)
            commander.flags = 0;
            if p.use_foliage
                && let Some((fh, obstacles)) = &foliage
                && now.saturating_sub(fh.rx_mono_ns) <= foliage_max_age_ns
            {
                if fh.alarm != 0 {
                    commander.flags |= command_flags::FOLIAGE_ALARM;
                }
                confirm_obstacles(&mut classes, grid, obstacles.iter().copied());
            }
            match planner.plan(&classes, grid, f64::from(o.v), f64::from(o.omega), (gx, gy)) {
                DwaOutcome::Drive { v, omega, .. } => commander.send(
                    v,
                    omega,
                    command_status::DRIVING,
                    h.stamp_ns,
                    h.source_seq,
                    now,
                    &mut faults,
                ),
                DwaOutcome::Blocked => commander.send(
                    0.0,
                    0.0,
                    command_status::BLOCKED,
                    h.stamp_ns,
                    h.source_seq,
                    now,
                    &mut faults,
                ),
            }
        }
        if !planned
            && (id.has_missed_deadline(&plan_guard)
                || now.saturating_sub(last_map_mono) > map_max_age_ns)
        {
            // no map for too long: keep the robot stopped, and say why
            commander.stale = "no map on map/plan for planner.map_max_age_s";
            commander.send(
                0.0,
                0.0,
                command_status::STALE_INPUT,
                0,
                0,
                now,
                &mut faults,
            );
        }
        CallbackProgression::Continue
    });
    commander.sd.stopping("stopping");
    match result {
        Ok(r) => tracing::info!(
            commands = commander.seq,
            "stopping ({r:?}); faults: {}",
            faults.summary()
        ),
        Err(e) => anyhow::bail!("WaitSet failed: {e:?}"),
    }
    Ok(())
}
