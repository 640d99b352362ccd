//! Odometry from the Basic Sensor Data's encoders and the Inertial Sensor Data's heading.
//!
//! The odometry frame follows REP-105: x forward, y left, yaw counter-clockwise, starting at
//! the origin with yaw 0 at the first feedback. Each frame:
//! - each wheel's travel is its encoder difference, taken as a wrapping `u16` difference read
//!   as `i16` (so 65535 → 2 is +3 ticks), times [`M_PER_TICK`]; the
//!   distance is the mean of the two wheels;
//! - the yaw is the gyro's angle minus its first reading, unwrapped (a step is taken the
//!   short way round), so it is continuous across ±180° and counts whole turns; a frame with
//!   no Inertial Sensor Data turns by the wheels' difference over the wheel base instead;
//! - x, y advance by the distance along the mean of the old and new yaw;
//! - the velocities are the frame's distance and yaw change over the time between the base's
//!   own timestamps (a wrapping `u16` of ms), not the host's receive times, which the USB
//!   serial link makes jittery. Two frames with the same timestamp keep the last velocities.
//!
//! The reference driver (kobuki_core `DiffDrive::update`, `Kobuki::getHeading`) takes the same
//! wrapping differences and uses the first gyro reading as zero heading.

use std::f64::consts::{PI, TAU};

use crate::feedback::{BasicSensorData, InertialSensorData};
use crate::{M_PER_TICK, WHEEL_BASE_M};

/// A pose and velocity estimate.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct OdomEstimate {
    /// Forward of the start, m.
    pub x: f64,
    /// Left of the start, m.
    pub y: f64,
    /// Heading, rad, counter-clockwise from the start; unwrapped (not limited to ±π).
    pub yaw: f64,
    /// Forward speed, m/s.
    pub v: f64,
    /// Turn rate, rad/s.
    pub w: f64,
    /// The base's timestamp of the frame this estimate is at, ms.
    pub stamp_ms: u16,
    /// Time from the previous frame by the base's clock, s (0 for the first).
    pub dt_s: f64,
}

/// Wraps `a` into [-π, π).
pub fn wrap_pi(a: f64) -> f64 {
    (a + PI).rem_euclid(TAU) - PI
}

/// The odometry integrator; see the module documentation.
#[derive(Debug, Clone)]
pub struct Odometry {
    m_per_tick: f64,
    wheel_base_m: f64,
    last: Option<Last>,
    est: OdomEstimate,
}

#[derive(Debug, Clone, Copy)]
struct Last {
    left: u16,
    right: u16,
    stamp_ms: u16,
    /// The last gyro angle read (rad), and the offset of the first.
    gyro: Option<(f64, f64)>,
}

impl Default for Odometry {
    fn default() -> Self {
        Self::new()
    }
}

impl Odometry {
    /// Odometry for the Kobuki's wheels ([`M_PER_TICK`], [`WHEEL_BASE_M`]).
    pub fn new() -> Self {
        Self::with_geometry(M_PER_TICK, WHEEL_BASE_M)
    }

    /// Odometry for other wheels: metres per tick and the wheel base, m.
    pub fn with_geometry(m_per_tick: f64, wheel_base_m: f64) -> Self {
        Odometry {
            m_per_tick,
            wheel_base_m,
            last: None,
            est: OdomEstimate::default(),
        }
    }

    /// The estimate after the last frame.
    pub fn estimate(&self) -> &OdomEstimate {
        &self.est
    }

    /// Starts again at the origin from the next frame.
    pub fn reset(&mut self) {
        self.last = None;
        self.est = OdomEstimate::default();
    }

    /// Forgets the last frame but keeps the pose: the next frame's encoders and gyro are taken
    /// as where the base is now (after the link was lost the base may have been switched off
    /// and on, its encoders and gyro starting again from zero). The motion while the link was
    /// down is not known.
    pub fn resync(&mut self) {
        self.last = None;
    }

    /// Takes one feedback frame's encoders and (if it had one) gyro reading.
    pub fn update(
        &mut self,
        basic: &BasicSensorData,
        inertial: Option<&InertialSensorData>,
    ) -> OdomEstimate {
        let angle = inertial.map(InertialSensorData::angle_rad);
        let Some(last) = self.last else {
            // the first frame, or the first after a resync: the pose stays where it is (the
            // origin at first), the gyro's zero is where it reads that heading
            self.last = Some(Last {
                left: basic.left_encoder,
                right: basic.right_encoder,
                stamp_ms: basic.timestamp_ms,
                gyro: angle.map(|a| (a, a - self.est.yaw)),
            });
            self.est = OdomEstimate {
                stamp_ms: basic.timestamp_ms,
                v: 0.0,
                w: 0.0,
                dt_s: 0.0,
                ..self.est
            };
            return self.est;
        };
        let dl = f64::from(basic.left_encoder.wrapping_sub(last.left) as i16) * self.m_per_tick;
        let dr = f64::from(basic.right_encoder.wrapping_sub(last.right) as i16) * self.m_per_tick;
        let d = (dl + dr) / 2.0;
        let (dyaw, gyro) = match (angle, last.gyro) {
            (Some(a), Some((prev, first))) => (wrap_pi(a - prev), Some((a, first))),
            // the first gyro reading after frames without one: its heading is where the
            // wheels say the base is
            (Some(a), None) => (0.0, Some((a, a - self.est.yaw))),
            (None, g) => ((dr - dl) / self.wheel_base_m, g),
        };
        let mid = self.est.yaw + dyaw / 2.0;
        self.est.x += d * mid.cos();
        self.est.y += d * mid.sin();
        self.est.yaw += dyaw;
        let dt_ms = basic.timestamp_ms.wrapping_sub(last.stamp_ms);
        self.est.stamp_ms = basic.timestamp_ms;
        self.est.dt_s = f64::from(dt_ms) / 1000.0;
        if dt_ms > 0 {
            self.est.v = d / self.est.dt_s;
            self.est.w = dyaw / self.est.dt_s;
        }
        self.last = Some(Last {
            left: basic.left_encoder,
            right: basic.right_encoder,
            stamp_ms: basic.timestamp_ms,
            gyro,
        });
        self.est
    }

