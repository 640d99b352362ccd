//! `mimnav-planner`: the planner service.
//!
//! Wiring only: `map/plan`, `odom`, `goal` and `foliage/alarm` go into the library's
//! [`Pilot`], whose decisions go out on `cmd_vel`. Every rule (input freshness, the goal in the
//! robot frame, foliage fusion, the fail-safe stops) is the pilot's; this file opens the topics,
//! reads the clock and logs. The map topic has a deadline of `planner.map_max_age_s` and the
//! loop a 100 ms tick, so a silent mapper stops the robot within that time and the stop is
//! repeated. The decision's status also goes to systemd (`STATUS=`).

use std::process::ExitCode;
use std::time::Duration;

use anyhow::Result;
use mimnav_config::Config;
use mimnav_planner::pilot::{Decision, Pilot};
use mimnav_shared::hop::{HopLatency, record_drops};
use mimnav_shared::ipc::{self, Listening, ValuePublisher};
use mimnav_shared::service::{self, Health, Service, ServiceCli};
use mimnav_shared::topics::{self, VelocityCommand};

/// The planner: map/plan + odom + goal + foliage/alarm → cmd_vel.
#[derive(Debug, clap::Parser)]
#[command(name = "mimnav-planner", version)]
struct Args {
    #[command(flatten)]
    service: mimnav_shared::cli::ServiceArgs,
}

impl ServiceCli for Args {
    fn service_args(&self) -> &mimnav_shared::cli::ServiceArgs {
        &self.service
    }
}

/// How often the counters are logged.
const STATS_INTERVAL: Duration = Duration::from_secs(10);

fn main() -> ExitCode {
    service::main("mimnav-planner", |_args: Args, config: Config| {
        run(&config).map(|()| ExitCode::SUCCESS)
    })
}

/// Sends the pilot's decisions, logging the per-revolution timing and status changes.
struct Sender {
    publisher: ValuePublisher<VelocityCommand>,
    last_status: u8,
    /// Per hop, for the periodic line: the revolution's last packet to the map's arrival here,
    /// the planning, and the last packet to the command sent (the stack's latency).
    latency: HopLatency,
}

impl Sender {
    /// Sends `d`; `map_times` (the revolution's last packet, the map's arrival; monotonic ns)
    /// for a decision planned on a map.
    fn send(
        &mut self,
        pilot: &mut Pilot,
        d: &Decision,
        map_times: Option<(u64, u64)>,
        h: &mut Health,
    ) {
        let sent = ipc::monotonic_ns(); // when it leaves: the stack's latency includes planning
        let cmd = pilot.command(d, sent);
        if let Err(e) = self.publisher.publish(cmd) {
            h.faults
                .record("publish_failed", std::time::Instant::now(), e);
        }
        if let Some((rx, arrived)) = map_times {
            let planning_us = sent.saturating_sub(arrived) / 1000;
            self.latency.push(rx, arrived, planning_us, sent);
            tracing::debug!(
                source_seq = d.source_seq,
                status = d.status,
                // from the revolution's last packet to this map's arrival here, and the planning
                waited_us = arrived.saturating_sub(rx) / 1000,
                processing_us = sent.saturating_sub(arrived) / 1000,
                "command"
            );
        }
        if d.status != self.last_status {
            tracing::info!(
                status = d.status,
                v = d.v,
                omega = d.omega,
                "command status changed"
            );
            self.last_status = d.status;
        }
        // sent only when it changes
        let dropped = pilot.map_hop().dropped();
        h.sd.status(&format!("{}; {dropped} maps dropped", d.describe()));
    }
}

fn run(config: &Config) -> Result<()> {
    let svc = Service::open(config, "planner")?;
    let (node, p) = (svc.node(), &config.planner);
    let plan_sub = ipc::plan_subscriber(node)?;
    let odom_sub = ipc::odom_subscriber(node)?;
    let goal_sub = ipc::goal_subscriber(node)?;
    let foliage_sub = ipc::foliage_subscriber(node)?;
    let mut sender = Sender {
        publisher: ipc::cmd_vel_publisher(node)?,
        last_status: u8::MAX,
        latency: HopLatency::new(),
    };
    let mut pilot = config.pilot();
    tracing::info!(inflation = ?p.inflation, "topics open: {}", topics::CMD_VEL);
    // a missed deadline on the map is stale input at once, not at the next tick
    let plan_guard = svc.on_deadline(&plan_sub, Duration::from_secs_f64(p.map_max_age_s))?;
    let _tick = svc.every(Duration::from_millis(100))?;
    let (mut health, mut last_report) = (svc.health(), std::time::Instant::now());
    svc.run(&mut health, "waiting for map/plan", |turn, h| {
        let _ = (odom_sub.heard(), goal_sub.heard(), plan_sub.heard());
        let now = ipc::monotonic_ns();
        loop {
            match foliage_sub.receive() {
                Ok(Some(s)) => pilot.foliage(s.user_header(), s.payload()),
                Ok(None) => break,
                Err(e) => {
                    h.faults.record("receive_failed", turn.now, e);
                    break;
                }
            }
        }
        h.take_latest(&odom_sub, turn.now, "bad_odom", |o| pilot.odom(o));
        h.take_latest(&goal_sub, turn.now, "bad_goal", |g| {
            let taken = pilot.goal(g);
            if taken.is_ok() && g.flags & topics::goal_flags::STOP != 0 {
                tracing::info!(
                    seq = g.seq,
                    "stop requested: zero velocity until a new goal"
                );
            } else if taken.is_ok() {
                tracing::info!(x = g.x, y = g.y, seq = g.seq, "new goal");
            }
            taken
        });
        let mut planned = false;
        while let Ok(Some(sample)) = plan_sub.receive() {
            let (header, arrived) = (*sample.user_header(), ipc::monotonic_ns());
            let dropped = pilot.map_hop().dropped();
            let d = pilot.on_map(&header, sample.payload().iter().map(|c| c.class), now);
            drop(sample);
            let lost = pilot.map_hop().dropped() - dropped;
            let what = ("maps", topics::MAP_PLAN, "planner");
            record_drops(&mut h.faults, "dropped_maps", turn.now, lost, what);
            planned = true;
            if let Some(stale) = d.stale {
                h.faults.record("stale_input", turn.now, stale.reason());
            }
            sender.send(&mut pilot, &d, Some((header.rx_mono_ns, arrived)), h);
        }
        if !planned && let Some(d) = pilot.on_silence(now, turn.missed(&plan_guard)) {
            // no map for too long: keep the robot stopped, and say why
            sender.send(&mut pilot, &d, None, h);
        }
        if last_report.elapsed() >= STATS_INTERVAL {
            let (hop, faults) = (pilot.map_hop(), h.faults.summary());
            tracing::info!(
                commands = pilot.commands(),
                dropped = hop.dropped(),
                "planning; {}: {}; faults: {faults}",
                topics::MAP_PLAN,
                hop.describe("maps")
            );
            if let Some(line) = sender.latency.take("map", "planning", "cmd_vel") {
                tracing::info!("{line}");
            }
            last_report = std::time::Instant::now();
        }
    })?;
    let hop = pilot.map_hop();
    tracing::info!(
        commands = pilot.commands(),
        dropped = hop.dropped(),
        "planner stopped; {}: {}",
        topics::MAP_PLAN,
        hop.describe("maps")
    );
    Ok(())
}
