//! `mimnav-mapper`: the map builder service.
//!
//! Wiring only: every revolution, with the latest `odom`, goes through the library's
//! [`MapStep`] — slice by slice from `lidar/slices` as it arrives, or whole from `lidar/points`
//! when no slices come or theirs broke off; its map goes out on `map/plan` (first: the planner
//! waits for it) and `map/layers`. The points topic has a deadline of `mapper.points_deadline_s`: a revolution
//! later than that is reported (rate-limited) as stale input; the loop goes on.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Result;
use mimnav_config::Config;
use mimnav_mapper::step::{MapStep, Mapped};
use mimnav_shared::hop::{HopLatency, record_drops};
use mimnav_shared::ipc::{self, Listening};
use mimnav_shared::service::{self, Health, Service, ServiceCli};
use mimnav_shared::topics::{self, PlanCell, map_status};

/// The map builder: lidar/points + odom → map/layers + map/plan.
#[derive(Debug, clap::Parser)]
#[command(name = "mimnav-mapper", version)]
struct Args {
    #[command(flatten)]
    service: mimnav_shared::cli::ServiceArgs,
}

impl ServiceCli for Args {
    fn service_args(&self) -> &mimnav_shared::cli::ServiceArgs {
        &self.service
    }
}

fn main() -> ExitCode {
    service::main("mimnav-mapper", |_args: Args, config: Config| {
        run(&config).map(|()| ExitCode::SUCCESS)
    })
}

fn run(config: &Config) -> Result<()> {
    let svc = Service::open(config, "mapper")?;
    let points = ipc::points_subscriber(svc.node())?;
    let slices = ipc::slices_subscriber(svc.node())?;
    let odom_sub = ipc::odom_subscriber(svc.node())?;
    let mut step = config.map_step();
    let (grid, n_layers) = (step.mapper().params().grid, step.mapper().layer_count());
    let layers_pub = ipc::layers_publisher(svc.node(), n_layers * grid.len())?;
    let plan_pub = ipc::plan_publisher(svc.node(), grid.len())?;
    tracing::info!(
        cells = grid.cells,
        cell_m = grid.cell_m,
        layers = n_layers,
        "topics open: {}, {}",
        topics::MAP_LAYERS,
        topics::MAP_PLAN
    );
    let deadline = Duration::from_secs_f64(config.mapper.points_deadline_s);
    let points_guard = svc.on_deadline(&points, deadline)?;
    let slices_guard = svc.on_data(&slices)?;
    let (odom_guard, _tick) = (svc.on_data(&odom_sub)?, svc.every(Duration::from_secs(10))?);
    let mut out = Output {
        plan_pub,
        layers_pub,
        len: n_layers * grid.len(),
        lat: HopLatency::new(),
        spent_us: 0,
        since_report: 0,
        dropped: 0,
    };
    let mut last_report = Instant::now();
    let mut health = svc.health();
    svc.run(&mut health, "waiting for lidar/points", |turn, h| {
        if turn.missed(&points_guard) {
            let what = format!(
                "stale input: no revolution on lidar/points for {:.1} s",
                deadline.as_secs_f64()
            );
            h.sd.status(&what);
            h.faults.record("stale_points", turn.now, what);
        }
        // only the listener that woke this turn has notifications to drain (each drain is a
        // system call; a turn comes per slice, some 27 a revolution): one that fired while
        // this turn ran wakes the next
        if turn.from(&slices_guard) {
            let _ = slices.heard();
        }
        if turn.from(&odom_guard) {
            let _ = odom_sub.heard();
        }
        if turn.from(&points_guard) {
            let _ = points.heard();
        }
        h.take_latest(&odom_sub, turn.now, "bad_odom", |o| step.odom(o));
        // the revolution binned slice by slice as it arrives (issue 27); mapped on its last
        loop {
            let sample = match slices.receive() {
                Ok(Some(s)) => s,
                Ok(None) => break,
                Err(e) => {
                    h.faults.record("receive_failed", turn.now, e);
                    break;
                }
            };
            let sh = *sample.user_header();
            if sh.last != 0 {
                // the odometry published before the revolution's last packet
                h.take_latest(&odom_sub, turn.now, "bad_odom", |o| step.odom(o));
            }
            let (started, now, broken) =
                (Instant::now(), ipc::monotonic_ns(), step.broken_slices());
            let mapped = step.slice(&sh, sample.payload(), now);
            drop(sample);
            if step.broken_slices() != broken {
                let what = format!(
                    "the slices of revolution {} broke off at slice {}: it is mapped from {} instead",
                    sh.revolution.seq,
                    sh.index,
                    topics::LIDAR_POINTS
                );
                h.faults.record("broken_slices", turn.now, what);
            }
            if let Some(mapped) = mapped {
                out.send(&step, mapped, sh.revolution.rx_mono_ns, (started, now), h, turn.now);
            }
        }
        // whole revolutions: mapped here when no slices came, or theirs broke off
        loop {
            let sample = match points.receive() {
                Ok(Some(s)) => s,
                Ok(None) => break,
                Err(e) => {
                    h.faults.record("receive_failed", turn.now, e);
                    break;
                }
            };
            let (started, now) = (Instant::now(), ipc::monotonic_ns());
            let rx = sample.user_header().rx_mono_ns;
            let mapped = step.revolution(sample.user_header(), sample.payload(), now);
            drop(sample);
            if let Some(mapped) = mapped {
                out.send(&step, mapped, rx, (started, now), h, turn.now);
            }
        }
        if last_report.elapsed() >= Duration::from_secs(10) && out.since_report > 0 {
            let mean_processing_us = out.spent_us / out.since_report;
            let (maps, faults, hop) = (step.maps(), h.faults.summary(), step.points_hop());
            tracing::info!(
                maps,
                mean_processing_us,
                dropped = hop.dropped(),
                from_slices = step.maps_from_slices(),
                broken_slices = step.broken_slices(),
                "mapping; {}: {}; faults: {faults}",
                topics::LIDAR_POINTS,
                hop.describe("revolutions")
            );
            (out.spent_us, out.since_report, last_report) = (0, 0, Instant::now());
            if let Some(line) = out.lat.take("revolution", "mapping", "map/plan sent") {
                tracing::info!("{line}");
            }
        }
    })?;
    let hop = step.points_hop();
    tracing::info!(
        maps = step.maps(),
        from_slices = step.maps_from_slices(),
        dropped = hop.dropped(),
        broken_slices = step.broken_slices(),
        "mapper stopped; {}: {}",
        topics::LIDAR_POINTS,
        hop.describe("revolutions")
    );
    Ok(())
}

