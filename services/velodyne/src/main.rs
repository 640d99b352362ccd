//! `mimnav-velodyne`: the VLP-16 driver service.
//!
//! Wiring only: config → iceoryx2 topics → a loop that takes datagrams from a UDP socket or a
//! capture, hands them to the library's [`Assembler`] and publishes each revolution on
//! `lidar/points` and `lidar/scan2d`. SIGTERM or SIGINT ends the loop cleanly.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use clap::Parser;
use iceoryx2::prelude::*;
use mimnav_shared::cli::ServiceArgs;
use mimnav_shared::config::{Config, VelodyneInput, toml_quote};
use mimnav_shared::faults::Faults;
use mimnav_shared::ipc::{self, PointsPublisher, ScanPublisher, Svc, ValuePublisher};
use mimnav_shared::systemd::Notifier;
use mimnav_shared::topics::{DATA_PACKET_LEN, RawPacket};
use mimnav_velodyne::capture::CaptureReader;
use mimnav_velodyne::packet::{POSITION_PACKET_LEN, PositionPacket, PpsStatus};
use mimnav_velodyne::replay::Pacer;
use mimnav_velodyne::revolution::{Assembler, AssemblerConfig, Revolution, max_scan_len};
use mimnav_velodyne::udp::{Port, UdpConfig, UdpSource};

/// The VLP-16 driver: decodes a live sensor (UDP) or replays a capture, and publishes
/// revolutions on lidar/points and lidar/scan2d.
#[derive(Debug, Parser)]
#[command(name = "mimnav-velodyne", version)]
struct Args {
    #[command(flatten)]
    service: ServiceArgs,
    /// Replay this capture instead of listening on UDP (sets velodyne.input = "pcap").
    #[arg(long, value_name = "FILE")]
    pcap: Option<PathBuf>,
    /// Check the config, print the settings in force and exit.
    #[arg(long)]
    check_config: bool,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let mut set = Vec::new();
    if let Some(p) = &args.pcap {
        set.push("velodyne.input=\"pcap\"".into());
        set.push(format!(
            "velodyne.pcap={}",
            toml_quote(&p.display().to_string())
        ));
    }
    let config = match args.service.load_or_exit("mimnav-velodyne", &set) {
        Ok(c) => c,
        Err(code) => return code,
    };
    if args.check_config {
        println!("{:#?}", config.velodyne);
        return ExitCode::SUCCESS;
    }
    mimnav_shared::logging::init(&config.log.level);
    // held until the service ends
    let _cpu_latency = mimnav_shared::realtime::apply(&config);
    if !config.from_file() {
        tracing::info!("no config file: running on the built-in defaults");
    }
    mimnav_shared::cli::finish("mimnav-velodyne", run(&config).map(|()| ExitCode::SUCCESS))
}

/// The driver's state between datagrams.
struct Driver {
    assembler: Assembler,
    points: PointsPublisher,
    scan: ScanPublisher,
    packets: Option<ValuePublisher<RawPacket>>,
    faults: Faults,
    stats: Stats,
    pps: Option<PpsStatus>,
    accept_0x21_logged: bool,
    data_port: u16,
    position_port: u16,
    /// READY, WATCHDOG and STATUS for systemd (a no-op outside it).
    sd: Notifier,
    last_datagram: Option<Instant>,
}

#[derive(Default)]
struct Stats {
    data_packets: u64,
    position_packets: u64,
    other_traffic: u64,
    revolutions: u64,
    points: u64,
    last_report: Option<Instant>,
    revolutions_at_report: u64,
    points_at_report: u64,
    packets_at_report: u64,
}

impl Driver {
    fn new(config: &Config, node: &Node<Svc>) -> Result<Self> {
        let asm = AssemblerConfig::from_config(config);
        let v = &config.velodyne;
        let max_duration_s = asm.max_duration_ns as f64 * 1e-9;
        let points = ipc::points_publisher(node, asm.max_points)?;
        let scan = ipc::scan_publisher(node, max_scan_len(v.rpm, max_duration_s))?;
        let packets = if v.publish_packets {
            Some(ipc::packets_publisher(node)?)
        } else {
            None
        };
        tracing::info!(
            max_points = asm.max_points,
            cut_azimuth_deg = ?v.cut_azimuth_deg,
            rpm = v.rpm,
            "topics open: {}, {}{}",
            mimnav_shared::topics::LIDAR_POINTS,
            mimnav_shared::topics::LIDAR_SCAN2D,
            if packets.is_some() { ", mimnav/lidar/packets" } else { "" }
        );
        Ok(Driver {
            assembler: Assembler::new(asm),
            points,
            scan,
            packets,
            faults: Faults::new(Duration::from_secs(5)),
            stats: Stats::default(),
            pps: None,
            accept_0x21_logged: false,
            data_port: v.data_port,
            position_port: v.position_port,
            sd: Notifier::from_env(),
            last_datagram: None,
        })
    }

