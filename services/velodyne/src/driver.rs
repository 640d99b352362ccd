//! The driver's step type: one datagram in, at most one finished revolution out, with the
//! counters, the position-packet log and the periodic statistics the service reports. No
//! sockets, no files, no clocks: the service's `main.rs` takes datagrams from a socket or a
//! capture, hands each to [`Driver::on_datagram`] with its times, and publishes what comes back.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use mimnav_shared::faults::Faults;
use mimnav_shared::topics::{DATA_PACKET_LEN, Point, RawPacket, SliceHeader};

use crate::packet::{POSITION_PACKET_LEN, PositionPacket, PpsStatus};
use crate::revolution::{Assembler, AssemblerConfig, Revolution};

/// Least time between two log lines about a change of the PPS status.
const PPS_LOG_INTERVAL: Duration = Duration::from_secs(5);

/// What a datagram is, by its port and size.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A data packet (or a datagram on the data port that claims to be one).
    Data,
    /// A position packet.
    Position,
    /// Neither: other traffic in a capture, counted and passed over.
    Other,
}

impl From<crate::udp::Port> for Kind {
    fn from(port: crate::udp::Port) -> Kind {
        match port {
            crate::udp::Port::Data => Kind::Data,
            crate::udp::Port::Position => Kind::Position,
        }
    }
}

/// Counters since the start, and where the last periodic report left them.
#[derive(Debug, Default, Clone)]
pub struct Stats {
    /// Data packets decoded.
    pub data_packets: u64,
    /// Position packets parsed.
    pub position_packets: u64,
    /// Datagrams in a capture that were neither (other ports and sizes).
    pub other_traffic: u64,
    /// Datagrams dropped because they came from a sender other than `velodyne.allowed_source`.
    pub foreign: u64,
    /// The sender of the last of them.
    pub last_foreign: Option<SocketAddr>,
    /// Revolutions finished.
    pub revolutions: u64,
    /// Points in them.
    pub points: u64,
    /// Datagrams the kernel dropped before the driver read them (its socket's receive buffer
    /// was full), as the socket last reported it; `None` for a capture.
    pub kernel_drops: Option<u64>,
    last_report: Option<Instant>,
    revolutions_at_report: u64,
    points_at_report: u64,
    packets_at_report: u64,
}

/// The driver between datagrams.
#[derive(Debug, Clone)]
pub struct Driver {
    assembler: Assembler,
    stats: Stats,
    pps: Option<PpsStatus>,
    pps_logged: Option<Instant>,
    accept_0x21_logged: bool,
    data_port: u16,
    position_port: u16,
}

impl Driver {
    /// A driver assembling revolutions by `config`, with the sensor's data and position ports
    /// (0: no position port).
    pub fn new(config: AssemblerConfig, data_port: u16, position_port: u16) -> Self {
        Driver {
            assembler: Assembler::new(config),
            stats: Stats::default(),
            pps: None,
            pps_logged: None,
            accept_0x21_logged: false,
            data_port,
            position_port,
        }
    }

    /// The counters.
    pub fn stats(&self) -> &Stats {
        &self.stats
    }

    /// Takes the sockets' count of datagrams the kernel dropped (see
    /// [`crate::udp::UdpSource::kernel_drops`]), for the reports.
    pub fn set_kernel_drops(&mut self, dropped: Option<u64>) {
        self.stats.kernel_drops = dropped;
    }

    /// What a datagram of `len` bytes sent to `port` is. A socket already tells the ports
    /// apart; a capture holds every datagram, so size and port decide.
    pub fn kind(&self, len: usize, port: u16) -> Kind {
        if len == POSITION_PACKET_LEN || port == self.position_port && len != DATA_PACKET_LEN {
            Kind::Position
        } else if len == DATA_PACKET_LEN || port == self.data_port {
            Kind::Data
        } else {
            Kind::Other
        }
    }

    /// One datagram of `kind`, received at `host_ns` (host clock, ns since the Unix epoch) and
    /// `mono_ns` (`CLOCK_MONOTONIC`). A bad one is counted in `faults` under its kind, named by
    /// `source` (an address or a file offset). Returns the revolution it finished, if any.
    pub fn on_datagram(
        &mut self,
        bytes: &[u8],
        kind: Kind,
        (host_ns, mono_ns): (u64, u64),
        now: Instant,
        faults: &mut Faults,
        source: &dyn Fn() -> String,
    ) -> Option<&Revolution> {
        match kind {
            Kind::Other => {
                self.stats.other_traffic += 1;
                None
            }
            Kind::Position => {
                self.on_position(bytes, now, faults, source);
                None
            }
            Kind::Data => match self.assembler.push(bytes, host_ns, mono_ns) {
                Ok(done) => {
                    self.stats.data_packets += 1;
                    if !self.accept_0x21_logged && bytes.get(1205) == Some(&0x21) {
                        self.accept_0x21_logged = true;
                        tracing::info!(
                            "product byte 0x21 (HDL-32E) accepted as a VLP-16 because \
                             velodyne.accept_product_0x21 = true (early VLP-16 firmware)"
                        );
                    }
                    done.inspect(|rev| count(&mut self.stats, rev))
                }
                Err(e) => {
                    faults.record(e.kind(), now, format_args!("{}: {e}", source()));
                    None
                }
            },
        }
    }

