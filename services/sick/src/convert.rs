//! From a scan's channels to the planar scan the foliage classifier reads: one [`ScanReturn`]
//! per measurement, its bearing in REP-103 and its range from the robot's axis, with the
//! scanner's mounting pose applied.
//!
//! **Angles.** SICK counts a 270° scanner's angles counter-clockwise seen from above, from −45°
//! to 225°, with 90° straight ahead (the listing's start angle and step, 1/10 000°). REP-103's
//! bearing (x forward, counter-clockwise) is the device angle − 90°, as the ROS SICK drivers
//! have it. A scanner mounted upside down sees the world mirrored: its bearing changes sign.
//!
//! **Mounting pose.** [`SickMount`]: the scanner's place on the robot (x forward, y left of the
//! robot's axis) and its yaw. Each return is moved into the frame of a scanner on the robot's
//! axis facing forward (its bearing and horizontal range from there), as the foliage service
//! does for the VLP-16 with `robot.mount`; what the classifier's sectors report is then the
//! robot's. The scanner is taken to be level: a planar ladar's plane is the robot's.
//!
//! **Echoes.** An LMS5xx sends up to five distance channels (`DIST1` … `DIST5`, one per echo,
//! nearest first) and their remission (`RSSI1` …). [`Echo::First`] takes the nearest valid echo
//! of each measurement, [`Echo::Last`] the farthest (through foliage, the one most likely to be
//! the surface behind it). Remission comes from the `RSSI` channel of the echo taken: 8-bit
//! values as they are, 16-bit ones scaled to 8 bits.
//!
//! **No echo.** A distance below `min_range_m` (SICK's 0 = no echo and, on an LMS1xx, 1–3 =
//! dazzle or errors, are all below 5 mm) or beyond `max_range_m` is "no return": range 0.

use mimnav_shared::topics::{ScanReturn, return_type};

use crate::scandata::{ChannelKind, ScanData};

/// Which echo of a multi-echo scanner a return takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Echo {
    /// The nearest valid echo.
    First,
    /// The farthest valid echo (the default: through foliage, the surface behind it).
    #[default]
    Last,
}

impl Echo {
    /// The [`return_type`] bits a return of this echo carries.
    pub fn return_type(self) -> u8 {
        match self {
            Echo::First => return_type::FIRST,
            Echo::Last => return_type::LAST,
        }
    }
}

/// Where the scanner sits on the robot (`[sick.mount]`); by default on the robot's axis facing
/// forward, its scan plane 0.4 m above the ground.
#[derive(Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SickMount {
    /// Forward of the robot's axis, m.
    pub x_m: f64,
    /// Left of the robot's axis, m.
    pub y_m: f64,
    /// Height of the scan plane above the ground, m (for the simulated scanner and the docs;
    /// a planar scan has no height of its own).
    pub z_m: f64,
    /// Yaw, degrees, counter-clockwise from the robot's forward.
    pub yaw_deg: f64,
    /// Mounted upside down (its scan runs clockwise seen from above).
    pub upside_down: bool,
}

impl Default for SickMount {
    fn default() -> Self {
        SickMount {
            x_m: 0.0,
            y_m: 0.0,
            z_m: 0.4,
            yaw_deg: 0.0,
            upside_down: false,
        }
    }
}

/// How a scan becomes returns.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Converter {
    /// The mounting pose.
    pub mount: SickMount,
    /// The echo taken.
    pub echo: Echo,
    /// Nearer than this is no return, m.
    pub min_range_m: f32,
    /// Farther than this is no return, m.
    pub max_range_m: f32,
}

/// Why a scan gives no returns.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ConvertError {
    /// No distance channel.
    #[error("LMDscandata without a DIST1 channel (channels: {0})")]
    NoDistance(String),
    /// A distance channel whose angles or count differ from `DIST1`'s.
    #[error(
        "{name} has {count} values from {start} step {step}, DIST1 {count1} from {start1} step {step1}"
    )]
    Mismatch {
        /// The channel.
        name: String,
        /// Its count, start and step.
        count: usize,
        /// Its start angle.
        start: i32,
        /// Its step.
        step: u16,
        /// DIST1's.
        count1: usize,
        /// DIST1's start.
        start1: i32,
        /// DIST1's step.
        step1: u16,
    },
}

/// What a converted scan was.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Converted {
    /// Returns written (one per measurement).
    pub count: usize,
    /// Distance channels (echoes) in the scan.
    pub echoes: usize,
    /// Returns with a range.
    pub valid: usize,
}

