//! `mimnav-sick`: a SICK planar ladar (LMS1xx, LMS5xx, TiM5xx/7xx) over CoLa on TCP.
//!
//! Wiring only. The library's [`Link`] runs on a thread of its own (its socket blocks): it
//! connects to `sick.host:sick.port`, logs in, configures the scan, starts the stream, turns
//! every `LMDscandata` into returns in REP-103 with `sick.mount` applied, and reconnects with
//! back-off. Its events come to this loop through a channel, with a byte on a socket pair to
//! wake the WaitSet: scans go out on `lidar/scan2d` for the foliage classifier; damaged
//! telegrams and link failures are counted and logged at a limited rate; the link's state and
//! the device's own status are in the log and in `STATUS=`.
//!
//! It runs only with `foliage.source = "sick"`: otherwise the VLP-16's driver publishes
//! `lidar/scan2d`, and two sources on one topic would interleave.

use std::io::{Read, Write};
use std::os::fd::AsRawFd;
use std::os::unix::net::UnixStream;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{self, TrySendError};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use mimnav_config::Config;
use mimnav_foliage::ScanSource;
use mimnav_shared::ipc;
use mimnav_shared::service::{self, Service, ServiceCli, SocketFd};
use mimnav_shared::topics::{self, ScanHeader, ScanReturn};
use mimnav_sick::link::{Link, LinkEvent};

/// The SICK ladar: CoLa over TCP → lidar/scan2d.
#[derive(Debug, clap::Parser)]
#[command(name = "mimnav-sick", version)]
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
/// Events (scans, faults) waiting for the loop; more are dropped and counted rather than
/// queued without bound (a burst of damaged telegrams is a few dozen).
const QUEUE: usize = 64;