    /// One datagram from `source` (an address or a file offset, for messages).
    fn on_datagram(
        &mut self,
        bytes: &[u8],
        is_position: bool,
        host_ns: u64,
        now: Instant,
        source: &dyn Fn() -> String,
    ) {
        if is_position {
            self.on_position(bytes, now, source);
            return;
        }
        let mono = ipc::monotonic_ns();
        if let Some(p) = &self.packets
            && bytes.len() == DATA_PACKET_LEN
        {
            let mut raw = RawPacket {
                seq: self.stats.data_packets,
                host_ns,
                rx_mono_ns: mono,
                len: bytes.len() as u32,
                port: self.data_port,
                ..RawPacket::default()
            };
            raw.data.copy_from_slice(bytes);
            if let Err(e) = p.publish(raw) {
                self.faults.record("publish_failed", now, e);
            }
        }
        match self.assembler.push(bytes, host_ns, mono) {
            Ok(done) => {
                self.stats.data_packets += 1;
                if !self.accept_0x21_logged && bytes.get(1205) == Some(&0x21) {
                    self.accept_0x21_logged = true;
                    tracing::info!(
                        "product byte 0x21 (HDL-32E) accepted as a VLP-16 because \
                         velodyne.accept_product_0x21 = true (early VLP-16 firmware)"
                    );
                }
                if let Some(rev) = done {
                    publish(
                        &self.points,
                        &self.scan,
                        rev,
                        &mut self.faults,
                        &mut self.stats,
                        now,
                    );
                }
            }
            Err(e) => {
                self.faults
                    .record(e.kind(), now, format_args!("{}: {e}", source()));
            }
        }
    }

    fn on_position(&mut self, bytes: &[u8], now: Instant, source: &dyn Fn() -> String) {
        match PositionPacket::parse(bytes) {
            Ok(p) => {
                self.stats.position_packets += 1;
                if self.pps != Some(p.pps) {
                    tracing::info!(
                        pps = ?p.pps,
                        gprmc_unix_s = ?p.gprmc_unix_s(),
                        "position packet: PPS {:?}, NMEA {:?}",
                        p.pps,
                        p.nmea
                    );
                    self.pps = Some(p.pps);
                }
            }
            Err(e) => {
                self.faults.record(
                    "bad_position_packet",
                    now,
                    format_args!("{}: {e}", source()),
                );
            }
        }
    }

    /// Flushes the partial revolution at the end of a capture.
    fn finish(&mut self, now: Instant) {
        if let Some(rev) = self.assembler.finish() {
            publish(
                &self.points,
                &self.scan,
                rev,
                &mut self.faults,
                &mut self.stats,
                now,
            );
        }
    }

    /// The closing line: totals and every fault counted.
    fn log_summary(&self, what: &str) {
        let s = &self.stats;
        tracing::info!(
            revolutions = s.revolutions,
            points = s.points,
            data_packets = s.data_packets,
            position_packets = s.position_packets,
            other_traffic = s.other_traffic,
            "{what}; faults: {}",
            self.faults.summary()
        );
    }

    fn report_if_due(&mut self, now: Instant, interval: Duration) {
        let last = *self.stats.last_report.get_or_insert(now);
        let dt = now.saturating_duration_since(last);
        if dt < interval {
            return;
        }
        let s = &mut self.stats;
        let secs = dt.as_secs_f64().max(1e-9);
        tracing::info!(
            packets = s.data_packets,
            revolutions = s.revolutions,
            "{:.1} revolutions/s, {:.0} points/s, {:.0} packets/s; position packets {}; \
             other traffic {}; faults: {}",
            (s.revolutions - s.revolutions_at_report) as f64 / secs,
            (s.points - s.points_at_report) as f64 / secs,
            (s.data_packets - s.packets_at_report) as f64 / secs,
            s.position_packets,
            s.other_traffic,
            self.faults.summary()
        );
        let status = format!(
            "{:.1} revolutions/s, {} revolutions, {} faults",
            (s.revolutions - s.revolutions_at_report) as f64 / secs,
            s.revolutions,
            self.faults.total()
        );
        s.last_report = Some(now);
        s.revolutions_at_report = s.revolutions;
        s.points_at_report = s.points;
        s.packets_at_report = s.data_packets;
        self.sd.status(&status);
    }

