//! The robot base: a unicycle that follows velocity commands within its speed and acceleration
//! limits, and the collision check against the scene.

use mimnav_shared::config::{Body, RobotProfile};
use mimnav_shared::pose::{Pose2, Pose2Ext, pose2};

use crate::geometry::footprint_distance;
use crate::world::Scene;

/// Pose and velocity of the base.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Base {
    /// Pose in the world.
    pub pose: Pose2,
    /// Forward speed, m/s.
    pub v: f64,
    /// Turn rate, rad/s.
    pub omega: f64,
}

impl Base {
    /// A base at rest at `pose`.
    pub fn at(pose: Pose2) -> Self {
        Base {
            pose,
            v: 0.0,
            omega: 0.0,
        }
    }

    /// Moves for `dt` seconds towards the commanded (v, ω), each clamped to the limits and
    /// reached no faster than the accelerations allow.
    pub fn step(&mut self, cmd_v: f64, cmd_omega: f64, dt: f64, lim: &RobotProfile) {
        let target_v = cmd_v.clamp(-lim.max_linear_mps, lim.max_linear_mps);
        let target_w = cmd_omega.clamp(-lim.max_angular_rps, lim.max_angular_rps);
        let dv = (target_v - self.v).clamp(-lim.max_linear_accel * dt, lim.max_linear_accel * dt);
        let dw =
            (target_w - self.omega).clamp(-lim.max_angular_accel * dt, lim.max_angular_accel * dt);
        let (v0, w0) = (self.v, self.omega);
        self.v += dv;
        self.omega += dw;
        // midpoint integration of the unicycle
        let v = 0.5 * (v0 + self.v);
        let w = 0.5 * (w0 + self.omega);
        let yaw = self.pose.yaw();
        let yaw_mid = yaw + 0.5 * w * dt;
        let x = self.pose.x() + v * yaw_mid.cos() * dt;
        let y = self.pose.y() + v * yaw_mid.sin() * dt;
        // (wrapped as the integrator always did, though a Pose2 needs no wrapping: the same
        // arithmetic gives the same numbers)
        let yaw = (yaw + w * dt + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        self.pose = pose2(x, y, yaw);
    }
}

/// Drives a base through waypoints: turn towards the next one, then drive at it, slowing down
/// near the last. A scripted driver for surveys, not a planner: it does not avoid anything.
#[derive(Debug, Clone)]
pub struct WaypointDriver {
    waypoints: Vec<[f64; 2]>,
    next: usize,
    tolerance_m: f64,
}

impl WaypointDriver {
    /// Drives through `waypoints`; one counts as reached within `tolerance_m`.
    pub fn new(waypoints: Vec<[f64; 2]>, tolerance_m: f64) -> Self {
        WaypointDriver {
            waypoints,
            next: 0,
            tolerance_m,
        }
    }

    /// True once the last waypoint is reached.
    pub fn done(&self) -> bool {
        self.next >= self.waypoints.len()
    }

