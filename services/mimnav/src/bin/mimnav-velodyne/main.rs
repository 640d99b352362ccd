//! `mimnav-velodyne`: the VLP-16 driver service.
//!
//! Wiring only: datagrams from a UDP socket or a capture go through the library's [`Driver`];
//! each revolution it finishes goes out on `lidar/points` and `lidar/scan2d` (and every data
//! packet on `lidar/packets` when `velodyne.publish_packets` is set). SIGTERM or SIGINT ends the
//! loop cleanly.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use mimnav_config::Config;
use mimnav_foliage::ScanSource;
use mimnav_shared::config::toml_quote;
use mimnav_shared::ipc;
use mimnav_shared::service::{self, Service, ServiceCli, SocketFd};
use mimnav_shared::topics;
use mimnav_velodyne::config::VelodyneInput;
use mimnav_velodyne::driver::Driver;
use mimnav_velodyne::pace::Pace;
use mimnav_velodyne::revolution::{AssemblerConfig, max_scan_len, max_slice_points};
use mimnav_velodyne::udp::{Port, UdpSource};

/// The VLP-16 driver: decodes a live sensor (UDP) or replays a capture, and publishes
/// revolutions on lidar/points and lidar/scan2d.
#[derive(Debug, clap::Parser)]
#[command(name = "mimnav-velodyne", version)]
struct Args {
    #[command(flatten)]
    service: mimnav_shared::cli::ServiceArgs,
    /// Replay this capture instead of listening on UDP (sets velodyne.input = "pcap").
    #[arg(long, value_name = "FILE")]
    pcap: Option<PathBuf>,
    /// Check the config, print the settings in force and exit.
    #[arg(long)]
    check_config: bool,
}

impl ServiceCli for Args {
    fn service_args(&self) -> &mimnav_shared::cli::ServiceArgs {
        &self.service
    }
    fn overrides(&self) -> Vec<String> {
        let quoted = |p: &PathBuf| toml_quote(&p.display().to_string());
        let set = |p| {
            [
                "velodyne.input=\"pcap\"".into(),
                format!("velodyne.pcap={}", quoted(p)),
            ]
        };
        self.pcap.iter().flat_map(set).collect()
    }
}

mod wired;
use wired::Wired;

fn main() -> ExitCode {
    service::main("mimnav-velodyne", |args: Args, config: Config| {
        if args.check_config {
            // a closed stdout is no failure of the check (issue 23 item 4)
            use std::io::Write as _;
            let _ = writeln!(std::io::stdout().lock(), "{:#?}", config.velodyne);
            return Ok(ExitCode::SUCCESS);
        }
        run(&config).map(|()| ExitCode::SUCCESS)
    })
}

fn run(config: &Config) -> Result<()> {
    let (svc, v) = (Service::open(config, "velodyne")?, &config.velodyne);
    let asm = AssemblerConfig::from_config(&config.velodyne);
    let max_scan = max_scan_len(v.rpm, asm.max_duration_ns as f64 * 1e-9);
    let points = ipc::points_publisher(svc.node(), asm.max_points)?;
    // the foliage classifier reads a SICK instead: lidar/scan2d is mimnav-sick's
    let scan = (config.foliage.source == ScanSource::Velodyne)
        .then(|| ipc::scan_publisher(svc.node(), max_scan))
        .transpose()?;
    let packets = (v
        .publish_packets
        .then(|| ipc::packets_publisher(svc.node())))
    .transpose()?;
    let slices = (v.slice_packets > 0)
        .then(|| {
            // the first slice after an early cut holds one packet more
            let capacity = max_slice_points(v.slice_packets + 1);
            ipc::slices_publisher(svc.node(), capacity).map(|p| (p, v.slice_packets))
        })
        .transpose()?;
    tracing::info!(
        rpm = v.rpm,
        slice_packets = v.slice_packets,
        "topics open: {}, {}, {}",
        topics::LIDAR_POINTS,
        topics::LIDAR_SCAN2D,
        topics::LIDAR_SLICES
    );
    let driver = Driver::new(asm, v.data_port, v.position_port);
    let mut wired = Wired(driver, points, scan, packets, slices);
    let (mut health, interval) = (svc.health(), Duration::from_secs_f64(v.stats_interval_s));
    let VelodyneInput::Udp = v.input else {
        return wired::replay(config, &svc, &mut wired, &mut health, interval);
    };
    let mut source = UdpSource::bind(v).with_context(|| {
        format!(
            "cannot bind UDP {} (data port {}, position port {})",
            v.bind_address, v.data_port, v.position_port
        )
    })?;
    let fds: Vec<SocketFd> = source
        .fds()
        .into_iter()
        .filter_map(SocketFd::borrowed)
        .collect();
    let (_sockets, _tick) = (svc.on_fds(&fds)?, svc.every(interval)?);
    let (mut buf, mut last_datagram) = (vec![0u8; 2048], Instant::now());
    // far from the revolution's end, the socket is read every velodyne.pace_ms, not per datagram
    let mut pace = Pace::new(v.pace_ms, v.rpm);
    let addr = source
        .data_addr()
        .map(|a| a.to_string())
        .unwrap_or_default();
    svc.run(&mut health, &format!("listening on {addr}"), |turn, h| {
        loop {
            // a flood can keep this loop draining for longer than the watchdog allows
            h.sd.alive(Instant::now());
            let driver = &mut wired.0;
            let foreign = &mut |from| driver.on_foreign(from, turn.now, &mut h.faults);
            match source.recv(&mut buf, foreign) {
                Ok(Some(r)) => {
                    last_datagram = turn.now;
                    let from = || format!("datagram from {}", r.from);
                    let waited = match r.port {
                        Port::Data => source.kernel_wait_ns(),
                        Port::Position => 0,
                    };
                    // stamped with its arrival: a paced or late read moves no time stamp (a
                    // revolution spanning more than velodyne.rpm allows is cut by host time)
                    let host_ns = ipc::realtime_ns().saturating_sub(waited);
                    let kind = (r.port.into(), waited);
                    wired.push(&buf[..r.len], kind, host_ns, h, &from);
                }
                Ok(None) => break,
                Err(e) => {
                    h.faults.record("udp_receive_failed", turn.now, &e);
                    break;
                }
            }
        }
        // the kernel's drops are read only when a report is due: it reads /proc/net/udp
        let kernel_drops = || source.kernel_drops();
        if let Some(status) = wired
            .0
            .report_if_due(turn.now, interval, &h.faults, kernel_drops)
        {
            h.sd.status(&status);
        }
        h.sd.silent(
            turn.now,
            last_datagram,
            Duration::from_secs(1),
            "no VLP-16 datagram",
        );
        if let Some(pause) = pace.pause(Instant::now(), wired.0.turn_left_cdeg()) {
            std::thread::sleep(pause);
        }
    })?;
    // the foreign senders' count and the last one's address are in the summary
    wired.0.set_kernel_drops(source.kernel_drops());
    wired.0.log_summary("stopped", &health.faults);
    Ok(())
}
