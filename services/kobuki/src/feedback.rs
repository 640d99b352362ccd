//! Feedback from the base: the sub-payloads of the frames it streams at 50 Hz, typed.
//!
//! Identifiers, lengths and fields from the protocol specification, "Feedback Packets"
//! (all little-endian):
//!
//! | id | name | length | fields |
//! |---|---|---|---|
//! | 0x01 | Basic Sensor Data | 15 | timestamp ms u16, bumper u8, wheel drop u8, cliff u8, left encoder u16, right encoder u16, left PWM i8, right PWM i8, buttons u8, charger u8, battery u8 (0.1 V), over-current u8 |
//! | 0x03 | Docking IR | 3 | skipped |
//! | 0x04 | Inertial Sensor Data | 7 | angle i16 (0.01°), angle rate i16 (0.01°/s), 3 unused bytes |
//! | 0x05 | Cliff Sensor Data | 6 | right, centre, left PSD ADC u16 |
//! | 0x06 | Current | 2 | left, right motor current u8 (10 mA) |
//! | 0x0A | Hardware Version | 4 | patch, minor, major u8, unused |
//! | 0x0B | Firmware Version | 4 | patch, minor, major u8, unused |
//! | 0x0D | Raw 3-axis gyro | varies | skipped |
//! | 0x10 | General Purpose Input | 16 | skipped |
//! | 0x13 | Unique Device Identifier | 12 | three u32 |
//! | 0x15 | Controller Info | 13 | skipped |
//!
//! The versions and the device identifier come only after a Request Extra command. A
//! sub-payload of an identifier the specification lists but this crate does not decode is
//! skipped by its length and counted in [`Feedback::skipped`]; one of an identifier it does not
//! list, in [`Feedback::unknown`]. A known identifier with the wrong length is reported in
//! [`Feedback::errors`]; neither makes the rest of the frame unusable.

use crate::frame::{Frame, FrameError, push_subpayload};

/// Identifiers of the feedback sub-payloads (specification, "Feedback Packets").
pub mod id {
    /// Basic Sensor Data.
    pub const BASIC_SENSOR_DATA: u8 = 0x01;
    /// Docking IR.
    pub const DOCKING_IR: u8 = 0x03;
    /// Inertial Sensor Data.
    pub const INERTIAL_SENSOR_DATA: u8 = 0x04;
    /// Cliff Sensor Data.
    pub const CLIFF_SENSOR_DATA: u8 = 0x05;
    /// Current.
    pub const CURRENT: u8 = 0x06;
    /// Hardware Version.
    pub const HARDWARE_VERSION: u8 = 0x0A;
    /// Firmware Version.
    pub const FIRMWARE_VERSION: u8 = 0x0B;
    /// Raw data of the 3-axis gyro.
    pub const RAW_GYRO: u8 = 0x0D;
    /// General Purpose Input.
    pub const GENERAL_PURPOSE_INPUT: u8 = 0x10;
    /// Unique Device Identifier.
    pub const UNIQUE_DEVICE_ID: u8 = 0x13;
    /// Controller Info.
    pub const CONTROLLER_INFO: u8 = 0x15;
}

/// Bumper bits of [`BasicSensorData::bumper`].
pub mod bumper {
    /// Right bumper pressed.
    pub const RIGHT: u8 = 0x01;
    /// Central bumper pressed.
    pub const CENTRAL: u8 = 0x02;
    /// Left bumper pressed.
    pub const LEFT: u8 = 0x04;
}

/// Wheel-drop bits of [`BasicSensorData::wheel_drop`].
pub mod wheel_drop {
    /// Right wheel dropped.
    pub const RIGHT: u8 = 0x01;
    /// Left wheel dropped.
    pub const LEFT: u8 = 0x02;
}

/// Cliff bits of [`BasicSensorData::cliff`].
pub mod cliff {
    /// Right cliff sensor sees a cliff.
    pub const RIGHT: u8 = 0x01;
    /// Central cliff sensor sees a cliff.
    pub const CENTRAL: u8 = 0x02;
    /// Left cliff sensor sees a cliff.
    pub const LEFT: u8 = 0x04;
}