/// What the link thread hands the loop.
enum Msg {
    Scan(ScanHeader, Vec<ScanReturn>),
    Connected(String),
    Streaming,
    Down(String, Duration),
    DeviceStatus(Option<String>),
    Fault(&'static str, String),
}

fn main() -> ExitCode {
    service::main("mimnav-sick", |_args: Args, config: Config| {
        run(&config).map(|()| ExitCode::SUCCESS)
    })
}

fn run(config: &Config) -> Result<()> {
    anyhow::ensure!(
        config.foliage.source == ScanSource::Sick,
        "foliage.source = \"velodyne\": the VLP-16's driver publishes lidar/scan2d; set \
         foliage.source = \"sick\" to classify the SICK's scans (see docs/sick.md)"
    );
    let s = &config.sick;
    let svc = Service::open(config, "sick")?;
    let scans = ipc::scan_publisher(svc.node(), s.max_returns())?;
    let (mode_hz, step_deg) = s.mode().map_err(anyhow::Error::msg)?;
    let target = format!("{}:{}", s.host, s.port);
    tracing::info!(
        model = s.model.spec().name,
        protocol = s.protocol.name(),
        frequency_hz = mode_hz,
        step_deg,
        "topics open: {}; scanner at {target}",
        topics::LIDAR_SCAN2D
    );
    // the link thread: its events through a channel, a byte on the socket pair to wake us
    let (wake_rx, mut wake_tx) = UnixStream::pair().context("a socket pair to wake the loop")?;
    wake_rx.set_nonblocking(true)?;
    wake_tx.set_nonblocking(true)?;
    let (tx, rx) = mpsc::sync_channel::<Msg>(QUEUE);
    let stop = Arc::new(AtomicBool::new(false));
    let thread_stop = Arc::clone(&stop);
    // events the full channel could not take: counted here, recorded by the loop
    let behind = Arc::new(AtomicU64::new(0));
    let thread_behind = Arc::clone(&behind);
    let mut link = Link::new(s);
    let reader = std::thread::Builder::new()
        .name("sick-link".into())
        .spawn(move || {
            link.run(&thread_stop, |e| {
                let msg = match e {
                    LinkEvent::Scan { header, returns } => Msg::Scan(header, returns.to_vec()),
                    LinkEvent::Connected(a) => Msg::Connected(a.to_string()),
                    LinkEvent::Streaming => Msg::Streaming,
                    LinkEvent::Down { why, retry } => Msg::Down(why, retry),
                    LinkEvent::DeviceStatus(d) => Msg::DeviceStatus(d),
                    LinkEvent::Fault { kind, what } => Msg::Fault(kind, what),
                };
                match tx.try_send(msg) {
                    Ok(()) => {}
                    Err(TrySendError::Full(_)) => _ = thread_behind.fetch_add(1, Ordering::Relaxed),
                    Err(TrySendError::Disconnected(_)) => {
                        thread_stop.store(true, Ordering::Relaxed)
                    }
                }
                // a full socket pair already holds a wake-up
                let _ = wake_tx.write(&[1]);
            });
        })
        .context("cannot start the link thread")?;
    let fds: Vec<SocketFd> = SocketFd::borrowed(wake_rx.as_raw_fd())
        .into_iter()
        .collect();
    let (_wake, _tick) = (svc.on_fds(&fds)?, svc.every(Duration::from_secs(1))?);
    let mut health = svc.health();
    let (mut published, mut last_scan, mut last_report) = (0u64, Instant::now(), Instant::now());
    let mut state = format!("connecting to the {} at {target}", s.model.spec().name);
    let mut device: Option<String> = None;
    let mut drain = [0u8; 256];
    svc.run(&mut health, &state.clone(), |turn, h| {
        while let Ok(n) = (&wake_rx).read(&mut drain) {
            if n < drain.len() {
                break;
            }
        }
        while let Ok(msg) = rx.try_recv() {
            match msg {
                Msg::Scan(header, returns) => {
                    last_scan = turn.now;
                    match scans.publish(header, &returns) {
                        Ok(_) => published += 1,
                        Err(e) => _ = h.faults.record("publish_failed", turn.now, e),
                    }
                }
                Msg::Connected(a) => {
                    tracing::info!("connected to the scanner at {a}; starting the stream");
                    state = format!("connected to {a}, starting the stream");
                }
                Msg::Streaming => {
                    tracing::info!("the scanner streams");
                    state = format!("streaming from {target}");
                }
                Msg::Down(why, retry) => {
                    h.faults.record(
                        "link_down",
                        turn.now,
                        format_args!("{target}: {why}; trying again in {retry:?}"),
                    );
                    state = format!("no scanner: {why}");
                }
                Msg::DeviceStatus(d) => {
                    match &d {
                        Some(what) => tracing::warn!("the scanner reports {what}"),
                        None => tracing::info!("the scanner reports no fault any more"),
                    }
                    device = d;
                }
                Msg::Fault(kind, what) => _ = h.faults.record(kind, turn.now, what),
            }
        }
        for _ in 0..behind.swap(0, Ordering::Relaxed) {
            let what = "a scan or fault of the link dropped: the loop is behind";
            h.faults.record("loop_behind", turn.now, what);
        }
        let status = match &device {
            Some(d) => format!("{state}; {d}; {published} scans"),
            None => format!("{state}; {published} scans"),
        };
        // a silent scanner's status names it; else what the link is doing
        match turn.now.saturating_duration_since(last_scan) >= Duration::from_secs(1) {
            true => {
                h.sd.silent(turn.now, last_scan, Duration::from_secs(1), &status)
            }
            false => h.sd.status(&status),
        }
        if last_report.elapsed() >= STATS_INTERVAL {
            tracing::info!(published, "{state}; faults: {}", h.faults.summary());
            last_report = Instant::now();
        }
    })?;
    stop.store(true, Ordering::Relaxed);
    drop(rx);
    if reader.join().is_err() {
        tracing::error!("the link thread panicked");
    }
    tracing::info!(
        published,
        "sick stopped; faults: {}",
        health.faults.summary()
    );
    Ok(())
}
