//! VLP-16 packet formats: validated views of data packets (port 2368) and position packets
//! (port 8308).
//!
//! Data packet layout (1206 bytes), as the VLP-16 manual and `shared/data/velodyne/README.md` give
//! it:
//!
//! | offset | size | field |
//! |---|---|---|
//! | 100·b | 2 | block flag `FF EE` |
//! | 100·b + 2 | 2 | azimuth, u16 LE, 0.01° (0–35999) |
//! | 100·b + 4 + 3·c | 3 | channel c: distance u16 LE (2 mm units, 0 = no return), reflectivity u8 |
//! | 1200 | 4 | timestamp, u32 LE, µs past the top of the hour (first firing of the packet) |
//! | 1204 | 1 | return mode: 0x37 strongest, 0x38 last, 0x39 dual |
//! | 1205 | 1 | product: 0x22 VLP-16, 0x24 Puck Hi-Res (0x21 on early VLP-16 firmware) |
//!
//! Channels 0–15 of a block are the first firing sequence and 16–31 the second; the laser id is
//! `channel % 16`.

use std::fmt;

use mimnav_shared::topics::{DATA_PACKET_LEN, return_mode};

/// Number of data blocks in a data packet.
pub const BLOCKS: usize = 12;
/// Channel records per block (two firing sequences of 16 lasers).
pub const CHANNELS: usize = 32;
/// Lasers of a VLP-16.
pub const LASERS: usize = 16;
/// Size of a position packet's UDP payload.
pub const POSITION_PACKET_LEN: usize = 512;
/// Distance unit of the raw distance, metres.
pub const DISTANCE_UNIT_M: f32 = 0.002;
/// Product byte of a VLP-16 (and Puck LITE).
pub const PRODUCT_VLP16: u8 = 0x22;
/// Product byte of a Puck Hi-Res.
pub const PRODUCT_PUCK_HI_RES: u8 = 0x24;
/// Product byte of an HDL-32E, reported by early VLP-16 firmware (2014) whose timing and channels
/// are those of a VLP-16.
pub const PRODUCT_HDL32E_ON_VLP16: u8 = 0x21;

/// Laser elevation by laser id, degrees: VLP-16 and Puck LITE.
pub const VLP16_ELEVATION_DEG: [f32; LASERS] = [
    -15.0, 1.0, -13.0, 3.0, -11.0, 5.0, -9.0, 7.0, -7.0, 9.0, -5.0, 11.0, -3.0, 13.0, -1.0, 15.0,
];
/// Laser elevation by laser id, degrees: Puck Hi-Res (±10° in 1.33° steps).
pub const PUCK_HI_RES_ELEVATION_DEG: [f32; LASERS] = [
    -10.0, 0.67, -8.67, 2.0, -7.33, 3.33, -6.0, 4.67, -4.67, 6.0, -3.33, 7.33, -2.0, 8.67, -0.67,
    10.0,
];

/// Ring (0–15 ordered by elevation, lowest first) of a laser id; the same for both products.
pub const fn ring_of(laser_id: usize) -> u8 {
    if laser_id.is_multiple_of(2) {
        (laser_id / 2) as u8
    } else {
        (8 + laser_id / 2) as u8
    }
}

/// Why a datagram is not a usable packet. Every variant is counted by kind and skipped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DecodeError {
    /// The datagram is neither a 1206-byte data packet nor a 512-byte position packet.
    WrongLength {
        /// Bytes received.
        len: usize,
    },
    /// A data block does not start with the flag `FF EE`.
    BadBlockFlag {
        /// Block index 0–11.
        block: u8,
        /// The two bytes found, as read little-endian.
        flag: u16,
    },
    /// A block azimuth is outside 0–35999.
    BadAzimuth {
        /// Block index 0–11.
        block: u8,
        /// The value found, 0.01°.
        azimuth: u16,
    },
    /// Byte 1204 is not 0x37, 0x38 or 0x39.
    UnknownReturnMode(u8),
    /// Byte 1205 is not a product this driver decodes.
    UnknownProduct(u8),
    /// Byte 1205 is 0x21 (HDL-32E) and the config does not allow it for a VLP-16.
    Product0x21NotAllowed,
}