    /// The (v, ω) command for `pose` within `lim`.
    pub fn command(&mut self, pose: &Pose2, lim: &RobotProfile) -> (f64, f64) {
        while let Some(w) = self.waypoints.get(self.next) {
            if (w[0] - pose.x()).hypot(w[1] - pose.y()) > self.tolerance_m {
                break;
            }
            self.next += 1;
        }
        let Some(w) = self.waypoints.get(self.next) else {
            return (0.0, 0.0);
        };
        // the waypoint in the robot frame: its bearing there is the heading error
        let (dx, dy) = pose.to_local(w[0], w[1]);
        let err = dy.atan2(dx);
        let omega = (2.0 * err).clamp(-lim.max_angular_rps, lim.max_angular_rps);
        let last = self.next + 1 == self.waypoints.len();
        let dist = dx.hypot(dy);
        let v = if err.abs() > 0.5 {
            0.0
        } else {
            let slow = if last { (dist / 1.0).min(1.0) } else { 1.0 };
            lim.max_linear_mps * slow * (1.0 - err.abs() / 0.5).max(0.2)
        };
        (v, omega)
    }
}

/// How far apart the points are that a rectangular body's outline is tested at, m: a contact is
/// called within half of this of the true outline.
pub const OUTLINE_SPACING_M: f64 = 0.02;

/// The first blocking object (solid or glass) the robot's `body` at `pose` touches. A round body
/// is exact; a rectangle is tested at points of its outline [`OUTLINE_SPACING_M`] apart, each
/// touching what lies within half that spacing (so a contact is called up to 1 cm early, never
/// missed), and at each object's centre, so that a small object wholly under the body counts.
pub fn body_contact(scene: &Scene, pose: &Pose2, body: &Body) -> Option<usize> {
    let (x, y) = (pose.x(), pose.y());
    let Body::Rectangle { .. } = body else {
        return contact(scene, x, y, body.enclosing_radius_m());
    };
    let reach = body.enclosing_radius_m();
    let (s, c) = pose.yaw().sin_cos();
    let outline: Vec<[f64; 2]> = body
        .outline(OUTLINE_SPACING_M)
        .into_iter()
        .map(|[bx, by]| [x + c * bx - s * by, y + s * bx + c * by])
        .collect();
    scene.objects.iter().position(|o| {
        if !o.blocks {
            return false;
        }
        let (centre, r) = o.bound;
        if (centre[0] - x).hypot(centre[1] - y) > r + reach {
            return false;
        }
        let (dx, dy) = (centre[0] - x, centre[1] - y);
        body.signed_distance(c * dx + s * dy, -s * dx + c * dy) < 0.0
            || outline
                .iter()
                .any(|&p| footprint_distance(&o.shape, p) < 0.5 * OUTLINE_SPACING_M)
    })
}

/// The first blocking object (solid or glass) a robot of `radius` at (x, y) touches.
pub fn contact(scene: &Scene, x: f64, y: f64, radius: f64) -> Option<usize> {
    scene.objects.iter().position(|o| {
        if !o.blocks {
            return false;
        }
        let (c, r) = o.bound;
        if (c[0] - x).hypot(c[1] - y) > r + radius {
            return false;
        }
        footprint_distance(&o.shape, [x, y]) < radius
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A base with round limits.
    fn lim() -> RobotProfile {
        RobotProfile {
            max_linear_mps: 0.5,
            max_angular_rps: 1.0,
            max_linear_accel: 0.5,
            max_angular_accel: 2.0,
            ..RobotProfile::default()
        }
    }

    #[test]
    fn accelerates_within_limits_and_drives_straight() {
        let lim = lim();
        let mut b = Base::at(pose2(0.0, 0.0, 0.0));
        b.step(2.0, 0.0, 0.5, &lim);
        assert!((b.v - 0.25).abs() < 1e-9, "accel-limited: {}", b.v);
        for _ in 0..100 {
            b.step(2.0, 0.0, 0.1, &lim);
        }
        assert!((b.v - 0.5).abs() < 1e-9, "speed-limited: {}", b.v);
        assert!(b.pose.y().abs() < 1e-9 && b.pose.x() > 4.0);
    }

    #[test]
    fn turns_in_place() {
        let lim = lim();
        let mut b = Base::at(pose2(1.0, 1.0, 0.0));
        for _ in 0..1000 {
            b.step(0.0, 1.0, 0.001, &lim);
        }
        assert!((b.pose.x() - 1.0).abs() < 1e-9 && (b.pose.y() - 1.0).abs() < 1e-9);
        // 0.5 s to reach 1 rad/s (0.25 rad), then 0.5 s at 1 rad/s
        assert!((b.pose.yaw() - 0.75).abs() < 1e-2, "{}", b.pose.yaw());
    }

    #[test]
    fn a_rectangular_body_touches_by_its_outline_and_its_heading() {
        let world = crate::world::WorldFile::parse(
            "name = \"t\"\nstart = [0.0, 0.0, 0.0]\ngoal = [5.0, 0.0]\ntime_limit_s = 10.0\n\
             [[wall]]\nfrom = [-3.0, 0.4]\nto = [3.0, 0.4]\n",
            "t",
        )
        .expect("world");
        let scene = world.compile();
        let spot = Body::Rectangle {
            length_m: 1.1,
            width_m: 0.5,
        };
        // along the wall, 0.4 m from it (its half width is 0.25): clear; a round body of the
        // enclosing radius (0.6 m) would touch
        assert_eq!(body_contact(&scene, &pose2(0.0, 0.0, 0.0), &spot), None);
        assert!(contact(&scene, 0.0, 0.0, spot.enclosing_radius_m()).is_some());
        // turned across it, the same body reaches 0.55 m: it touches
        assert!(
            body_contact(&scene, &pose2(0.0, 0.0, std::f64::consts::FRAC_PI_2), &spot).is_some()
        );
        assert!(body_contact(&scene, &pose2(0.0, 0.0, 0.6), &spot).is_some());
        // a round body is tested as before
        assert_eq!(
            body_contact(&scene, &pose2(0.0, 0.0, 0.0), &Body::Round(0.2)),
            None
        );
    }
}