/// Why one sub-payload of a checked frame was not decoded. The frame's other sub-payloads are
/// still used.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SubPayloadError {
    /// A sub-payload of a known identifier has a length the specification does not give it.
    #[error(
        "sub-payload 0x{id:02x} ({name}) at payload byte {offset} of the frame at stream byte {frame_at}: {len} data bytes, expected {expected}"
    )]
    WrongLength {
        /// Stream offset of the frame's first header byte.
        frame_at: u64,
        /// Offset of the sub-payload's identifier in the payload.
        offset: usize,
        /// The identifier.
        id: u8,
        /// The specification's name for it.
        name: &'static str,
        /// Its length byte.
        len: usize,
        /// The length the specification gives.
        expected: usize,
    },
}

/// Sub-payload 0x01, Basic Sensor Data: the base's core state, in every feedback frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BasicSensorData {
    /// The base's clock, ms; wraps from 65535 to 0.
    pub timestamp_ms: u16,
    /// Pressed bumpers ([`bumper`] bits).
    pub bumper: u8,
    /// Dropped wheels ([`wheel_drop`] bits).
    pub wheel_drop: u8,
    /// Cliff sensors seeing a cliff ([`cliff`] bits).
    pub cliff: u8,
    /// Left wheel encoder, ticks; wraps.
    pub left_encoder: u16,
    /// Right wheel encoder, ticks; wraps.
    pub right_encoder: u16,
    /// Left motor PWM, -100 to 100.
    pub left_pwm: i8,
    /// Right motor PWM, -100 to 100.
    pub right_pwm: i8,
    /// Buttons B0, B1, B2 pressed (bits 0x01, 0x02, 0x04).
    pub buttons: u8,
    /// Charger state: 0 discharging, 2 docking charged, 6 docking charging, 18 adapter charged,
    /// 22 adapter charging.
    pub charger: u8,
    /// Battery voltage, 0.1 V.
    pub battery_dv: u8,
    /// Over-current: 0x01 left wheel, 0x02 right wheel.
    pub over_current: u8,
}

impl BasicSensorData {
    /// Data bytes on the wire.
    pub const LEN: usize = 15;

    /// Battery voltage, volts.
    pub fn battery_volts(&self) -> f64 {
        f64::from(self.battery_dv) / 10.0
    }

    fn decode(d: &[u8; Self::LEN]) -> Self {
        BasicSensorData {
            timestamp_ms: u16::from_le_bytes([d[0], d[1]]),
            bumper: d[2],
            wheel_drop: d[3],
            cliff: d[4],
            left_encoder: u16::from_le_bytes([d[5], d[6]]),
            right_encoder: u16::from_le_bytes([d[7], d[8]]),
            left_pwm: d[9] as i8,
            right_pwm: d[10] as i8,
            buttons: d[11],
            charger: d[12],
            battery_dv: d[13],
            over_current: d[14],
        }
    }

    fn encode(&self) -> [u8; Self::LEN] {
        let [t0, t1] = self.timestamp_ms.to_le_bytes();
        let [l0, l1] = self.left_encoder.to_le_bytes();
        let [r0, r1] = self.right_encoder.to_le_bytes();
        [
            t0,
            t1,
            self.bumper,
            self.wheel_drop,
            self.cliff,
            l0,
            l1,
            r0,
            r1,
            self.left_pwm as u8,
            self.right_pwm as u8,
            self.buttons,
            self.charger,
            self.battery_dv,
            self.over_current,
        ]
    }
}

/// Sub-payload 0x04, Inertial Sensor Data: the gyro's integrated heading and its rate.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct InertialSensorData {
    /// Heading, 0.01° (counter-clockwise positive), as the base integrates it.
    pub angle_cdeg: i16,
    /// Rate of turn, 0.01°/s.
    pub angle_rate_cdeg_s: i16,
}

impl InertialSensorData {
    /// Data bytes on the wire (the last three unused).
    pub const LEN: usize = 7;