impl DecodeError {
    /// Short, stable name of the kind of fault, used as the counter key in statistics and logs.
    pub fn kind(&self) -> &'static str {
        match self {
            DecodeError::WrongLength { .. } => "wrong_length",
            DecodeError::BadBlockFlag { .. } => "bad_block_flag",
            DecodeError::BadAzimuth { .. } => "bad_azimuth",
            DecodeError::UnknownReturnMode(_) => "unknown_return_mode",
            DecodeError::UnknownProduct(_) => "unknown_product",
            DecodeError::Product0x21NotAllowed => "product_0x21_not_allowed",
        }
    }
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DecodeError::WrongLength { len } => write!(
                f,
                "datagram of {len} bytes is neither a {DATA_PACKET_LEN}-byte data packet nor a \
                 {POSITION_PACKET_LEN}-byte position packet"
            ),
            DecodeError::BadBlockFlag { block, flag } => {
                write!(
                    f,
                    "block {block} has flag {flag:#06x}, expected 0xeeff (bytes FF EE)"
                )
            }
            DecodeError::BadAzimuth { block, azimuth } => {
                write!(
                    f,
                    "block {block} has azimuth {azimuth}, expected 0..=35999 (0.01 deg)"
                )
            }
            DecodeError::UnknownReturnMode(m) => write!(
                f,
                "unknown return mode byte {m:#04x} (expected 0x37 strongest, 0x38 last, 0x39 dual)"
            ),
            DecodeError::UnknownProduct(p) => write!(
                f,
                "unknown product byte {p:#04x} (expected 0x22 VLP-16 or 0x24 Puck Hi-Res)"
            ),
            DecodeError::Product0x21NotAllowed => write!(
                f,
                "product byte 0x21 (HDL-32E) on a VLP-16 data stream; set \
                 velodyne.accept_product_0x21 = true if this is an early-firmware VLP-16"
            ),
        }
    }
}

impl std::error::Error for DecodeError {}

/// A validated view of a 1206-byte data packet.
#[derive(Clone, Copy)]
pub struct DataPacket<'a> {
    bytes: &'a [u8; DATA_PACKET_LEN],
}

impl<'a> DataPacket<'a> {
    /// Checks length, block flags, azimuths, return mode and product byte.
    ///
    /// `accept_0x21` lets product byte 0x21 through (early VLP-16 firmware reports the HDL-32E's
    /// byte); the packet is then decoded as a VLP-16.
    pub fn parse(bytes: &'a [u8], accept_0x21: bool) -> Result<Self, DecodeError> {
        let bytes: &[u8; DATA_PACKET_LEN] = bytes
            .try_into()
            .map_err(|_| DecodeError::WrongLength { len: bytes.len() })?;
        let pkt = DataPacket { bytes };
        match pkt.return_mode() {
            return_mode::STRONGEST | return_mode::LAST | return_mode::DUAL => {}
            m => return Err(DecodeError::UnknownReturnMode(m)),
        }
        match pkt.product() {
            PRODUCT_VLP16 | PRODUCT_PUCK_HI_RES => {}
            PRODUCT_HDL32E_ON_VLP16 if accept_0x21 => {}
            PRODUCT_HDL32E_ON_VLP16 => return Err(DecodeError::Product0x21NotAllowed),
            p => return Err(DecodeError::UnknownProduct(p)),
        }
        for block in 0..BLOCKS {
            let flag = u16::from_le_bytes([bytes[100 * block], bytes[100 * block + 1]]);
            if flag != 0xEEFF {
                return Err(DecodeError::BadBlockFlag {
                    block: block as u8,
                    flag,
                });
            }
            let azimuth = pkt.azimuth(block);
            if azimuth >= 36000 {
                return Err(DecodeError::BadAzimuth {
                    block: block as u8,
                    azimuth,
                });
            }
        }
        Ok(pkt)
    }

    /// The packet's bytes.
    pub fn bytes(&self) -> &'a [u8; DATA_PACKET_LEN] {
        self.bytes
    }

    /// Azimuth of block `block` (laser 0 of its first firing sequence), 0.01°.
    #[inline]
    pub fn azimuth(&self, block: usize) -> u16 {
        u16::from_le_bytes([self.bytes[100 * block + 2], self.bytes[100 * block + 3]])
    }

    /// Raw distance (2 mm units) and reflectivity of channel `channel` of block `block`.
    #[inline]
    pub fn channel(&self, block: usize, channel: usize) -> (u16, u8) {
        let o = 100 * block + 4 + 3 * channel;
        (
            u16::from_le_bytes([self.bytes[o], self.bytes[o + 1]]),
            self.bytes[o + 2],
        )
    }

    /// Time of the packet's first firing, µs past the top of the hour.
    pub fn timestamp_us(&self) -> u32 {
        u32::from_le_bytes([
            self.bytes[1200],
            self.bytes[1201],
            self.bytes[1202],
            self.bytes[1203],
        ])
    }

    /// Return mode byte (see [`return_mode`]).
    pub fn return_mode(&self) -> u8 {
        self.bytes[1204]
    }

    /// Product byte.
    pub fn product(&self) -> u8 {
        self.bytes[1205]
    }

    /// True in dual-return mode.
    pub fn is_dual(&self) -> bool {
        self.return_mode() == return_mode::DUAL
    }
}

