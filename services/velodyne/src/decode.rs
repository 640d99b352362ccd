//! Decoding a validated data packet into points and planar-scan returns.
//!
//! The conventions follow the VLP-16 manual and agree with velodyne-decoder 3.1 point for point
//! (the reference decodes in `shared/data/velodyne/reference`):
//! - firing time of channel `c` in block `b`: 55.296 µs · (2·b + c/16) + 2.304 µs · (c % 16) in
//!   single-return mode; dual mode uses the block *pair* index ⌊b/2⌋ instead of `b`;
//! - azimuth interpolation: the packet's mean rotation rate (last block azimuth minus first, over
//!   the time between them) times the firing's delay after the block's first firing, rounded to
//!   0.01°. Using the whole packet's rate avoids the dual-mode trap where both blocks of a pair
//!   carry the same azimuth;
//! - dual pairs: the even block holds the last return, the odd block the strongest (or second
//!   strongest). Equal distances are one return ("both"); otherwise the last return is emitted
//!   first, then the strongest, each only if non-zero;
//! - geometry: x = d·cos ω·cos α, y = −d·cos ω·sin α, z = d·sin ω (ω elevation, α azimuth).

use crate::config::VelodyneConfig;
use mimnav_shared::topics::{Point, ScanReturn, return_mode, return_type};

use crate::packet::{
    BLOCKS, CHANNELS, DISTANCE_UNIT_M, DataPacket, LASERS, PRODUCT_PUCK_HI_RES,
    PUCK_HI_RES_ELEVATION_DEG, VLP16_ELEVATION_DEG, ring_of,
};

/// Duration of one firing sequence (16 lasers plus recharge), ns.
pub const SEQUENCE_NS: u32 = 55_296;
/// Delay between two lasers of a sequence, ns.
pub const LASER_NS: u32 = 2_304;

/// Which return of a dual pair a planar scan takes: `velodyne.scan_return`.
pub use crate::config::ScanReturnSelect;

/// Per-laser geometry of one product.
#[derive(Debug, Clone)]
struct LaserTable {
    cos_elev: [f32; LASERS],
    sin_elev: [f32; LASERS],
}

impl LaserTable {
    fn new(elevation_deg: &[f32; LASERS]) -> Self {
        let mut t = LaserTable {
            cos_elev: [0.0; LASERS],
            sin_elev: [0.0; LASERS],
        };
        for (i, e) in elevation_deg.iter().enumerate() {
            let r = f64::from(*e).to_radians();
            t.cos_elev[i] = r.cos() as f32;
            t.sin_elev[i] = r.sin() as f32;
        }
        t
    }
}

/// Stateless packet decoder with precomputed tables.
#[derive(Debug, Clone)]
pub struct Decoder {
    /// `[velodyne]`: the range limits, the product rule and the planar scan.
    config: VelodyneConfig,
    /// `velodyne.min_range_m` and `max_range_m` as the distances are compared (f32).
    range_m: (f32, f32),
    vlp16: LaserTable,
    hi_res: LaserTable,
    /// cos and sin of every azimuth in 0.01° steps.
    cos_az: Vec<f32>,
    sin_az: Vec<f32>,
    /// Firing-time offsets in seconds (f32, as velodyne-decoder computes them), by sequence index
    /// within the packet (0..24) and laser.
    timing_s: [[f32; LASERS]; 2 * BLOCKS],
}

/// What one packet contributed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PacketCounts {
    /// Points appended.
    pub points: u32,
    /// Of those, strongest-only.
    pub strongest: u32,
    /// Of those, last-only.
    pub last: u32,
    /// Of those, both.
    pub both: u32,
}

