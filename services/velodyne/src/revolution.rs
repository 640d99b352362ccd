//! Assembling decoded packets into revolutions.
//!
//! A revolution is a run of whole packets. It ends with the packet whose last block's azimuth
//! wraps past the revolution's starting azimuth after more than half a turn of coverage — the
//! starting azimuth being the configured cut azimuth, or, without one, the last azimuth of the
//! previous revolution (so revolutions follow each other seamlessly wherever the stream began).
//! This is velodyne-decoder's rule, so frames agree with its reference decodes packet for packet.
//!
//! A revolution is also cut early, *before* the packet that would break it, when that packet came
//! too long after the revolution's first one (a gap in the stream), when it would not fit in the
//! configured capacity, or when the return mode or product changes; the header's `cut_reason`
//! says which.

use mimnav_shared::config::seconds_ns;

use crate::config::VelodyneConfig;
use mimnav_shared::topics::{Point, PointsHeader, ScanHeader, ScanReturn, SliceHeader, cut_reason};

use crate::decode::{Decoder, PacketCounts};
use crate::packet::{BLOCKS, CHANNELS, DataPacket, DecodeError};

/// Nanoseconds in an hour: the period of the sensor's timestamp.
const HOUR_NS: u64 = 3_600_000_000_000;

/// Settings of the assembler: the `[velodyne]` section (the decoder's range limits, the product
/// rule, the planar scan, the cut azimuth) and the two limits derived from the rotation rate.
#[derive(Debug, Clone, PartialEq)]
pub struct AssemblerConfig {
    /// `[velodyne]`.
    pub velodyne: VelodyneConfig,
    /// Longest time a revolution may span (host clock and sensor clock), ns.
    pub max_duration_ns: u64,
    /// Most points a revolution may hold; the capacity of the published payload.
    pub max_points: usize,
}

impl Default for AssemblerConfig {
    /// `[velodyne]`'s defaults, with limits sized for the slowest rate (300 rpm, 1.5 turns), so
    /// a stream of any rate is assembled whole.
    fn default() -> Self {
        Self {
            velodyne: VelodyneConfig::default(),
            max_duration_ns: 300_000_000,
            max_points: max_points_per_revolution(300.0, 0.3),
        }
    }
}

impl AssemblerConfig {
    /// The assembler of `[velodyne]`: a revolution may last up to 1.5 turns at `velodyne.rpm`
    /// before it is cut, and the capacity covers that in dual-return mode.
    pub fn from_config(v: &VelodyneConfig) -> Self {
        let max_duration_s = 1.5 * 60.0 / v.rpm;
        AssemblerConfig {
            velodyne: v.clone(),
            max_duration_ns: seconds_ns(max_duration_s),
            max_points: max_points_per_revolution(v.rpm, max_duration_s),
        }
    }

    /// `velodyne.cut_azimuth_deg` in the packets' unit, 0.01°.
    pub fn cut_azimuth_cdeg(&self) -> Option<u16> {
        (self.velodyne.cut_azimuth_deg).map(|d| (d * 100.0).round() as u16 % 36000)
    }
}

/// Worst-case points of a revolution lasting at most `max_duration_s` of a sensor spinning at
/// `rpm`, in dual-return mode (every channel of every block pair giving two returns).
pub fn max_points_per_revolution(rpm: f64, max_duration_s: f64) -> usize {
    max_packets_per_revolution(rpm, max_duration_s) * (BLOCKS / 2) * CHANNELS * 2
}

/// Most points a `lidar/slices` sample of `packets` packets holds (every channel of every block
/// a point, as dual-return mode gives).
pub fn max_slice_points(packets: u32) -> usize {
    packets as usize * BLOCKS * CHANNELS
}

/// Worst-case data packets of a revolution: the longer of one turn and `max_duration_s`, at the
/// dual-return packet rate (the higher), plus a margin of two packets.
pub fn max_packets_per_revolution(rpm: f64, max_duration_s: f64) -> usize {
    let turn_s = 60.0 / rpm.max(1.0);
    let dual_packet_s = 6.0 * 2.0 * 55.296e-6;
    (turn_s.max(max_duration_s) / dual_packet_s).ceil() as usize + 2
}

/// Worst-case firings of one laser in a revolution (the length of a planar scan).
pub fn max_scan_len(rpm: f64, max_duration_s: f64) -> usize {
    // single-return mode fires 24 sequences per packet at half the dual packet rate
    max_packets_per_revolution(rpm, max_duration_s) * BLOCKS
}