    /// Heading, radians.
    pub fn angle_rad(&self) -> f64 {
        (f64::from(self.angle_cdeg) / 100.0).to_radians()
    }

    /// Rate of turn, rad/s.
    pub fn angle_rate_rad_s(&self) -> f64 {
        (f64::from(self.angle_rate_cdeg_s) / 100.0).to_radians()
    }
}

/// Sub-payload 0x05, Cliff Sensor Data: the cliff PSD sensors' raw ADC readings.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CliffSensorData {
    /// ADC of the right, central and left sensors (0–4095).
    pub adc: [u16; 3],
}

/// Sub-payload 0x06, Current: the wheel motors' currents.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MotorCurrent {
    /// Left and right motor current, 10 mA.
    pub current_10ma: [u8; 2],
}

/// Sub-payloads 0x0A and 0x0B: a hardware or firmware version.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Version {
    /// Major version.
    pub major: u8,
    /// Minor version.
    pub minor: u8,
    /// Patch version.
    pub patch: u8,
}

impl std::fmt::Display for Version {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}.{}.{}", self.major, self.minor, self.patch)
    }
}

/// One feedback frame, decoded: each sub-payload it carried, and what was not decoded.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Feedback {
    /// Basic Sensor Data (0x01).
    pub basic: Option<BasicSensorData>,
    /// Inertial Sensor Data (0x04).
    pub inertial: Option<InertialSensorData>,
    /// Cliff Sensor Data (0x05).
    pub cliff: Option<CliffSensorData>,
    /// Current (0x06).
    pub current: Option<MotorCurrent>,
    /// Hardware Version (0x0A), after a Request Extra.
    pub hardware_version: Option<Version>,
    /// Firmware Version (0x0B), after a Request Extra.
    pub firmware_version: Option<Version>,
    /// Unique Device Identifier (0x13), after a Request Extra.
    pub unique_device_id: Option<[u32; 3]>,
    /// Sub-payloads of identifiers the specification lists and this crate skips.
    pub skipped: u32,
    /// Sub-payloads of identifiers the specification does not list, skipped by their length.
    pub unknown: u32,
    /// Sub-payloads of known identifiers with a wrong length, not decoded.
    pub errors: Vec<SubPayloadError>,
}

fn fixed<const N: usize>(
    frame: &Frame,
    sub: &crate::frame::SubPayload<'_>,
    name: &'static str,
    errors: &mut Vec<SubPayloadError>,
) -> Option<[u8; N]> {
    match <[u8; N]>::try_from(sub.data) {
        Ok(a) => Some(a),
        Err(_) => {
            errors.push(SubPayloadError::WrongLength {
                frame_at: frame.stream_offset(),
                offset: sub.offset,
                id: sub.id,
                name,
                len: sub.data.len(),
                expected: N,
            });
            None
        }
    }
}

fn version(d: [u8; 4]) -> Version {
    Version {
        patch: d[0],
        minor: d[1],
        major: d[2],
    }
}

