//! The topic contract: every payload that crosses a process boundary, and the name of every topic.
//!
//! Each payload is `#[repr(C)]`, holds no pointer or heap data, derives [`ZeroCopySend`] and
//! carries an explicit, versioned `type_name`. Changing the layout of a type means bumping the
//! version in its name: iceoryx2 then refuses to connect an old process to a new one instead of
//! letting it read garbage.
//!
//! `docs/topics.md` documents this contract for clients outside the workspace (service names,
//! layouts with offsets, QoS, event ids); `tests/topics_doc.rs` fails when the two disagree.
//!
//! Every message carries a sequence number and timestamps so latency and drops can be measured
//! end to end (DESIGN §2):
//! - `stamp_ns`: the sensor's (or simulator's) time of the data, nanoseconds since the Unix epoch;
//! - `rx_mono_ns`: `CLOCK_MONOTONIC` when the data entered the stack (the same clock in every
//!   process on the machine, so differences between processes are meaningful).

use iceoryx2::prelude::ZeroCopySend;

/// Topic of one assembled lidar revolution: `[Point]` with a [`PointsHeader`].
pub const LIDAR_POINTS: &str = "mimnav/lidar/points";
/// Topic of a revolution's points as the driver assembles them, a few packets at a time:
/// `[Point]` with a [`SliceHeader`]. The mapper bins them while the revolution arrives; the
/// whole revolution still follows on [`LIDAR_POINTS`].
pub const LIDAR_SLICES: &str = "mimnav/lidar/slices";
/// Topic of one laser of a revolution as a planar scan: `[ScanReturn]` with a [`ScanHeader`].
pub const LIDAR_SCAN2D: &str = "mimnav/lidar/scan2d";
/// Topic of the raw sensor packets, one [`RawPacket`] per datagram (optional, off by default).
pub const LIDAR_PACKETS: &str = "mimnav/lidar/packets";

/// Event id a publisher notifies with after it sent a sample.
pub const EVENT_NEW_DATA: usize = 0;
/// Event id a replaying source notifies with once its capture has ended and every sample of it
/// was sent; receivers can stop waiting.
pub const EVENT_END_OF_STREAM: usize = 1;

/// Return-type bits of a [`Point`] and a [`ScanReturn`].
pub mod return_type {
    /// The strongest return of the firing (single-return mode 0x37, or the odd block in dual mode).
    pub const STRONGEST: u8 = 1;
    /// The last return of the firing (single-return mode 0x38, or the even block in dual mode).
    pub const LAST: u8 = 2;
    /// Both: in dual mode the two blocks hold the same distance, so the firing had one return.
    pub const BOTH: u8 = STRONGEST | LAST;
    /// The first (nearest) echo of a multi-echo planar ladar (`sick.echo = "first"`); a SICK
    /// scan taken with `sick.echo = "last"` carries [`LAST`].
    pub const FIRST: u8 = 4;
}

/// One lidar return in the sensor frame (REP-103: x forward, y left, z up; metres).
///
/// 24 bytes. `z` is `d·sin(elevation)` measured from the sensor's optical centre, without the
/// per-laser vertical offset some decoders add.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("mimnav/Point/v1")]
pub struct Point {
    /// Forward, metres.
    pub x: f32,
    /// Left, metres.
    pub y: f32,
    /// Up, metres.
    pub z: f32,
    /// Firing time relative to the revolution's `stamp_ns`, nanoseconds.
    pub time_offset_ns: u32,
    /// Raw distance in the sensor's 2 mm units (never 0: a missing return is not a point).
    pub distance_raw: u16,
    /// Interpolated azimuth of the firing, hundredths of a degree in [0, 36000), clockwise seen
    /// from above (the sensor's own convention).
    pub azimuth_cdeg: u16,
    /// Calibrated reflectivity byte: 0–100 diffuse, 101–255 retro-reflectors.
    pub intensity: u8,
    /// Laser id within a firing sequence, 0–15 (firing order).
    pub laser_id: u8,
    /// Ring, 0–15 ordered by elevation (−15° is 0, +15° is 15).
    pub ring: u8,
    /// [`return_type`] bits.
    pub return_type: u8,
}

