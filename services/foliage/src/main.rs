//! `mimnav-foliage`: the foliage classifier service.
//!
//! Wiring only: every planar scan on `lidar/scan2d` (one laser of each VLP-16 revolution, chosen
//! by `velodyne.scan_laser` and `velodyne.scan_return`) goes through the classifier
//! (`mimnav_foliage`), and its verdict — the alarm flag, the nearest obstacle per sector and the
//! class of every return — goes out on `foliage/alarm`, naming the scan's sequence number. The
//! alarm's rising and falling edges are logged; processing time every 10 s. SIGTERM or SIGINT
//! ends the loop cleanly.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Result;
use clap::Parser;
use iceoryx2::prelude::*;
use mimnav_foliage::{Classifier, FoliageParams, Motion};
use mimnav_shared::cli::ServiceArgs;
use mimnav_shared::config::Config;
use mimnav_shared::faults::Faults;
use mimnav_shared::ipc::{self, Listening, Svc};
use mimnav_shared::systemd::Notifier;
use mimnav_shared::topics::{FoliageHeader, FoliageReturn, MAX_FOLIAGE_SECTORS};
use mimnav_velodyne::revolution::{AssemblerConfig, max_scan_len};

/// The foliage classifier: lidar/scan2d → foliage/alarm.
#[derive(Debug, Parser)]
#[command(name = "mimnav-foliage", version)]
struct Args {
    #[command(flatten)]
    service: ServiceArgs,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let config = match args.service.load_or_exit("mimnav-foliage", &[]) {
        Ok(c) => c,
        Err(code) => return code,
    };
    mimnav_shared::logging::init(&config.log.level);
    // held until the service ends
    let _cpu_latency = mimnav_shared::realtime::apply(&config);
    mimnav_shared::cli::finish("mimnav-foliage", run(&config).map(|()| ExitCode::SUCCESS))
}

