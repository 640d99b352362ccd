//! Commands to the base, and the velocity conversion the base's Base Control expects.
//!
//! Identifiers and layouts from the protocol specification, "Command Packets":
//!
//! | id | name | length | fields |
//! |---|---|---|---|
//! | 0x01 | Base Control | 4 | speed i16 (mm/s), radius i16 (mm) |
//! | 0x04 | Sound Sequence | 1 | sequence number (0 on, 1 off, 2 recharge, 3 button, 4 error, 5 cleaning start, 6 cleaning end) |
//! | 0x09 | Request Extra | 2 | flags u16: 0x01 hardware version, 0x02 firmware version, 0x08 unique device id |
//!
//! Base Control's (speed, radius) is not (v, ω): radius 0 drives straight at `speed`; radius 1
//! turns in place, `speed` being each wheel's speed (the right wheel forward for positive
//! speed); any other radius is the turning radius (positive: centre of turn on the left) and
//! `speed` is the outer wheel's speed. [`BaseControl::from_twist`] follows the reference
//! driver's `DiffDrive::velocityCommands` (kobuki_core); [`BaseControl::wheel_speeds`] is the
//! same relation solved for the wheels, as the simulated base uses it.

use crate::WHEEL_BASE_M;
use crate::feedback::SubPayloadError;
use crate::frame::{Frame, FrameError, encode_frame, push_subpayload};

/// Identifiers of the command sub-payloads used here (specification, "Command Packets").
pub mod id {
    /// Base Control.
    pub const BASE_CONTROL: u8 = 0x01;
    /// Sound Sequence.
    pub const SOUND_SEQUENCE: u8 = 0x04;
    /// Request Extra.
    pub const REQUEST_EXTRA: u8 = 0x09;
}

/// Request Extra flags.
pub mod request {
    /// Hardware Version (answered with sub-payload 0x0A).
    pub const HARDWARE_VERSION: u16 = 0x01;
    /// Firmware Version (0x0B).
    pub const FIRMWARE_VERSION: u16 = 0x02;
    /// Unique Device Identifier (0x13).
    pub const UNIQUE_DEVICE_ID: u16 = 0x08;
}

/// Below this |ω| (rad/s) or |v| (m/s) the reference driver treats a component as zero.
pub const EPSILON: f64 = 1e-4;

/// Base Control: the only motion command.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BaseControl {
    /// Speed, mm/s: of both wheels (radius 0), of each wheel turning in place (radius ±1), or
    /// of the outer wheel.
    pub speed_mm_s: i16,
    /// Radius of the turn, mm: 0 straight, 1 in place, positive turning left.
    pub radius_mm: i16,
}

/// `x` bounded to the i16 range and truncated toward zero, as the reference driver's `bound`.
fn bound(x: f64) -> i16 {
    // `as` saturates at the range's ends and truncates toward zero
    x as i16
}

impl BaseControl {
    /// Stop.
    pub const STOP: BaseControl = BaseControl {
        speed_mm_s: 0,
        radius_mm: 0,
    };

    /// The command for forward speed `v` (m/s) and turn rate `w` (rad/s, counter-clockwise),
    /// for a base of wheel base [`WHEEL_BASE_M`]; as the reference driver computes it, bounded
    /// to the i16 range. A non-finite input stops the base.
    pub fn from_twist(v: f64, w: f64) -> BaseControl {
        Self::from_twist_with(v, w, WHEEL_BASE_M)
    }

    /// [`BaseControl::from_twist`] for wheel base `wheel_base_m`.
    pub fn from_twist_with(v: f64, w: f64, wheel_base_m: f64) -> BaseControl {
        if !(v.is_finite() && w.is_finite() && wheel_base_m.is_finite()) {
            return BaseControl::STOP;
        }
        let half_base_mm = 1000.0 * wheel_base_m / 2.0;
        if w.abs() < EPSILON {
            // straight
            return BaseControl {
                speed_mm_s: bound(1000.0 * v),
                radius_mm: 0,
            };
        }
        let radius = 1000.0 * v / w;
        if v.abs() < EPSILON || radius.abs() <= 1.0 {
            // in place: each wheel at ω·b/2
            return BaseControl {
                speed_mm_s: bound(half_base_mm * w),
                radius_mm: 1,
            };
        }
        // the outer wheel's speed
        let speed = if radius > 0.0 {
            (radius + half_base_mm) * w
        } else {
            (radius - half_base_mm) * w
        };
        BaseControl {
            speed_mm_s: bound(speed),
            radius_mm: bound(radius),
        }
    }