    /// Once per turn of the loop: the watchdog ping, and a status naming a silent sensor.
    fn alive(&mut self, now: Instant, silent_after: Duration) {
        self.sd.alive(now);
        if let Some(t) = self.last_datagram {
            self.sd.silent(now, t, silent_after, "no VLP-16 datagram");
        }
    }
}

fn publish(
    points: &PointsPublisher,
    scan: &ScanPublisher,
    rev: &Revolution,
    faults: &mut Faults,
    stats: &mut Stats,
    now: Instant,
) {
    stats.revolutions += 1;
    stats.points += rev.points.len() as u64;
    if let Err(e) = points.publish(rev.header, &rev.points) {
        faults.record("publish_failed", now, e);
    }
    if let Err(e) = scan.publish(rev.scan_header, &rev.scan) {
        faults.record("publish_failed", now, e);
    }
    tracing::debug!(
        seq = rev.header.seq,
        points = rev.header.point_count,
        packets = rev.header.packet_count,
        cut = rev.header.cut_reason,
        "revolution"
    );
}

fn run(config: &Config) -> Result<()> {
    let node = ipc::node(config, "velodyne")?;
    let mut driver = Driver::new(config, &node)?;
    match config.velodyne.input {
        VelodyneInput::Udp => run_udp(config, &node, &mut driver),
        VelodyneInput::Pcap => run_replay(config, &node, &mut driver),
    }
}

/// A socket's descriptor, so the WaitSet can wait on it beside iceoryx2's own events.
#[derive(Debug)]
struct SocketFd(FileDescriptor);

impl FileDescriptorBased for SocketFd {
    fn file_descriptor(&self) -> &FileDescriptor {
        &self.0
    }
}

impl SynchronousMultiplexing for SocketFd {}

fn run_udp(config: &Config, _node: &Node<Svc>, driver: &mut Driver) -> Result<()> {
    let v = &config.velodyne;
    let udp = UdpConfig {
        bind_address: v.bind_address,
        data_port: v.data_port,
        position_port: (v.position_port != 0).then_some(v.position_port),
        allowed_source: v.allowed_source,
        recv_buffer_bytes: v.recv_buffer_bytes,
    };
    let mut source = UdpSource::bind(&udp).with_context(|| {
        format!(
            "cannot bind UDP {}:{} / {}",
            v.bind_address, v.data_port, v.position_port
        )
    })?;
    let granted = source.recv_buffer_bytes().unwrap_or(0);
    if granted < v.recv_buffer_bytes {
        tracing::info!(
            asked = v.recv_buffer_bytes,
            granted,
            "the kernel granted a smaller UDP receive buffer (raise net.core.rmem_max to get more)"
        );
    }
    tracing::info!(
        data = %source.data_addr().map(|a| a.to_string()).unwrap_or_default(),
        position_port = v.position_port,
        allowed_source = ?v.allowed_source,
        "listening for VLP-16 datagrams"
    );
    let fds: Vec<SocketFd> = source
        .fds()
        .into_iter()
        .filter_map(|fd| FileDescriptor::non_owning_new(fd).map(SocketFd))
        .collect();
    let waitset = WaitSetBuilder::new()
        .signal_handling_mode(SignalHandlingMode::HandleTerminationRequests)
        .create::<Svc>()
        .map_err(|e| anyhow::anyhow!("cannot create the WaitSet: {e:?}"))?;
    let mut guards = Vec::new();
    for fd in &fds {
        guards.push(
            waitset
                .attach_notification(fd)
                .map_err(|e| anyhow::anyhow!("cannot wait on the UDP socket: {e:?}"))?,
        );
    }
    let interval = Duration::from_secs_f64(v.stats_interval_s);
    let _tick = waitset
        .attach_interval(interval.min(driver.sd.tick()))
        .map_err(|e| anyhow::anyhow!("cannot attach the statistics interval: {e:?}"))?;
    let mut buf = vec![0u8; 2048];
    let mut io_error_logged = false;
    let listening = format!(
        "listening on {}",
        source
            .data_addr()
            .map(|a| a.to_string())
            .unwrap_or_default()
    );
    driver.sd.ready(&listening);
    driver.last_datagram = Some(Instant::now());
    let result = ipc::run_waitset(&waitset, |_id| {
        let now = Instant::now();
        loop {
            match source.recv(&mut buf) {
                Ok(Some(r)) => {
                    driver.last_datagram = Some(now);
                    let host_ns = ipc::realtime_ns();
                    let from = r.from;
                    let is_position = r.port == Port::Position;
                    driver.on_datagram(&buf[..r.len], is_position, host_ns, now, &|| {
                        format!("datagram from {from}")
                    });
                }
                Ok(None) => break,
                Err(e) => {
                    if !io_error_logged {
                        tracing::warn!("UDP receive failed: {e}");
                        io_error_logged = true;
                    }
                    driver.faults.record("udp_receive_failed", now, &e);
                    break;
                }
            }
        }
        driver.report_if_due(now, interval);
        driver.alive(now, Duration::from_secs(1));
        CallbackProgression::Continue
    });
    driver.sd.stopping("stopping");
    if source.rejected() > 0 {
        tracing::info!(
            count = source.rejected(),
            "datagrams from other senders than velodyne.allowed_source dropped"
        );
    }
    match result {
        Ok(r) => driver.log_summary(&format!("stopping ({r:?})")),
        Err(e) => anyhow::bail!("WaitSet failed: {e:?}"),
    }
    Ok(())
}

