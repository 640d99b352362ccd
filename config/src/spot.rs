//! `[spot]`: the Spot bridge (`mimnav-spot`, Python on Boston Dynamics' SDK). The bridge reads
//! this section of the same file itself; the Rust side parses and checks it so that
//! `mimnav check-config` names a bad value before the bridge starts.

use std::path::PathBuf;

use serde::Deserialize;

use mimnav_shared::config::{Checks, Invalid};

/// The keys of `[spot]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SpotConfig {
    /// The robot's address (its hostname or IP on the payload or WiFi network).
    pub hostname: String,
    /// The robot's API port (TLS).
    pub port: u16,
    /// A PEM file of the CA that signed the robot's certificate; empty: the robot CA the SDK
    /// ships.
    pub ca_cert: String,
    /// The file holding the robot user's name and password (readable by the service user
    /// only); under systemd the unit's `LoadCredential=spot:` takes precedence.
    pub credentials_file: PathBuf,
    /// A velocity command is sent to the robot valid at most this long, s (and never past the
    /// planner's `valid_until_mono_ns`).
    pub command_validity_cap_s: f64,
    /// The E-Stop endpoint's timeout, s: the robot cuts its motors when the bridge's check-ins
    /// stop for this long.
    pub estop_timeout_s: f64,
    /// How often the robot's state is read and `odom` published, Hz.
    pub odom_rate_hz: f64,
}

impl Default for SpotConfig {
    fn default() -> Self {
        SpotConfig {
            hostname: "192.168.80.3".into(),
            port: 443,
            ca_cert: String::new(),
            credentials_file: PathBuf::from("/etc/mimnav/spot-credentials"),
            command_validity_cap_s: 0.6,
            estop_timeout_s: 9.0,
            odom_rate_hz: 25.0,
        }
    }
}

impl SpotConfig {
    /// Checks every key.
    pub fn validate(&self) -> Result<(), Invalid> {
        let mut r = Checks::default();
        r.require(
            !self.hostname.trim().is_empty(),
            "spot.hostname",
            "spot.hostname is empty: name the robot's address",
        );
        r.check(
            "spot.command_validity_cap_s",
            self.command_validity_cap_s,
            0.05,
            5.0,
        );
        r.check("spot.estop_timeout_s", self.estop_timeout_s, 1.0, 60.0);
        r.check("spot.odom_rate_hz", self.odom_rate_hz, 1.0, 200.0);
        r.require(
            self.port != 0,
            "spot.port",
            "spot.port is 0: name the robot's API port (443)",
        );
        r.finish()
    }
}