/// The map's topics and what is measured of the maps sent.
struct Output {
    plan_pub: ipc::PlanPublisher,
    layers_pub: ipc::LayersPublisher,
    len: usize,
    /// Per hop (issue 27): the last packet to the mapping, the mapping, the last packet to
    /// map/plan sent.
    lat: HopLatency,
    spent_us: u64,
    since_report: u64,
    /// Revolutions dropped by the last map sent.
    dropped: u64,
}

impl Output {
    /// Sends a map (the plan first: the planner waits for it) of the revolution whose last
    /// packet arrived at `rx`, mapped from `started` (monotonic `now`).
    fn send(
        &mut self,
        step: &MapStep,
        mut mapped: Mapped,
        rx: u64,
        (started, now): (Instant, u64),
        h: &mut Health,
        at: Instant,
    ) {
        let lost = step.points_hop().dropped() - self.dropped;
        self.dropped = step.points_hop().dropped();
        let what = ("revolutions", topics::LIDAR_POINTS, "mapper");
        record_drops(&mut h.faults, "dropped_revolutions", at, lost, what);
        if mapped.header.status == map_status::ODOM_STALE {
            h.faults.record("stale_odom", at, mapped.describe());
        }
        let us = started.elapsed().as_micros().min(u128::from(u32::MAX)) as u32;
        mapped.header.processing_us = us;
        let (classes, cost) = (step.mapper().classes(), step.mapper().cost());
        // indexed, not iterated: the fill is vectorised (the planner waits for it)
        let n = classes.len().min(cost.len());
        let (classes, cost) = (&classes[..n], &cost[..n]);
        let plan = |i: usize| PlanCell {
            class: classes[i],
            cost: cost[i],
        };
        if let Err(e) = self.plan_pub.publish_from_fn(mapped.header, n, plan) {
            h.faults.record("publish_failed", at, e);
        }
        let plan_sent = ipc::monotonic_ns();
        let plan_sent_us = plan_sent.saturating_sub(rx) / 1000;
        self.lat.push(rx, now, u64::from(us), plan_sent);
        // the layers (the view's, a recording's, a snapshot's) only when someone reads them:
        // writing them takes a twentieth of the mapper's time in grass
        let mapper = step.mapper();
        if self.layers_pub.has_subscribers()
            && let Err(e) = self
                .layers_pub
                .publish_filled(mapped.header, self.len, |out| mapper.write_layers(out))
        {
            h.faults.record("publish_failed", at, e);
        }
        let (hd, s) = (&mapped.header, &mapped.stats);
        tracing::debug!(
            seq = hd.seq,
            source_seq = hd.source_seq,
            // from the revolution's last packet to here: the driver's publish and the wake-up
            waited_us = now.saturating_sub(rx) / 1000,
            processing_us = us,
            plan_sent_us,
            glass_detected = s.glass_detected,
            glass_memory = s.glass_memory,
            surface_found = s.surface_found,
            surface_memory = s.surface_memory,
            tall_memory = s.tall_memory,
            status = hd.status,
            "map"
        );
        (self.spent_us, self.since_report) = (self.spent_us + u64::from(us), self.since_report + 1);
        // sent only when it changes
        let dropped = step.points_hop().dropped();
        h.sd.status(&format!(
            "{}; {dropped} revolutions dropped",
            mapped.describe()
        ));
    }
}