/// PPS status of a position packet (byte 202).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PpsStatus {
    /// No PPS detected.
    Absent,
    /// Synchronising to PPS.
    Synchronizing,
    /// PPS locked.
    Locked,
    /// Error.
    Error,
    /// A value the manual does not define.
    Other(u8),
}

impl From<u8> for PpsStatus {
    fn from(b: u8) -> Self {
        match b {
            0 => PpsStatus::Absent,
            1 => PpsStatus::Synchronizing,
            2 => PpsStatus::Locked,
            3 => PpsStatus::Error,
            o => PpsStatus::Other(o),
        }
    }
}

/// Offset of the NMEA sentence in a position packet.
pub const NMEA_OFFSET: usize = 206;
/// Room for the NMEA sentence: bytes 206–333 (128 bytes; the manual's older revisions give 72,
/// the rest of which is unused and zero).
pub const NMEA_LEN: usize = 128;

/// Why a 512-byte datagram is not a position packet. Each is counted as a fault of its
/// [`kind`](PositionError::kind) and skipped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PositionError {
    /// Not 512 bytes.
    WrongLength {
        /// Bytes received.
        len: usize,
    },
    /// The PPS status (byte 202) is none of the four the manual defines (0–3).
    BadPps(u8),
    /// The NMEA field (bytes 206–333) is neither empty (all zero: no GPS) nor a sentence
    /// starting with `$` and made of printable ASCII up to its `*`.
    NotNmea {
        /// Offset in the packet of the first byte that does not fit.
        offset: usize,
    },
    /// A well-formed sentence, but not an `RMC` one (the sensor forwards `$GPRMC` / `$GNRMC`).
    NotRmc,
    /// The sentence has no `*hh` checksum, or one that is not two hex digits.
    NoChecksum,
    /// The checksum (XOR of the bytes between `$` and `*`) does not match.
    BadChecksum {
        /// The XOR of the sentence's bytes.
        computed: u8,
        /// The value after `*`.
        given: u8,
    },
}

impl PositionError {
    /// Short, stable name of the kind of fault, used as the counter key in statistics and logs.
    pub fn kind(&self) -> &'static str {
        match self {
            PositionError::WrongLength { .. } => "position_wrong_length",
            PositionError::BadPps(_) => "position_bad_pps",
            PositionError::NotNmea { .. } | PositionError::NotRmc => "position_bad_nmea",
            PositionError::NoChecksum | PositionError::BadChecksum { .. } => {
                "position_bad_checksum"
            }
        }
    }
}

impl fmt::Display for PositionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PositionError::WrongLength { len } => write!(
                f,
                "position packet of {len} bytes, expected {POSITION_PACKET_LEN}"
            ),
            PositionError::BadPps(b) => {
                write!(f, "position packet with PPS status {b}, expected 0 to 3")
            }
            PositionError::NotNmea { offset } => write!(
                f,
                "position packet without an NMEA sentence at byte {NMEA_OFFSET} (byte {offset} \
                 does not fit)"
            ),
            PositionError::NotRmc => write!(f, "position packet whose NMEA sentence is not RMC"),
            PositionError::NoChecksum => {
                write!(f, "position packet whose NMEA sentence has no *hh checksum")
            }
            PositionError::BadChecksum { computed, given } => write!(
                f,
                "position packet whose NMEA checksum is {given:02X}, the sentence gives \
                 {computed:02X}"
            ),
        }
    }
}

impl std::error::Error for PositionError {}