impl Point {
    /// Distance from the optical centre, metres.
    pub fn distance_m(&self) -> f32 {
        f32::from(self.distance_raw) * 0.002
    }
}

/// Sensor return mode as the packet's byte 1204 says.
pub mod return_mode {
    /// Strongest return only.
    pub const STRONGEST: u8 = 0x37;
    /// Last return only.
    pub const LAST: u8 = 0x38;
    /// Dual return: last and strongest.
    pub const DUAL: u8 = 0x39;
}

/// User header of a `lidar/points` sample: one revolution.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("mimnav/PointsHeader/v1")]
pub struct PointsHeader {
    /// Revolution sequence number, counting from 0 at the driver's start.
    pub seq: u64,
    /// Sensor time of the revolution's first firing, ns since the Unix epoch.
    pub stamp_ns: u64,
    /// `CLOCK_MONOTONIC` when the revolution's last packet arrived in the host's kernel (or was
    /// replayed), ns.
    pub rx_mono_ns: u64,
    /// Sequence number (data packets since start) of the revolution's first packet.
    pub first_packet_seq: u64,
    /// Number of data packets in the revolution.
    pub packet_count: u32,
    /// Number of points in the payload.
    pub point_count: u32,
    /// Points with the strongest return only.
    pub strongest_count: u32,
    /// Points with the last return only.
    pub last_count: u32,
    /// Points that are both (dual mode, identical blocks).
    pub both_count: u32,
    /// Return mode byte of the revolution's packets (see [`return_mode`]).
    pub return_mode: u8,
    /// Product byte of the revolution's packets (0x22 VLP-16).
    pub product: u8,
    /// Why the revolution ended (see [`cut_reason`]).
    pub cut_reason: u8,
    /// Reserved, zero.
    pub reserved: u8,
}

/// User header of a `lidar/slices` sample: the next whole packets of a revolution.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("mimnav/SliceHeader/v1")]
pub struct SliceHeader {
    /// The revolution's header as far as it is assembled: `seq`, `stamp_ns`, `first_packet_seq`,
    /// `return_mode` and `product` hold from the first slice on, the counts and `rx_mono_ns`
    /// grow; in the last slice it is the header `lidar/points` carries.
    pub revolution: PointsHeader,
    /// The slice's number within its revolution, from 0.
    pub index: u32,
    /// Index within the revolution of the slice's first point.
    pub first_point: u32,
    /// 1 in the revolution's last slice (which may hold no point), else 0.
    pub last: u8,
    /// Reserved, zero.
    pub reserved: [u8; 7],
}

/// Why a revolution was cut where it was ([`PointsHeader::cut_reason`]).
pub mod cut_reason {
    /// The azimuth passed the cut (a full turn): the normal case.
    pub const AZIMUTH: u8 = 0;
    /// Too long since the revolution's first packet (a gap in the stream or a slow sensor).
    pub const DURATION: u8 = 1;
    /// The next packet would not fit in the payload's capacity.
    pub const CAPACITY: u8 = 2;
    /// The return mode or product changed mid-revolution.
    pub const MODE_CHANGE: u8 = 3;
    /// The stream ended (end of a capture): the revolution may be partial.
    pub const END_OF_STREAM: u8 = 4;
}

/// One firing of the chosen laser in a planar scan.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("mimnav/ScanReturn/v1")]
pub struct ScanReturn {
    /// Bearing in the sensor frame, radians, counter-clockwise from x (REP-103), in (−π, π].
    pub angle_rad: f32,
    /// Horizontal range (distance · cos(elevation)), metres; 0 means no return.
    pub range_m: f32,
    /// Reflectivity byte, 0 where there is no return.
    pub intensity: u8,
    /// [`return_type`] bits of the return used, 0 where there is none.
    pub return_type: u8,
    /// Reserved, zero.
    pub reserved: [u8; 2],
}

