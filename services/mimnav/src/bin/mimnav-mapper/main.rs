//! `mimnav-mapper`: the map builder service.
//!
//! Wiring only: every revolution of `lidar/points`, with the latest `odom`, goes through the
//! library's [`MapStep`]; its map goes out on `map/plan` (first: the planner waits for it) and
//! `map/layers`. The points topic has a deadline of `mapper.points_deadline_s`: a revolution
//! later than that is reported (rate-limited) as stale input; the loop goes on.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Result;
use mimnav_config::Config;
use mimnav_shared::hop::{HopLatency, record_drops};
use mimnav_shared::ipc::{self, Listening};
use mimnav_shared::service::{self, Service, ServiceCli};
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
    let (_odom_guard, _tick) = (svc.on_data(&odom_sub)?, svc.every(Duration::from_secs(10))?);
    let (mut spent_us, mut since_report, mut last_report) = (0u64, 0u64, Instant::now());
    // per hop (issue 27): the last packet to here, the mapping, the last packet to map/plan sent
    let mut lat = HopLatency::new();
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
        let _ = (odom_sub.heard(), points.heard());
        h.take_latest(&odom_sub, turn.now, "bad_odom", |o| step.odom(o));
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
            let (rx, dropped) = (sample.user_header().rx_mono_ns, step.points_hop().dropped());
            let mut mapped = step.revolution(sample.user_header(), sample.payload(), now);
            drop(sample);
            let lost = step.points_hop().dropped() - dropped;
            let what = ("revolutions", topics::LIDAR_POINTS, "mapper");
            record_drops(&mut h.faults, "dropped_revolutions", turn.now, lost, what);
            if mapped.header.status == map_status::ODOM_STALE {
                h.faults.record("stale_odom", turn.now, mapped.describe());
            }
            let us = started.elapsed().as_micros().min(u128::from(u32::MAX)) as u32;
            mapped.header.processing_us = us;
            let (classes, cost) = (step.mapper().classes(), step.mapper().cost());
            let plan = (classes.iter().zip(cost)).map(|(&class, &cost)| PlanCell { class, cost });
            if let Err(e) = plan_pub.publish_from_iter(mapped.header, classes.len(), plan) {
                h.faults.record("publish_failed", turn.now, e);
            }
            let plan_sent = ipc::monotonic_ns();
            let plan_sent_us = plan_sent.saturating_sub(rx) / 1000;
            lat.push(rx, now, u64::from(us), plan_sent);
            let len = n_layers * grid.len();
            let layers = step.mapper().layers();
            if let Err(e) = layers_pub.publish_from_iter(mapped.header, len, layers) {
                h.faults.record("publish_failed", turn.now, e);
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
            (spent_us, since_report) = (spent_us + u64::from(us), since_report + 1);
            // sent only when it changes
            let dropped = step.points_hop().dropped();
            h.sd.status(&format!(
                "{}; {dropped} revolutions dropped",
                mapped.describe()
            ));
        }
        if last_report.elapsed() >= Duration::from_secs(10) && since_report > 0 {
            let mean_processing_us = spent_us / since_report;
            let (maps, faults, hop) = (step.maps(), h.faults.summary(), step.points_hop());
            tracing::info!(
                maps,
                mean_processing_us,
                dropped = hop.dropped(),
                "mapping; {}: {}; faults: {faults}",
                topics::LIDAR_POINTS,
                hop.describe("revolutions")
            );
            (spent_us, since_report, last_report) = (0, 0, Instant::now());
            if let Some(line) = lat.take("revolution", "mapping", "map/plan sent") {
                tracing::info!("{line}");
            }
        }
    })?;
    let hop = step.points_hop();
    tracing::info!(
        maps = step.maps(),
        dropped = hop.dropped(),
        "mapper stopped; {}: {}",
        topics::LIDAR_POINTS,
        hop.describe("revolutions")
    );
    Ok(())
}
