//! `[sim]`: the simulator.

use std::net::IpAddr;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use mimnav_shared::config::{Checks, Invalid};

/// Return mode the simulated sensor is set to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SimReturnMode {
    /// Strongest return (0x37).
    Strongest,
    /// Last return (0x38).
    Last,
    /// Dual return (0x39).
    Dual,
}

impl SimReturnMode {
    /// The return-mode byte the sensor writes in its data packets ([`mimnav_shared::topics::return_mode`]).
    pub fn byte(self) -> u8 {
        use mimnav_shared::topics::return_mode;
        match self {
            SimReturnMode::Strongest => return_mode::STRONGEST,
            SimReturnMode::Last => return_mode::LAST,
            SimReturnMode::Dual => return_mode::DUAL,
        }
    }
}

/// Which echo of a beam a simulated one-echo SICK (LMS1xx, TiM) reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SickEcho {
    /// The strongest echo (as the VLP-16 in strongest mode).
    Strongest,
    /// The nearest echo.
    First,
    /// The farthest echo (through foliage, the surface behind it).
    Last,
}

/// How the simulated robot's base meets the stack.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SimBase {
    /// The simulator itself follows `cmd_vel` and publishes `odom` (its true pose).
    Ideal,
    /// A simulated Kobuki on a pseudo-terminal at `sim.kobuki_link`, speaking the base's serial
    /// protocol: `mimnav-kobuki` drives it and publishes `odom` from its encoders and gyro, as
    /// on a Turtlebot 2. Real-time streaming only (not lock-step).
    Kobuki,
}

/// The simulator (`[sim]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimConfig {
    /// World file; a relative path is taken from the config file's folder.
    pub world: PathBuf,
    /// Seed of every random draw: the same seed gives the same bytes.
    pub seed: u64,
    /// The simulated sensor's return mode.
    pub return_mode: SimReturnMode,
    /// Where streamed packets go (data to `velodyne.data_port`, position packets to
    /// `velodyne.position_port`); loopback only unless you mean it.
    pub udp_target: IpAddr,
    /// Standard deviation of the range noise of solid surfaces, metres.
    pub range_noise_m: f64,
    /// Standard deviation of the intensity noise, reflectivity units.
    pub intensity_noise: f64,
    /// Glass returns only within this angle of normal incidence, degrees.
    pub glass_specular_deg: f64,
    /// Lock-step: send one revolution, then wait for the stack's command before the next.
    pub lockstep: bool,
    /// Streaming: how many times faster than real time the packets go out (1: as a VLP-16
    /// sends them; 10: a revolution every 10 ms at 600 rpm, for soak tests). The sensor's and
    /// the odometry's stamps stay in simulated time; commands expire on the host's clock.
    pub time_scale: f64,
    /// Without an end: reaching the goal or the world's time limit does not end the episode,
    /// the robot follows `cmd_vel` for as long as the simulator runs (a contact still stops
    /// it). For soak tests, where the robot patrols.
    pub endless: bool,
    /// In lock-step, how long to wait for the stack's command before going on without one, s.
    pub lockstep_timeout_s: f64,
    /// The goal counts as reached within this distance, metres.
    pub goal_tolerance_m: f64,
    /// Grass as blades standing in the ground, which neighbouring beams meet alike (the
    /// VLP-16's spot is wider than its firing spacing), instead of blades drawn for each beam
    /// on its own (the default, which every published figure uses).
    pub grass_blades: bool,
    /// How the robot's base meets the stack: `ideal` (the simulator follows `cmd_vel` and
    /// publishes `odom`) or `kobuki` (a simulated Kobuki on a pseudo-terminal; see [`SimBase`]).
    pub base: SimBase,
    /// With `base = "kobuki"`: the symlink to the pseudo-terminal the simulator makes (point
    /// `kobuki.device` at it).
    pub kobuki_link: PathBuf,
    /// Serve a simulated SICK 2D ladar (the `[sick]` model, mode and mount; [`crate::sick`])
    /// over TCP at `sim.sick_bind`:`sim.sick_port`, as the real scanner serves CoLa: one
    /// client at a time, scans cast from the robot's pose while the client streams. Point
    /// `sick.host` and `sick.port` at it.
    pub sick: bool,
    /// The address the simulated SICK listens on (loopback unless you mean it).
    pub sick_bind: IpAddr,
    /// Its TCP port (a SICK's CoLa port is 2111).
    pub sick_port: u16,
    /// The echo a simulated one-echo SICK (LMS1xx, TiM) reports of each beam: `last` (the
    /// default, as SICK's echo filter defaults to the last echo), `first` or `strongest` (an
    /// LMS5xx reports them all; [`crate::sick`]).
    pub sick_echo: SickEcho,
    /// A client that has not taken what was sent to it for this long is dropped (it never
    /// holds the simulator up), s.
    pub sick_stall_s: f64,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            world: PathBuf::from("worlds/scenario1_glass_wall.toml"),
            seed: 1,
            return_mode: SimReturnMode::Dual,
            udp_target: IpAddr::from([127, 0, 0, 1]),
            range_noise_m: 0.015,
            intensity_noise: 1.5,
            glass_specular_deg: 3.0,
            lockstep: false,
            time_scale: 1.0,
            endless: false,
            lockstep_timeout_s: 5.0,
            goal_tolerance_m: 0.3,
            grass_blades: false,
            base: SimBase::Ideal,
            kobuki_link: PathBuf::from("/tmp/mimnav/kobuki"),
            sick: false,
            sick_bind: IpAddr::from([127, 0, 0, 1]),
            sick_port: 2111,
            sick_echo: SickEcho::Last,
            sick_stall_s: 1.0,
        }
    }
}

impl SimConfig {
    /// Checks every key of `[sim]`: each value refused names its key and what is allowed.
    pub fn validate(&self) -> Result<(), Invalid> {
        let mut r = Checks::default();
        r.check("sim.range_noise_m", self.range_noise_m, 0.0, 0.5);
        r.check("sim.intensity_noise", self.intensity_noise, 0.0, 50.0);
        r.check("sim.glass_specular_deg", self.glass_specular_deg, 0.1, 30.0);
        r.check(
            "sim.lockstep_timeout_s",
            self.lockstep_timeout_s,
            0.01,
            600.0,
        );
        r.check("sim.goal_tolerance_m", self.goal_tolerance_m, 0.01, 5.0);
        r.check("sim.time_scale", self.time_scale, 0.1, 100.0);
        r.check("sim.sick_stall_s", self.sick_stall_s, 0.05, 60.0);
        r.require(
            !self.sick || self.sick_port != 0,
            "sim.sick_port",
            "sim.sick_port = 0: name the TCP port the simulated SICK listens on (a SICK's is 2111)",
        );
        r.require(
            !(self.base == SimBase::Kobuki && self.lockstep),
            "sim.base",
            "sim.base = \"kobuki\" runs in real time: it cannot be lock-stepped (sim.lockstep = true)",
        );
        r.require(
            self.base != SimBase::Kobuki || !self.kobuki_link.as_os_str().is_empty(),
            "sim.kobuki_link",
            "sim.kobuki_link is empty: name the symlink to make to the simulated Kobuki",
        );
        r.finish()
    }

    /// The world file, relative paths taken from `config_dir`.
    pub fn world_path(&self, config_dir: &Path) -> PathBuf {
        if self.world.is_absolute() {
            self.world.clone()
        } else {
            config_dir.join(&self.world)
        }
    }
}