    /// The yaw the gyro's first reading is zero of, rad (`None` before a gyro reading).
    pub fn gyro_offset(&self) -> Option<f64> {
        self.last.and_then(|l| l.gyro.map(|(_, first)| first))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn basic(t: u16, l: u16, r: u16) -> BasicSensorData {
        BasicSensorData {
            timestamp_ms: t,
            left_encoder: l,
            right_encoder: r,
            ..BasicSensorData::default()
        }
    }

    fn gyro(cdeg: i16) -> InertialSensorData {
        InertialSensorData {
            angle_cdeg: cdeg,
            angle_rate_cdeg_s: 0,
        }
    }

    #[test]
    fn straight_across_encoder_and_timestamp_wrap() {
        let mut o = Odometry::new();
        // start 10 ticks below the wrap, 20 ms below the timestamp's wrap
        let (mut l, mut t) = (65526u16, 65516u16);
        o.update(&basic(t, l, l), Some(&gyro(4500)));
        for _ in 0..50 {
            // 47 ticks per 20 ms ≈ 0.2 m/s
            l = l.wrapping_add(47);
            t = t.wrapping_add(20);
            o.update(&basic(t, l, l), Some(&gyro(4500)));
        }
        let e = *o.estimate();
        let expected = 50.0 * 47.0 * M_PER_TICK;
        assert!((e.x - expected).abs() < 1e-9, "{e:?}");
        assert!(e.y.abs() < 1e-12 && e.yaw.abs() < 1e-12, "{e:?}");
        assert!((e.v - 47.0 * M_PER_TICK / 0.02).abs() < 1e-9, "{e:?}");
        assert!((e.dt_s - 0.02).abs() < 1e-12);
        assert!((expected - 0.2).abs() < 0.01);
    }

    #[test]
    fn backwards_across_the_wrap() {
        let mut o = Odometry::new();
        o.update(&basic(0, 2, 2), None);
        let e = o.update(&basic(20, 65533, 65533), None);
        assert!((e.x + 5.0 * M_PER_TICK).abs() < 1e-12, "{e:?}");
        assert!(e.v < 0.0);
    }

    #[test]
    fn gyro_heading_is_relative_and_unwrapped() {
        let mut o = Odometry::new();
        // the gyro starts at 170°; turn +30° per frame for 24 frames: two whole turns
        let mut a: i32 = 17000;
        o.update(&basic(0, 0, 0), Some(&gyro(a as i16)));
        for k in 1..=24 {
            a += 3000;
            // the base reports its angle within ±180°
            let wrapped = (a + 18000).rem_euclid(36000) - 18000;
            let e = o.update(&basic(20 * k, 0, 0), Some(&gyro(wrapped as i16)));
            assert!(
                (e.yaw - (30.0 * f64::from(k)).to_radians()).abs() < 1e-9,
                "{k}: {e:?}"
            );
            assert!((e.w - 30f64.to_radians() / 0.02).abs() < 1e-6);
        }
        assert!((o.estimate().yaw - 2.0 * TAU).abs() < 1e-9);
        assert!((o.gyro_offset().unwrap() - 170f64.to_radians()).abs() < 1e-12);
    }

    #[test]
    fn arc_follows_heading() {
        // a quarter circle of radius 0.5 m in 100 frames, by the gyro
        let mut o = Odometry::new();
        o.update(&basic(0, 0, 0), Some(&gyro(0)));
        let r = 0.5;
        let quarter = std::f64::consts::FRAC_PI_2;
        let (mut l, mut rt) = (0f64, 0f64);
        for k in 1..=100u16 {
            let dyaw = quarter / 100.0;
            l += dyaw * (r - WHEEL_BASE_M / 2.0) / M_PER_TICK;
            rt += dyaw * (r + WHEEL_BASE_M / 2.0) / M_PER_TICK;
            let yaw_cdeg = (f64::from(k) * dyaw).to_degrees() * 100.0;
            o.update(
                &basic(20 * k, l.round() as u16, rt.round() as u16),
                Some(&gyro(yaw_cdeg.round() as i16)),
            );
        }
        let e = o.estimate();
        assert!((e.x - r).abs() < 3e-3 && (e.y - r).abs() < 3e-3, "{e:?}");
        assert!((e.yaw - quarter).abs() < 1e-3);
    }

    #[test]
    fn same_timestamp_keeps_velocity_and_wheels_turn_without_gyro() {
        let mut o = Odometry::new();
        o.update(&basic(100, 0, 0), None);
        let e = o.update(&basic(120, 0, 100), None);
        let w = 100.0 * M_PER_TICK / WHEEL_BASE_M / 0.02;
        assert!((e.w - w).abs() < 1e-9);
        let e = o.update(&basic(120, 0, 100), None);
        assert!((e.w - w).abs() < 1e-9, "{e:?}");
        o.reset();
        assert_eq!(o.update(&basic(7, 5, 5), None).x, 0.0);
    }

    #[test]
    fn wrap_pi_range() {
        for a in [-7.0, -PI, 0.0, PI, 3.5 * PI, 100.0] {
            let w = wrap_pi(a);
            assert!((-PI..PI).contains(&w), "{a} → {w}");
            assert!(((a - w) / TAU - ((a - w) / TAU).round()).abs() < 1e-9);
        }
    }
}
