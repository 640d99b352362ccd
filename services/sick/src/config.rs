//! `[sick]`: the SICK ladar's driver (`mimnav-sick`), and the scanner models it knows.

use serde::Deserialize;

use mimnav_shared::config::{Checks, Invalid, seconds_ns};

use crate::cola::{DEFAULT_MAX_TELEGRAM, Dialect};
use crate::command::{CLIENT_LEVEL, CLIENT_PASSWORD, Request};
use crate::convert::{Converter, Echo, SickMount};
use crate::session::SessionConfig;

/// The scanner families the driver knows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Model {
    /// LMS1xx (LMS111, LMS151): 270°, 25 Hz at 0.25° or 50 Hz at 0.5°, 20 m.
    Lms1xx,
    /// LMS5xx (LMS511): 190°, 25–100 Hz at 0.1667°–0.6667°, 80 m, up to five echoes.
    Lms5xx,
    /// TiM5xx (TiM551, TiM561, TiM571): 270°, 15 Hz at 1° (TiM571: 0.3333°), 10–25 m.
    Tim5xx,
    /// TiM7xx (TiM781): 270°, 15 Hz at 0.3333°, 25 m.
    Tim7xx,
}

/// What a model can do (its operating instructions' technical data).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelSpec {
    /// The name in the logs.
    pub name: &'static str,
    /// The scanned field in device angles, degrees (first, last).
    pub field_deg: (f64, f64),
    /// The (frequency Hz, step °) pairs it supports; the first is the default.
    pub modes: &'static [(f64, f64)],
    /// Its range, m.
    pub max_range_m: f64,
    /// Distance channels (echoes) it can send.
    pub echoes: u8,
    /// Takes `mLMPsetscancfg` (the TiMs' frequency and step are fixed).
    pub configurable: bool,
}

impl Model {
    /// The model's figures.
    pub fn spec(self) -> ModelSpec {
        match self {
            Model::Lms1xx => ModelSpec {
                name: "LMS1xx",
                field_deg: (-45.0, 225.0),
                modes: &[(25.0, 0.25), (50.0, 0.5)],
                max_range_m: 20.0,
                echoes: 1,
                configurable: true,
            },
            Model::Lms5xx => ModelSpec {
                name: "LMS5xx",
                field_deg: (-5.0, 185.0),
                modes: &[
                    (25.0, 1.0 / 6.0),
                    (35.0, 0.25),
                    (50.0, 1.0 / 3.0),
                    (75.0, 0.5),
                    (100.0, 2.0 / 3.0),
                ],
                max_range_m: 80.0,
                echoes: 5,
                configurable: true,
            },
            Model::Tim5xx => ModelSpec {
                name: "TiM5xx",
                field_deg: (-45.0, 225.0),
                modes: &[(15.0, 1.0), (15.0, 1.0 / 3.0)],
                max_range_m: 10.0,
                echoes: 1,
                configurable: false,
            },
            Model::Tim7xx => ModelSpec {
                name: "TiM7xx",
                field_deg: (-45.0, 225.0),
                modes: &[(15.0, 1.0 / 3.0)],
                max_range_m: 25.0,
                echoes: 1,
                configurable: false,
            },
        }
    }
}

/// The keys of `[sick]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SickConfig {
    /// The scanner's address (SICK's factory default is 192.168.0.1).
    pub host: String,
    /// Its CoLa port (2111; some TiMs serve CoLa-A on 2112).
    pub port: u16,
    /// `"cola_b"` (binary, checksummed; the default) or `"cola_a"` (ASCII).
    pub protocol: Dialect,
    /// `"lms1xx"`, `"lms5xx"`, `"tim5xx"` or `"tim7xx"`.
    pub model: Model,
    /// Scan frequency, Hz; 0: the model's default. Must be one of the model's modes.
    pub frequency_hz: f64,
    /// Angular step, degrees; 0: the model's default for the frequency.
    pub resolution_deg: f64,
    /// Which echo a return takes: `"last"` (through foliage, the surface behind it) or
    /// `"first"`.
    pub echo: Echo,
    /// Ask for remission (RSSI) channels.
    pub remission: bool,
    /// Log in and configure the scan (frequency, step, output, echoes) before streaming. Off:
    /// only `Run` and `sEN LMDscandata 1` are sent, for a scanner configured with SOPAS ET.
    pub configure: bool,
    /// Where the scanner sits on the robot.
    pub mount: SickMount,
    /// Nearer than this is no return, m (SICK's 0–3 mm mean no echo or an error).
    pub min_range_m: f64,
    /// Farther than this is no return, m; 0: the model's range.
    pub max_range_m: f64,
    /// Connecting gives up after this long, s.
    pub connect_timeout_s: f64,
    /// An answer to a request must come within this, s.
    pub answer_timeout_s: f64,
    /// No scan for this long while streaming: the connection is closed and opened again, s.
    pub silence_s: f64,
    /// The first wait before connecting again, s; doubled after each failure …
    pub reconnect_min_s: f64,
    /// … up to this, s (kept short so scans flow again soon after the scanner is back).
    pub reconnect_max_s: f64,
    /// The longest telegram accepted, bytes.
    pub max_telegram_bytes: usize,
}

