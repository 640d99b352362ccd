//! The mimnav scenario simulator as a library: worlds, a VLP-16 that writes genuine packets from
//! a material model, a SICK 2D ladar measuring with the same model ([`sick`]), a robot base that
//! follows velocity commands, collisions and ground truth.
//! No inter-process communication: `main.rs` wires it to UDP, pcap files and iceoryx2.
//!
//! Read it in this order: [`world`] (the TOML format and the compiled [`world::Scene`]),
//! [`geometry`] (ray–shape intersections), [`physics`] (what a beam returns), [`lidar`] (firing
//! times, azimuths and packets), [`motion`] (the base), [`truth`] (the true map), and [`Sim`],
//! which runs them together one packet at a time. [`generate`] draws families of worlds from a
//! seed and [`reach`] says whether a robot can reach a world's goal at all, by the simulator's own
//! collision test.
//!
//! ```
//! use mimnav_sim::{Sim, SimSettings, world::WorldFile};
//! let world = WorldFile::parse(
//!     "name = 'wall'\nstart = [0.0, 0.0, 0.0]\ngoal = [3.0, 0.0]\ntime_limit_s = 10.0\n\
//!      [[wall]]\nfrom = [5.0, -2.0]\nto = [5.0, 2.0]\n",
//!     "inline",
//! ).expect("valid world");
//! let mut sim = Sim::new(world.compile(), SimSettings::default(), 7, mimnav_sim::DEFAULT_EPOCH_NS);
//! let step = sim.step();
//! assert_eq!(step.data.len(), 1206);
//! ```
#![deny(missing_docs)]

pub mod blades;
pub mod config;
pub mod generate;
pub mod geometry;
pub mod lidar;
pub mod motion;
pub mod physics;
pub mod reach;
pub mod sick;
pub mod truth;
pub mod world;

use mimnav_shared::config::RobotProfile;

use crate::config::SimConfig;
use mimnav_shared::grid::GridSpec;
use mimnav_shared::pose::{Pose2, Pose2Ext, pose2};
use mimnav_shared::topics::{DATA_PACKET_LEN, Odometry};
use mimnav_velodyne::packet::{BLOCKS, POSITION_PACKET_LEN};
use mimnav_velodyne::revolution::TurnCutter;

use crate::lidar::Vlp16;
use crate::motion::Base;
use crate::world::Scene;

/// Source address of simulated packets in captures: the VLP-16's factory default.
pub const SENSOR_ADDRESS: std::net::Ipv4Addr = std::net::Ipv4Addr::new(192, 168, 1, 201);

/// What [`write_capture`] wrote.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CaptureStats {
    /// Data packets.
    pub packets: u64,
    /// Revolutions completed.
    pub revolutions: u64,
}

/// Writes `seconds` of `sim`'s sensor to `out` as a pcap: data packets to `ports.0`, position
/// packets to `ports.1` (0: none), from the sensor's address to broadcast, stamped when sent.
pub fn write_capture<W: std::io::Write>(
    sim: &mut Sim,
    seconds: f64,
    ports: (u16, u16),
    out: W,
) -> Result<CaptureStats, pcap_file::PcapError> {
    let mut w = mimnav_velodyne::capture::PcapDatagramWriter::new(out)?;
    let dst = std::net::Ipv4Addr::BROADCAST;
    let mut stats = CaptureStats {
        packets: 0,
        revolutions: 0,
    };
    while sim.elapsed_s() < seconds {
        let step = sim.step();
        if let Some((pos, t)) = step.position
            && ports.1 != 0
        {
            w.write(t, (SENSOR_ADDRESS, ports.1), (dst, ports.1), &pos)?;
        }
        w.write(
            step.send_ns,
            (SENSOR_ADDRESS, ports.0),
            (dst, ports.0),
            &step.data,
        )?;
        stats.packets += 1;
        stats.revolutions += u64::from(step.completes_revolution);
    }
    Ok(stats)
}

