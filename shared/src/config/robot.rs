//! `[robot]`: the robot profile (`config/robots/NAME.toml`).

use serde::{Deserialize, Serialize};

use super::check::{Checks, Invalid};

/// A robot: footprint, sensor mounting and motion limits (`config/robots/NAME.toml`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RobotProfile {
    /// Profile name.
    pub name: String,
    /// Radius of the round body, metres (a round robot's footprint; see [`RobotProfile::body`]).
    pub radius_m: f64,
    /// Length of a rectangular body along the heading, metres; with `width_m`, the footprint is
    /// this rectangle centred on the base, and `radius_m` is not used. 0 (the default): round.
    pub length_m: f64,
    /// Width of a rectangular body across the heading, metres (0: round).
    pub width_m: f64,
    /// Height of the lidar's optical centre above the ground, metres.
    pub sensor_height_m: f64,
    /// Height of the robot's top above the ground, metres.
    pub height_m: f64,
    /// Largest forward speed, m/s.
    pub max_linear_mps: f64,
    /// Largest turn rate, rad/s.
    pub max_angular_rps: f64,
    /// Largest linear acceleration, m/s².
    pub max_linear_accel: f64,
    /// Largest angular acceleration, rad/s².
    pub max_angular_accel: f64,
    /// How long a velocity command stays valid on the base, seconds.
    pub command_validity_s: f64,
    /// Where the lidar sits on the robot (`[robot.mount]`; its height is `sensor_height_m`).
    pub mount: crate::pose::LidarMount,
}

impl Default for RobotProfile {
    /// The Turtlebot 2 (DESIGN §4).
    fn default() -> Self {
        RobotProfile {
            name: "turtlebot2".into(),
            radius_m: 0.20,
            length_m: 0.0,
            width_m: 0.0,
            sensor_height_m: 0.5,
            height_m: 0.6,
            max_linear_mps: 0.5,
            max_angular_rps: 1.5,
            max_linear_accel: 0.6,
            max_angular_accel: 3.0,
            command_validity_s: 0.5,
            mount: crate::pose::LidarMount::default(),
        }
    }
}

impl RobotProfile {
    /// Checks every key of `[robot]`: each value refused names its key and what is allowed.
    pub fn validate(&self) -> Result<(), Invalid> {
        let mut r = Checks::default();
        r.check("robot.radius_m", self.radius_m, 0.05, 3.0);
        if self.length_m != 0.0 || self.width_m != 0.0 {
            r.check("robot.length_m", self.length_m, 0.1, 6.0);
            r.check("robot.width_m", self.width_m, 0.1, 6.0);
            r.require(
                self.width_m <= self.length_m || self.width_m.is_nan(),
                "robot.width_m",
                format!(
                    "robot.width_m = {} is more than robot.length_m = {}: the length is along the \
                     heading, the longer side",
                    self.width_m, self.length_m
                ),
            );
        }
        r.check("robot.sensor_height_m", self.sensor_height_m, 0.05, 3.0);
        r.check("robot.height_m", self.height_m, 0.05, 3.0);
        r.check("robot.max_linear_mps", self.max_linear_mps, 0.01, 5.0);
        r.check("robot.max_angular_rps", self.max_angular_rps, 0.01, 10.0);
        r.check("robot.max_linear_accel", self.max_linear_accel, 0.01, 20.0);
        r.check(
            "robot.max_angular_accel",
            self.max_angular_accel,
            0.01,
            50.0,
        );
        r.check(
            "robot.command_validity_s",
            self.command_validity_s,
            0.01,
            10.0,
        );
        r.merge(self.mount.validate());
        r.finish()
    }
}

/// The robot's body on the ground, centred on the base, x along the heading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Body {
    /// A round body of this radius, m.
    Round(f64),
    /// A rectangle of this length (along the heading) and width, m.
    Rectangle {
        /// Along the heading, m.
        length_m: f64,
        /// Across the heading, m.
        width_m: f64,
    },
}

/// One disc of a cover of the body: its centre `x_m` ahead of the base's centre along the
/// heading, and its radius.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Disc {
    /// Centre along the heading from the base's centre, m (negative: behind).
    pub x_m: f64,
    /// Radius, m.
    pub radius_m: f64,
}

impl RobotProfile {
    /// The body: a rectangle when `length_m` and `width_m` are given, else round of `radius_m`.
    pub fn body(&self) -> Body {
        if self.length_m > 0.0 && self.width_m > 0.0 {
            Body::Rectangle {
                length_m: self.length_m,
                width_m: self.width_m,
            }
        } else {
            Body::Round(self.radius_m)
        }
    }
}