impl Default for SickConfig {
    fn default() -> Self {
        SickConfig {
            host: "192.168.0.1".into(),
            port: 2111,
            protocol: Dialect::ColaB,
            model: Model::Lms1xx,
            frequency_hz: 0.0,
            resolution_deg: 0.0,
            echo: Echo::Last,
            remission: true,
            configure: true,
            mount: SickMount::default(),
            min_range_m: 0.05,
            max_range_m: 0.0,
            connect_timeout_s: 1.0,
            answer_timeout_s: 1.0,
            silence_s: 0.5,
            reconnect_min_s: 0.1,
            reconnect_max_s: 0.5,
            max_telegram_bytes: DEFAULT_MAX_TELEGRAM,
        }
    }
}

impl SickConfig {
    /// The scan mode (frequency Hz, step °) the config asks for, or why the model has none.
    pub fn mode(&self) -> Result<(f64, f64), String> {
        let spec = self.model.spec();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-3 * b.max(1e-9);
        let found = spec.modes.iter().find(|(f, s)| {
            (self.frequency_hz == 0.0 || close(self.frequency_hz, *f))
                && (self.resolution_deg == 0.0 || close(self.resolution_deg, *s))
        });
        found.copied().ok_or_else(|| {
            let modes: Vec<String> = spec
                .modes
                .iter()
                .map(|(f, s)| format!("{f} Hz at {s:.4}°"))
                .collect();
            format!(
                "sick.frequency_hz = {} with sick.resolution_deg = {}: the {} scans {}",
                self.frequency_hz,
                self.resolution_deg,
                spec.name,
                modes.join(", ")
            )
        })
    }

    /// Checks every key.
    pub fn validate(&self) -> Result<(), Invalid> {
        let mut r = Checks::default();
        r.require(
            !self.host.trim().is_empty(),
            "sick.host",
            "sick.host is empty: name the scanner's address (SICK's default is 192.168.0.1)",
        );
        r.check("sick.port", f64::from(self.port), 1.0, 65535.0);
        if let Err(e) = self.mode() {
            r.require(false, "sick.frequency_hz", e);
        }
        let m = &self.mount;
        r.check("sick.mount.x_m", m.x_m, -3.0, 3.0);
        r.check("sick.mount.y_m", m.y_m, -3.0, 3.0);
        r.check("sick.mount.z_m", m.z_m, 0.0, 3.0);
        r.check("sick.mount.yaw_deg", m.yaw_deg, -180.0, 180.0);
        r.check("sick.min_range_m", self.min_range_m, 0.0, 5.0);
        r.check("sick.max_range_m", self.max_range_m, 0.0, 300.0);
        r.require(
            self.max_range_m == 0.0 || self.max_range_m > self.min_range_m,
            "sick.max_range_m",
            format!(
                "sick.max_range_m = {} must exceed sick.min_range_m = {} (or be 0: the model's range)",
                self.max_range_m, self.min_range_m
            ),
        );
        r.check("sick.connect_timeout_s", self.connect_timeout_s, 0.01, 60.0);
        r.check("sick.answer_timeout_s", self.answer_timeout_s, 0.01, 60.0);
        r.check("sick.silence_s", self.silence_s, 0.05, 60.0);
        r.check("sick.reconnect_min_s", self.reconnect_min_s, 0.01, 60.0);
        r.check("sick.reconnect_max_s", self.reconnect_max_s, 0.01, 600.0);
        r.require(
            self.reconnect_max_s >= self.reconnect_min_s,
            "sick.reconnect_max_s",
            format!(
                "sick.reconnect_max_s = {} is below sick.reconnect_min_s = {}",
                self.reconnect_max_s, self.reconnect_min_s
            ),
        );
        r.check(
            "sick.max_telegram_bytes",
            self.max_telegram_bytes as f64,
            1024.0,
            16.0 * 1024.0 * 1024.0,
        );
        r.finish()
    }