impl Feedback {
    /// Decodes every sub-payload of `frame`. A later sub-payload of the same identifier
    /// replaces an earlier one.
    pub fn decode(frame: &Frame) -> Feedback {
        let mut fb = Feedback::default();
        let mut errors = Vec::new();
        for sub in frame.subpayloads() {
            match sub.id {
                id::BASIC_SENSOR_DATA => {
                    if let Some(d) = fixed(frame, &sub, "Basic Sensor Data", &mut errors) {
                        fb.basic = Some(BasicSensorData::decode(&d));
                    }
                }
                id::INERTIAL_SENSOR_DATA => {
                    if let Some(d) = fixed::<7>(frame, &sub, "Inertial Sensor Data", &mut errors) {
                        fb.inertial = Some(InertialSensorData {
                            angle_cdeg: i16::from_le_bytes([d[0], d[1]]),
                            angle_rate_cdeg_s: i16::from_le_bytes([d[2], d[3]]),
                        });
                    }
                }
                id::CLIFF_SENSOR_DATA => {
                    if let Some(d) = fixed::<6>(frame, &sub, "Cliff Sensor Data", &mut errors) {
                        fb.cliff = Some(CliffSensorData {
                            adc: [
                                u16::from_le_bytes([d[0], d[1]]),
                                u16::from_le_bytes([d[2], d[3]]),
                                u16::from_le_bytes([d[4], d[5]]),
                            ],
                        });
                    }
                }
                id::CURRENT => {
                    if let Some(d) = fixed::<2>(frame, &sub, "Current", &mut errors) {
                        fb.current = Some(MotorCurrent { current_10ma: d });
                    }
                }
                id::HARDWARE_VERSION => {
                    if let Some(d) = fixed::<4>(frame, &sub, "Hardware Version", &mut errors) {
                        fb.hardware_version = Some(version(d));
                    }
                }
                id::FIRMWARE_VERSION => {
                    if let Some(d) = fixed::<4>(frame, &sub, "Firmware Version", &mut errors) {
                        fb.firmware_version = Some(version(d));
                    }
                }
                id::UNIQUE_DEVICE_ID => {
                    if let Some(d) =
                        fixed::<12>(frame, &sub, "Unique Device Identifier", &mut errors)
                    {
                        let word = |i: usize| {
                            u32::from_le_bytes([d[4 * i], d[4 * i + 1], d[4 * i + 2], d[4 * i + 3]])
                        };
                        fb.unique_device_id = Some([word(0), word(1), word(2)]);
                    }
                }
                id::DOCKING_IR | id::RAW_GYRO | id::GENERAL_PURPOSE_INPUT | id::CONTROLLER_INFO => {
                    fb.skipped += 1
                }
                _ => fb.unknown += 1,
            }
        }
        fb.errors = errors;
        fb
    }