/// A decoded 512-byte position packet (port 8308).
///
/// Layout (VLP-16 manual, "Position Packet"): bytes 0–197 unused or temperatures, 198–201 the
/// timestamp (µs past the hour, u32 LE), 202 the PPS status, 203–205 status bytes, 206–333 the
/// last NMEA `$GPRMC` sentence the GPS sent (`*hh` checksum, CR LF, NUL padding; all zero without
/// a GPS), 334–511 unused.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PositionPacket {
    /// Sensor time, µs past the top of the hour.
    pub timestamp_us: u32,
    /// PPS status.
    pub pps: PpsStatus,
    /// The NMEA sentence (`$GPRMC,…*hh`), without CR LF and padding; empty when the GPS sends
    /// none.
    pub nmea: String,
}

impl PositionPacket {
    /// Decodes and checks a position packet: its length, a PPS status the manual defines, and
    /// either an empty NMEA field or one RMC sentence of printable ASCII with a correct
    /// checksum, followed only by CR, LF and NULs.
    pub fn parse(bytes: &[u8]) -> Result<Self, PositionError> {
        let bytes: &[u8; POSITION_PACKET_LEN] = bytes
            .try_into()
            .map_err(|_| PositionError::WrongLength { len: bytes.len() })?;
        let timestamp_us = u32::from_le_bytes([bytes[198], bytes[199], bytes[200], bytes[201]]);
        if bytes[202] > 3 {
            return Err(PositionError::BadPps(bytes[202]));
        }
        let field = &bytes[NMEA_OFFSET..NMEA_OFFSET + NMEA_LEN];
        let nmea = check_nmea(field)?;
        Ok(PositionPacket {
            timestamp_us,
            pps: PpsStatus::from(bytes[202]),
            nmea: nmea.to_string(),
        })
    }

    /// The UTC time the GPRMC sentence gives, seconds since the Unix epoch, if the sentence is a
    /// well-formed `$GPRMC` with status `A` (valid).
    pub fn gprmc_unix_s(&self) -> Option<f64> {
        parse_gprmc(&self.nmea)
    }
}

/// The sentence in a position packet's NMEA field (`""` when the field is all zero), checked.
fn check_nmea(field: &[u8]) -> Result<&str, PositionError> {
    let at = |i: usize| PositionError::NotNmea {
        offset: NMEA_OFFSET + i,
    };
    if field.iter().all(|&b| b == 0) {
        return Ok("");
    }
    if field[0] != b'$' {
        return Err(at(0));
    }
    let star = (1..field.len())
        .find(|&i| !(0x20..0x7f).contains(&field[i]) || field[i] == b'*')
        .ok_or(PositionError::NoChecksum)?;
    if field[star] != b'*' {
        return Err(if matches!(field[star], 0 | b'\r' | b'\n') {
            PositionError::NoChecksum
        } else {
            at(star)
        });
    }
    let hex = |i: usize| {
        field
            .get(i)
            .and_then(|&b| char::from(b).to_digit(16))
            .map(|d| d as u8)
    };
    let given = match (hex(star + 1), hex(star + 2)) {
        (Some(h), Some(l)) => (h << 4) | l,
        _ => return Err(PositionError::NoChecksum),
    };
    // after the checksum: CR LF (either may be missing), then NUL padding only
    let mut end = star + 3;
    for want in [b'\r', b'\n'] {
        if field.get(end) == Some(&want) {
            end += 1;
        }
    }
    if let Some(i) = (end..field.len()).find(|&i| field[i] != 0) {
        return Err(at(i));
    }
    let computed = field[1..star].iter().fold(0u8, |a, b| a ^ b);
    if computed != given {
        return Err(PositionError::BadChecksum { computed, given });
    }
    // printable ASCII throughout, so this cannot fail
    let sentence = std::str::from_utf8(&field[..star + 3]).map_err(|_| at(0))?;
    let talker = sentence[1..star].split(',').next().unwrap_or("");
    if talker.len() != 5 || !talker.ends_with("RMC") {
        return Err(PositionError::NotRmc);
    }
    Ok(sentence)
}

/// Parses the time and date of a `$GPRMC` sentence with status `A` into Unix seconds.
pub fn parse_gprmc(sentence: &str) -> Option<f64> {
    let body = sentence.split('*').next()?;
    let mut f = body.split(',');
    let talker = f.next()?;
    if !talker.ends_with("RMC") {
        return None;
    }
    let hms = f.next()?;
    let status = f.next()?;
    if status != "A" {
        return None;
    }
    let date = f.nth(6)?;
    if hms.len() < 6 || date.len() != 6 || !hms.is_ascii() || !date.is_ascii() {
        return None;
    }
    let num = |s: &str| s.parse::<u32>().ok();
    let (hh, mm, ss) = (
        num(&hms[0..2])?,
        num(&hms[2..4])?,
        hms[4..].parse::<f64>().ok()?,
    );
    let (day, month, yy) = (num(&date[0..2])?, num(&date[2..4])?, num(&date[4..6])?);
    if hh > 23 || mm > 59 || !(0.0..61.0).contains(&ss) || !(1..=31).contains(&day) {
        return None;
    }
    if !(1..=12).contains(&month) {
        return None;
    }
    let days = days_from_civil(2000 + i64::from(yy), month, day);
    Some(days as f64 * 86400.0 + f64::from(hh * 3600 + mm * 60) + ss)
}

