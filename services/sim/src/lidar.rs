//! The simulated VLP-16: all 16 lasers at their real elevations and firing times, spinning at a
//! configured rate, writing genuine data packets (single or dual return) and position packets.
//!
//! Timing follows the sensor's manual (and the driver's decoder): a block (single mode) or block
//! pair (dual mode) lasts 110.592 µs and holds two firing sequences of 55.296 µs; laser j fires
//! 2.304 µs × j into its sequence. Every firing is cast at its own instant and azimuth; the block
//! azimuth is the azimuth of the block's first firing. The packet timestamp is its first firing,
//! in µs past the top of the hour.

use crate::config::SimConfig;
use mimnav_shared::pose::{LidarMount, Pose2, Pose2Ext, pose2};
use mimnav_shared::topics::{DATA_PACKET_LEN, return_mode};
use mimnav_velodyne::packet::{
    BLOCKS, CHANNELS, LASERS, POSITION_PACKET_LEN, VLP16_ELEVATION_DEG, encode_data_packet,
    encode_position_packet,
};

use crate::SimSettings;
use crate::physics::{BeamCaster, Echo, MAX_RANGE_M, dual_returns, last, strongest};
use crate::world::Scene;

/// The product byte the simulated sensor writes: a VLP-16.
const PRODUCT: u8 = 0x22;

/// Duration of a block (two firing sequences), ns.
pub const BLOCK_NS: u64 = 110_592;
/// Duration of a firing sequence, ns.
pub const SEQUENCE_NS: u64 = 55_296;
/// Delay between two lasers of a sequence, ns.
pub const LASER_NS: u64 = 2_304;

/// The sensor's state: its clock, its rotation and its random draws.
#[derive(Debug)]
pub struct Vlp16 {
    /// Revolutions per minute (`velodyne.rpm`).
    rpm: f64,
    /// Return-mode byte (`sim.return_mode`).
    return_mode: u8,
    /// Height of the optical centre above the ground, m (`robot.sensor_height_m`).
    sensor_height_m: f64,
    /// The beam physics' settings (`[sim]`).
    physics: SimConfig,
    rng: fastrand::Rng,
    caster: BeamCaster,
    candidates: Vec<usize>,
    cos_elev: [f64; LASERS],
    sin_elev: [f64; LASERS],
    epoch_ns: u64,
    elapsed_ns: u64,
    /// Where the sensor sits on the robot (`robot.mount`).
    mount: LidarMount,
    /// The mount's roll and pitch (Ry·Rx), when the sensor is tilted.
    tilt: Option<[[f64; 3]; 3]>,
}

/// The rotation of a mount's roll and pitch (Ry·Rx), or `None` for a level sensor.
fn tilt(mount: &LidarMount) -> Option<[[f64; 3]; 3]> {
    (mount.roll_deg != 0.0 || mount.pitch_deg != 0.0).then(|| {
        let level = LidarMount {
            yaw_deg: 0.0,
            x_m: 0.0,
            y_m: 0.0,
            ..*mount
        };
        let m = level.isometry().rotation.to_rotation_matrix();
        std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
    })
}

/// How far off a beam may pass an object's bounding circle and still be tested: covers the
/// azimuth the lasers of one sequence sweep (0.02° at 1200 rpm) out to 100 m.
const PREFILTER_MARGIN_M: f64 = 0.05;

impl Vlp16 {
    /// A sensor whose clock starts at `epoch_ns` (ns since the Unix epoch) at azimuth 0, with
    /// random draws seeded by `seed`.
    pub fn new(settings: &SimSettings, seed: u64, epoch_ns: u64) -> Self {
        let mut cos_elev = [0.0; LASERS];
        let mut sin_elev = [0.0; LASERS];
        for (i, e) in VLP16_ELEVATION_DEG.iter().enumerate() {
            let r = f64::from(*e).to_radians();
            cos_elev[i] = r.cos();
            sin_elev[i] = r.sin();
        }
        Vlp16 {
            rpm: settings.rpm,
            return_mode: settings.sim.return_mode.byte(),
            sensor_height_m: settings.robot.sensor_height_m,
            physics: settings.sim.clone(),
            rng: fastrand::Rng::with_seed(seed),
            // the grass is drawn apart from the per-beam noise
            caster: BeamCaster::new(seed ^ 0x6772_6173_735f_6669),
            candidates: Vec::with_capacity(64),
            cos_elev,
            sin_elev,
            epoch_ns,
            elapsed_ns: 0,
            mount: settings.robot.mount,
            tilt: tilt(&settings.robot.mount),
        }
    }

    /// The sensor's pose on the ground plane when the robot's base is at `base`: the mount's
    /// offset and yaw composed onto the base's pose.
    pub fn sensor_pose(&self, base: &Pose2) -> Pose2 {
        let m = &self.mount;
        if m.x_m == 0.0 && m.y_m == 0.0 && m.yaw_deg == 0.0 {
            return *base;
        }
        base * pose2(m.x_m, m.y_m, m.yaw_deg.to_radians())
    }