impl Decoder {
    /// Builds the tables for the `[velodyne]` settings `config`.
    pub fn new(config: &VelodyneConfig) -> Self {
        let mut cos_az = Vec::with_capacity(36000);
        let mut sin_az = Vec::with_capacity(36000);
        for a in 0..36000u32 {
            let r = (f64::from(a) * 0.01).to_radians();
            cos_az.push(r.cos() as f32);
            sin_az.push(r.sin() as f32);
        }
        let mut timing_s = [[0.0f32; LASERS]; 2 * BLOCKS];
        for (seq, row) in timing_s.iter_mut().enumerate() {
            for (laser, t) in row.iter_mut().enumerate() {
                *t = (55.296e-6 * seq as f64 + 2.304e-6 * laser as f64) as f32;
            }
        }
        Decoder {
            range_m: (config.min_range_m as f32, config.max_range_m as f32),
            config: config.clone(),
            vlp16: LaserTable::new(&VLP16_ELEVATION_DEG),
            hi_res: LaserTable::new(&PUCK_HI_RES_ELEVATION_DEG),
            cos_az,
            sin_az,
            timing_s,
        }
    }

    /// The settings this decoder was built with.
    pub fn config(&self) -> &VelodyneConfig {
        &self.config
    }

    /// Elevation in radians of `laser_id` for `product`.
    pub fn elevation_rad(product: u8, laser_id: usize) -> f32 {
        let table = if product == PRODUCT_PUCK_HI_RES {
            &PUCK_HI_RES_ELEVATION_DEG
        } else {
            &VLP16_ELEVATION_DEG
        };
        table[laser_id % LASERS].to_radians()
    }

    /// Decodes `pkt`, appending its in-range points to `points` and, when a scan laser is
    /// configured, one [`ScanReturn`] per firing of that laser (range 0 where there is none) to
    /// `scan`. `packet_offset_ns` is the packet's first firing relative to the revolution's
    /// stamp; it is added to every point's firing offset.
    pub fn decode(
        &self,
        pkt: &DataPacket<'_>,
        packet_offset_ns: u32,
        points: &mut Vec<Point>,
        scan: &mut Vec<ScanReturn>,
    ) -> PacketCounts {
        let table = if pkt.product() == PRODUCT_PUCK_HI_RES {
            &self.hi_res
        } else {
            &self.vlp16
        };
        let dual = pkt.is_dual();
        // Mean rotation rate over the packet, 0.01° per second (f32 like the reference, so the
        // rounded azimuths agree exactly).
        let az_diff = (i32::from(pkt.azimuth(BLOCKS - 1)) - i32::from(pkt.azimuth(0)) + 36000)
            .rem_euclid(36000) as f32;
        let span_s = self.timing_s[if dual { BLOCKS - 2 } else { 2 * (BLOCKS - 1) }][0];
        let rate = az_diff / span_s;
        let single_type = if pkt.return_mode() == return_mode::LAST {
            return_type::LAST
        } else {
            return_type::STRONGEST
        };
        let mut counts = PacketCounts::default();
        let step = if dual { 2 } else { 1 };
        for block in (0..BLOCKS).step_by(step) {
            let seq0 = if dual { block } else { 2 * block };
            let t0 = self.timing_s[seq0][0];
            let block_az = f32::from(pkt.azimuth(block));
            for ch in 0..CHANNELS {
                let laser = ch % LASERS;
                let seq = seq0 + ch / LASERS;
                let dt = self.timing_s[seq][laser] - t0;
                let az = round(block_az + rate * dt + 36000.0).rem_euclid(36000) as u16;
                let offset_ns = packet_offset_ns
                    .wrapping_add(SEQUENCE_NS * seq as u32 + LASER_NS * laser as u32);
                let (d_a, i_a) = pkt.channel(block, ch);
                let mut emit = |raw: u16, intensity: u8, rtype: u8| {
                    if let Some(p) = self.point(table, raw, intensity, rtype, laser, az, offset_ns)
                    {
                        points.push(p);
                        counts.points += 1;
                        match rtype {
                            return_type::BOTH => counts.both += 1,
                            return_type::LAST => counts.last += 1,
                            _ => counts.strongest += 1,
                        }
                    }
                };
                let scan_pick;
                if dual {
                    // even block: last; odd block: strongest
                    let (d_s, i_s) = pkt.channel(block + 1, ch);
                    if d_a == d_s {
                        if d_a != 0 {
                            emit(d_s, i_s, return_type::BOTH);
                        }
                        scan_pick = (d_s, i_s, return_type::BOTH);
                    } else {
                        if d_a != 0 {
                            emit(d_a, i_a, return_type::LAST);
                        }
                        if d_s != 0 {
                            emit(d_s, i_s, return_type::STRONGEST);
                        }
                        scan_pick = match self.config.scan_return {
                            ScanReturnSelect::Strongest => (d_s, i_s, return_type::STRONGEST),
                            ScanReturnSelect::Last => (d_a, i_a, return_type::LAST),
                        };
                    }
                } else {
                    if d_a != 0 {
                        emit(d_a, i_a, single_type);
                    }
                    scan_pick = (d_a, i_a, single_type);
                }
                if usize::from(self.config.scan_laser) == laser {
                    scan.push(self.scan_return(table, scan_pick, laser, az));
                }
            }
        }
        counts
    }

    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn point(
        &self,
        table: &LaserTable,
        raw: u16,
        intensity: u8,
        rtype: u8,
        laser: usize,
        az: u16,
        time_offset_ns: u32,
    ) -> Option<Point> {
        let d = f32::from(raw) * DISTANCE_UNIT_M;
        if !(d >= self.range_m.0 && d <= self.range_m.1) {
            return None;
        }
        let xy = d * table.cos_elev[laser];
        Some(Point {
            x: xy * self.cos_az[az as usize],
            y: -xy * self.sin_az[az as usize],
            z: d * table.sin_elev[laser],
            time_offset_ns,
            distance_raw: raw,
            azimuth_cdeg: az,
            intensity,
            laser_id: laser as u8,
            ring: ring_of(laser),
            return_type: rtype,
        })
    }