/// Days since 1970-01-01 of a proleptic Gregorian date (H. Hinnant's algorithm).
fn days_from_civil(y: i64, m: u32, d: u32) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let m = i64::from(m);
    let doy = (153 * (if m > 2 { m - 3 } else { m + 9 }) + 2) / 5 + i64::from(d) - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146097 + doe - 719468
}

/// Builds a data packet: the inverse of [`DataPacket`], used by the simulator and the tests.
/// `blocks[b]` is the block's azimuth (0.01°) and its 32 channel records (raw distance, 2 mm
/// units; reflectivity).
pub fn encode_data_packet(
    timestamp_us: u32,
    return_mode: u8,
    product: u8,
    blocks: &[(u16, [(u16, u8); CHANNELS]); BLOCKS],
) -> [u8; DATA_PACKET_LEN] {
    let mut p = [0u8; DATA_PACKET_LEN];
    for (b, (azimuth, channels)) in blocks.iter().enumerate() {
        let o = 100 * b;
        p[o] = 0xFF;
        p[o + 1] = 0xEE;
        p[o + 2..o + 4].copy_from_slice(&azimuth.to_le_bytes());
        for (c, (d, r)) in channels.iter().enumerate() {
            let q = o + 4 + 3 * c;
            p[q..q + 2].copy_from_slice(&d.to_le_bytes());
            p[q + 2] = *r;
        }
    }
    p[1200..1204].copy_from_slice(&timestamp_us.to_le_bytes());
    p[1204] = return_mode;
    p[1205] = product;
    p
}

