//! `[kobuki]`: the Turtlebot 2's base service (`mimnav-kobuki`).

use std::path::PathBuf;

use serde::Deserialize;

use mimnav_shared::config::{Checks, Invalid, seconds_ns};

use crate::driver::DriverConfig;
use crate::safety::SafetyConfig;

/// The keys of `[kobuki]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct KobukiConfig {
    /// The base's serial device (the udev rule in docs/deployment.md names it `/dev/kobuki`).
    pub device: PathBuf,
    /// Heading from the base's gyro (true) or from the wheels alone.
    pub use_gyro: bool,
    /// Feedback older than this stops the base: its bumpers and cliffs are not known, s. The
    /// base sends feedback every 20 ms.
    pub feedback_timeout_s: f64,
    /// No byte from an open port for this long: the link is down, the port is closed and
    /// opened again, s.
    pub silence_s: f64,
    /// How often a missing or failed device is tried again, s.
    pub reconnect_s: f64,
    /// Bytes of the serial port read at most per turn of the loop.
    pub read_bytes: usize,
}

impl Default for KobukiConfig {
    fn default() -> Self {
        KobukiConfig {
            device: PathBuf::from("/dev/kobuki"),
            use_gyro: true,
            feedback_timeout_s: 0.2,
            silence_s: 1.0,
            reconnect_s: 1.0,
            read_bytes: 4096,
        }
    }
}

impl KobukiConfig {
    /// Checks every key.
    pub fn validate(&self) -> Result<(), Invalid> {
        let mut r = Checks::default();
        r.require(
            !self.device.as_os_str().is_empty(),
            "kobuki.device",
            "kobuki.device is empty: name the base's serial device (/dev/kobuki with the udev rule)",
        );
        r.check(
            "kobuki.feedback_timeout_s",
            self.feedback_timeout_s,
            0.02,
            10.0,
        );
        r.check("kobuki.silence_s", self.silence_s, 0.05, 60.0);
        r.check("kobuki.reconnect_s", self.reconnect_s, 0.05, 60.0);
        r.check(
            "kobuki.read_bytes",
            self.read_bytes as f64,
            64.0,
            1_048_576.0,
        );
        r.finish()
    }

    /// The driver's settings.
    pub fn driver(&self) -> DriverConfig {
        DriverConfig {
            safety: SafetyConfig {
                feedback_timeout_ns: seconds_ns(self.feedback_timeout_s),
            },
            use_gyro: self.use_gyro,
        }
    }
}