    /// The payload of a frame carrying this feedback's sub-payloads, in identifier order (the
    /// counts and errors are not encoded). Used by the simulated base.
    pub fn encode_payload(&self, payload: &mut Vec<u8>) -> Result<(), FrameError> {
        if let Some(b) = &self.basic {
            push_subpayload(payload, id::BASIC_SENSOR_DATA, &b.encode())?;
        }
        if let Some(i) = &self.inertial {
            let [a0, a1] = i.angle_cdeg.to_le_bytes();
            let [r0, r1] = i.angle_rate_cdeg_s.to_le_bytes();
            push_subpayload(
                payload,
                id::INERTIAL_SENSOR_DATA,
                &[a0, a1, r0, r1, 0, 0, 0],
            )?;
        }
        if let Some(c) = &self.cliff {
            let mut d = [0; 6];
            for (k, v) in c.adc.iter().enumerate() {
                d[2 * k..2 * k + 2].copy_from_slice(&v.to_le_bytes());
            }
            push_subpayload(payload, id::CLIFF_SENSOR_DATA, &d)?;
        }
        if let Some(c) = &self.current {
            push_subpayload(payload, id::CURRENT, &c.current_10ma)?;
        }
        for (sid, v) in [
            (id::HARDWARE_VERSION, &self.hardware_version),
            (id::FIRMWARE_VERSION, &self.firmware_version),
        ] {
            if let Some(v) = v {
                push_subpayload(payload, sid, &[v.patch, v.minor, v.major, 0])?;
            }
        }
        if let Some(u) = &self.unique_device_id {
            let mut d = [0; 12];
            for (k, w) in u.iter().enumerate() {
                d[4 * k..4 * k + 4].copy_from_slice(&w.to_le_bytes());
            }
            push_subpayload(payload, id::UNIQUE_DEVICE_ID, &d)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{FrameParser, encode_frame};

    fn full() -> Feedback {
        Feedback {
            basic: Some(BasicSensorData {
                timestamp_ms: 65530,
                bumper: bumper::LEFT | bumper::RIGHT,
                wheel_drop: wheel_drop::LEFT,
                cliff: cliff::CENTRAL,
                left_encoder: 0xFFFE,
                right_encoder: 0x1234,
                left_pwm: -100,
                right_pwm: 55,
                buttons: 0x04,
                charger: 22,
                battery_dv: 161,
                over_current: 0x02,
            }),
            inertial: Some(InertialSensorData {
                angle_cdeg: -17999,
                angle_rate_cdeg_s: 12345,
            }),
            cliff: Some(CliffSensorData {
                adc: [1, 2000, 4095],
            }),
            current: Some(MotorCurrent {
                current_10ma: [3, 250],
            }),
            hardware_version: Some(Version {
                major: 1,
                minor: 0,
                patch: 4,
            }),
            firmware_version: Some(Version {
                major: 1,
                minor: 2,
                patch: 0,
            }),
            unique_device_id: Some([1, 0xDEAD_BEEF, u32::MAX]),
            ..Feedback::default()
        }
    }

    fn parse(bytes: &[u8]) -> Feedback {
        let mut p = FrameParser::new();
        let frames: Vec<_> = p.push(bytes).collect();
        assert_eq!(frames.len(), 1, "{frames:?}");
        Feedback::decode(frames[0].as_ref().unwrap())
    }

    #[test]
    fn round_trip_every_decoded_subpayload() {
        let fb = full();
        let mut payload = Vec::new();
        fb.encode_payload(&mut payload).unwrap();
        let mut bytes = Vec::new();
        encode_frame(&payload, &mut bytes).unwrap();
        assert_eq!(parse(&bytes), fb);
        assert_eq!(fb.basic.unwrap().battery_volts(), 16.1);
        assert_eq!(fb.firmware_version.unwrap().to_string(), "1.2.0");
    }

    #[test]
    fn basic_sensor_data_layout_from_the_specification() {
        // timestamp 0x0102, bumper 1, drop 2, cliff 4, encoders 0x0304 / 0x0506, PWM -1 / 1,
        // buttons 0, charger 6, battery 15.2 V, over-current 3
        let data = [2, 1, 1, 2, 4, 4, 3, 6, 5, 0xFF, 1, 0, 6, 152, 3];
        let mut payload = vec![0x01, 15];
        payload.extend(data);
        let mut bytes = Vec::new();
        encode_frame(&payload, &mut bytes).unwrap();
        let b = parse(&bytes).basic.unwrap();
        assert_eq!(b.timestamp_ms, 0x0102);
        assert_eq!((b.bumper, b.wheel_drop, b.cliff), (1, 2, 4));
        assert_eq!((b.left_encoder, b.right_encoder), (0x0304, 0x0506));
        assert_eq!((b.left_pwm, b.right_pwm), (-1, 1));
        assert_eq!((b.charger, b.battery_dv, b.over_current), (6, 152, 3));
    }

    #[test]
    fn inertial_units() {
        let i = InertialSensorData {
            angle_cdeg: 9000,
            angle_rate_cdeg_s: -4500,
        };
        assert!((i.angle_rad() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((i.angle_rate_rad_s() + std::f64::consts::FRAC_PI_4).abs() < 1e-12);
    }

    #[test]
    fn unknown_skipped_and_wrong_length_do_not_spoil_the_frame() {
        let mut payload = Vec::new();
        push_subpayload(&mut payload, 0x77, &[0xAA, 0x55, 9]).unwrap(); // unknown
        push_subpayload(&mut payload, id::DOCKING_IR, &[0, 0, 0]).unwrap(); // skipped
        push_subpayload(&mut payload, id::RAW_GYRO, &[0; 14]).unwrap(); // skipped
        push_subpayload(&mut payload, id::INERTIAL_SENSOR_DATA, &[1, 2]).unwrap(); // too short
        full().encode_payload(&mut payload).unwrap();
        let mut bytes = Vec::new();
        encode_frame(&payload, &mut bytes).unwrap();
        let fb = parse(&bytes);
        assert_eq!((fb.unknown, fb.skipped), (1, 2));
        assert_eq!(fb.errors.len(), 1);
        let msg = fb.errors[0].to_string();
        assert!(
            msg.contains("0x04") && msg.contains("Inertial") && msg.contains("payload byte 26"),
            "{msg}"
        );
        // the well-formed inertial sub-payload later in the frame is still decoded
        assert_eq!(fb.inertial, full().inertial);
        assert_eq!(fb.basic, full().basic);
    }
}