/// User header of a `lidar/scan2d` sample.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("mimnav/ScanHeader/v1")]
pub struct ScanHeader {
    /// Sequence number of the revolution ([`PointsHeader::seq`]) the scan was taken from.
    pub seq: u64,
    /// Sensor time of the scan's first firing, ns since the Unix epoch.
    pub stamp_ns: u64,
    /// `CLOCK_MONOTONIC` when the revolution's last packet was received, ns.
    pub rx_mono_ns: u64,
    /// Number of returns in the payload, one per firing of the laser, in firing order.
    pub count: u32,
    /// Elevation of the laser, radians.
    pub elevation_rad: f32,
    /// Laser id (0–15) the scan was taken from.
    pub laser_id: u8,
    /// Which return was used: [`return_type::STRONGEST`] or [`return_type::LAST`].
    pub return_select: u8,
    /// Reserved, zero.
    pub reserved: [u8; 6],
}

/// Size of a VLP-16 data packet's UDP payload.
pub const DATA_PACKET_LEN: usize = 1206;

/// One raw sensor datagram, as received.
#[derive(Debug, Clone, Copy, ZeroCopySend)]
#[repr(C)]
#[type_name("mimnav/RawPacket/v1")]
pub struct RawPacket {
    /// Data-packet sequence number since the driver's start.
    pub seq: u64,
    /// Host receive time (or capture timestamp when replaying), ns since the Unix epoch.
    pub host_ns: u64,
    /// `CLOCK_MONOTONIC` when the packet was received (or replayed), ns.
    pub rx_mono_ns: u64,
    /// Bytes used in `data`.
    pub len: u32,
    /// UDP destination port the packet came to.
    pub port: u16,
    /// Reserved, zero.
    pub reserved: [u8; 2],
    /// The UDP payload.
    pub data: [u8; DATA_PACKET_LEN],
}