    /// Left and right wheel speeds (m/s) the base drives for this command on wheel base
    /// `wheel_base_m`: the inverse of [`BaseControl::from_twist_with`]. Radius -1 turns in
    /// place clockwise for positive speed (the limit of the general case; the reference driver
    /// never sends it).
    pub fn wheel_speeds(&self, wheel_base_m: f64) -> (f64, f64) {
        let s = f64::from(self.speed_mm_s) / 1000.0;
        let r = f64::from(self.radius_mm) / 1000.0;
        let half = wheel_base_m / 2.0;
        match self.radius_mm {
            0 => (s, s),
            1 => (-s, s),
            -1 => (s, -s),
            _ if r > 0.0 => (s * (r - half) / (r + half), s),
            _ => (s, s * (-r - half) / (-r + half)),
        }
    }

    /// Forward speed (m/s) and turn rate (rad/s) the base drives for this command.
    pub fn twist(&self, wheel_base_m: f64) -> (f64, f64) {
        let (l, r) = self.wheel_speeds(wheel_base_m);
        ((l + r) / 2.0, (r - l) / wheel_base_m)
    }
}

/// A Sound Sequence number (specification, "Sound Sequence").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum SoundSequence {
    /// Turning on.
    On = 0,
    /// Turning off.
    Off = 1,
    /// Recharge start.
    Recharge = 2,
    /// Button.
    Button = 3,
    /// Error.
    Error = 4,
    /// Cleaning start.
    CleaningStart = 5,
    /// Cleaning end.
    CleaningEnd = 6,
}

impl SoundSequence {
    /// The sequence of `n`, if the specification lists it.
    pub fn from_u8(n: u8) -> Option<SoundSequence> {
        use SoundSequence::*;
        [On, Off, Recharge, Button, Error, CleaningStart, CleaningEnd]
            .get(usize::from(n))
            .copied()
    }
}

/// A command sub-payload.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Command {
    /// Base Control (0x01).
    BaseControl(BaseControl),
    /// Sound Sequence (0x04).
    SoundSequence(SoundSequence),
    /// Request Extra (0x09) with [`request`] flags.
    RequestExtra(u16),
}

/// Why a command sub-payload received (by the simulated base) was not used.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CommandError {
    /// A known command with the wrong length.
    #[error(transparent)]
    SubPayload(#[from] SubPayloadError),
    /// A Sound Sequence number the specification does not list.
    #[error(
        "Sound Sequence at payload byte {offset} of the frame at stream byte {frame_at}: sequence {n}, expected 0 to 6"
    )]
    UnknownSound {
        /// Stream offset of the frame.
        frame_at: u64,
        /// Offset of the sub-payload in the payload.
        offset: usize,
        /// The number received.
        n: u8,
    },
    /// An identifier not implemented here (the base ignores it).
    #[error(
        "command 0x{id:02x} at payload byte {offset} of the frame at stream byte {frame_at} is not implemented"
    )]
    Unknown {
        /// Stream offset of the frame.
        frame_at: u64,
        /// Offset of the sub-payload in the payload.
        offset: usize,
        /// The identifier.
        id: u8,
    },
}

impl Command {
    /// Appends this command's sub-payload to `payload`.
    pub fn push_to(&self, payload: &mut Vec<u8>) -> Result<(), FrameError> {
        match self {
            Command::BaseControl(b) => {
                let [s0, s1] = b.speed_mm_s.to_le_bytes();
                let [r0, r1] = b.radius_mm.to_le_bytes();
                push_subpayload(payload, id::BASE_CONTROL, &[s0, s1, r0, r1])
            }
            Command::SoundSequence(s) => push_subpayload(payload, id::SOUND_SEQUENCE, &[*s as u8]),
            Command::RequestExtra(flags) => {
                push_subpayload(payload, id::REQUEST_EXTRA, &flags.to_le_bytes())
            }
        }
    }

    /// Appends one frame carrying `commands` to `out`.
    pub fn encode_all(commands: &[Command], out: &mut Vec<u8>) -> Result<(), FrameError> {
        let mut payload = Vec::with_capacity(commands.len() * 6);
        for c in commands {
            c.push_to(&mut payload)?;
        }
        encode_frame(&payload, out)
    }