/// Resolves a sensor timestamp (µs past the top of the hour) to ns since the Unix epoch, taking
/// the hour from `reference_ns` (host or capture time) and correcting by an hour where the two
/// are more than half an hour apart.
pub fn resolve_top_of_hour(us_past_hour: u32, reference_ns: u64) -> u64 {
    let t = reference_ns - reference_ns % HOUR_NS + u64::from(us_past_hour) * 1000;
    if t > reference_ns + HOUR_NS / 2 {
        t.saturating_sub(HOUR_NS)
    } else if t + HOUR_NS / 2 < reference_ns {
        t + HOUR_NS
    } else {
        t
    }
}

/// The revolution boundary rule on its own (see the module docs), for anything that must agree
/// with the assembler on where revolutions end — the simulator cuts its lock-step chunks with it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TurnCutter {
    cut: Option<i32>,
    start: Option<i32>,
    coverage: i32,
}

impl TurnCutter {
    /// Cuts at `cut_azimuth_cdeg`, or wherever a full turn completes when `None`.
    pub fn new(cut_azimuth_cdeg: Option<u16>) -> Self {
        let cut = cut_azimuth_cdeg.map(i32::from);
        TurnCutter {
            cut,
            start: cut,
            coverage: 0,
        }
    }

    /// Takes the last-block azimuth (0.01°) of a packet just added to the revolution; true when
    /// that packet completes it (the next revolution then starts after it).
    pub fn push(&mut self, last_block_azimuth: u16) -> bool {
        let az = i32::from(last_block_azimuth);
        let start = *self.start.get_or_insert(az);
        let coverage = (az - start + 36000) % 36000;
        let wrapped = self.coverage > 18000 && self.coverage > coverage;
        self.coverage = coverage;
        if wrapped {
            self.cut_after(last_block_azimuth);
        }
        wrapped
    }

    /// A revolution was ended early after a packet with last-block azimuth `az`: the next one
    /// starts there (or at the cut azimuth).
    pub fn cut_after(&mut self, az: u16) {
        self.start = Some(self.cut.unwrap_or(i32::from(az)));
        self.coverage = 0;
    }

    /// How far the turn has still to go before it completes, 0.01° (a whole turn before its
    /// first packet).
    pub fn left_cdeg(&self) -> u32 {
        (36000 - self.coverage).clamp(0, 36000) as u32
    }

    /// The stream ended: the next packet starts afresh.
    pub fn reset(&mut self) {
        self.start = self.cut;
        self.coverage = 0;
    }
}

/// One assembled revolution: the points, the planar scan of the configured laser and their
/// headers, ready to publish.
#[derive(Debug, Clone, Default)]
pub struct Revolution {
    /// Header of the points.
    pub header: PointsHeader,
    /// The points, in packet order.
    pub points: Vec<Point>,
    /// Header of the planar scan.
    pub scan_header: ScanHeader,
    /// The planar scan, one return per firing of the laser, in firing order.
    pub scan: Vec<ScanReturn>,
    first_us: u32,
    first_host_ns: u64,
    last_azimuth: u16,
}

impl Revolution {
    fn clear(&mut self) {
        self.header = PointsHeader::default();
        self.scan_header = ScanHeader::default();
        self.points.clear();
        self.scan.clear();
    }

    fn is_empty(&self) -> bool {
        self.header.packet_count == 0
    }
}

/// Cuts a packet stream into revolutions (see the module docs).
#[derive(Debug, Clone)]
pub struct Assembler {
    config: AssemblerConfig,
    decoder: Decoder,
    cur: Revolution,
    out: Revolution,
    cutter: TurnCutter,
    next_seq: u64,
    packet_seq: u64,
    slicing: Slicing,
}

/// What of the revolutions has been handed out as slices ([`Assembler::take_slices`]).
#[derive(Debug, Clone, Copy, Default)]
struct Slicing {
    /// Points of the current revolution handed out.
    sent: usize,
    /// Packets added to the current revolution since its last slice.
    pending: u32,
    /// The number of the current revolution's next slice.
    index: u32,
    /// The completed revolution's last slice, still to hand out: from this point, numbered so.
    tail: Option<(usize, u32)>,
}