/// The angle `a` wrapped into (−π, π].
fn wrap(a: f32) -> f32 {
    use std::f32::consts::{PI, TAU};
    let w = a - TAU * ((a + PI) / TAU).floor();
    if w <= -PI { w + TAU } else { w }
}

impl Converter {
    /// Converts `scan` into `out` (cleared first).
    pub fn convert(
        &self,
        scan: &ScanData,
        out: &mut Vec<ScanReturn>,
    ) -> Result<Converted, ConvertError> {
        out.clear();
        let chans = scan.channels();
        let mut dist: [Option<usize>; 9] = [None; 9];
        let mut rssi: [Option<usize>; 9] = [None; 9];
        for (i, c) in chans.iter().enumerate() {
            match c.kind() {
                ChannelKind::Dist(n) => dist[usize::from(n - 1)] = Some(i),
                ChannelKind::Rssi(n) => rssi[usize::from(n - 1)] = Some(i),
                ChannelKind::Other => {}
            }
        }
        let Some(d1) = dist[0].map(|i| &chans[i]) else {
            let names: Vec<&str> = chans.iter().map(|c| c.name_str()).collect();
            return Err(ConvertError::NoDistance(names.join(" ")));
        };
        let n = d1.values.len();
        let same = |i: usize| {
            let c = &chans[i];
            if c.values.len() == n && c.start_angle == d1.start_angle && c.step == d1.step {
                Ok(())
            } else {
                Err(ConvertError::Mismatch {
                    name: c.name_str().to_string(),
                    count: c.values.len(),
                    start: c.start_angle,
                    step: c.step,
                    count1: n,
                    start1: d1.start_angle,
                    step1: d1.step,
                })
            }
        };
        // the echoes present, nearest first, each with its remission channel if it has one
        let mut echoes: Vec<(usize, Option<usize>)> = Vec::with_capacity(5);
        for k in 0..9 {
            if let Some(i) = dist[k] {
                same(i)?;
                let r = rssi[k].filter(|&j| same(j).is_ok());
                echoes.push((i, r));
            }
        }
        if self.echo == Echo::Last {
            echoes.reverse();
        }
        let m = &self.mount;
        let flip = if m.upside_down { -1.0f32 } else { 1.0 };
        let yaw = (m.yaw_deg as f32).to_radians();
        let (mx, my) = (m.x_m as f32, m.y_m as f32);
        let offset = mx != 0.0 || my != 0.0;
        let step = f32::from(d1.step) * 1e-4;
        let rt = self.echo.return_type();
        let mut valid = 0;
        out.reserve(n);
        for idx in 0..n {
            let device_deg = d1.start_angle as f32 * 1e-4 + idx as f32 * step;
            let sensor = flip * (device_deg - 90.0).to_radians();
            let mut range = 0.0f32;
            let mut intensity = 0u8;
            for &(di, ri) in &echoes {
                let c = &chans[di];
                let r = (f32::from(c.values[idx]) * c.scale + c.offset) / 1000.0;
                if r >= self.min_range_m && r <= self.max_range_m && r.is_finite() {
                    range = r;
                    intensity = ri.map_or(0, |j| {
                        let rc = &chans[j];
                        let v = rc.values[idx];
                        if rc.bits == 16 {
                            (v >> 8) as u8
                        } else {
                            v.min(255) as u8
                        }
                    });
                    break;
                }
            }
            let mut angle = wrap(sensor + yaw);
            if offset && range > 0.0 {
                let (s, c) = angle.sin_cos();
                let (x, y) = (mx + range * c, my + range * s);
                angle = y.atan2(x);
                range = x.hypot(y);
            }
            valid += usize::from(range > 0.0);
            out.push(ScanReturn {
                angle_rad: angle,
                range_m: range,
                intensity,
                return_type: if range > 0.0 { rt } else { 0 },
                reserved: [0; 2],
            });
        }
        Ok(Converted {
            count: n,
            echoes: echoes.len(),
            valid,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scandata::Channel;

    /// Channels starting at device angle −45° with 5° steps.
    fn scan(values: &[(&[u8; 5], u8, Vec<u16>)]) -> ScanData {
        let mut s = ScanData::default();
        for (name, bits, v) in values {
            s.push_channel(Channel {
                name: **name,
                bits: *bits,
                scale: 1.0,
                offset: 0.0,
                start_angle: -450_000,
                step: 50_000,
                values: v.clone(),
            });
        }
        s
    }

    fn conv(mount: SickMount, echo: Echo) -> Converter {
        Converter {
            mount,
            echo,
            min_range_m: 0.05,
            max_range_m: 25.0,
        }
    }

    #[test]
    fn device_angles_become_rep103_bearings() {
        // -45° … 225° in the device's convention, 5° apart
        let s = scan(&[(b"DIST1", 16, (0..55).map(|i| 1000 + i).collect())]);
        let mut out = Vec::new();
        conv(SickMount::default(), Echo::Last)
            .convert(&s, &mut out)
            .expect("converts");
        let deg: Vec<f32> = [0, 18, 36, 54]
            .iter()
            .map(|&i| out[i].angle_rad.to_degrees())
            .collect();
        for (got, want) in deg.iter().zip([-135.0, -45.0, 45.0, 135.0]) {
            assert!((got - want).abs() < 1e-3, "{deg:?}");
        }
        assert_eq!(out[36].range_m, 1.036);
        // upside down: mirrored
        let m = SickMount {
            upside_down: true,
            ..SickMount::default()
        };
        conv(m, Echo::Last).convert(&s, &mut out).expect("converts");
        assert!((out[0].angle_rad.to_degrees() - 135.0).abs() < 1e-3);
    }

    #[test]
    fn the_mount_moves_returns_to_the_robots_axis() {
        // straight ahead of a scanner 0.5 m forward, turned 90° left: 1 m left of it
        let mut v = vec![0u16; 55];
        v[18] = 1000;
        let s = scan(&[(b"DIST1", 16, v)]);
        let m = SickMount {
            x_m: 0.5,
            yaw_deg: 90.0,
            ..SickMount::default()
        };
        let mut out = Vec::new();
        conv(m, Echo::Last).convert(&s, &mut out).expect("converts");
        // device 45° = 45° right of the scanner's forward = 45° left of the robot's
        let r = out[18];
        let (x, y) = (r.range_m * r.angle_rad.cos(), r.range_m * r.angle_rad.sin());
        let want = (
            0.5 + 1000e-3 * 45f32.to_radians().cos(),
            45f32.to_radians().sin(),
        );
        assert!(
            (x - want.0).abs() < 1e-5 && (y - want.1).abs() < 1e-5,
            "{x} {y}"
        );
        assert_eq!(out[0].range_m, 0.0, "no echo stays no return");
    }

    #[test]
    fn first_and_last_echo_and_their_remission() {
        let s = scan(&[
            (b"DIST1", 16, vec![1000, 0, 2, 500]),
            (b"DIST2", 16, vec![3000, 0, 1500, 0]),
            (b"RSSI1", 8, vec![10, 0, 0, 40]),
            (b"RSSI2", 16, vec![0x3000, 0, 0x2000, 0]),
        ]);
        let mut out = Vec::new();
        let c = conv(SickMount::default(), Echo::Last)
            .convert(&s, &mut out)
            .expect("converts");
        assert_eq!((c.count, c.echoes, c.valid), (4, 2, 3));
        let got: Vec<(f32, u8)> = out.iter().map(|r| (r.range_m, r.intensity)).collect();
        assert_eq!(got, vec![(3.0, 0x30), (0.0, 0), (1.5, 0x20), (0.5, 40)]);
        conv(SickMount::default(), Echo::First)
            .convert(&s, &mut out)
            .expect("converts");
        let got: Vec<(f32, u8)> = out.iter().map(|r| (r.range_m, r.intensity)).collect();
        assert_eq!(got, vec![(1.0, 10), (0.0, 0), (1.5, 0x20), (0.5, 40)]);
        assert_eq!(out[0].return_type, return_type::FIRST);
    }

    #[test]
    fn a_scan_without_distances_or_with_mismatched_echoes_is_named() {
        let mut out = Vec::new();
        let c = conv(SickMount::default(), Echo::Last);
        let e = c
            .convert(&scan(&[(b"RSSI1", 8, vec![1])]), &mut out)
            .expect_err("no DIST1");
        assert!(e.to_string().contains("RSSI1"));
        let e = c
            .convert(
                &scan(&[(b"DIST1", 16, vec![1, 2]), (b"DIST2", 16, vec![1])]),
                &mut out,
            )
            .expect_err("mismatch");
        assert!(matches!(e, ConvertError::Mismatch { count: 1, .. }));
    }
}
