//! `mimnav-foliage`: the foliage classifier service.
//!
//! Wiring only: every planar scan on `lidar/scan2d` (one laser of each VLP-16 revolution, chosen
//! by `velodyne.scan_laser` and `velodyne.scan_return`), with the latest `odom`, goes through the
//! library's [`ScanStep`]; its verdict — the alarm flag, the nearest obstacle per sector and the
//! class of every return — goes out on `foliage/alarm`, naming the scan's sequence number. The
//! alarm's rising and falling edges are logged; processing time every 100 scans at debug level.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Result;
use mimnav_config::Config;
use mimnav_foliage::step::OdomUse;
use mimnav_shared::hop::{HopLatency, record_drops};
use mimnav_shared::ipc::{self, Listening};
use mimnav_shared::service::{self, Service, ServiceCli};
use mimnav_shared::topics;

/// The foliage classifier: lidar/scan2d (+ odom) → foliage/alarm.
#[derive(Debug, clap::Parser)]
#[command(name = "mimnav-foliage", version)]
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
    service::main("mimnav-foliage", |_args: Args, config: Config| {
        run(&config).map(|()| ExitCode::SUCCESS)
    })
}

fn run(config: &Config) -> Result<()> {
    let mut step = config.scan_step()?;
    let svc = Service::open(config, "foliage")?;
    let scans = ipc::scan_subscriber(svc.node())?;
    // the sensor's motion between scans, for the carried scans (interpretation 17); optional
    let odom_sub = ipc::odom_subscriber(svc.node())?;
    // as long as the driver's longest scan (the VLP-16's or the SICK's, by foliage.source)
    let max_returns = config.scan_capacity();
    let alarms = ipc::foliage_publisher(svc.node(), max_returns)?;
    let p = step.params();
    tracing::info!(
        windows = p.n_windows(),
        sectors = p.n_sectors(),
        "topics open: {}",
        topics::FOLIAGE_ALARM
    );
    let (_scan_guard, _tick) = (svc.on_data(&scans)?, svc.every(Duration::from_secs(1))?);
    let (mut alarm_on, mut alarmed, mut told_no_odom) = (false, 0u64, false);
    let (mut spent_us, mut since_report, mut last_scan) = (0u64, 0u64, Instant::now());
    let (mut health, mut last_report) = (svc.health(), Instant::now());
    // per hop (issue 27): the last packet to here, the classifying, the last packet to the alarm
    let mut lat = HopLatency::new();
    svc.run(&mut health, "waiting for lidar/scan2d", |turn, h| {
        let _ = (odom_sub.heard(), scans.heard());
        h.take_latest(&odom_sub, turn.now, "bad_odom", |o| step.odom(o));
        loop {
            let sample = match scans.receive() {
                Ok(Some(s)) => s,
                Ok(None) => break,
                Err(e) => {
                    h.faults.record("receive_failed", turn.now, e);
                    break;
                }
            };
            let (started, now) = (Instant::now(), ipc::monotonic_ns());
            let dropped = step.scan_hop().dropped();
            last_scan = started;
            let mut c = step.scan(sample.user_header(), sample.payload(), now);
            drop(sample);
            match c.odometry {
                OdomUse::Missing if !told_no_odom => {
                    told_no_odom = true;
                    let odom = topics::ODOM;
                    tracing::info!("no odometry on {odom} yet: earlier scans are not carried");
                }
                OdomUse::Stale => {
                    _ = h.faults.record(
                        "stale_odom",
                        turn.now,
                        "odometry is stale: earlier scans are not carried",
                    )
                }
                _ => {}
            }
            let hd = &mut c.header;
            if (hd.alarm != 0) != alarm_on {
                alarm_on = hd.alarm != 0;
                let (scan, obstacles) = (hd.source_seq, hd.obstacles);
                tracing::info!(alarm = alarm_on, scan, obstacles, "foliage alarm changed");
            }
            alarmed += u64::from(hd.alarm);
            let us = started.elapsed().as_micros().min(u128::from(u32::MAX)) as u32;
            hd.processing_us = us;
            let rx = c.header.rx_mono_ns;
            if let Err(e) = alarms.publish(c.header, c.returns) {
                h.faults.record("publish_failed", turn.now, e);
            }
            if rx > 0 {
                lat.push(rx, now, u64::from(us), ipc::monotonic_ns());
            }
            (spent_us, since_report) = (spent_us + u64::from(us), since_report + 1);
            let lost = step.scan_hop().dropped() - dropped;
            let what = ("scans", topics::LIDAR_SCAN2D, "classifier");
            record_drops(&mut h.faults, "dropped_scans", turn.now, lost, what);
            let dropped = step.scan_hop().dropped();
            h.sd.status(&match alarm_on {
                true => format!(
                    "classifying; alarm: an obstacle that is not foliage; {dropped} scans dropped"
                ),
                false => format!("classifying; no alarm; {dropped} scans dropped"),
            });
        }
        h.sd.silent(
            turn.now,
            last_scan,
            Duration::from_secs(1),
            "no scan on lidar/scan2d",
        );
        if last_report.elapsed() >= STATS_INTERVAL {
            let (hop, faults) = (step.scan_hop(), h.faults.summary());
            tracing::info!(
                scans = step.scans(),
                alarmed,
                dropped = hop.dropped(),
                "classifying; {}: {}; faults: {faults}",
                topics::LIDAR_SCAN2D,
                hop.describe("scans")
            );
            last_report = Instant::now();
            if let Some(line) = lat.take("scan", "classifying", "foliage/alarm sent") {
                tracing::info!("{line}");
            }
        }
        if since_report >= 100 {
            let (scans, mean_us) = (step.scans(), spent_us / since_report);
            tracing::debug!(scans, alarmed, mean_us, "classifier time per scan");
            (spent_us, since_report) = (0, 0);
        }
    })?;
    let hop = step.scan_hop();
    tracing::info!(
        scans = step.scans(),
        alarmed,
        dropped = hop.dropped(),
        "foliage classifier stopped; {}: {}",
        topics::LIDAR_SCAN2D,
        hop.describe("scans")
    );
    Ok(())
}
