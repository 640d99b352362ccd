//! `[velodyne]`: the VLP-16 driver.

use std::net::IpAddr;
use std::path::PathBuf;

use serde::Deserialize;

use mimnav_shared::config::{Checks, Invalid};

/// Where the driver's datagrams come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum VelodyneInput {
    /// A UDP socket: a live sensor, or a simulator streaming.
    Udp,
    /// A pcap or pcapng capture (`velodyne.pcap`).
    Pcap,
}

/// Which return of a dual pair the planar scan takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ScanReturnSelect {
    /// The strongest return (odd blocks in dual mode).
    Strongest,
    /// The last return (even blocks in dual mode).
    Last,
}

impl ScanReturnSelect {
    /// The return type ([`mimnav_shared::topics::return_type`]) a scan header names this choice by.
    pub fn return_type(self) -> u8 {
        use mimnav_shared::topics::return_type;
        match self {
            ScanReturnSelect::Strongest => return_type::STRONGEST,
            ScanReturnSelect::Last => return_type::LAST,
        }
    }
}

/// Most packets `velodyne.slice_packets` may ask for (a slice's capacity on `lidar/slices`).
pub const MAX_SLICE_PACKETS: u32 = 64;

/// The VLP-16 driver (`[velodyne]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VelodyneConfig {
    /// `udp` or `pcap`.
    pub input: VelodyneInput,
    /// Address the UDP sockets bind to.
    pub bind_address: IpAddr,
    /// UDP port of the data packets.
    pub data_port: u16,
    /// UDP port of the position packets; 0 does not listen for them.
    pub position_port: u16,
    /// Accept datagrams from this sender only (the sensor's address).
    pub allowed_source: Option<IpAddr>,
    /// UDP receive buffer asked of the kernel, bytes.
    pub recv_buffer_bytes: usize,
    /// Capture file replayed when `input = "pcap"`.
    pub pcap: Option<PathBuf>,
    /// Replay speed factor (1.0 is real time).
    pub replay_speed: f64,
    /// Replay as fast as possible instead of by the capture's timestamps.
    pub replay_fast: bool,
    /// Start the capture over when it ends.
    pub replay_loop: bool,
    /// Gaps in the capture longer than this are shortened to it, seconds.
    pub replay_max_gap_s: f64,
    /// After a capture ends, keep the topics open this long so subscribers can take the last
    /// samples, then exit; seconds.
    pub replay_linger_s: f64,
    /// Sensor rotation rate, revolutions per minute (the sensor's own setting, 300–1200).
    pub rpm: f64,
    /// Cut revolutions where the azimuth passes this angle (degrees, clockwise from forward);
    /// unset: wherever a full turn completes.
    pub cut_azimuth_deg: Option<f64>,
    /// Drop returns nearer than this, metres.
    pub min_range_m: f64,
    /// Drop returns farther than this, metres.
    pub max_range_m: f64,
    /// Decode product byte 0x21 (early VLP-16 firmware) as a VLP-16.
    pub accept_product_0x21: bool,
    /// Laser id (0–15, firing order) published as the planar scan; 14 is the −1° laser.
    pub scan_laser: u8,
    /// Return of a dual pair the planar scan takes: `last` (default: the foliage classifier sees
    /// an obstacle behind grass through the beams that reach it) or `strongest`.
    pub scan_return: ScanReturnSelect,
    /// Publish every raw datagram on `lidar/packets`.
    pub publish_packets: bool,
    /// Packets per `lidar/slices` sample: the mapper bins a revolution while it arrives, this
    /// many packets at a time (the revolution's last slice holds what is left); 0: no slices,
    /// the mapper maps each revolution from `lidar/points` once it is whole.
    pub slice_packets: u32,
    /// While the revolution's end is further away than this and a margin, the driver reads the
    /// socket once every this many milliseconds — the datagrams wait in the kernel's buffer —
    /// instead of waking for each one; near the end it wakes for each, so the revolution's last
    /// packet is read as it arrives ([`crate::pace`]). 0: wake for each datagram.
    pub pace_ms: f64,
    /// Interval of the statistics log line, seconds.
    pub stats_interval_s: f64,
}

impl Default for VelodyneConfig {
    fn default() -> Self {
        VelodyneConfig {
            input: VelodyneInput::Udp,
            bind_address: IpAddr::from([0, 0, 0, 0]),
            data_port: 2368,
            position_port: 8308,
            allowed_source: None,
            recv_buffer_bytes: 4 << 20,
            pcap: None,
            replay_speed: 1.0,
            replay_fast: false,
            replay_loop: false,
            replay_max_gap_s: 1.0,
            replay_linger_s: 2.0,
            rpm: 600.0,
            cut_azimuth_deg: None,
            min_range_m: 0.1,
            max_range_m: 200.0,
            accept_product_0x21: false,
            scan_laser: 14,
            scan_return: ScanReturnSelect::Last,
            publish_packets: false,
            slice_packets: 4,
            pace_ms: 5.0,
            stats_interval_s: 10.0,
        }
    }
}

impl VelodyneConfig {
    /// Checks every key of `[velodyne]`: each value refused names its key and what is allowed.
    pub fn validate(&self) -> Result<(), Invalid> {
        let mut r = Checks::default();
        r.check("velodyne.replay_speed", self.replay_speed, 0.01, 100.0);
        r.check(
            "velodyne.replay_max_gap_s",
            self.replay_max_gap_s,
            0.001,
            3600.0,
        );
        r.check("velodyne.replay_linger_s", self.replay_linger_s, 0.0, 60.0);
        r.check("velodyne.rpm", self.rpm, 300.0, 1200.0);
        if let Some(c) = self.cut_azimuth_deg {
            r.check("velodyne.cut_azimuth_deg", c, 0.0, 359.99);
        }
        r.check("velodyne.min_range_m", self.min_range_m, 0.0, 200.0);
        r.check("velodyne.max_range_m", self.max_range_m, 0.1, 200.0);
        r.require(
            self.min_range_m < self.max_range_m,
            "velodyne.min_range_m",
            format!(
                "velodyne.min_range_m = {} must be below velodyne.max_range_m = {}",
                self.min_range_m, self.max_range_m
            ),
        );
        r.check("velodyne.scan_laser", f64::from(self.scan_laser), 0.0, 15.0);
        r.check(
            "velodyne.slice_packets",
            f64::from(self.slice_packets),
            0.0,
            f64::from(MAX_SLICE_PACKETS),
        );
        r.check("velodyne.pace_ms", self.pace_ms, 0.0, 20.0);
        r.check(
            "velodyne.stats_interval_s",
            self.stats_interval_s,
            0.1,
            3600.0,
        );
        r.check(
            "velodyne.data_port",
            f64::from(self.data_port),
            1.0,
            65535.0,
        );
        r.require(
            self.input != VelodyneInput::Pcap || self.pcap.is_some(),
            "velodyne.pcap",
            "velodyne.input = \"pcap\" needs velodyne.pcap = \"FILE\"",
        );
        r.finish()
    }
}