impl Assembler {
    /// A new assembler; the first revolution gets sequence number 0.
    pub fn new(config: AssemblerConfig) -> Self {
        let decoder = Decoder::new(&config.velodyne);
        let mut cur = Revolution::default();
        cur.points.reserve(config.max_points);
        let mut out = Revolution::default();
        out.points.reserve(config.max_points);
        Assembler {
            cutter: TurnCutter::new(config.cut_azimuth_cdeg()),
            config,
            decoder,
            cur,
            out,
            next_seq: 0,
            packet_seq: 0,
            slicing: Slicing::default(),
        }
    }

    /// The last revolution completed (by [`push`](Self::push) or [`finish`](Self::finish)).
    pub fn revolution(&self) -> &Revolution {
        &self.out
    }

    /// How far the current revolution has still to turn before it completes, 0.01°
    /// ([`TurnCutter::left_cdeg`]).
    pub fn turn_left_cdeg(&self) -> u32 {
        self.cutter.left_cdeg()
    }

    /// Hands out the points assembled since the last call as slices, in order (called after
    /// every [`push`](Self::push) and [`finish`](Self::finish)): the last slice of a revolution
    /// just completed (it may hold no point); else the current revolution's next slice once
    /// `packets` packets wait in it (0: none before the revolution ends). Every revolution
    /// comes out whole, in slices of whole packets numbered from 0.
    pub fn take_slices(&mut self, packets: u32, mut emit: impl FnMut(&SliceHeader, &[Point])) {
        // the next revolution's first slice waits for the next call: whoever maps the last one
        // reads its map before the next one begins
        if let Some((from, index)) = self.slicing.tail.take() {
            let header = SliceHeader {
                revolution: self.out.header,
                index,
                first_point: from as u32,
                last: 1,
                reserved: [0; 7],
            };
            emit(&header, self.out.points.get(from..).unwrap_or_default());
            return;
        }
        let sl = &mut self.slicing;
        if packets > 0 && sl.pending >= packets {
            let header = SliceHeader {
                revolution: PointsHeader {
                    seq: self.next_seq,
                    ..self.cur.header
                },
                index: sl.index,
                first_point: sl.sent as u32,
                last: 0,
                reserved: [0; 7],
            };
            emit(&header, self.cur.points.get(sl.sent..).unwrap_or_default());
            (sl.sent, sl.pending, sl.index) = (self.cur.points.len(), 0, sl.index + 1);
        }
    }

    /// The settings.
    pub fn config(&self) -> &AssemblerConfig {
        &self.config
    }

    /// Data packets accepted so far.
    pub fn packets_accepted(&self) -> u64 {
        self.packet_seq
    }

    /// Feeds one data-packet datagram received at `host_ns` (ns since the Unix epoch: the
    /// receive time, or the capture timestamp when replaying) and `rx_mono_ns`
    /// (`CLOCK_MONOTONIC`). Returns the revolution it completed, if any; the reference stays
    /// valid until the next call. A packet that fails validation changes nothing.
    pub fn push(
        &mut self,
        bytes: &[u8],
        host_ns: u64,
        rx_mono_ns: u64,
    ) -> Result<Option<&Revolution>, DecodeError> {
        let pkt = DataPacket::parse(bytes, self.config.velodyne.accept_product_0x21)?;
        let mut completed = false;
        if !self.cur.is_empty()
            && let Some(reason) = self.early_cut(&pkt, host_ns)
        {
            self.complete(reason);
            completed = true;
        }
        self.add(&pkt, host_ns, rx_mono_ns);
        if self.cutter.push(pkt.azimuth(BLOCKS - 1)) {
            // A packet that completes a revolution right after an early cut cannot happen: the
            // early cut resets the coverage to zero.
            debug_assert!(!completed);
            self.complete(cut_reason::AZIMUTH);
            completed = true;
        }
        Ok(if completed { Some(&self.out) } else { None })
    }

    /// Ends the stream: returns the partial revolution collected since the last complete one,
    /// if it holds any packet. The next packet starts a new stream, cut as if the assembler were
    /// new (sequence numbers go on).
    pub fn finish(&mut self) -> Option<&Revolution> {
        let done = !self.cur.is_empty();
        if done {
            self.complete(cut_reason::END_OF_STREAM);
        }
        self.cutter.reset();
        done.then_some(&self.out)
    }