impl Body {
    /// Radius of the circle around the base's centre that encloses the body: what a robot
    /// turning in place sweeps, m.
    pub fn enclosing_radius_m(&self) -> f64 {
        match *self {
            Body::Round(r) => r,
            Body::Rectangle { length_m, width_m } => 0.5 * length_m.hypot(width_m),
        }
    }

    /// The body with `by_m` more on every side: a round one's radius, a rectangle's length and
    /// width by twice it (what keeping `by_m` from everything asks of the world), m.
    pub fn grown(&self, by_m: f64) -> Body {
        match *self {
            Body::Round(r) => Body::Round(r + by_m),
            Body::Rectangle { length_m, width_m } => Body::Rectangle {
                length_m: length_m + 2.0 * by_m,
                width_m: width_m + 2.0 * by_m,
            },
        }
    }

    /// Half the narrowest gap the body passes through driving straight, m.
    pub fn half_width_m(&self) -> f64 {
        match *self {
            Body::Round(r) => r,
            Body::Rectangle { width_m, .. } => 0.5 * width_m,
        }
    }

    /// Discs along the heading whose union covers the body, each of radius half the width plus
    /// `side_m` (so the cover reaches at most `side_m` beyond the long sides); one disc for a
    /// round body. Every disc is the same size, the end ones centred so that they just cover
    /// the corners; the cover therefore reaches beyond the front and the back by
    /// `width/2 + side_m − √(side_m·(width + side_m))` (0.15 m for Spot at 3 cm). A point
    /// farther than a disc's radius from every disc's centre is outside the body.
    pub fn discs(&self, side_m: f64) -> Vec<Disc> {
        match *self {
            Body::Round(r) => vec![Disc {
                x_m: 0.0,
                radius_m: r,
            }],
            Body::Rectangle { length_m, width_m } => {
                let side_m = side_m.max(1e-3);
                let radius_m = 0.5 * width_m + side_m;
                // half the length along the axis one disc covers across the full width
                let a = (side_m * (width_m + side_m)).sqrt();
                let span = (length_m - 2.0 * a).max(0.0);
                let n = (span / (2.0 * a)).ceil() as usize + 1;
                (0..n)
                    .map(|i| Disc {
                        x_m: if n == 1 {
                            0.0
                        } else {
                            -0.5 * span + span * i as f64 / (n - 1) as f64
                        },
                        radius_m,
                    })
                    .collect()
            }
        }
    }

    /// The distance from the body's outline to the point `(x, y)` in the body's frame (x along
    /// the heading, origin at the base's centre), m: negative inside.
    pub fn signed_distance(&self, x: f64, y: f64) -> f64 {
        match *self {
            Body::Round(r) => x.hypot(y) - r,
            Body::Rectangle { length_m, width_m } => {
                let dx = x.abs() - 0.5 * length_m;
                let dy = y.abs() - 0.5 * width_m;
                dx.max(0.0).hypot(dy.max(0.0)) + dx.max(dy).min(0.0)
            }
        }
    }

    /// The sides of a rectangular body, counter-clockwise from the front left corner (body
    /// frame): each side's first corner, its unit direction and its length; none for a round
    /// body.
    pub fn sides(&self) -> Vec<Side> {
        match *self {
            Body::Round(_) => Vec::new(),
            Body::Rectangle { length_m, width_m } => {
                let (hl, hw) = (0.5 * length_m, 0.5 * width_m);
                vec![
                    Side {
                        from: [hl, hw],
                        dir: [-1.0, 0.0],
                        len_m: length_m,
                    },
                    Side {
                        from: [-hl, hw],
                        dir: [0.0, -1.0],
                        len_m: width_m,
                    },
                    Side {
                        from: [-hl, -hw],
                        dir: [1.0, 0.0],
                        len_m: length_m,
                    },
                    Side {
                        from: [hl, -hw],
                        dir: [0.0, 1.0],
                        len_m: width_m,
                    },
                ]
            }
        }
    }

    /// Points along the body's outline no farther apart than `spacing_m` (body frame), for
    /// contact tests against shapes that give a distance to a point; a round body gives none
    /// (its centre and radius decide).
    pub fn outline(&self, spacing_m: f64) -> Vec<[f64; 2]> {
        let mut out = Vec::new();
        for s in self.sides() {
            let n = (s.len_m / spacing_m.max(1e-3)).ceil().max(1.0) as usize;
            for i in 0..n {
                out.push(s.at(s.len_m * i as f64 / n as f64));
            }
        }
        out
    }
}