    /// Appends one frame carrying this command to `out`.
    pub fn encode(&self, out: &mut Vec<u8>) -> Result<(), FrameError> {
        Self::encode_all(std::slice::from_ref(self), out)
    }

    /// The commands of a frame, in order, each decoded or the reason it was not.
    pub fn decode_all(frame: &Frame) -> impl Iterator<Item = Result<Command, CommandError>> + '_ {
        let frame_at = frame.stream_offset();
        frame.subpayloads().map(move |sub| {
            let wrong = |name: &'static str, expected: usize| {
                CommandError::SubPayload(SubPayloadError::WrongLength {
                    frame_at,
                    offset: sub.offset,
                    id: sub.id,
                    name,
                    len: sub.data.len(),
                    expected,
                })
            };
            match (sub.id, sub.data) {
                (id::BASE_CONTROL, &[s0, s1, r0, r1]) => Ok(Command::BaseControl(BaseControl {
                    speed_mm_s: i16::from_le_bytes([s0, s1]),
                    radius_mm: i16::from_le_bytes([r0, r1]),
                })),
                (id::BASE_CONTROL, _) => Err(wrong("Base Control", 4)),
                (id::SOUND_SEQUENCE, &[n]) => SoundSequence::from_u8(n)
                    .map(Command::SoundSequence)
                    .ok_or(CommandError::UnknownSound {
                        frame_at,
                        offset: sub.offset,
                        n,
                    }),
                (id::SOUND_SEQUENCE, _) => Err(wrong("Sound Sequence", 1)),
                (id::REQUEST_EXTRA, &[f0, f1]) => {
                    Ok(Command::RequestExtra(u16::from_le_bytes([f0, f1])))
                }
                (id::REQUEST_EXTRA, _) => Err(wrong("Request Extra", 2)),
                (id, _) => Err(CommandError::Unknown {
                    frame_at,
                    offset: sub.offset,
                    id,
                }),
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::FrameParser;
    use proptest::prelude::*;

    #[test]
    fn special_cases_of_the_reference_driver() {
        // straight
        assert_eq!(
            BaseControl::from_twist(0.2, 0.0),
            BaseControl {
                speed_mm_s: 200,
                radius_mm: 0
            }
        );
        // in place: radius 1, speed ω·b/2 = 1.0 · 115 mm/s
        assert_eq!(
            BaseControl::from_twist(0.0, 1.0),
            BaseControl {
                speed_mm_s: 115,
                radius_mm: 1
            }
        );
        assert_eq!(
            BaseControl::from_twist(0.0, -1.0),
            BaseControl {
                speed_mm_s: -115,
                radius_mm: 1
            }
        );
        // radius under 1 mm counts as in place
        assert_eq!(BaseControl::from_twist(0.0005, 1.0).radius_mm, 1);
        // general: R = 200 mm, outer (right) wheel (200 + 115)·0.5 = 157.5 → 157
        assert_eq!(
            BaseControl::from_twist(0.1, 0.5),
            BaseControl {
                speed_mm_s: 157,
                radius_mm: 200
            }
        );
        // turning right: R = -200 mm, outer (left) wheel (-200 - 115)·(-0.5) = 157.5
        assert_eq!(
            BaseControl::from_twist(0.1, -0.5),
            BaseControl {
                speed_mm_s: 157,
                radius_mm: -200
            }
        );
        // reversing while turning left: speed negative
        assert_eq!(BaseControl::from_twist(-0.1, 0.5).speed_mm_s, -157);
    }

    #[test]
    fn bounded_and_non_finite() {
        assert_eq!(BaseControl::from_twist(100.0, 0.0).speed_mm_s, i16::MAX);
        assert_eq!(BaseControl::from_twist(-100.0, 0.0).speed_mm_s, i16::MIN);
        // a huge radius (tiny ω) is bounded
        assert_eq!(BaseControl::from_twist(1.0, 0.001).radius_mm, i16::MAX);
        for (v, w) in [
            (f64::NAN, 0.0),
            (0.0, f64::INFINITY),
            (f64::NEG_INFINITY, 1.0),
        ] {
            assert_eq!(BaseControl::from_twist(v, w), BaseControl::STOP);
        }
    }

    #[test]
    fn wheel_speeds_of_the_special_cases() {
        let b = WHEEL_BASE_M;
        assert_eq!(
            BaseControl {
                speed_mm_s: 300,
                radius_mm: 0
            }
            .wheel_speeds(b),
            (0.3, 0.3)
        );
        assert_eq!(
            BaseControl {
                speed_mm_s: 115,
                radius_mm: 1
            }
            .twist(b),
            (0.0, 1.0)
        );
        assert_eq!(
            BaseControl {
                speed_mm_s: 115,
                radius_mm: -1
            }
            .twist(b),
            (0.0, -1.0)
        );
    }

    proptest! {
        /// What the base drives for the command is the twist asked for, within the command's
        /// millimetre truncation, wherever it is inside the i16 range.
        #[test]
        fn twist_round_trip(v in -0.7f64..0.7, w in -3.0f64..3.0) {
            let c = BaseControl::from_twist(v, w);
            let (v2, w2) = c.twist(WHEEL_BASE_M);
            let r = 1000.0 * v / w;
            if w.abs() < EPSILON {
                prop_assert!((v2 - v).abs() < 1.5e-3, "{c:?}: {v2} vs {v}");
                prop_assert_eq!(w2, 0.0);
            } else if v.abs() < EPSILON || r.abs() <= 1.0 {
                prop_assert_eq!(v2, 0.0);
                prop_assert!((w2 - w).abs() < 1e-2, "{c:?}: {w2} vs {w}");
            } else if r.abs() < 30000.0 && r.abs() > 20.0 {
                // the truncation of speed (1 mm/s) and radius (1 mm) bound the error
                let tol_v = 2e-3 + v.abs() * 1.0 / r.abs();
                prop_assert!((v2 - v).abs() < tol_v, "{c:?}: v {v2} vs {v}");
                prop_assert!((w2 - w).abs() < 2e-2 + w.abs() * 2.0 / r.abs(),
                    "{c:?}: w {w2} vs {w}");
            }
        }
    }

    #[test]
    fn encode_decode_round_trip() {
        let cmds = [
            Command::BaseControl(BaseControl {
                speed_mm_s: -300,
                radius_mm: 1,
            }),
            Command::SoundSequence(SoundSequence::Error),
            Command::RequestExtra(
                request::HARDWARE_VERSION | request::FIRMWARE_VERSION | request::UNIQUE_DEVICE_ID,
            ),
        ];
        let mut bytes = Vec::new();
        Command::encode_all(&cmds, &mut bytes).unwrap();
        // AA 55, length 6 + 3 + 4
        assert_eq!(&bytes[..3], &[0xAA, 0x55, 13]);
        assert_eq!(&bytes[3..9], &[0x01, 0x04, 0xD4, 0xFE, 0x01, 0x00]);
        let mut p = FrameParser::new();
        let frames: Vec<_> = p.push(&bytes).flatten().collect();
        let back: Vec<_> = Command::decode_all(&frames[0]).collect();
        assert_eq!(back, cmds.map(Ok).to_vec());
    }

    #[test]
    fn bad_commands_are_reported_one_by_one() {
        let mut payload = Vec::new();
        push_subpayload(&mut payload, id::BASE_CONTROL, &[1, 2, 3]).unwrap();
        push_subpayload(&mut payload, id::SOUND_SEQUENCE, &[9]).unwrap();
        push_subpayload(&mut payload, 0x0C, &[0, 0]).unwrap();
        Command::RequestExtra(1).push_to(&mut payload).unwrap();
        let frame = Frame::from_payload(&payload).unwrap();
        let out: Vec<_> = Command::decode_all(&frame).collect();
        assert!(matches!(
            &out[0],
            Err(CommandError::SubPayload(SubPayloadError::WrongLength {
                len: 3,
                expected: 4,
                ..
            }))
        ));
        assert!(matches!(
            out[1],
            Err(CommandError::UnknownSound {
                n: 9,
                offset: 5,
                ..
            })
        ));
        assert!(matches!(
            out[2],
            Err(CommandError::Unknown { id: 0x0C, .. })
        ));
        assert_eq!(out[3], Ok(Command::RequestExtra(1)));
        assert!(
            out[0]
                .as_ref()
                .unwrap_err()
                .to_string()
                .contains("Base Control")
        );
    }
}