    /// Time one data packet covers, ns.
    pub fn packet_period_ns(&self) -> u64 {
        if self.return_mode == return_mode::DUAL {
            6 * BLOCK_NS
        } else {
            12 * BLOCK_NS
        }
    }

    /// Sensor time of the next packet's first firing, ns since the Unix epoch.
    pub fn now_ns(&self) -> u64 {
        self.epoch_ns + self.elapsed_ns
    }

    /// Lets `dt_ns` pass without casting: the sensor spins on unseen (for runs with another
    /// sensor, [`crate::Sim::idle`]).
    pub fn idle(&mut self, dt_ns: u64) {
        self.elapsed_ns += dt_ns;
    }

    /// Azimuth at `elapsed_ns` after the epoch, degrees clockwise from forward in [0, 360).
    fn azimuth_deg(&self, elapsed_ns: u64) -> f64 {
        let deg_per_ns = self.rpm * 6.0 * 1e-9;
        (elapsed_ns as f64 * deg_per_ns).rem_euclid(360.0)
    }

    /// Casts every firing of the next packet from `pose` and encodes it; the sensor's clock moves
    /// on by one packet.
    pub fn next_packet(&mut self, scene: &Scene, base: &Pose2) -> [u8; DATA_PACKET_LEN] {
        // the loops over the firings take the sensor's position and heading as numbers, read
        // once a packet (a Pose2's heading is an atan2)
        let pose = self.sensor_pose(base);
        let (origin, yaw) = ([pose.x(), pose.y(), self.sensor_height_m], pose.yaw());
        let dual = self.return_mode == return_mode::DUAL;
        let t0 = self.elapsed_ns;
        let mut blocks = [(0u16, [(0u16, 0u8); CHANNELS]); BLOCKS];
        let firing_blocks = if dual { BLOCKS / 2 } else { BLOCKS };
        for k in 0..firing_blocks {
            let t_block = t0 + k as u64 * BLOCK_NS;
            let az_raw = (self.azimuth_deg(t_block) * 100.0).round() as u32 % 36000;
            let mut chans_a = [(0u16, 0u8); CHANNELS];
            let mut chans_b = [(0u16, 0u8); CHANNELS];
            for seq in 0..2 {
                let t_seq = t_block + seq as u64 * SEQUENCE_NS;
                self.prefilter(scene, origin, yaw, self.azimuth_deg(t_seq));
                for laser in 0..LASERS {
                    let t_fire = firing_ns(t0, k, seq, laser);
                    let az_deg = self.azimuth_deg(t_fire);
                    let (a, b) = self.fire(scene, origin, yaw, laser, az_deg, t_fire);
                    chans_a[seq * LASERS + laser] = a;
                    chans_b[seq * LASERS + laser] = b;
                }
            }
            if dual {
                blocks[2 * k] = (az_raw as u16, chans_a);
                blocks[2 * k + 1] = (az_raw as u16, chans_b);
            } else {
                blocks[k] = (az_raw as u16, chans_a);
            }
        }
        let ts_us = ((self.epoch_ns + t0) / 1000 % 3_600_000_000) as u32;
        self.elapsed_ns += self.packet_period_ns();
        encode_data_packet(ts_us, self.return_mode, PRODUCT, &blocks)
    }

    /// The beams `laser` fires in the next packet from `pose`, in firing order: the very rays
    /// [`Vlp16::next_packet`] casts for it (origin, direction and azimuth), for ground truth
    /// about what one laser can see (`mimnav foliage-eval`). `out` is cleared first; the
    /// sensor's clock does not move.
    pub fn next_beams(&self, base: &Pose2, laser: usize, out: &mut Vec<Beam>) {
        let pose = self.sensor_pose(base);
        let yaw = pose.yaw();
        out.clear();
        let laser = laser % LASERS;
        let dual = self.return_mode == return_mode::DUAL;
        let firing_blocks = if dual { BLOCKS / 2 } else { BLOCKS };
        for k in 0..firing_blocks {
            for seq in 0..2 {
                let az_deg = self.azimuth_deg(firing_ns(self.elapsed_ns, k, seq, laser));
                out.push(Beam {
                    origin: [pose.x(), pose.y(), self.sensor_height_m],
                    dir: self.direction(yaw, laser, az_deg),
                    azimuth_deg: az_deg,
                });
            }
        }
    }

    /// Unit direction of `laser`'s beam at azimuth `az_deg` (clockwise from forward) from a
    /// sensor heading `yaw` (rad).
    fn direction(&self, yaw: f64, laser: usize, az_deg: f64) -> [f64; 3] {
        let Some(r) = &self.tilt else {
            let heading = yaw - az_deg.to_radians();
            let (s, c) = heading.sin_cos();
            return [
                self.cos_elev[laser] * c,
                self.cos_elev[laser] * s,
                self.sin_elev[laser],
            ];
        };
        // in the sensor's frame, tilted by the mount's roll and pitch, then turned by the
        // sensor's heading (written out with its sine and cosine: this runs for every beam)
        let (s, c) = (-az_deg.to_radians()).sin_cos();
        let d = [
            self.cos_elev[laser] * c,
            self.cos_elev[laser] * s,
            self.sin_elev[laser],
        ];
        let t: [f64; 3] = std::array::from_fn(|i| r[i][0] * d[0] + r[i][1] * d[1] + r[i][2] * d[2]);
        let (s, c) = yaw.sin_cos();
        [c * t[0] - s * t[1], s * t[0] + c * t[1], t[2]]
    }