impl Default for RawPacket {
    fn default() -> Self {
        Self {
            seq: 0,
            host_ns: 0,
            rx_mono_ns: 0,
            len: 0,
            port: 0,
            reserved: [0; 2],
            data: [0; DATA_PACKET_LEN],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn payload_layouts_are_stable() {
        // A change here changes the wire format: bump the type_name version with it.
        assert_eq!(core::mem::size_of::<Point>(), 24);
        assert_eq!(core::mem::size_of::<ScanReturn>(), 12);
        assert_eq!(core::mem::size_of::<PointsHeader>(), 56);
        assert_eq!(core::mem::size_of::<SliceHeader>(), 72);
        assert_eq!(core::mem::size_of::<ScanHeader>(), 40);
        assert_eq!(core::mem::size_of::<FoliageReturn>(), 12);
        assert_eq!(core::mem::size_of::<BaseState>(), 48);
        assert_eq!(
            core::mem::size_of::<FoliageHeader>(),
            56 + 4 * MAX_FOLIAGE_SECTORS
        );
    }
}

/// Topic of the planner's velocity commands: [`VelocityCommand`].
pub const CMD_VEL: &str = "mimnav/cmd_vel";
/// Topic of the robot's odometry: [`Odometry`].
pub const ODOM: &str = "mimnav/odom";
/// Topic of the simulator's ground truth: `[u8]` cell classes with a [`TruthHeader`].
pub const SIM_TRUTH: &str = "mimnav/sim/truth";

/// Status of a [`VelocityCommand`].
pub mod command_status {
    /// Driving towards the goal.
    pub const DRIVING: u8 = 0;
    /// The goal is reached: zero velocity.
    pub const GOAL_REACHED: u8 = 1;
    /// No feasible motion: zero velocity.
    pub const BLOCKED: u8 = 2;
    /// An input is older than allowed: zero velocity.
    pub const STALE_INPUT: u8 = 3;
    /// No goal: zero velocity.
    pub const NO_GOAL: u8 = 4;
}

/// Bits of [`VelocityCommand::flags`].
pub mod command_flags {
    /// The foliage classifier raised its alarm (an obstacle that is not foliage is in range):
    /// the planner took its obstacles as solid.
    pub const FOLIAGE_ALARM: u8 = 1;
    /// The map holds no route to the goal for the robot's body: the planner drives on slowly by
    /// the straight line, and with the `blocked` status it has stopped after
    /// `planner.no_route_stop_s` (as opposed to no feasible motion this instant).
    pub const NO_ROUTE: u8 = 2;
    /// The robot is backing out: the dynamic window held it still (a long body beside glass or
    /// a wall it could not turn away from) for `planner.recovery_after_s`, so it moves back
    /// (v < 0) for `planner.recovery_s`; with the `blocked` status it has stopped after
    /// `planner.recovery_max` tries without getting nearer the goal.
    pub const BACKING_OUT: u8 = 4;
    /// The robot is going to look at suspected glass its route leads into: it drives beside the
    /// pane's line so its beams meet the unseen stretch squarely (`planner.look_after_s`).
    pub const LOOKING: u8 = 8;
    /// The robot is squeezing through: its route led it no nearer the goal for
    /// `planner.tight_after_s`, so it plans with `planner.tight_margin_m` instead of
    /// `planner.margin_m`, slowly, for `planner.tight_s` (a gap the body fits with less than
    /// the margin each side).
    pub const TIGHT: u8 = 16;
    /// The robot is following a way out by straight moves forward and back and turns on the
    /// spot: the dynamic window held a long body still (a door in the side of a corridor it
    /// came past) for `planner.recovery_after_s`, and a search over its poses found a way on
    /// (`planner.maneuver_s`).
    pub const MANEUVERING: u8 = 32;
}

/// A velocity command for the base (REP-103: v forward, ω counter-clockwise).
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("mimnav/VelocityCommand/v2")]
pub struct VelocityCommand {
    /// Command sequence number.
    pub seq: u64,
    /// `CLOCK_MONOTONIC` when the command was computed, ns.
    pub stamp_mono_ns: u64,
    /// Sensor stamp (`stamp_ns`) of the revolution the command was computed from.
    pub source_stamp_ns: u64,
    /// Sequence number of the revolution the command was computed from.
    pub source_seq: u64,
    /// `CLOCK_MONOTONIC` time after which the base must stop if no newer command came, ns.
    pub valid_until_mono_ns: u64,
    /// Forward speed, m/s.
    pub v: f32,
    /// Turn rate, rad/s.
    pub omega: f32,
    /// [`command_status`].
    pub status: u8,
    /// [`command_flags`] bits.
    pub flags: u8,
    /// Reserved, zero.
    pub reserved: [u8; 6],
}

/// The robot's 2-D pose and velocity in the fixed odometry frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("mimnav/Odometry/v1")]
pub struct Odometry {
    /// Sequence number.
    pub seq: u64,
    /// Time of the pose, ns since the Unix epoch (the sensor's clock).
    pub stamp_ns: u64,
    /// `CLOCK_MONOTONIC` when it was published, ns.
    pub rx_mono_ns: u64,
    /// Position, metres.
    pub x: f64,
    /// Position, metres.
    pub y: f64,
    /// Heading, radians counter-clockwise from x.
    pub yaw: f64,
    /// Forward speed, m/s.
    pub v: f32,
    /// Turn rate, rad/s.
    pub omega: f32,
}

/// Class of a map cell, in ground truth and in the mapper's output.
pub mod cell_class {
    /// Observed and empty.
    pub const FREE: u8 = 0;
    /// A solid obstacle (wall, pillar, trunk, rock, bush).
    pub const SOLID: u8 = 1;
    /// Passable although it returns light (tall grass, string curtain).
    pub const PASSABLE: u8 = 2;
    /// Glass.
    pub const GLASS: u8 = 3;
    /// Never observed (or outside the world).
    pub const UNKNOWN: u8 = 4;
    /// Glass drawn along a pane's fitted line where the pane itself has not been seen: the
    /// stretch may be glass or an opening until a beam meets it squarely (issue 22). Only the
    /// mapper's planning map holds it, never ground truth. Kept off like glass by the dynamic
    /// window; the route may cross it at a cost, so the robot goes to look.
    pub const SUSPECTED_GLASS: u8 = 5;