/// Builds a position packet with `nmea` (truncated to the 128 bytes of its field) at byte 206.
pub fn encode_position_packet(timestamp_us: u32, pps: u8, nmea: &str) -> [u8; POSITION_PACKET_LEN] {
    let mut p = [0u8; POSITION_PACKET_LEN];
    p[198..202].copy_from_slice(&timestamp_us.to_le_bytes());
    p[202] = pps;
    let n = nmea.len().min(NMEA_LEN);
    p[NMEA_OFFSET..NMEA_OFFSET + n].copy_from_slice(&nmea.as_bytes()[..n]);
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rings_follow_elevation_order() {
        let mut by_ring = [0.0f32; LASERS];
        for (id, e) in VLP16_ELEVATION_DEG.iter().enumerate() {
            by_ring[ring_of(id) as usize] = *e;
        }
        assert!(by_ring.windows(2).all(|w| w[0] < w[1]), "{by_ring:?}");
    }

    #[test]
    fn gprmc_time_and_date() {
        // 2015-07-23 21:41:07 UTC
        let s = "$GPRMC,214107,A,3707.8060,N,12139.2696,W,000.0,000.0,230715,013.9,E,D*04";
        assert_eq!(parse_gprmc(s), Some(1_437_687_667.0));
        assert_eq!(parse_gprmc("$GPRMC,214107,V,,,,,,,230715,,,N*00"), None);
        assert_eq!(parse_gprmc("$GPGGA,1"), None);
        assert_eq!(parse_gprmc("$GPRMC,2é4107,A,,,,,,,230715"), None);
    }

    /// Issue 23 item 5: 512-byte random datagrams on the position port were taken as position
    /// packets (and each new "PPS status" logged at INFO).
    #[test]
    fn position_port_garbage_is_refused_by_nmea_checksum() {
        let good = "$GPRMC,214107,A,3707.8060,N,12139.2696,W,000.0,000.0,230715,013.9,E,D*0A";
        let p = PositionPacket::parse(&encode_position_packet(5, 2, good)).expect("valid");
        assert_eq!((p.nmea.as_str(), p.pps), (good, PpsStatus::Locked));
        let crlf = format!("{good}\r\n");
        assert_eq!(
            PositionPacket::parse(&encode_position_packet(5, 2, &crlf)).map(|p| p.nmea),
            Ok(good.to_string())
        );
        // no GPS: the field is all zero, PPS absent
        let none = PositionPacket::parse(&encode_position_packet(5, 0, "")).expect("no GPS");
        assert_eq!((none.nmea.as_str(), none.pps), ("", PpsStatus::Absent));

        let err = |b: [u8; POSITION_PACKET_LEN]| PositionPacket::parse(&b).err();
        assert_eq!(
            PositionPacket::parse(&[0u8; 511]).err(),
            Some(PositionError::WrongLength { len: 511 })
        );
        assert_eq!(
            err(encode_position_packet(5, 7, good)),
            Some(PositionError::BadPps(7))
        );
        // one character changed: the checksum no longer matches
        let bent = good.replace("214107", "214108");
        assert!(matches!(
            err(encode_position_packet(5, 2, &bent)),
            Some(PositionError::BadChecksum { given: 0x0A, .. })
        ));
        let no_sum = &good[..good.len() - 3];
        assert_eq!(
            err(encode_position_packet(5, 2, no_sum)),
            Some(PositionError::NoChecksum)
        );
        assert_eq!(
            err(encode_position_packet(5, 2, "GPRMC,1*00")),
            Some(PositionError::NotNmea { offset: 206 })
        );
        let gga = "$GPGGA,1";
        let gga = format!("{gga}*{:02X}", gga[1..].bytes().fold(0u8, |a, b| a ^ b));
        assert_eq!(
            err(encode_position_packet(5, 2, &gga)),
            Some(PositionError::NotRmc)
        );
        let mut tail = encode_position_packet(5, 2, good);
        tail[300] = b'x';
        assert_eq!(err(tail), Some(PositionError::NotNmea { offset: 300 }));

        // random datagrams (a fixed xorshift stream): none passes, every refusal has a kind
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        let mut kinds = std::collections::BTreeMap::new();
        for _ in 0..20_000 {
            let mut b = [0u8; POSITION_PACKET_LEN];
            for v in b.iter_mut() {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                *v = x as u8;
            }
            // give half of them a plausible PPS byte and a `$`, so the sentence checks are reached
            if x & 1 == 0 {
                b[202] = (x >> 8) as u8 & 3;
                b[NMEA_OFFSET] = b'$';
            }
            let e = PositionPacket::parse(&b).expect_err("random bytes are no position packet");
            *kinds.entry(e.kind()).or_insert(0u32) += 1;
        }
        assert!(
            kinds.get("position_bad_pps").is_some_and(|&n| n > 5000),
            "{kinds:?}"
        );
        assert!(
            kinds.get("position_bad_nmea").is_some_and(|&n| n > 5000),
            "{kinds:?}"
        );
    }

    #[test]
    fn rejects_each_kind_of_bad_packet() {
        let mut p = vec![0u8; DATA_PACKET_LEN];
        for b in 0..BLOCKS {
            p[100 * b] = 0xFF;
            p[100 * b + 1] = 0xEE;
        }
        p[1204] = 0x39;
        p[1205] = 0x22;
        assert!(DataPacket::parse(&p, false).is_ok());
        assert_eq!(
            DataPacket::parse(&p[..1000], false).err(),
            Some(DecodeError::WrongLength { len: 1000 })
        );
        let mut q = p.clone();
        q[1205] = 0x21;
        assert_eq!(
            DataPacket::parse(&q, false).err(),
            Some(DecodeError::Product0x21NotAllowed)
        );
        assert!(DataPacket::parse(&q, true).is_ok());
        q[1205] = 0x28;
        assert_eq!(
            DataPacket::parse(&q, true).err(),
            Some(DecodeError::UnknownProduct(0x28))
        );
        let mut q = p.clone();
        q[1204] = 0x3a;
        assert_eq!(
            DataPacket::parse(&q, false).err(),
            Some(DecodeError::UnknownReturnMode(0x3a))
        );
        let mut q = p.clone();
        q[701] = 0xDD;
        assert_eq!(
            DataPacket::parse(&q, false).err(),
            Some(DecodeError::BadBlockFlag {
                block: 7,
                flag: 0xDDFF
            })
        );
        let mut q = p.clone();
        q[302..304].copy_from_slice(&36000u16.to_le_bytes());
        assert_eq!(
            DataPacket::parse(&q, false).err(),
            Some(DecodeError::BadAzimuth {
                block: 3,
                azimuth: 36000
            })
        );
    }
}