/// One side of a rectangular body ([`Body::sides`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Side {
    /// Its first corner (body frame), m.
    pub from: [f64; 2],
    /// Unit direction along it.
    pub dir: [f64; 2],
    /// Its length, m.
    pub len_m: f64,
}

impl Side {
    /// The point `t` metres along the side from its first corner.
    pub fn at(&self, t: f64) -> [f64; 2] {
        [
            self.from[0] + self.dir[0] * t,
            self.from[1] + self.dir[1] * t,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spot() -> Body {
        Body::Rectangle {
            length_m: 1.1,
            width_m: 0.5,
        }
    }

    #[test]
    fn a_grown_body_keeps_that_much_more_on_every_side() {
        let by = 0.05;
        for body in [spot(), Body::Round(0.2)] {
            let g = body.grown(by);
            // a point on the body's outline lies `by` inside the grown one's, on every side
            let mut on = 0;
            for (x, y) in [
                (0.55, 0.0),
                (0.0, 0.25),
                (-0.55, 0.1),
                (0.2, -0.25),
                (0.2, 0.0),
            ] {
                let (d, dg) = (body.signed_distance(x, y), g.signed_distance(x, y));
                if d.abs() < 1e-9 {
                    on += 1;
                    assert!((dg + by).abs() < 1e-9, "{body:?} at ({x}, {y}): {dg}");
                }
                // and everywhere else too: the grown body's edge is `by` farther out
                if d > 0.0 && dg > 0.0 {
                    assert!(dg <= d - by + 1e-9, "{body:?} at ({x}, {y}): {d} {dg}");
                }
            }
            assert!(on >= 1, "{body:?}: no test point on its outline");
            assert!((g.half_width_m() - body.half_width_m() - by).abs() < 1e-12);
        }
    }

    #[test]
    fn the_discs_cover_the_rectangle_and_stay_near_its_long_sides() {
        for side in [0.01, 0.03, 0.1] {
            let discs = spot().discs(side);
            assert!(discs.len() >= 2, "{side}: {discs:?}");
            // every point of the rectangle is inside some disc
            for i in 0..=110 {
                for j in 0..=50 {
                    let (x, y) = (-0.55 + 0.01 * f64::from(i), -0.25 + 0.01 * f64::from(j));
                    assert!(
                        discs
                            .iter()
                            .any(|d| (x - d.x_m).hypot(y) <= d.radius_m + 1e-9),
                        "{side}: ({x}, {y}) uncovered"
                    );
                }
            }
            // no disc reaches farther than `side` beyond the long sides
            for d in &discs {
                assert!(d.radius_m <= 0.25 + side + 1e-9, "{d:?}");
            }
        }
    }

    #[test]
    fn the_rectangle_knows_inside_from_outside() {
        let b = spot();
        assert!(b.signed_distance(0.0, 0.0) < 0.0);
        assert!((b.signed_distance(0.65, 0.0) - 0.1).abs() < 1e-12);
        assert!((b.signed_distance(0.0, -0.35) - 0.1).abs() < 1e-12);
        assert!((b.signed_distance(0.55 + 0.3, 0.25 + 0.4) - 0.5).abs() < 1e-12);
        assert!((b.enclosing_radius_m() - 0.604_152).abs() < 1e-6);
        assert_eq!(b.half_width_m(), 0.25);
        let outline = b.outline(0.02);
        assert!(outline.len() >= 160, "{}", outline.len());
        assert!(
            outline
                .iter()
                .all(|p| b.signed_distance(p[0], p[1]).abs() < 1e-9)
        );
        assert_eq!(
            Body::Round(0.2).discs(0.03),
            vec![Disc {
                x_m: 0.0,
                radius_m: 0.2
            }]
        );
    }

    #[test]
    fn a_profile_with_length_and_width_is_a_rectangle_checked_both_ways() {
        let mut p = RobotProfile {
            length_m: 1.1,
            width_m: 0.5,
            ..RobotProfile::default()
        };
        assert_eq!(p.body(), spot());
        assert_eq!(p.validate(), Ok(()));
        p.width_m = 1.2;
        let e = p.validate().expect_err("wider than long");
        assert!(e.get("robot.width_m").is_some(), "{e}");
        p.width_m = 0.0;
        let e = p.validate().expect_err("only one side");
        assert!(e.get("robot.width_m").is_some(), "{e}");
        assert_eq!(RobotProfile::default().body(), Body::Round(0.2));
    }
}