    /// Objects whose bounding circle the beam at azimuth `az_deg` from a sensor at `origin`
    /// heading `yaw` passes near.
    fn prefilter(&mut self, scene: &Scene, origin: [f64; 3], yaw: f64, az_deg: f64) {
        let heading = yaw - az_deg.to_radians();
        let (uy, ux) = heading.sin_cos();
        self.candidates.clear();
        if self.tilt.is_some() {
            // a tilted beam leaves the vertical plane of its azimuth: test every object
            self.candidates.extend(0..scene.objects.len());
            return;
        }
        for (i, obj) in scene.objects.iter().enumerate() {
            let (c, r) = obj.bound;
            let (dx, dy) = (c[0] - origin[0], c[1] - origin[1]);
            let along = dx * ux + dy * uy;
            let r = r + PREFILTER_MARGIN_M;
            if along < -r || along > MAX_RANGE_M + r {
                continue;
            }
            let across = (dx * uy - dy * ux).abs();
            if across <= r {
                self.candidates.push(i);
            }
        }
    }

    /// One laser's firing: the (even, odd) block channel records.
    fn fire(
        &mut self,
        scene: &Scene,
        origin: [f64; 3],
        yaw: f64,
        laser: usize,
        az_deg: f64,
        elapsed_ns: u64,
    ) -> ((u16, u8), (u16, u8)) {
        let d = self.direction(yaw, laser, az_deg);
        let echoes = self.caster.cast(
            scene,
            &self.candidates,
            origin,
            d,
            elapsed_ns as f64 * 1e-9,
            &self.physics,
            &mut self.rng,
        );
        let rec = |e: Option<Echo>| match e {
            Some(e) if e.range > 0.0 => (
                (e.range / 0.002).round().clamp(1.0, 65535.0) as u16,
                e.intensity.round().clamp(0.0, 255.0) as u8,
            ),
            _ => (0, 0),
        };
        match self.return_mode {
            return_mode::DUAL => match dual_returns(echoes) {
                Some((l, s)) => (rec(Some(l)), rec(Some(s))),
                None => ((0, 0), (0, 0)),
            },
            return_mode::LAST => {
                let r = rec(last(echoes));
                (r, r)
            }
            _ => {
                let r = rec(strongest(echoes));
                (r, r)
            }
        }
    }

    /// A position packet stamped `t_ns` (ns since the Unix epoch): PPS locked, a GPRMC
    /// sentence with the time and date.
    pub fn position_packet(t_ns: u64) -> [u8; POSITION_PACKET_LEN] {
        let secs = t_ns / 1_000_000_000;
        let days = (secs / 86_400) as i64;
        let tod = secs % 86_400;
        let (y, m, d) = civil_from_days(days);
        let body = format!(
            "GPRMC,{:02}{:02}{:02},A,0000.0000,N,00000.0000,E,000.0,000.0,{:02}{:02}{:02},000.0,E,A",
            tod / 3600,
            tod / 60 % 60,
            tod % 60,
            d,
            m,
            y % 100
        );
        let checksum = body.bytes().fold(0u8, |a, b| a ^ b);
        let sentence = format!("${body}*{checksum:02X}");
        encode_position_packet(((t_ns / 1000) % 3_600_000_000) as u32, 2, &sentence)
    }
}

/// Time of `laser`'s firing in sequence `seq` (0 or 1) of firing block `k` of the packet whose
/// first firing is at `t0_ns` (ns since the sensor's epoch).
fn firing_ns(t0_ns: u64, k: usize, seq: usize, laser: usize) -> u64 {
    t0_ns + k as u64 * BLOCK_NS + seq as u64 * SEQUENCE_NS + laser as u64 * LASER_NS
}

/// One laser firing's beam (see [`Vlp16::next_beams`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Beam {
    /// The sensor's optical centre, m (world frame).
    pub origin: [f64; 3],
    /// Unit direction (world frame).
    pub dir: [f64; 3],
    /// Azimuth of the firing, degrees clockwise from forward, in [0, 360).
    pub azimuth_deg: f64,
}

/// (year, month, day) of a day count since 1970-01-01 (H. Hinnant's algorithm).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (if m <= 2 { y + 1 } else { y }, m, d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use mimnav_velodyne::packet::PositionPacket;

    #[test]
    fn position_packets_carry_a_valid_gprmc() {
        // 2026-01-01 12:34:56 UTC
        let t = 1_767_270_896u64 * 1_000_000_000;
        let p = PositionPacket::parse(&Vlp16::position_packet(t)).expect("parses");
        assert_eq!(p.gprmc_unix_s(), Some(1_767_270_896.0));
        assert_eq!(
            p.timestamp_us,
            ((1_767_270_896u64 % 3600) * 1_000_000) as u32
        );
    }
}