/// Sensor clock start of captures, for reproducible bytes: 2026-01-01T00:00:00Z.
pub const DEFAULT_EPOCH_NS: u64 = 1_767_225_600_000_000_000;

/// Everything the simulation needs besides the world: `[sim]` (the beam physics, the return
/// mode, the goal tolerance), the robot of `[robot]` (the sensor's height, the footprint, the
/// base's limits) and the rate the sensor is set to spin at (`velodyne.rpm`).
#[derive(Debug, Clone, PartialEq)]
pub struct SimSettings {
    /// `[sim]`.
    pub sim: SimConfig,
    /// `[robot]`.
    pub robot: RobotProfile,
    /// Revolutions per minute the sensor spins at (`velodyne.rpm`, the sensor's own setting).
    pub rpm: f64,
}

impl Default for SimSettings {
    /// The documented defaults: a Turtlebot 2 with a dual-return VLP-16 at 600 rpm. The stack's
    /// config builds the settings of a file (`mimnav_config::Config::sim_settings`).
    fn default() -> Self {
        SimSettings {
            sim: SimConfig::default(),
            robot: RobotProfile::default(),
            rpm: mimnav_velodyne::config::VelodyneConfig::default().rpm,
        }
    }
}

/// The end of a simulation: where the robot got, how far it drove, how the episode ended.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Summary {
    /// World name.
    pub world: String,
    /// `running`, `stopped` (by a signal), `goal_reached`, `contact:<object index>` or `timeout`.
    pub outcome: String,
    /// Simulated time, s.
    pub time_s: f64,
    /// Distance driven, m.
    pub path_length_m: f64,
    /// Straight distance from the start to the goal, m.
    pub straight_m: f64,
    /// Distance left to the goal, m.
    pub distance_to_goal_m: f64,
    /// Final position, m.
    pub x: f64,
    /// Final position, m.
    pub y: f64,
    /// Revolutions completed.
    pub revolutions: u64,
    /// Lock-step revolutions the stack did not answer in time.
    pub lockstep_timeouts: u64,
}

impl std::fmt::Display for Summary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {} after {:.1} s; driven {:.2} m (straight line {:.2} m, ratio {:.2}); at ({:.2}, {:.2}), {:.2} m from the goal; {} revolutions",
            self.world,
            self.outcome,
            self.time_s,
            self.path_length_m,
            self.straight_m,
            self.path_length_m / self.straight_m.max(1e-9),
            self.x,
            self.y,
            self.distance_to_goal_m,
            self.revolutions
        )
    }
}

/// How an episode stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Still going.
    Running,
    /// The robot reached the goal without contact.
    GoalReached,
    /// The robot touched a solid or glass object (index into the scene's objects).
    Contact(usize),
    /// The time limit passed.
    Timeout,
}

/// One step of the simulation: one data packet, and a position packet once a second.
#[derive(Debug, Clone)]
pub struct Step {
    /// The data packet.
    pub data: [u8; DATA_PACKET_LEN],
    /// Sensor time of its first firing, ns since the Unix epoch.
    pub first_firing_ns: u64,
    /// When the sensor sends it (after its last firing), ns since the Unix epoch.
    pub send_ns: u64,
    /// True when this packet completes a revolution by the driver's rule.
    pub completes_revolution: bool,
    /// A position packet due now, with its send time.
    pub position: Option<([u8; POSITION_PACKET_LEN], u64)>,
}

/// A running simulation: scene, sensor, base and the episode's record.
#[derive(Debug)]
pub struct Sim {
    scene: Scene,
    settings: SimSettings,
    lidar: Vlp16,
    base: Base,
    cmd: (f64, f64),
    cutter: TurnCutter,
    epoch_ns: u64,
    next_position_ns: u64,
    outcome: Outcome,
    path_length_m: f64,
    revolutions: u64,
    revolution_start_ns: u64,
    revolution_start_pose: Pose2,
}

