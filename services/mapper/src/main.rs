//! `mimnav-mapper`: the map builder service.
//!
//! Wiring only: config → topics → a WaitSet loop that maps every revolution of `lidar/points`
//! with the latest `odom` and publishes `map/layers` and `map/plan`. A revolution later than
//! `mapper.points_deadline_s` is reported (rate-limited) as stale input; the loop goes on.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Result;
use clap::Parser;
use iceoryx2::prelude::*;
use mimnav_mapper::glass::Pose2;
use mimnav_mapper::{Mapper, MapperParams, Odom, OdomInput};
use mimnav_shared::cli::ServiceArgs;
use mimnav_shared::config::Config;
use mimnav_shared::faults::Faults;
use mimnav_shared::ipc::{self, Listening, Svc};
use mimnav_shared::systemd::Notifier;
use mimnav_shared::topics::{MapHeader, Odometry, PlanCell, map_status};

/// The map builder: lidar/points + odom → map/layers + map/plan.
#[derive(Debug, Parser)]
#[command(name = "mimnav-mapper", version)]
struct Args {
    #[command(flatten)]
    service: ServiceArgs,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let config = match args.service.load_or_exit("mimnav-mapper", &[]) {
        Ok(c) => c,
        Err(code) => return code,
    };
    mimnav_shared::logging::init(&config.log.level);
    // held until the service ends
    let _cpu_latency = mimnav_shared::realtime::apply(&config);
    mimnav_shared::cli::finish("mimnav-mapper", run(&config).map(|()| ExitCode::SUCCESS))
}

