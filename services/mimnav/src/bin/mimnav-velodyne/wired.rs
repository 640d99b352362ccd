//! The driver wired to its topics, and the replay of a capture (part of the `mimnav-velodyne`
//! binary, not of the library).

use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use mimnav_config::Config;
use mimnav_shared::config::seconds_ns;
use mimnav_shared::ipc::{self, PointsPublisher, ScanPublisher, SlicesPublisher, ValuePublisher};
use mimnav_shared::service::{Health, Service};
use mimnav_shared::topics::RawPacket;
use mimnav_velodyne::driver::{Driver, Kind};
use mimnav_velodyne::replay::{Next, Replay};

/// The driver and the topics it publishes on (`lidar/scan2d` only when the foliage classifier
/// reads the VLP-16: `foliage.source = "velodyne"`; `lidar/slices` of so many packets unless
/// `velodyne.slice_packets` is 0).
pub struct Wired(
    pub Driver,
    pub PointsPublisher,
    pub Option<ScanPublisher>,
    pub Option<ValuePublisher<RawPacket>>,
    pub Option<(SlicesPublisher, u32)>,
);

impl Wired {
    /// One datagram through the driver, which waited `waited_ns` in the kernel before it was
    /// read; the revolution it finishes is published. With `bytes` empty: the partial
    /// revolution at the end of a capture.
    pub fn push(
        &mut self,
        bytes: &[u8],
        (kind, waited_ns): (Kind, u64),
        host_ns: u64,
        h: &mut Health,
        source: &dyn Fn() -> String,
    ) {
        // received when it arrived: the revolution's latency counts from there
        let (now, mono) = (
            Instant::now(),
            ipc::monotonic_ns().saturating_sub(waited_ns),
        );
        let Wired(driver, points, scan, packets, slices) = self;
        if let Some(raw) = packets
            .as_ref()
            .zip(driver.raw_packet(bytes, kind, (host_ns, mono)))
            && let Err(e) = raw.0.publish(raw.1)
        {
            h.faults.record("publish_failed", now, e);
        }
        let rev = match bytes.is_empty() {
            true => driver.finish(),
            false => driver.on_datagram(bytes, kind, (host_ns, mono), now, &mut h.faults, source),
        };
        let completed = rev.is_some();
        // the slices first: the mapper maps the revolution from them before lidar/points
        if let Some((slices, packets)) = slices {
            driver.take_slices(*packets, |header, points| {
                if let Err(e) = slices.publish(*header, points) {
                    h.faults.record("publish_failed", now, e);
                }
            });
        }
        if completed {
            let rev = driver.revolution();
            let sent = (points.publish(rev.header, &rev.points)).and(
                scan.as_ref()
                    .map_or(Ok(0), |s| s.publish(rev.scan_header, &rev.scan)),
            );
            if let Err(e) = sent {
                h.faults.record("publish_failed", now, e);
            }
        }
    }
}

/// Replays `velodyne.pcap` at its pace (or as fast as it goes), looped if asked.
pub fn replay(
    config: &Config,
    svc: &Service,
    wired: &mut Wired,
    h: &mut Health,
    interval: Duration,
) -> Result<()> {
    let v = &config.velodyne;
    let path = v.pcap.clone().context("velodyne.pcap is not set")?;
    let speed = (!v.replay_fast).then_some(v.replay_speed);
    let mut replay = Replay::open(&path, speed, seconds_ns(v.replay_max_gap_s), v.replay_loop)?;
    // READY=1 once: it resets the manager's ping clock without a WATCHDOG=1, so sending it on
    // every pass of a looped replay let the watchdog kill the driver
    h.sd.ready(&format!("replaying {}", path.display()));
    let (mut outcome, mut in_pass) = (Ok(()), 0u64);
    let stopped = loop {
        // every turn pings when a ping is due, whatever the turn does (a pass that ends, a
        // capture reopened for the next pass, a datagram due at once)
        h.sd.alive(Instant::now());
        let next = match replay.next(Instant::now()) {
            Ok(next) => next,
            Err(e) => {
                outcome = Err(anyhow::Error::new(e).context("replay ended early"));
                break false;
            }
        };
        match next {
            Next::Datagram(d, due) => {
                in_pass += 1;
                if !svc.sleep_until(h, due) {
                    break true;
                }
                let kind = wired.0.kind(d.payload.len(), d.dst_port);
                let at = || format!("{} byte offset {}", path.display(), d.offset);
                wired.push(d.payload, (kind, 0), d.ts_ns, h, &at);
                if let Some(status) =
                    wired
                        .0
                        .report_if_due(Instant::now(), interval, &h.faults, || None)
                {
                    h.sd.status(&status);
                }
            }
            // a looped capture without a single datagram would spin here for ever
            Next::PassEnded if in_pass == 0 => {
                outcome = Err(anyhow::anyhow!(
                    "{} holds no UDP datagram to replay",
                    path.display()
                ));
                break false;
            }
            // the partial revolution at the end of the capture
            Next::PassEnded => {
                in_pass = 0;
                wired.push(&[], (Kind::Data, 0), 0, h, &String::new);
            }
            Next::Finished => break false,
        }
        if !ipc::sleep(svc.node(), Duration::ZERO) {
            break true;
        }
    };
    wired.push(&[], (Kind::Data, 0), 0, h, &String::new);
    let what = if stopped {
        "replay stopped by signal"
    } else {
        "replay finished"
    };
    h.sd.stopping(what);
    wired.0.log_summary(what, &h.faults);
    wired.1.end_of_stream()?;
    if let Some((slices, _)) = &wired.4 {
        slices.end_of_stream()?;
    }
    if let Some(scan) = &wired.2 {
        scan.end_of_stream()?;
    }
    if !stopped && v.replay_linger_s > 0.0 {
        // let subscribers take the last samples before the publisher goes away
        svc.sleep_until(
            h,
            Instant::now() + Duration::from_secs_f64(v.replay_linger_s),
        );
    }
    outcome
}