impl Sim {
    /// A simulation of `scene` starting at the scene's start pose; the sensor's clock starts at
    /// `epoch_ns`, and every random draw follows `seed`.
    pub fn new(scene: Scene, settings: SimSettings, seed: u64, epoch_ns: u64) -> Self {
        let start = pose2(scene.start[0], scene.start[1], scene.start[2]);
        Sim {
            lidar: Vlp16::new(&settings, seed, epoch_ns),
            base: Base::at(start),
            scene,
            settings,
            cmd: (0.0, 0.0),
            cutter: TurnCutter::new(None),
            epoch_ns,
            next_position_ns: epoch_ns,
            outcome: Outcome::Running,
            path_length_m: 0.0,
            revolutions: 0,
            revolution_start_ns: epoch_ns,
            revolution_start_pose: start,
        }
    }

    /// The scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The settings.
    pub fn settings(&self) -> &SimSettings {
        &self.settings
    }

    /// The base (pose and velocity).
    pub fn base(&self) -> &Base {
        &self.base
    }

    /// Sets the velocity command the base follows from now on.
    pub fn set_command(&mut self, v: f64, omega: f64) {
        self.cmd = (v, omega);
    }

    /// Seconds of simulated time so far.
    pub fn elapsed_s(&self) -> f64 {
        (self.lidar.now_ns() - self.epoch_ns) as f64 * 1e-9
    }

    /// Sensor time now, ns since the Unix epoch.
    pub fn now_ns(&self) -> u64 {
        self.lidar.now_ns()
    }

    /// How the episode stands.
    pub fn outcome(&self) -> Outcome {
        self.outcome
    }

    /// Distance driven so far, m.
    pub fn path_length_m(&self) -> f64 {
        self.path_length_m
    }

    /// Revolutions completed so far.
    pub fn revolutions(&self) -> u64 {
        self.revolutions
    }

    /// Sensor time and pose at the start of the current revolution.
    pub fn revolution_start(&self) -> (u64, Pose2) {
        (self.revolution_start_ns, self.revolution_start_pose)
    }

    /// Where the lidar's optical centre is now: x, y on the ground plane (the mount's offset
    /// applied to the base's pose) and its height, m, world frame.
    pub fn sensor_position(&self) -> [f64; 3] {
        let p = self.lidar.sensor_pose(&self.base.pose);
        [p.x(), p.y(), self.settings.robot.sensor_height_m]
    }

    /// Distance from the robot to the goal, m.
    pub fn distance_to_goal(&self) -> f64 {
        let p = &self.base.pose;
        (self.scene.goal[0] - p.x()).hypot(self.scene.goal[1] - p.y())
    }

    /// The beams `laser` (firing order) fires in the next [`Sim::step`], from the current pose,
    /// in firing order: one per firing, as the driver's planar scan has one return per firing.
    pub fn next_beams(&self, laser: usize, out: &mut Vec<lidar::Beam>) {
        self.lidar.next_beams(&self.base.pose, laser, out);
    }

    /// Moves the base for `dt_ns` of simulated time without casting the VLP-16 (its clock and
    /// rotation move on as if it spun unseen; no packet, no revolution is counted): how a run
    /// with only a SICK ([`Sim::sick_scan`]) lets time pass.
    pub fn idle(&mut self, dt_ns: u64) {
        self.lidar.idle(dt_ns);
        self.advance(dt_ns as f64 * 1e-9);
    }

    /// Casts a scan of the simulated SICK `sick` with geometry `g` (its device's current mode)
    /// from the current pose, at the current time; see [`sick`].
    pub fn sick_scan(
        &self,
        sick: &mut sick::SickScanner,
        g: &mimnav_sick::device::Geometry,
        out: &mut sick::SickScan,
    ) {
        sick.scan(&self.scene, &self.base.pose, self.elapsed_s(), g, out);
    }

    /// The beams of the SICK scan [`Sim::sick_scan`] would cast now, in measurement order.
    pub fn sick_beams(
        &self,
        sick: &sick::SickScanner,
        g: &mimnav_sick::device::Geometry,
        out: &mut Vec<lidar::Beam>,
    ) {
        sick.beams(&self.base.pose, g, out);
    }