    /// The range beyond which a distance is no return, m.
    pub fn max_range(&self) -> f64 {
        if self.max_range_m > 0.0 {
            self.max_range_m
        } else {
            self.model.spec().max_range_m
        }
    }

    /// The most returns one scan can have: the model's field at its finest step.
    pub fn max_returns(&self) -> usize {
        let spec = self.model.spec();
        let finest = spec.modes.iter().map(|m| m.1).fold(f64::INFINITY, f64::min);
        ((spec.field_deg.1 - spec.field_deg.0) / finest).round() as usize + 1
    }

    /// How the driver turns scans into returns.
    pub fn converter(&self) -> Converter {
        Converter {
            mount: self.mount,
            echo: self.echo,
            min_range_m: self.min_range_m as f32,
            max_range_m: self.max_range() as f32,
        }
    }

    /// The requests sent after connecting, in order.
    pub fn start_requests(&self) -> Vec<Request> {
        let spec = self.model.spec();
        let mut v = Vec::new();
        if self.configure {
            v.push(Request::Login {
                level: CLIENT_LEVEL,
                password: CLIENT_PASSWORD,
            });
            if spec.configurable
                && let Ok((f, s)) = self.mode()
            {
                v.push(Request::ScanConfig {
                    frequency: (f * 100.0).round() as u32,
                    resolution: (s * 10_000.0).round() as u32,
                    start: (spec.field_deg.0 * 10_000.0).round() as i32,
                    stop: (spec.field_deg.1 * 10_000.0).round() as i32,
                });
            }
            v.push(Request::OutputConfig {
                remission: self.remission,
                remission_16bit: false,
            });
            if spec.echoes > 1 {
                // every echo: the driver picks one per `sick.echo`
                v.push(Request::EchoFilter(1));
            }
        }
        v.push(Request::Run);
        v.push(Request::Stream(true));
        v
    }

    /// The session's settings.
    pub fn session(&self) -> SessionConfig {
        SessionConfig {
            dialect: self.protocol,
            requests: self.start_requests(),
            answer_timeout_ns: seconds_ns(self.answer_timeout_s),
            silence_ns: seconds_ns(self.silence_s),
            max_telegram: self.max_telegram_bytes,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_validate_and_name_the_mode() {
        let c = SickConfig::default();
        c.validate().expect("defaults are valid");
        assert_eq!(c.mode(), Ok((25.0, 0.25)));
        assert_eq!(c.max_returns(), 1081);
        let lms5 = SickConfig {
            model: Model::Lms5xx,
            ..c.clone()
        };
        assert_eq!(lms5.max_returns(), 1141);
        assert!(matches!(
            lms5.start_requests().as_slice(),
            [
                Request::Login { .. },
                Request::ScanConfig {
                    frequency: 2500,
                    resolution: 1667,
                    start: -50_000,
                    stop: 1_850_000
                },
                Request::OutputConfig { .. },
                Request::EchoFilter(1),
                Request::Run,
                Request::Stream(true)
            ]
        ));
    }

    #[test]
    fn a_partial_mount_keeps_the_other_defaults() {
        let c: SickConfig = toml::from_str("[mount]\nupside_down = true\n").expect("parses");
        assert_eq!((c.mount.z_m, c.mount.upside_down), (0.4, true));
    }

    #[test]
    fn a_mode_the_model_lacks_is_refused_by_name() {
        let c = SickConfig {
            frequency_hz: 50.0,
            resolution_deg: 0.25,
            ..SickConfig::default()
        };
        let e = c.validate().expect_err("LMS1xx has no 50 Hz at 0.25°");
        let m = e.to_string();
        assert!(
            m.contains("sick.frequency_hz") && m.contains("25 Hz at 0.2500°"),
            "{m}"
        );
        let tim = SickConfig {
            model: Model::Tim5xx,
            configure: true,
            ..SickConfig::default()
        };
        tim.validate().expect("valid");
        assert!(
            !tim.start_requests()
                .iter()
                .any(|r| matches!(r, Request::ScanConfig { .. })),
            "a TiM takes no scan configuration"
        );
    }
}
