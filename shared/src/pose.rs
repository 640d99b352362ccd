//! Poses and frame transforms, on nalgebra: one 2-D pose type, [`Pose2`], for the robot in the
//! odometry frame, and one way to bring a point from a fixed frame into the robot's
//! ([`Pose2Ext::to_local`]) and back ([`Pose2Ext::to_fixed`]).
//!
//! Frames follow REP-103 / REP-105: x forward, y left, z up; metres and radians; the odometry
//! frame is fixed, the robot frame moves with the robot (DESIGN §4). Hot inner loops that move
//! thousands of points may keep a pose's sine and cosine in plain numbers; everything else goes
//! through this module.
//!
//! ```
//! use mimnav_shared::pose::{Pose2Ext, pose2};
//! // a robot at (1, 2) facing +y sees a goal at (1, 5) 3 m straight ahead
//! let robot = pose2(1.0, 2.0, std::f64::consts::FRAC_PI_2);
//! let (x, y) = robot.to_local(1.0, 5.0);
//! assert!((x - 3.0).abs() < 1e-12 && y.abs() < 1e-12);
//! ```

pub use nalgebra::{Isometry2, Isometry3, Point2, Point3, Translation3, UnitQuaternion, Vector2};

use crate::config::{Checks, Invalid};
use crate::topics::Odometry;

/// A pose in the plane: position (m) and heading (rad, counter-clockwise from x). As a transform
/// it maps points of the posed frame (the robot's) into the frame it is given in (odometry).
pub type Pose2 = Isometry2<f64>;

/// The pose at `(x, y)` with heading `yaw`.
pub fn pose2(x: f64, y: f64, yaw: f64) -> Pose2 {
    Isometry2::new(Vector2::new(x, y), yaw)
}

/// The robot's pose an `odom` message gives, or `None` when a field is not finite.
pub fn odom_pose(odom: &Odometry) -> Option<Pose2> {
    (odom.x.is_finite() && odom.y.is_finite() && odom.yaw.is_finite())
        .then(|| pose2(odom.x, odom.y, odom.yaw))
}

/// Odometry with a number that is not finite: refused where it arrives, so it never steers and
/// never moves a memory (the last good message ages into stale odometry instead).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("odometry with a non-finite pose or velocity (seq {0}): ignored")]
pub struct NonFiniteOdometry(pub u64);

/// The robot's pose an `odom` message gives, when its pose and velocity are all finite.
pub fn check_odometry(odom: &Odometry) -> Result<Pose2, NonFiniteOdometry> {
    odom_pose(odom)
        .filter(|_| odom.v.is_finite() && odom.omega.is_finite())
        .ok_or(NonFiniteOdometry(odom.seq))
}

/// What every code path asks of a pose.
pub trait Pose2Ext {
    /// x, m.
    fn x(&self) -> f64;
    /// y, m.
    fn y(&self) -> f64;
    /// Heading in (−π, π], rad.
    fn yaw(&self) -> f64;
    /// A point given in the fixed frame, in this pose's frame (e.g. the goal in the robot frame).
    fn to_local(&self, x: f64, y: f64) -> (f64, f64);
    /// A point given in this pose's frame, in the fixed frame (the T of MIM equation 6).
    fn to_fixed(&self, x: f64, y: f64) -> (f64, f64);
    /// `other` seen from this pose: the motion from here to there, in this pose's frame.
    fn motion_to(&self, other: &Self) -> Self;
    /// All three numbers finite.
    fn is_finite(&self) -> bool;
}

impl Pose2Ext for Pose2 {
    fn x(&self) -> f64 {
        self.translation.x
    }

    fn y(&self) -> f64 {
        self.translation.y
    }

    fn yaw(&self) -> f64 {
        self.rotation.angle()
    }

    fn to_local(&self, x: f64, y: f64) -> (f64, f64) {
        let p = self.inverse_transform_point(&Point2::new(x, y));
        (p.x, p.y)
    }

    fn to_fixed(&self, x: f64, y: f64) -> (f64, f64) {
        let p = self.transform_point(&Point2::new(x, y));
        (p.x, p.y)
    }

    fn motion_to(&self, other: &Self) -> Self {
        self.inv_mul(other)
    }