fn run_replay(config: &Config, node: &Node<Svc>, driver: &mut Driver) -> Result<()> {
    let v = &config.velodyne;
    let path = v.pcap.clone().context("velodyne.pcap is not set")?;
    let speed = if v.replay_fast {
        None
    } else {
        Some(v.replay_speed)
    };
    let mut pacer = Pacer::new(speed, (v.replay_max_gap_s * 1e9) as u64);
    // the loop below waits at most this long at a time, so the watchdog is pinged in long gaps
    let tick = driver.sd.tick();
    let interval = Duration::from_secs_f64(v.stats_interval_s);
    let mut outcome: Result<()> = Ok(());
    let mut stopped = false;
    'passes: loop {
        let mut reader = CaptureReader::open(&path)?;
        tracing::info!(
            file = %path.display(),
            bytes = reader.file_len(),
            speed = ?speed,
            "replaying capture"
        );
        pacer.restart();
        driver.sd.ready(&format!("replaying {}", path.display()));
        loop {
            let datagram = match reader.next() {
                Ok(Some(d)) => d,
                Ok(None) => break,
                Err(e) => {
                    outcome = Err(anyhow::Error::new(e).context("replay ended early"));
                    break 'passes;
                }
            };
            let mut now = Instant::now();
            let due = pacer.due(datagram.ts_ns, now);
            while due > now {
                driver.sd.alive(now);
                if !ipc::sleep(node, (due - now).min(tick)) {
                    stopped = true;
                    break 'passes;
                }
                now = Instant::now();
            }
            driver.sd.alive(now);
            let len = datagram.payload.len();
            let port = datagram.dst_port;
            let is_position = len == POSITION_PACKET_LEN
                || port == driver.position_port && len != DATA_PACKET_LEN;
            if len != DATA_PACKET_LEN && !is_position && port != driver.data_port {
                driver.stats.other_traffic += 1;
                continue;
            }
            let offset = datagram.offset;
            let shown = path.display();
            driver.on_datagram(datagram.payload, is_position, datagram.ts_ns, now, &|| {
                format!("{shown} byte offset {offset}")
            });
            driver.report_if_due(now, interval);
        }
        driver.finish(Instant::now());
        for (kind, n) in reader.skipped() {
            tracing::info!(kind, count = n, "frames without a UDP datagram passed over");
        }
        if !v.replay_loop {
            break;
        }
        if !ipc::sleep(node, Duration::ZERO) {
            stopped = true;
            break;
        }
    }
    driver.finish(Instant::now());
    driver.sd.stopping(if stopped {
        "stopping"
    } else {
        "replay finished"
    });
    driver.log_summary(if stopped {
        "replay stopped by signal"
    } else {
        "replay finished"
    });
    driver.points.end_of_stream()?;
    driver.scan.end_of_stream()?;
    if !stopped && v.replay_linger_s > 0.0 {
        // let subscribers take the last samples before the publisher goes away
        let end = Instant::now() + Duration::from_secs_f64(v.replay_linger_s);
        loop {
            let now = Instant::now();
            driver.sd.alive(now);
            if now >= end || !ipc::sleep(node, (end - now).min(tick)) {
                break;
            }
        }
    }
    outcome
}