    fn scan_return(
        &self,
        table: &LaserTable,
        (raw, intensity, rtype): (u16, u8, u8),
        laser: usize,
        az: u16,
    ) -> ScanReturn {
        // REP-103 bearing: the sensor's azimuth grows clockwise, angles grow counter-clockwise.
        let mut angle = -(f32::from(az) * 0.01).to_radians();
        if angle <= -std::f32::consts::PI {
            angle += 2.0 * std::f32::consts::PI;
        }
        let d = f32::from(raw) * DISTANCE_UNIT_M;
        if raw == 0 || !(d >= self.range_m.0 && d <= self.range_m.1) {
            return ScanReturn {
                angle_rad: angle,
                ..ScanReturn::default()
            };
        }
        ScanReturn {
            angle_rad: angle,
            range_m: d * table.cos_elev[laser],
            intensity,
            return_type: rtype,
            reserved: [0; 2],
        }
    }
}

/// `x.round() as i64` (halves away from zero) without the call into libm's `roundf`, a tenth
/// of the driver's user time in grass: the fraction `x - trunc(x)` of an `f32` is exact, so comparing
/// it with ±0.5 rounds exactly as `roundf` does (NaN gives 0 and ±∞ saturate, as `as` does).
#[inline]
fn round(x: f32) -> i64 {
    let t = x as i64;
    let frac = x - t as f32;
    if frac >= 0.5 {
        t.saturating_add(1)
    } else if frac <= -0.5 {
        t.saturating_sub(1)
    } else {
        t
    }
}

#[cfg(test)]
mod tests {
    use super::round;
    use proptest::prelude::*;

    #[test]
    fn round_agrees_with_roundf_at_the_edges() {
        let edges = [
            0.0f32,
            -0.0,
            0.5,
            -0.5,
            0.499_999_97,
            -0.499_999_97,
            1.5,
            2.5,
            -2.5,
            36_000.5,
            65_535.496,
            65_535.5,
            71_999.5,
            8_388_607.5,
            16_777_216.0,
            1e19,
            -1e19,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        for x in edges {
            assert_eq!(round(x), x.round() as i64, "{x:?}");
        }
        // every value the azimuth takes before its modulo (the block's azimuth, 36 000 and at
        // most 7 200 of interpolation: the largest packet span over the shortest delay), to the
        // f32's last bit around each half
        for n in 36_000..80_000 {
            let half = n as f32 + 0.5;
            for x in [half.next_down(), half, half.next_up()] {
                assert_eq!(round(x), x.round() as i64, "{x:?}");
            }
        }
    }

    proptest! {
        #[test]
        fn round_agrees_with_roundf(bits: u32) {
            let x = f32::from_bits(bits);
            prop_assert_eq!(round(x), x.round() as i64);
        }
    }
}