fn run(config: &Config) -> Result<()> {
    let params = FoliageParams::from_config(&config.foliage);
    let mut classifier = Classifier::new(params).map_err(|e| anyhow::anyhow!("[foliage]: {e}"))?;
    anyhow::ensure!(
        params.n_sectors() <= MAX_FOLIAGE_SECTORS,
        "[foliage]: sector_deg = {} gives {} sectors, more than the {MAX_FOLIAGE_SECTORS} foliage/alarm carries",
        config.foliage.sector_deg,
        params.n_sectors()
    );
    let node = ipc::node(config, "foliage")?;
    let scans = ipc::scan_subscriber(&node)?;
    // the sensor's motion between scans, for the carried scans (interpretation 17); optional
    let odom_sub = ipc::odom_subscriber(&node)?;
    let odom_max_age_ns = (config.foliage.odom_max_age_s * 1e9) as u64;
    // as long as the driver's longest scan
    let asm = AssemblerConfig::from_config(config);
    let max_returns = max_scan_len(config.velodyne.rpm, asm.max_duration_ns as f64 * 1e-9);
    let alarms = ipc::foliage_publisher(&node, max_returns)?;
    tracing::info!(
        windows = params.n_windows(),
        sectors = params.n_sectors(),
        "topics open: {}",
        mimnav_shared::topics::FOLIAGE_ALARM
    );
    let waitset = WaitSetBuilder::new()
        .signal_handling_mode(SignalHandlingMode::HandleTerminationRequests)
        .create::<Svc>()
        .map_err(|e| anyhow::anyhow!("cannot create the WaitSet: {e:?}"))?;
    let _scan_guard = waitset
        .attach_notification(scans.listener())
        .map_err(|e| anyhow::anyhow!("cannot wait on lidar/scan2d: {e:?}"))?;
    let mut sd = Notifier::from_env();
    let _tick = waitset
        .attach_interval(sd.tick())
        .map_err(|e| anyhow::anyhow!("cannot attach an interval: {e:?}"))?;
    let mut faults = Faults::new(Duration::from_secs(10));
    let (mut angles, mut ranges) = (Vec::new(), Vec::new());
    let mut out: Vec<FoliageReturn> = Vec::with_capacity(max_returns);
    let (mut seq, mut alarm_on, mut alarmed) = (0u64, false, 0u64);
    let (mut spent_us, mut since_report) = (0u64, 0u64);
    let mut last_scan = Instant::now();
    let mut latest_odom: Option<mimnav_shared::topics::Odometry> = None;
    // the odometry pose at the previous scan, when it was fresh
    let mut last_pose: Option<[f64; 3]> = None;
    let mut told_no_odom = false;
    sd.ready("waiting for lidar/scan2d");
    let result = ipc::run_waitset(&waitset, |_id| {
        let now = Instant::now();
        sd.alive(now);
        let _ = odom_sub.heard();
        match odom_sub.latest() {
            Ok(Some(o)) => latest_odom = Some(o),
            Ok(None) => {}
            Err(e) => {
                faults.record("receive_failed", Instant::now(), e);
            }
        }
        let _ = scans.heard();
        loop {
            let sample = match scans.receive() {
                Ok(Some(s)) => s,
                Ok(None) => break,
                Err(e) => {
                    faults.record("receive_failed", Instant::now(), e);
                    break;
                }
            };
            let started = Instant::now();
            last_scan = started;
            let h = *sample.user_header();
            angles.clear();
            ranges.clear();
            for r in sample.payload() {
                angles.push(r.angle_rad);
                ranges.push(r.range_m);
            }
            drop(sample);
            let pose = match latest_odom {
                _ if params.carry_scans == 0 => None,
                None => {
                    if !told_no_odom {
                        told_no_odom = true;
                        tracing::info!(
                            "no odometry on {} yet: earlier scans are not carried (foliage.carry_scans)",
                            mimnav_shared::topics::ODOM
                        );
                    }
                    None
                }
                Some(o) if ipc::monotonic_ns().saturating_sub(o.rx_mono_ns) > odom_max_age_ns => {
                    faults.record(
                        "stale_odom",
                        Instant::now(),
                        "odometry is stale: earlier scans are not carried",
                    );
                    None
                }
                Some(o) => Some([o.x, o.y, o.yaw]),
            };
            let motion = last_pose
                .zip(pose)
                .map(|(from, to)| Motion::between(from, to));
            last_pose = pose;
            let verdict = classifier.classify_moved(&angles, &ranges, motion);
            out.clear();
            out.extend(angles.iter().zip(&ranges).zip(verdict.classes).map(
                |((&angle_rad, &range_m), &class)| FoliageReturn {
                    angle_rad,
                    range_m,
                    class,
                    reserved: [0; 3],
                },
            ));
            let mut header = FoliageHeader {
                seq,
                source_seq: h.seq,
                stamp_ns: h.stamp_ns,
                rx_mono_ns: h.rx_mono_ns,
                count: out.len() as u32,
                sectors: verdict.nearest_per_sector.len().min(MAX_FOLIAGE_SECTORS) as u32,
                obstacles: verdict.obstacle_count as u32,
                processing_us: 0,
                alarm: u8::from(verdict.alarm),
                laser_id: h.laser_id,
                ..FoliageHeader::default()
            };
            for (slot, &r) in header.nearest_m.iter_mut().zip(verdict.nearest_per_sector) {
                *slot = r;
            }
            if verdict.alarm != alarm_on {
                alarm_on = verdict.alarm;
                tracing::info!(
                    alarm = alarm_on,
                    scan = h.seq,
                    obstacles = verdict.obstacle_count,
                    "foliage alarm changed"
                );
            }
            alarmed += u64::from(verdict.alarm);
            let us = started.elapsed().as_micros().min(u128::from(u32::MAX)) as u32;
            header.processing_us = us;
            if let Err(e) = alarms.publish(header, &out) {
                faults.record("publish_failed", Instant::now(), e);
            }
            seq += 1;
            spent_us += u64::from(us);
            since_report += 1;
            sd.status(if alarm_on {
                "classifying; alarm: an obstacle that is not foliage"
            } else {
                "classifying; no alarm"
            });
        }
        sd.silent(
            now,
            last_scan,
            Duration::from_secs(1),
            "no scan on lidar/scan2d",
        );
        if since_report > 0 && seq % 100 < since_report {
            tracing::debug!(
                scans = seq,
                alarmed,
                mean_us = spent_us / since_report.max(1),
                "classifier time per scan"
            );
            spent_us = 0;
            since_report = 0;
        }
        CallbackProgression::Continue
    });
    sd.stopping("stopping");
    match result {
        Ok(r) => tracing::info!(
            scans = seq,
            alarmed,
            "stopping ({r:?}); faults: {}",
            faults.summary()
        ),
        Err(e) => anyhow::bail!("WaitSet failed: {e:?}"),
    }
    Ok(())
}