    fn on_position(
        &mut self,
        bytes: &[u8],
        now: Instant,
        faults: &mut Faults,
        source: &dyn Fn() -> String,
    ) {
        match PositionPacket::parse(bytes) {
            Ok(p) => {
                self.stats.position_packets += 1;
                // a change of the PPS status is news; a sensor flapping between two is logged
                // once per interval
                let quiet = (self.pps_logged)
                    .is_none_or(|t| now.saturating_duration_since(t) >= PPS_LOG_INTERVAL);
                if self.pps != Some(p.pps) && quiet {
                    self.pps_logged = Some(now);
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
            // garbage on the position port: counted by kind, logged at a limited rate
            Err(e) => _ = faults.record(e.kind(), now, format_args!("{}: {e}", source())),
        }
    }

    /// A datagram from `from`, a sender other than `velodyne.allowed_source`, was dropped:
    /// counted (fault kind `foreign_sender`, logged at a limited rate) and remembered for the
    /// periodic statistics and the status line.
    pub fn on_foreign(&mut self, from: SocketAddr, now: Instant, faults: &mut Faults) {
        self.stats.foreign += 1;
        self.stats.last_foreign = Some(from);
        faults.record(
            "foreign_sender",
            now,
            format_args!("datagram from {from} dropped: not velodyne.allowed_source"),
        );
    }

    /// `bytes` as a `lidar/packets` sample, when it is a data packet of the right size.
    pub fn raw_packet(
        &self,
        bytes: &[u8],
        kind: Kind,
        (host_ns, mono_ns): (u64, u64),
    ) -> Option<RawPacket> {
        let mut raw = RawPacket {
            seq: self.stats.data_packets,
            host_ns,
            rx_mono_ns: mono_ns,
            len: bytes.len() as u32,
            port: self.data_port,
            ..RawPacket::default()
        };
        (kind == Kind::Data && bytes.len() == DATA_PACKET_LEN).then(|| {
            raw.data.copy_from_slice(bytes);
            raw
        })
    }

    /// The last revolution completed.
    pub fn revolution(&self) -> &Revolution {
        self.assembler.revolution()
    }

    /// How far the current revolution has still to turn before it completes, 0.01°.
    pub fn turn_left_cdeg(&self) -> u32 {
        self.assembler.turn_left_cdeg()
    }

    /// The points assembled since the last call, as `lidar/slices` samples of `packets` packets
    /// (see [`Assembler::take_slices`]); call it after every datagram and [`finish`](Self::finish).
    pub fn take_slices(&mut self, packets: u32, emit: impl FnMut(&SliceHeader, &[Point])) {
        self.assembler.take_slices(packets, emit);
    }

    /// The partial revolution at the end of a capture, if any.
    pub fn finish(&mut self) -> Option<&Revolution> {
        self.assembler
            .finish()
            .inspect(|rev| count(&mut self.stats, rev))
    }

    /// Every `interval`: logs the rates since the last report and returns the one-line status
    /// for systemd; `None` between reports. `kernel_drops` is asked for the socket's count of
    /// datagrams the kernel dropped (see [`Driver::set_kernel_drops`]) when a report is due.
    pub fn report_if_due(
        &mut self,
        now: Instant,
        interval: Duration,
        faults: &Faults,
        kernel_drops: impl FnOnce() -> Option<u64>,
    ) -> Option<String> {
        let last = *self.stats.last_report.get_or_insert(now);
        let dt = now.saturating_duration_since(last);
        if dt < interval {
            return None;
        }
        self.set_kernel_drops(kernel_drops());
        let s = &mut self.stats;
        let secs = dt.as_secs_f64().max(1e-9);
        let revs_per_s = (s.revolutions - s.revolutions_at_report) as f64 / secs;
        let foreign = foreign_text(s) + &kernel_text(s);
        tracing::info!(
            packets = s.data_packets,
            revolutions = s.revolutions,
            foreign = s.foreign,
            kernel_drops = s.kernel_drops,
            "{revs_per_s:.1} revolutions/s, {:.0} points/s, {:.0} packets/s; position packets {}; \
             other traffic {}{foreign}; faults: {}",
            (s.points - s.points_at_report) as f64 / secs,
            (s.data_packets - s.packets_at_report) as f64 / secs,
            s.position_packets,
            s.other_traffic,
            faults.summary()
        );
        s.last_report = Some(now);
        s.revolutions_at_report = s.revolutions;
        s.points_at_report = s.points;
        s.packets_at_report = s.data_packets;
        Some(format!(
            "{revs_per_s:.1} revolutions/s, {} revolutions, {} faults{foreign}",
            s.revolutions,
            faults.total()
        ))
    }

    /// The closing line: totals and every fault counted.
    pub fn log_summary(&self, what: &str, faults: &Faults) {
        let s = &self.stats;
        tracing::info!(
            revolutions = s.revolutions,
            points = s.points,
            data_packets = s.data_packets,
            position_packets = s.position_packets,
            other_traffic = s.other_traffic,
            foreign = s.foreign,
            kernel_drops = s.kernel_drops,
            "{what}{}{}; faults: {}",
            foreign_text(s),
            kernel_text(s),
            faults.summary()
        );
    }
}

/// `, N datagrams from foreign senders (last ADDR)`, or nothing when there were none.
fn foreign_text(s: &Stats) -> String {
    match s.last_foreign {
        Some(a) if s.foreign > 0 => {
            format!(", {} datagrams from foreign senders (last {a})", s.foreign)
        }
        _ => String::new(),
    }
}

/// `, N datagrams dropped by the kernel (receive buffer full)` when the driver reads a socket.
fn kernel_text(s: &Stats) -> String {
    match s.kernel_drops {
        Some(n) => format!(", {n} datagrams dropped by the kernel (receive buffer full)"),
        None => String::new(),
    }
}

fn count(stats: &mut Stats, rev: &Revolution) {
    stats.revolutions += 1;
    stats.points += rev.points.len() as u64;
    tracing::debug!(
        seq = rev.header.seq,
        points = rev.header.point_count,
        packets = rev.header.packet_count,
        cut = rev.header.cut_reason,
        "revolution"
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    fn driver() -> Driver {
        Driver::new(AssemblerConfig::default(), 2368, 8308)
    }

    #[test]
    fn datagrams_are_told_apart_by_size_and_port() {
        let d = driver();
        assert_eq!(d.kind(DATA_PACKET_LEN, 2368), Kind::Data);
        assert_eq!(d.kind(DATA_PACKET_LEN, 9999), Kind::Data);
        assert_eq!(d.kind(POSITION_PACKET_LEN, 2368), Kind::Position);
        assert_eq!(d.kind(100, 8308), Kind::Position);
        // a short datagram on the data port is a bad data packet, counted as one
        assert_eq!(d.kind(100, 2368), Kind::Data);
        assert_eq!(d.kind(100, 53), Kind::Other);
    }

    #[test]
    fn bad_datagrams_are_counted_by_kind_and_nothing_is_assembled() {
        let mut d = driver();
        let mut faults = Faults::new(Duration::from_secs(60));
        let now = Instant::now();
        let none = || "test".to_string();
        assert!(
            d.on_datagram(&[0u8; 100], Kind::Data, (0, 0), now, &mut faults, &none)
                .is_none()
        );
        assert!(
            d.on_datagram(&[0u8; 100], Kind::Position, (0, 0), now, &mut faults, &none)
                .is_none()
        );
        assert!(
            d.on_datagram(&[0u8; 10], Kind::Other, (0, 0), now, &mut faults, &none)
                .is_none()
        );
        assert_eq!(faults.total(), 2, "{}", faults.summary());
        assert_eq!(d.stats().other_traffic, 1);
        assert_eq!(d.stats().data_packets, 0);
        assert!(d.finish().is_none());
    }

    /// Issue 23 item 6: datagrams from a sender other than `allowed_source` were reported only
    /// at exit.
    #[test]
    fn foreign_senders_in_periodic_stats_and_status() {
        let mut d = driver();
        let mut faults = Faults::new(Duration::from_secs(60));
        let t0 = Instant::now();
        let every = Duration::from_secs(1);
        assert!(
            d.report_if_due(t0, every, &faults, || None).is_none(),
            "first call starts the clock"
        );
        let t1 = t0 + every;
        let quiet = d.report_if_due(t1, every, &faults, || None).expect("due");
        assert!(!quiet.contains("foreign"), "{quiet}");
        for port in [4000, 4001, 4002] {
            d.on_foreign(SocketAddr::from(([10, 0, 0, 9], port)), t1, &mut faults);
        }
        let status = d.report_if_due(t1 + every, every, &faults, || Some(12));
        let status = status.expect("due");
        assert!(
            status.contains("12 datagrams dropped by the kernel (receive buffer full)"),
            "{status}"
        );
        assert!(
            status.contains("3 datagrams from foreign senders (last 10.0.0.9:4002)"),
            "{status}"
        );
        assert!(status.contains("3 faults"), "{status}");
        assert_eq!(faults.count("foreign_sender"), 3);
        assert_eq!(d.stats().foreign, 3);
    }
}