    /// Glass seen or suspected: what the robot must not drive into.
    pub fn is_glass(class: u8) -> bool {
        class == GLASS || class == SUSPECTED_GLASS
    }

    /// Solid, glass or suspected glass: a cell the body must not touch.
    pub fn blocks(class: u8) -> bool {
        class == SOLID || is_glass(class)
    }
}

/// User header of a `sim/truth` sample: the true class of every map cell around the robot.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("mimnav/TruthHeader/v1")]
pub struct TruthHeader {
    /// Simulated revolution number.
    pub seq: u64,
    /// Sensor stamp of the revolution's first firing, ns since the Unix epoch (matches the
    /// driver's `PointsHeader::stamp_ns` for the same revolution).
    pub stamp_ns: u64,
    /// Robot pose in the world when the revolution started.
    pub x: f64,
    /// Robot pose.
    pub y: f64,
    /// Robot heading.
    pub yaw: f64,
    /// Cells per side of the square grid.
    pub cells: u32,
    /// Cell size, metres.
    pub cell_m: f32,
}

/// Topic of the multi-layer intensity map: `[f32]` with a [`MapHeader`].
pub const MAP_LAYERS: &str = "mimnav/map/layers";
/// Topic of the planning map: `[PlanCell]` with a [`MapHeader`].
pub const MAP_PLAN: &str = "mimnav/map/plan";

/// [`MapHeader::status`] bits.
pub mod map_status {
    /// No odometry has arrived yet: the glass memory cannot be placed.
    pub const ODOM_MISSING: u8 = 1;
    /// The latest odometry is older than allowed: the glass memory was not moved.
    pub const ODOM_STALE: u8 = 2;
}

/// User header of `map/layers` and `map/plan`: which revolution and odometry a map was built
/// from, and the grid.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("mimnav/MapHeader/v1")]
pub struct MapHeader {
    /// Map sequence number.
    pub seq: u64,
    /// Sequence number of the revolution ([`PointsHeader::seq`]) it was built from.
    pub source_seq: u64,
    /// Sensor stamp of that revolution.
    pub stamp_ns: u64,
    /// `CLOCK_MONOTONIC` when that revolution's last packet was received, ns.
    pub rx_mono_ns: u64,
    /// Sequence number of the odometry used (0 with [`map_status::ODOM_MISSING`]).
    pub odom_seq: u64,
    /// Stamp of the odometry used.
    pub odom_stamp_ns: u64,
    /// Odometry pose used: x, m.
    pub x: f64,
    /// Odometry pose used: y, m.
    pub y: f64,
    /// Odometry pose used: heading, rad.
    pub yaw: f64,
    /// Cells per side.
    pub cells: u32,
    /// Cell size, m.
    pub cell_m: f32,
    /// Number of layers (in `map/layers`).
    pub layers: u32,
    /// Time the mapper spent on this revolution, µs.
    pub processing_us: u32,
    /// [`map_status`] bits.
    pub status: u8,
    /// Reserved, zero.
    pub reserved: [u8; 7],
}

/// One cell of the planning map.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, ZeroCopySend)]
#[repr(C)]
#[type_name("mimnav/PlanCell/v2")]
pub struct PlanCell {
    /// [`cell_class`].
    pub class: u8,
    /// Planning cost, 0–255 for 0–1: free 0, passable small, solid, glass and suspected glass 255.
    pub cost: u8,
}

/// Topic of the navigation goal: [`Goal`].
pub const GOAL: &str = "mimnav/goal";

/// A goal in the odometry frame, or a stop request ([`goal_flags::STOP`]).
///
/// v2 (issue 25) added `flags` so that a stop request from the network travels on the same
/// topic as goals, in order with them: the newest message wins.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("mimnav/Goal/v2")]
pub struct Goal {
    /// Goal sequence number (a new goal replaces the old one).
    pub seq: u64,
    /// `CLOCK_MONOTONIC` when it was sent, ns.
    pub stamp_mono_ns: u64,
    /// Position, m, odometry frame.
    pub x: f64,
    /// Position, m, odometry frame.
    pub y: f64,
    /// Reached within this distance, m.
    pub tolerance_m: f64,
    /// [`goal_flags`]; 0 for a goal.
    pub flags: u8,
    /// Zero.
    pub reserved: [u8; 7],
}

/// Bits of [`Goal::flags`].
pub mod goal_flags {
    /// A stop request, not a goal: the planner drops its goal and holds zero velocity (status
    /// `NO_GOAL`) until a new goal comes; x, y and the tolerance are ignored.
    pub const STOP: u8 = 1;
}

/// Topic of the robot base's state: [`BaseState`], published by the base's service
/// (`mimnav-kobuki`, `mimnav-spot`) with every feedback and when the link changes.
pub const BASE_STATE: &str = "mimnav/base/state";

/// [`BaseState::base`]: which base published it.
pub mod base_kind {
    /// The Turtlebot 2's Kobuki base.
    pub const KOBUKI: u8 = 1;
    /// Boston Dynamics Spot.
    pub const SPOT: u8 = 2;
}

/// [`BaseState::link`].
pub mod base_link {
    /// The base answers.
    pub const UP: u8 = 0;
    /// The device or connection is gone (unplugged, server down): nothing moves until it is back.
    pub const DOWN: u8 = 1;
}

/// Bits of [`BaseState::halted`]: why the base refuses (some) motion now. Zero: it follows
/// `cmd_vel`.
pub mod base_halt {
    /// A bumper is pressed: forward motion refused (backing off and turning allowed).
    pub const BUMPER: u16 = 1;
    /// A cliff sensor sees no floor: forward motion refused.
    pub const CLIFF: u16 = 2;
    /// A wheel has dropped (the robot is lifted): every motion refused.
    pub const WHEEL_DROP: u16 = 4;
    /// The last `cmd_vel` expired (`valid_until_mono_ns` passed) or none came: stopped.
    pub const COMMAND_EXPIRED: u16 = 8;
    /// The link to the base is down.
    pub const LINK_DOWN: u16 = 16;
    /// An e-stop is engaged (Spot).
    pub const ESTOP: u16 = 32;
    /// The lease is lost (Spot).
    pub const NO_LEASE: u16 = 64;
    /// The motors are off (Spot not powered or not standing).
    pub const MOTORS_OFF: u16 = 128;
    /// A wheel's motor drew too much current (Kobuki).
    pub const OVER_CURRENT: u16 = 256;
}

/// The robot base's state: its safety sensors, its link and why it refuses motion.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("mimnav/BaseState/v1")]
pub struct BaseState {
    /// Sequence number.
    pub seq: u64,
    /// `CLOCK_MONOTONIC` when the feedback it reports was received, ns.
    pub rx_mono_ns: u64,
    /// The base's own timestamp of that feedback, ms (Kobuki: wraps at 65536), 0 when none.
    pub base_stamp_ms: u32,
    /// Battery voltage, V (NaN when unknown).
    pub battery_v: f32,
    /// [`base_halt`] bits.
    pub halted: u16,
    /// [`base_kind`].
    pub base: u8,
    /// [`base_link`].
    pub link: u8,
    /// Bumpers pressed (Kobuki bits: 1 right, 2 centre, 4 left).
    pub bumper: u8,
    /// Cliff sensors without floor (1 right, 2 centre, 4 left).
    pub cliff: u8,
    /// Wheels dropped (1 right, 2 left).
    pub wheel_drop: u8,
    /// Buttons pressed (Kobuki: 1 B0, 2 B1, 4 B2).
    pub buttons: u8,
    /// Charger state as the base reports it (Kobuki: 0 discharging, 2 docking charged,
    /// 6 docking charging, 18 adapter charged, 22 adapter charging).
    pub charger: u8,
    /// Wheels over current (1 left, 2 right).
    pub over_current: u8,
    /// Reserved, zero.
    pub reserved: [u8; 6],
    /// Frames or messages from the base rejected since the service started (bad checksum,
    /// malformed, refused).
    pub rejected: u32,
    /// Times the link went down since the service started.
    pub link_losses: u32,
}

/// Topic of the foliage classifier's verdicts, one per planar scan: `[FoliageReturn]` with a
/// [`FoliageHeader`].
pub const FOLIAGE_ALARM: &str = "mimnav/foliage/alarm";

/// Most sectors a [`FoliageHeader`] carries (5° sectors).
pub const MAX_FOLIAGE_SECTORS: usize = 72;

/// Class of a return in a [`FoliageReturn`].
pub mod foliage_class {
    /// No return.
    pub const NO_RETURN: u8 = 0;
    /// Foliage (or anything the classifier does not take for an obstacle).
    pub const FOLIAGE: u8 = 1;
    /// An obstacle that is not foliage: the alarm.
    pub const OBSTACLE: u8 = 2;
    /// An obstacle candidate held back (seen once, thin, or out of range).
    pub const PRUNED: u8 = 3;
}

/// User header of a `foliage/alarm` sample.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("mimnav/FoliageHeader/v1")]
pub struct FoliageHeader {
    /// Verdict sequence number.
    pub seq: u64,
    /// Sequence number of the scan ([`ScanHeader::seq`], the revolution's).
    pub source_seq: u64,
    /// Sensor time of the scan ([`ScanHeader::stamp_ns`]).
    pub stamp_ns: u64,
    /// `CLOCK_MONOTONIC` when the revolution's last packet was received, ns.
    pub rx_mono_ns: u64,
    /// Returns in the payload (one per return of the scan, in its order).
    pub count: u32,
    /// Sectors in `nearest_m`.
    pub sectors: u32,
    /// Returns classed [`foliage_class::OBSTACLE`].
    pub obstacles: u32,
    /// Time the classifier took, µs.
    pub processing_us: u32,
    /// 1: an obstacle that is not foliage is in range (the alarm).
    pub alarm: u8,
    /// Laser id of the scan.
    pub laser_id: u8,
    /// Reserved, zero.
    pub reserved: [u8; 6],
    /// R_s: the nearest obstacle's range per sector, m (sector k spans bearings
    /// −π + k·2π/sectors onwards); infinite where there is none.
    pub nearest_m: [f32; MAX_FOLIAGE_SECTORS],
}

impl Default for FoliageHeader {
    fn default() -> Self {
        FoliageHeader {
            seq: 0,
            source_seq: 0,
            stamp_ns: 0,
            rx_mono_ns: 0,
            count: 0,
            sectors: 0,
            obstacles: 0,
            processing_us: 0,
            alarm: 0,
            laser_id: 0,
            reserved: [0; 6],
            nearest_m: [f32::INFINITY; MAX_FOLIAGE_SECTORS],
        }
    }
}

/// One return of a classified scan (R_f).
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("mimnav/FoliageReturn/v1")]
pub struct FoliageReturn {
    /// Bearing in the sensor frame, radians (as the scan's).
    pub angle_rad: f32,
    /// Horizontal range, m; 0: no return.
    pub range_m: f32,
    /// [`foliage_class`].
    pub class: u8,
    /// Reserved, zero.
    pub reserved: [u8; 3],
}