    fn is_finite(&self) -> bool {
        self.translation.x.is_finite()
            && self.translation.y.is_finite()
            && self.rotation.re.is_finite()
            && self.rotation.im.is_finite()
    }
}

/// Where the lidar sits on the robot (`robot.mount`): its optical centre `x_m` forward and
/// `y_m` left of the robot's vertical axis, at `robot.sensor_height_m` above the ground, turned
/// by `roll_deg`, `pitch_deg`, `yaw_deg` (REP-103: about x, y, z, applied in that order, i.e.
/// R = Rz(yaw)·Ry(pitch)·Rx(roll)). Spot carries its VLP-16 on its back, not at its centre.
///
/// The mapper and the foliage classifier bring every return through [`MountTransform`] into the
/// frame of a virtual sensor centred on the robot's axis at the same height, level and facing
/// forward; everything downstream (layers, glass, classes, the planner) sees a centred sensor.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct LidarMount {
    /// Forward of the robot's axis, m.
    pub x_m: f64,
    /// Left of the robot's axis, m.
    pub y_m: f64,
    /// Roll, degrees (right side down is positive).
    pub roll_deg: f64,
    /// Pitch, degrees (nose down is positive).
    pub pitch_deg: f64,
    /// Yaw, degrees (counter-clockwise from the robot's forward).
    pub yaw_deg: f64,
}

impl LidarMount {
    /// Checks every value is finite and within a range a robot can have: the sensor within 3 m
    /// of the axis, tilted at most 45°; each value refused names its key (`robot.mount.…`).
    pub fn validate(&self) -> Result<(), Invalid> {
        let mut r = Checks::default();
        r.check("robot.mount.x_m", self.x_m, -3.0, 3.0);
        r.check("robot.mount.y_m", self.y_m, -3.0, 3.0);
        r.check("robot.mount.roll_deg", self.roll_deg, -45.0, 45.0);
        r.check("robot.mount.pitch_deg", self.pitch_deg, -45.0, 45.0);
        r.check("robot.mount.yaw_deg", self.yaw_deg, -180.0, 180.0);
        r.finish()
    }

    /// The sensor's frame in the centred sensor's: rotation and the offset on the ground plane.
    pub fn isometry(&self) -> Isometry3<f64> {
        let r = UnitQuaternion::from_euler_angles(
            self.roll_deg.to_radians(),
            self.pitch_deg.to_radians(),
            self.yaw_deg.to_radians(),
        );
        Isometry3::from_parts(Translation3::new(self.x_m, self.y_m, 0.0), r)
    }
}

/// A [`LidarMount`] ready for the inner loops: its rotation and offset in `f32`. `None` from
/// [`MountTransform::of`] for a centred, level mount: then nothing is moved and the points stay
/// bit for bit what the driver published.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MountTransform {
    r: [[f32; 3]; 3],
    t: [f32; 3],
}

impl MountTransform {
    /// The transform of `mount`, or `None` when it is the identity.
    pub fn of(mount: &LidarMount) -> Option<MountTransform> {
        if *mount == LidarMount::default() {
            return None;
        }
        Some(MountTransform::from_isometry(&mount.isometry()))
    }

    /// The inverse: the centred sensor's frame in the mounted sensor's (for tests and
    /// simulations of a mounted sensor).
    pub fn inverse_of(mount: &LidarMount) -> MountTransform {
        MountTransform::from_isometry(&mount.isometry().inverse())
    }