fn run(config: &Config) -> Result<()> {
    let node = ipc::node(config, "mapper")?;
    let points = ipc::points_subscriber(&node)?;
    let odom_sub = ipc::odom_subscriber(&node)?;
    let params = MapperParams::from_config(config);
    let grid = params.grid;
    let n_layers = params.layers.len();
    let layers_pub = ipc::layers_publisher(&node, n_layers * grid.len())?;
    let plan_pub = ipc::plan_publisher(&node, grid.len())?;
    let mut mapper = Mapper::new(params);
    let mut sd = Notifier::from_env();
    tracing::info!(
        cells = grid.cells,
        cell_m = grid.cell_m,
        layers = n_layers,
        "topics open: {}, {}",
        mimnav_shared::topics::MAP_LAYERS,
        mimnav_shared::topics::MAP_PLAN
    );
    let waitset = WaitSetBuilder::new()
        .signal_handling_mode(SignalHandlingMode::HandleTerminationRequests)
        .create::<Svc>()
        .map_err(|e| anyhow::anyhow!("cannot create the WaitSet: {e:?}"))?;
    let deadline = Duration::from_secs_f64(config.mapper.points_deadline_s);
    let points_guard = waitset
        .attach_deadline(points.listener(), deadline)
        .map_err(|e| anyhow::anyhow!("cannot wait on lidar/points: {e:?}"))?;
    let _odom_guard = waitset
        .attach_notification(odom_sub.listener())
        .map_err(|e| anyhow::anyhow!("cannot wait on odom: {e:?}"))?;
    let _tick = waitset
        .attach_interval(sd.tick())
        .map_err(|e| anyhow::anyhow!("cannot attach an interval: {e:?}"))?;
    let mut faults = Faults::new(Duration::from_secs(10));
    let mut latest_odom: Option<Odometry> = None;
    let odom_max_age_ns = (config.mapper.odom_max_age_s * 1e9) as u64;
    let mut seq = 0u64;
    let mut spent_us = 0u64;
    let mut since_report = 0u64;
    let mut last_report = Instant::now();
    sd.ready("waiting for lidar/points");
    let result = ipc::run_waitset(&waitset, |id| {
        sd.alive(Instant::now());
        if id.has_missed_deadline(&points_guard) {
            sd.status(&format!(
                "stale input: no revolution on lidar/points for {:.1} s",
                deadline.as_secs_f64()
            ));
            faults.record(
                "stale_points",
                Instant::now(),
                format_args!(
                    "no revolution on lidar/points for {:.1} s",
                    deadline.as_secs_f64()
                ),
            );
        }
        let _ = odom_sub.heard();
        match odom_sub.latest() {
            Ok(Some(o)) => latest_odom = Some(o),
            Ok(None) => {}
            Err(e) => {
                faults.record("receive_failed", Instant::now(), e);
            }
        }
        let _ = points.heard();
        loop {
            let sample = match points.receive() {
                Ok(Some(s)) => s,
                Ok(None) => break,
                Err(e) => {
                    faults.record("receive_failed", Instant::now(), e);
                    break;
                }
            };
            let started = Instant::now();
            let h = *sample.user_header();
            let now_mono = ipc::monotonic_ns();
            // from the revolution's last packet to here: the driver's publish and this wake-up
            let waited_us = now_mono.saturating_sub(h.rx_mono_ns) / 1000;
            let (odom, status) = match latest_odom {
                None => (OdomInput::Missing, map_status::ODOM_MISSING),
                Some(o) if now_mono.saturating_sub(o.rx_mono_ns) > odom_max_age_ns => {
                    (OdomInput::Stale, map_status::ODOM_STALE)
                }
                Some(o) => (
                    OdomInput::Fresh(Odom {
                        pose: Pose2 {
                            x: o.x,
                            y: o.y,
                            yaw: o.yaw,
                        },
                        v: f64::from(o.v),
                        omega: f64::from(o.omega),
                    }),
                    0,
                ),
            };
            if status == map_status::ODOM_STALE {
                faults.record(
                    "stale_odom",
                    Instant::now(),
                    "odometry is stale: the glass memory is not moved",
                );
            }
            let stats = mapper.update(sample.payload(), odom, h.stamp_ns);
            drop(sample);
            let o = latest_odom.unwrap_or_default();
            let processing_us = started.elapsed().as_micros().min(u128::from(u32::MAX)) as u32;
            let header = MapHeader {
                seq,
                source_seq: h.seq,
                stamp_ns: h.stamp_ns,
                rx_mono_ns: h.rx_mono_ns,
                odom_seq: o.seq,
                odom_stamp_ns: o.stamp_ns,
                x: o.x,
                y: o.y,
                yaw: o.yaw,
                cells: grid.cells as u32,
                cell_m: grid.cell_m,
                layers: n_layers as u32,
                processing_us,
                status,
                reserved: [0; 7],
            };
            // the plan first, written straight into shared memory: the planner waits for it;
            // the layers (for pictures and diagnostics) after
            let (classes, cost) = (mapper.classes(), mapper.cost());
            let plan = classes
                .iter()
                .zip(cost)
                .map(|(&class, &cost)| PlanCell { class, cost });
            if let Err(e) = plan_pub.publish_from_iter(header, classes.len(), plan) {
                faults.record("publish_failed", Instant::now(), e);
            }
            let plan_sent_us = ipc::monotonic_ns().saturating_sub(h.rx_mono_ns) / 1000;
            let len = n_layers * grid.len();
            if let Err(e) = layers_pub.publish_from_iter(header, len, mapper.layers()) {
                faults.record("publish_failed", Instant::now(), e);
            }
            tracing::debug!(
                seq,
                source_seq = h.seq,
                waited_us,
                processing_us,
                plan_sent_us,
                glass_detected = stats.glass_detected,
                glass_memory = stats.glass_memory,
                surface_found = stats.surface_found,
                surface_memory = stats.surface_memory,
                tall_memory = stats.tall_memory,
                status,
                "map"
            );
            seq += 1;
            spent_us += u64::from(processing_us);
            since_report += 1;
            // sent only when it changes (after a stale-input line, too)
            sd.status(match status {
                map_status::ODOM_MISSING => "mapping; no odometry (the glass memory stays put)",
                map_status::ODOM_STALE => "mapping; stale odometry (the glass memory stays put)",
                _ => "mapping",
            });
        }
        if last_report.elapsed() >= Duration::from_secs(10) && since_report > 0 {
            tracing::info!(
                maps = seq,
                mean_processing_us = spent_us / since_report,
                "mapping; faults: {}",
                faults.summary()
            );
            spent_us = 0;
            since_report = 0;
            last_report = Instant::now();
        }
        CallbackProgression::Continue
    });
    sd.stopping("stopping");
    match result {
        Ok(r) => tracing::info!(maps = seq, "stopping ({r:?}); faults: {}", faults.summary()),
        Err(e) => anyhow::bail!("WaitSet failed: {e:?}"),
    }
    Ok(())
}