    fn early_cut(&self, pkt: &DataPacket<'_>, host_ns: u64) -> Option<u8> {
        let h = &self.cur.header;
        if pkt.return_mode() != h.return_mode || pkt.product() != h.product {
            return Some(cut_reason::MODE_CHANGE);
        }
        if self.cur.points.len() + BLOCKS * CHANNELS > self.config.max_points {
            return Some(cut_reason::CAPACITY);
        }
        let host_span = host_ns.saturating_sub(self.cur.first_host_ns);
        let sensor_span = self.sensor_offset_ns(pkt.timestamp_us());
        if host_span > self.config.max_duration_ns || sensor_span > self.config.max_duration_ns {
            return Some(cut_reason::DURATION);
        }
        None
    }

    /// Sensor time of a packet relative to the revolution's first packet, ns (a step backwards
    /// reads as almost an hour).
    fn sensor_offset_ns(&self, us: u32) -> u64 {
        let hour_us = (HOUR_NS / 1000) as i64;
        (i64::from(us) - i64::from(self.cur.first_us)).rem_euclid(hour_us) as u64 * 1000
    }

    fn add(&mut self, pkt: &DataPacket<'_>, host_ns: u64, rx_mono_ns: u64) {
        let cur = &mut self.cur;
        if cur.is_empty() {
            cur.first_us = pkt.timestamp_us();
            cur.first_host_ns = host_ns;
            cur.header.stamp_ns = resolve_top_of_hour(pkt.timestamp_us(), host_ns);
            cur.header.first_packet_seq = self.packet_seq;
            cur.header.return_mode = pkt.return_mode();
            cur.header.product = pkt.product();
        }
        let offset = self
            .sensor_offset_ns(pkt.timestamp_us())
            .min(u64::from(u32::MAX)) as u32;
        let cur = &mut self.cur;
        let c: PacketCounts = self
            .decoder
            .decode(pkt, offset, &mut cur.points, &mut cur.scan);
        let h = &mut cur.header;
        h.packet_count += 1;
        h.point_count += c.points;
        h.strongest_count += c.strongest;
        h.last_count += c.last;
        h.both_count += c.both;
        h.rx_mono_ns = rx_mono_ns;
        cur.last_azimuth = pkt.azimuth(BLOCKS - 1);
        self.packet_seq += 1;
        self.slicing.pending += 1;
    }

    fn complete(&mut self, reason: u8) {
        std::mem::swap(&mut self.cur, &mut self.out);
        self.cur.clear();
        let sl = &mut self.slicing;
        *sl = Slicing {
            tail: Some((sl.sent, sl.index)),
            ..Slicing::default()
        };
        let out = &mut self.out;
        out.header.seq = self.next_seq;
        out.header.cut_reason = reason;
        self.next_seq += 1;
        let v = &self.config.velodyne;
        out.scan_header = ScanHeader {
            seq: out.header.seq,
            stamp_ns: out.header.stamp_ns,
            rx_mono_ns: out.header.rx_mono_ns,
            count: out.scan.len() as u32,
            elevation_rad: Decoder::elevation_rad(out.header.product, usize::from(v.scan_laser)),
            laser_id: v.scan_laser,
            return_select: v.scan_return.return_type(),
            reserved: [0; 6],
        };
        if reason != cut_reason::AZIMUTH {
            // the cutter already moved on when the azimuth wrapped
            self.cutter.cut_after(out.last_azimuth);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hour_ambiguity_is_resolved_both_ways() {
        let hour = HOUR_NS;
        let base = 1000 * hour;
        // packet 10 s past the hour, host 20 s past: same hour
        assert_eq!(
            resolve_top_of_hour(10_000_000, base + 20_000_000_000),
            base + 10_000_000_000
        );
        // packet 59 min past the hour, host 1 min past the next hour: previous hour
        assert_eq!(
            resolve_top_of_hour(3_540_000_000, base + 60_000_000_000),
            base - hour + 3_540_000_000_000
        );
        // packet 1 min past, host at 59 min: next hour
        assert_eq!(
            resolve_top_of_hour(60_000_000, base + 3_540_000_000_000),
            base + hour + 60_000_000_000
        );
    }

    #[test]
    fn capacity_covers_a_slow_dual_revolution() {
        // 300 rpm dual: 0.2 s at 1507 packets/s is 302 packets of up to 384 points
        let n = max_points_per_revolution(300.0, 0.3);
        assert!(n >= 302 * 384, "{n}");
        assert!(n < 200_000, "{n}");
    }
}