    fn from_isometry(iso: &Isometry3<f64>) -> MountTransform {
        let m = iso.rotation.to_rotation_matrix();
        let r = std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)] as f32));
        let t = iso.translation.vector;
        MountTransform {
            r,
            t: [t.x as f32, t.y as f32, t.z as f32],
        }
    }

    /// A point of the mounted sensor's frame in the centred sensor's.
    #[inline]
    pub fn apply(&self, [x, y, z]: [f32; 3]) -> [f32; 3] {
        let r = &self.r;
        [
            r[0][0] * x + r[0][1] * y + r[0][2] * z + self.t[0],
            r[1][0] * x + r[1][1] * y + r[1][2] * z + self.t[1],
            r[2][0] * x + r[2][1] * y + r[2][2] * z + self.t[2],
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    #[test]
    fn a_mount_moves_points_into_the_centred_sensors_frame() {
        assert_eq!(MountTransform::of(&LidarMount::default()), None);
        // turned 90° left, 0.3 m behind the axis: what it sees ahead is left of the robot
        let m = LidarMount {
            x_m: -0.3,
            yaw_deg: 90.0,
            ..LidarMount::default()
        };
        let [x, y, z] = MountTransform::of(&m)
            .expect("not centred")
            .apply([2.0, 0.0, 0.0]);
        assert!((x + 0.3).abs() < 1e-6 && (y - 2.0).abs() < 1e-6 && z.abs() < 1e-6);
        // nose down 10°: a point 1 m ahead of the sensor is below the centred sensor's level
        let m = LidarMount {
            pitch_deg: 10.0,
            ..LidarMount::default()
        };
        let [_, _, z] = MountTransform::of(&m)
            .expect("tilted")
            .apply([1.0, 0.0, 0.0]);
        assert!((z + 10f32.to_radians().sin()).abs() < 1e-6, "{z}");
        // and back
        let m = LidarMount {
            x_m: 0.25,
            y_m: -0.1,
            roll_deg: 3.0,
            pitch_deg: -7.0,
            yaw_deg: 170.0,
        };
        let p = [4.0, -1.5, 0.3];
        let there = MountTransform::inverse_of(&m).apply(p);
        let back = MountTransform::of(&m).expect("mounted").apply(there);
        assert!(
            p.iter().zip(back).all(|(a, b)| (a - b).abs() < 1e-5),
            "{back:?}"
        );
    }

    #[test]
    fn an_impossible_mount_is_refused_by_key() {
        assert!(LidarMount::default().validate().is_ok());
        let nan = LidarMount {
            pitch_deg: f64::NAN,
            ..LidarMount::default()
        };
        let e = nan.validate().expect_err("NaN");
        assert!(e.get("robot.mount.pitch_deg").is_some(), "{e}");
        let far = LidarMount {
            y_m: 7.0,
            ..LidarMount::default()
        };
        let e = far.validate().expect_err("7 m off the axis");
        assert_eq!(
            e.to_string(),
            "robot.mount.y_m = 7 is out of range: allowed -3 to 3"
        );
    }

    #[test]
    fn to_local_and_to_fixed_are_inverse() {
        let p = pose2(-3.0, 4.5, 2.3);
        for &(x, y) in &[(0.0, 0.0), (1.0, -2.0), (100.0, 3.0)] {
            let (lx, ly) = p.to_local(x, y);
            let (fx, fy) = p.to_fixed(lx, ly);
            assert!((fx - x).abs() < 1e-9 && (fy - y).abs() < 1e-9, "{x} {y}");
        }
    }

    #[test]
    fn a_goal_behind_and_left_of_a_turned_robot() {
        // facing −x at the origin: a goal at (−1, −2) is 1 m ahead and 2 m to the left
        let (x, y) = pose2(0.0, 0.0, PI).to_local(-1.0, -2.0);
        assert!(
            (x - 1.0).abs() < 1e-12 && (y - 2.0).abs() < 1e-12,
            "{x} {y}"
        );
    }

    #[test]
    fn motion_to_is_the_second_pose_in_the_first_frame_and_wraps() {
        let a = pose2(1.0, 1.0, FRAC_PI_2);
        let b = pose2(1.0, 3.0, -PI + 0.1);
        let m = a.motion_to(&b);
        assert!((m.x() - 2.0).abs() < 1e-12 && m.y().abs() < 1e-12);
        // from +90° to −179.9°: a turn of +90.1°, not −269.9°
        assert!((m.yaw() - (FRAC_PI_2 + 0.1)).abs() < 1e-12, "{}", m.yaw());
    }

    #[test]
    fn non_finite_odometry_has_no_pose() {
        let o = Odometry {
            x: f64::NAN,
            ..Odometry::default()
        };
        assert!(odom_pose(&o).is_none());
        assert!(odom_pose(&Odometry::default()).is_some_and(|p| p.is_finite()));
        let fast = Odometry {
            seq: 4,
            v: f32::INFINITY,
            ..Odometry::default()
        };
        assert_eq!(check_odometry(&fast), Err(NonFiniteOdometry(4)));
        assert!(check_odometry(&Odometry::default()).is_ok());
    }
}
