//! The Kobuki (Turtlebot 2) base: its serial protocol, odometry, a safety gate for velocity
//! commands and a simulated base, with no inter-process communication and no I/O except in
//! [`simbase`]'s serving loop.
//!
//! Follow the bytes in this order:
//! - [`frame`]: finding frames in the byte stream (`0xAA 0x55`, length, sub-payloads, XOR
//!   checksum), counting every byte that is not part of a good frame by reason, and writing
//!   frames;
//! - [`feedback`]: the base's 50 Hz feedback sub-payloads, typed ([`feedback::Feedback`]);
//! - [`command`]: Base Control and the other commands, and the conversion of (v, ω) to Base
//!   Control's (speed, radius) ([`command::BaseControl::from_twist`]);
//! - [`odometry`]: pose and velocity from the encoders, the gyro and the base's clock;
//! - [`safety`]: what may be sent to the base given the last command's age and the bumper,
//!   cliff and wheel-drop bits;
//! - [`simbase`]: a simulated base on the other end of the protocol, stepped by hand or
//!   served on a pseudo-terminal.
//!
//! A driver's loop: read the port, [`frame::FrameParser::push`] the bytes,
//! [`feedback::Feedback::decode`] each frame, feed [`odometry::Odometry::update`] and
//! [`safety::Safety::set_hazards`]; every cycle [`safety::Safety::decide`] and write
//! [`command::Command::encode`] of [`command::BaseControl::from_twist`] of the decision.
//!
//! ```
//! use mimnav_kobuki::command::{BaseControl, Command};
//! use mimnav_kobuki::feedback::Feedback;
//! use mimnav_kobuki::frame::FrameParser;
//! use mimnav_kobuki::simbase::{SimBase, SimBaseConfig};
//!
//! let mut base = SimBase::new(SimBaseConfig::default());
//! let mut bytes = Vec::new();
//! Command::BaseControl(BaseControl::from_twist(0.2, 0.0)).encode(&mut bytes).unwrap();
//! base.receive(&bytes);
//! base.step(1.0);
//! let mut wire = Vec::new();
//! base.feedback_frame(&mut wire);
//! let mut parser = FrameParser::new();
//! let frame = parser.push(&wire).next().unwrap().unwrap();
//! let basic = Feedback::decode(&frame).basic.unwrap();
//! // 0.2 m of wheel travel at 11 724 ticks/m
//! assert_eq!(basic.left_encoder, 2345);
//! ```
//!
//! # Protocol facts used, and where they come from
//!
//! From Yujin Robot's kobuki_driver documentation, "Appendix: Protocol Specification":
//! - "Structure of Bytestream": header `0xAA 0x55`, a length byte (the payload's length, at
//!   least 3), the payload, and a checksum that is the XOR of every byte but the headers;
//!   "Structure of Sub-Payloads": identifier byte, length byte, data. "Serialization":
//!   little-endian.
//! - "Command Packets": Base Control (0x01, 4 bytes: speed mm/s, radius mm, both i16), Sound
//!   Sequence (0x04, 1 byte), Request Extra (0x09, 2 bytes of flags: 0x01 hardware version,
//!   0x02 firmware version, 0x08 unique device id).
//! - "Feedback Packets", streamed at 50 Hz: Basic Sensor Data (0x01, 15 bytes), Docking IR
//!   (0x03), Inertial Sensor Data (0x04, 7 bytes: angle and angle rate in 0.01° and 0.01°/s),
//!   Cliff (0x05, 6), Current (0x06, 2), General Purpose Input (0x10); on request Hardware
//!   Version (0x0A, 4), Firmware Version (0x0B, 4), Unique Device Identifier (0x13, 12). The
//!   field tables are in [`feedback`] and [`command`].
//!
//! From "Appendix: Kobuki Parameters": wheel base 230 mm, wheel radius 35 mm, 2578.33 ticks a
//! wheel turn, i.e. [`TICK_TO_RAD`] = 0.002436916871363930187454 rad a tick.
//!
//! From the reference driver (kobuki_core, `DiffDrive::velocityCommands`): the (v, ω) →
//! (speed, radius) conversion with its special cases (|ω| < 1e-4: straight, radius 0; |v| <
//! 1e-4 or |radius| ≤ 1 mm: in place, radius 1, speed ω·b/2; otherwise speed is the outer
//! wheel's, (radius ± b/2)·ω), bounded to i16 by truncation; and (`DiffDrive::update`,
//! `Kobuki::getHeading`) the wrapping encoder and timestamp differences and the first gyro
//! reading taken as zero heading. Its packet finder rejects a frame whose checksum fails; the
//! resynchronisation here (from the byte after the rejected header) is this crate's own.
//!
//! The maximum wheel speed the simulated base allows (0.7 m/s) is the Kobuki user guide's
//! maximum translational velocity, recalled rather than checked against the document here.
//! What the simulated base models and what it does not is in [`simbase`].
#![deny(missing_docs)]

pub mod command;
pub mod config;
pub mod driver;
pub mod feedback;
pub mod frame;
pub mod odometry;
pub mod safety;
pub mod simbase;

/// Distance between the wheels' contact points, m ("Kobuki Parameters": bias).
pub const WHEEL_BASE_M: f64 = 0.230;
/// Wheel radius, m ("Kobuki Parameters").
pub const WHEEL_RADIUS_M: f64 = 0.035;
/// Wheel rotation per encoder tick, rad ("Kobuki Parameters": 2π / (52 · 6545/132)).
#[allow(clippy::excessive_precision)]
pub const TICK_TO_RAD: f64 = 0.002436916871363930187454;
/// Wheel travel per encoder tick, m (about 0.0853 mm; 11 724.4 ticks a metre).
pub const M_PER_TICK: f64 = TICK_TO_RAD * WHEEL_RADIUS_M;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    #[allow(clippy::excessive_precision)]
    fn tick_constants_agree_with_the_parameters_appendix() {
        // "tick to meter 0.000085292090497737556558", "meter to tick 11724.41658"
        assert!((M_PER_TICK - 0.000085292090497737556558).abs() < 1e-15);
        assert!((1.0 / M_PER_TICK - 11724.41658029856624751591).abs() < 1e-6);
        // 52 ticks a motor turn, gear ratio 6545/132: the appendix's constant agrees to 2e-7
        // (it was evidently computed in lower precision); the appendix's value is used
        let per_turn = 52.0 * 6545.0 / 132.0;
        assert!((TICK_TO_RAD * per_turn / std::f64::consts::TAU - 1.0).abs() < 3e-7);
    }
}