    /// Casts the next packet from the current pose, then moves the base for one packet period.
    pub fn step(&mut self) -> Step {
        let first_firing_ns = self.lidar.now_ns();
        let data = self.lidar.next_packet(&self.scene, &self.base.pose);
        let period = self.lidar.packet_period_ns();
        let send_ns = first_firing_ns + period;
        let position = if first_firing_ns >= self.next_position_ns {
            self.next_position_ns += 1_000_000_000;
            Some((Vlp16::position_packet(first_firing_ns), send_ns))
        } else {
            None
        };
        self.advance(period as f64 * 1e-9);
        let last_az =
            u16::from_le_bytes([data[100 * (BLOCKS - 1) + 2], data[100 * (BLOCKS - 1) + 3]]);
        let completes_revolution = self.cutter.push(last_az);
        if completes_revolution {
            self.revolutions += 1;
            self.revolution_start_ns = self.lidar.now_ns();
            self.revolution_start_pose = self.base.pose;
        }
        Step {
            data,
            first_firing_ns,
            send_ns,
            completes_revolution,
            position,
        }
    }

    fn advance(&mut self, dt: f64) {
        if self.outcome != Outcome::Running {
            self.base.v = 0.0;
            self.base.omega = 0.0;
            return;
        }
        let before = self.base;
        self.base
            .step(self.cmd.0, self.cmd.1, dt, &self.settings.robot);
        let p = self.base.pose;
        if let Some(i) = motion::body_contact(&self.scene, &p, &self.settings.robot.body()) {
            self.base = before;
            self.base.v = 0.0;
            self.base.omega = 0.0;
            self.outcome = Outcome::Contact(i);
            return;
        }
        self.path_length_m += (p.x() - before.pose.x()).hypot(p.y() - before.pose.y());
        if self.settings.sim.endless {
            return;
        }
        if self.distance_to_goal() <= self.settings.sim.goal_tolerance_m {
            self.outcome = Outcome::GoalReached;
        } else if self.elapsed_s() > self.scene.time_limit_s {
            self.outcome = Outcome::Timeout;
        }
    }

    /// The base's pose and velocity now as a robot base publishes them on `odom` (the sim's
    /// clock as the stamp): the simulator's service and the in-process runner build the same
    /// message, so the stack sees the same numbers either way.
    pub fn odometry(&self, seq: u64, rx_mono_ns: u64) -> Odometry {
        let b = &self.base;
        Odometry {
            seq,
            stamp_ns: self.now_ns(),
            rx_mono_ns,
            x: b.pose.x(),
            y: b.pose.y(),
            yaw: b.pose.yaw(),
            v: b.v as f32,
            omega: b.omega as f32,
        }
    }

    /// How the episode stands, for people (`Display`) and programs (JSON).
    pub fn summary(&self, stopped: bool, lockstep_timeouts: u64) -> Summary {
        let p = &self.base.pose;
        let (start, goal) = (self.scene.start, self.scene.goal);
        Summary {
            world: self.scene.name.clone(),
            outcome: match self.outcome {
                Outcome::Running if stopped => "stopped".to_string(),
                Outcome::Running => "running".to_string(),
                Outcome::GoalReached => "goal_reached".to_string(),
                Outcome::Contact(i) => format!("contact:{i}"),
                Outcome::Timeout => "timeout".to_string(),
            },
            time_s: self.elapsed_s(),
            path_length_m: self.path_length_m,
            straight_m: (goal[0] - start[0]).hypot(goal[1] - start[1]),
            distance_to_goal_m: self.distance_to_goal(),
            x: p.x(),
            y: p.y(),
            revolutions: self.revolutions,
            lockstep_timeouts,
        }
    }

    /// The true class of every cell of `grid` around the current pose.
    pub fn truth(&self, grid: GridSpec, out: &mut Vec<u8>) {
        truth::truth_grid(&self.scene, &self.base.pose, grid, out);
    }
}
