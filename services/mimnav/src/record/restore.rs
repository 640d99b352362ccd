//! The other way round from [`super::convert`]: a recorded message back into the topic's sample,
//! for `mimnav replay run.mcap`. Only the topics a stack takes from its sensors and base are
//! restored — `lidar/points`, `lidar/scan2d`, `odom` — since those are what a newer mapper,
//! planner or classifier is fed from.
//!
//! The sample comes back exactly as it was published (every field, bit for bit) except
//! `rx_mono_ns`, which is a time on the recording host's monotonic clock: the replay stamps its
//! own. A message that cannot be restored says what is wrong with it ([`BadRecord`]); the replay
//! counts it and goes on.

use serde_json::Value;

use mimnav_shared::topics::{Odometry, Point, PointsHeader, ScanHeader, ScanReturn};

use super::convert::{POINT_FIELDS, POINT_STRIDE};

/// Why a recorded message cannot be replayed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct BadRecord(pub String);

fn bad(what: impl Into<String>) -> BadRecord {
    BadRecord(what.into())
}

fn parse(msg: &[u8]) -> Result<Value, BadRecord> {
    serde_json::from_slice(msg).map_err(|e| bad(format!("not JSON: {e}")))
}

fn get<'a>(v: &'a Value, key: &str) -> Result<&'a Value, BadRecord> {
    v.get(key).ok_or_else(|| bad(format!("no `{key}`")))
}

fn u64_of(v: &Value, key: &str) -> Result<u64, BadRecord> {
    get(v, key)?
        .as_u64()
        .ok_or_else(|| bad(format!("`{key}` is not an unsigned integer")))
}

fn int_of<T: TryFrom<u64>>(v: &Value, key: &str) -> Result<T, BadRecord> {
    T::try_from(u64_of(v, key)?).map_err(|_| bad(format!("`{key}` is out of range")))
}

fn f64_of(v: &Value, key: &str) -> Result<f64, BadRecord> {
    let x = get(v, key)?
        .as_f64()
        .ok_or_else(|| bad(format!("`{key}` is not a number")))?;
    if x.is_finite() {
        Ok(x)
    } else {
        Err(bad(format!("`{key}` is not finite")))
    }
}

/// An `f32` field: JSON holds it as the `f64` it widens to, which narrows back exactly.
fn f32_of(v: &Value, key: &str) -> Result<f32, BadRecord> {
    let x = f64_of(v, key)?;
    if x.abs() > f64::from(f32::MAX) {
        return Err(bad(format!("`{key}` is out of range")));
    }
    Ok(x as f32)
}

fn array<'a>(v: &'a Value, key: &str) -> Result<&'a Vec<Value>, BadRecord> {
    get(v, key)?
        .as_array()
        .ok_or_else(|| bad(format!("`{key}` is not an array")))
}

/// The `mimnav` object `convert` adds for what Foxglove's schema has no place for.
fn extra(v: &Value) -> Result<&Value, BadRecord> {
    v.get("mimnav").filter(|m| m.is_object()).ok_or_else(|| {
        bad("no `mimnav` header: recorded by a `mimnav record` older than replay (it kept x, y, z and intensity only)")
    })
}

/// A recorded `foxglove.PointCloud` of `lidar/points` back into the revolution.
pub fn points(msg: &[u8]) -> Result<(PointsHeader, Vec<Point>), BadRecord> {
    use base64::Engine as _;
    let v = parse(msg)?;
    let m = extra(&v)?;
    let stride = u64_of(&v, "point_stride")?;
    let fields = array(&v, "fields")?;
    let layout_ok = stride == POINT_STRIDE as u64
        && fields.len() == POINT_FIELDS.len()
        && fields
            .iter()
            .zip(POINT_FIELDS)
            .all(|(f, (name, offset, kind))| {
                f.get("name").and_then(Value::as_str) == Some(name)
                    && f.get("offset").and_then(Value::as_u64) == Some(offset as u64)
                    && f.get("type").and_then(Value::as_u64) == Some(u64::from(kind))
            });
    if !layout_ok {
        return Err(bad(format!(
            "the points' layout (stride {stride}, {} fields) is not the one `mimnav record` writes (stride {POINT_STRIDE}: {})",
            fields.len(),
            POINT_FIELDS.map(|f| f.0).join(", ")
        )));
    }
    let data = get(&v, "data")?
        .as_str()
        .ok_or_else(|| bad("`data` is not a string"))?;
    let data = base64::engine::general_purpose::STANDARD
        .decode(data)
        .map_err(|e| bad(format!("`data` is not base64: {e}")))?;
    let h = PointsHeader {
        seq: u64_of(m, "seq")?,
        stamp_ns: u64_of(m, "stamp_ns")?,
        rx_mono_ns: u64_of(m, "rx_mono_ns")?,
        first_packet_seq: u64_of(m, "first_packet_seq")?,
        packet_count: int_of(m, "packet_count")?,
        point_count: 0,
        strongest_count: int_of(m, "strongest_count")?,
        last_count: int_of(m, "last_count")?,
        both_count: int_of(m, "both_count")?,
        return_mode: int_of(m, "return_mode")?,
        product: int_of(m, "product")?,
        cut_reason: int_of(m, "cut_reason")?,
        ..PointsHeader::default()
    };
    if data.len() % POINT_STRIDE != 0 {
        return Err(bad(format!(
            "{} bytes of points is not a whole number of {POINT_STRIDE}-byte points",
            data.len()
        )));
    }
    let f32_at = |b: &[u8], o: usize| f32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]]);
    let mut pts = Vec::with_capacity(data.len() / POINT_STRIDE);
    for (k, b) in data.chunks_exact(POINT_STRIDE).enumerate() {
        let (x, y, z, intensity) = (f32_at(b, 0), f32_at(b, 4), f32_at(b, 8), f32_at(b, 12));
        if !(x.is_finite() && y.is_finite() && z.is_finite()) {
            return Err(bad(format!("point {k} is not finite: ({x}, {y}, {z})")));
        }
        if !(0.0..=255.0).contains(&intensity) || intensity.fract() != 0.0 {
            return Err(bad(format!(
                "point {k}'s intensity {intensity} is not a reflectivity byte"
            )));
        }
        pts.push(Point {
            x,
            y,
            z,
            time_offset_ns: u32::from_le_bytes([b[16], b[17], b[18], b[19]]),
            distance_raw: u16::from_le_bytes([b[20], b[21]]),
            azimuth_cdeg: u16::from_le_bytes([b[22], b[23]]),
            intensity: intensity as u8,
            laser_id: b[24],
            ring: b[25],
            return_type: b[26],
        });
    }
    let n = u32::try_from(pts.len()).map_err(|_| bad("too many points"))?;
    Ok((
        PointsHeader {
            point_count: n,
            ..h
        },
        pts,
    ))
}

/// A recorded `lidar/scan2d` (`mimnav.Scan2d`) back into the scan.
pub fn scan(msg: &[u8]) -> Result<(ScanHeader, Vec<ScanReturn>), BadRecord> {
    let v = parse(msg)?;
    let (angle, range, intensity, kind) = (
        array(&v, "angle_rad")?,
        array(&v, "range_m")?,
        array(&v, "intensity")?,
        array(&v, "return_type")?,
    );
    let n = angle.len();
    if [range.len(), intensity.len(), kind.len()] != [n; 3] {
        return Err(bad(format!(
            "the scan's arrays differ in length: angle_rad {n}, range_m {}, intensity {}, return_type {}",
            range.len(),
            intensity.len(),
            kind.len()
        )));
    }
    let h = ScanHeader {
        seq: u64_of(&v, "seq")?,
        stamp_ns: u64_of(&v, "stamp_ns")?,
        rx_mono_ns: u64_of(&v, "rx_mono_ns")?,
        count: u32::try_from(n).map_err(|_| bad("too many returns"))?,
        elevation_rad: f32_of(&v, "elevation_rad")?,
        laser_id: int_of(&v, "laser_id")?,
        return_select: int_of(&v, "return_select")?,
        ..ScanHeader::default()
    };
    let number = |a: &Value, what: &str, k: usize| -> Result<f64, BadRecord> {
        a.as_f64()
            .filter(|x| x.is_finite() && x.abs() <= f64::from(f32::MAX))
            .ok_or_else(|| bad(format!("{what}[{k}] is not a finite number")))
    };
    let byte = |a: &Value, what: &str, k: usize| -> Result<u8, BadRecord> {
        a.as_u64()
            .and_then(|x| u8::try_from(x).ok())
            .ok_or_else(|| bad(format!("{what}[{k}] is not a byte")))
    };
    let mut returns = Vec::with_capacity(n);
    for k in 0..n {
        returns.push(ScanReturn {
            angle_rad: number(&angle[k], "angle_rad", k)? as f32,
            range_m: number(&range[k], "range_m", k)? as f32,
            intensity: byte(&intensity[k], "intensity", k)?,
            return_type: byte(&kind[k], "return_type", k)?,
            ..ScanReturn::default()
        });
    }
    Ok((h, returns))
}

/// A recorded `odom` (`foxglove.PoseInFrame` with its `mimnav` fields) back into the sample.
pub fn odom(msg: &[u8]) -> Result<Odometry, BadRecord> {
    let v = parse(msg)?;
    let m = extra(&v)?;
    Ok(Odometry {
        seq: u64_of(m, "seq")?,
        stamp_ns: u64_of(m, "stamp_ns")?,
        rx_mono_ns: u64_of(m, "rx_mono_ns")?,
        x: f64_of(m, "x")?,
        y: f64_of(m, "y")?,
        yaw: f64_of(m, "yaw")?,
        v: f32_of(m, "v")?,
        omega: f32_of(m, "omega")?,
    })
}

#[cfg(test)]
mod tests {
    use super::super::convert;
    use super::*;
    use proptest::prelude::*;

    fn point() -> impl Strategy<Value = Point> {
        (
            (-200.0f32..200.0, -200.0f32..200.0, -50.0f32..50.0),
            any::<u32>(),
            1u16..,
            0u16..36000,
            any::<u8>(),
            0u8..16,
            0u8..16,
            0u8..4,
        )
            .prop_map(|((x, y, z), t, d, a, i, l, r, k)| Point {
                x,
                y,
                z,
                time_offset_ns: t,
                distance_raw: d,
                azimuth_cdeg: a,
                intensity: i,
                laser_id: l,
                ring: r,
                return_type: k,
            })
    }

    proptest! {
        /// Every field of every point and of the header comes back bit for bit.
        #[test]
        fn a_revolution_comes_back_as_it_was_recorded(
            pts in proptest::collection::vec(point(), 0..200),
            seq in any::<u64>(), stamp in any::<u64>(), rx in any::<u64>(),
            first in any::<u64>(), packets in any::<u32>(), counts in any::<(u32, u32, u32)>(),
            bytes in any::<(u8, u8, u8)>(),
        ) {
            let h = PointsHeader {
                seq, stamp_ns: stamp, rx_mono_ns: rx, first_packet_seq: first,
                packet_count: packets, point_count: pts.len() as u32,
                strongest_count: counts.0, last_count: counts.1, both_count: counts.2,
                return_mode: bytes.0, product: bytes.1, cut_reason: bytes.2,
                ..PointsHeader::default()
            };
            let (h2, pts2) = points(&convert::points(&h, &pts)).unwrap();
            prop_assert_eq!(h2, h);
            prop_assert_eq!(pts2.len(), pts.len());
            for (a, b) in pts.iter().zip(&pts2) {
                prop_assert_eq!(a.x.to_bits(), b.x.to_bits());
                prop_assert_eq!(a.y.to_bits(), b.y.to_bits());
                prop_assert_eq!(a.z.to_bits(), b.z.to_bits());
                prop_assert_eq!(
                    (a.time_offset_ns, a.distance_raw, a.azimuth_cdeg, a.intensity, a.laser_id, a.ring, a.return_type),
                    (b.time_offset_ns, b.distance_raw, b.azimuth_cdeg, b.intensity, b.laser_id, b.ring, b.return_type)
                );
            }
        }

        #[test]
        fn odometry_comes_back_as_it_was_recorded(
            seq in any::<u64>(), stamp in any::<u64>(), rx in any::<u64>(),
            x in -1e6f64..1e6, y in -1e6f64..1e6, yaw in -4.0f64..4.0,
            v in -3.0f32..3.0, omega in -3.0f32..3.0,
        ) {
            let o = Odometry { seq, stamp_ns: stamp, rx_mono_ns: rx, x, y, yaw, v, omega };
            let back = odom(&convert::odom(&o)).unwrap();
            prop_assert_eq!(back.x.to_bits(), x.to_bits());
            prop_assert_eq!(back.yaw.to_bits(), yaw.to_bits());
            prop_assert_eq!(back.v.to_bits(), v.to_bits());
            prop_assert_eq!(back, o);
        }
    }

    #[test]
    fn a_scan_comes_back_as_it_was_recorded() {
        let h = ScanHeader {
            seq: 9,
            stamp_ns: 1_700_000_000_000_000_001,
            rx_mono_ns: 5,
            count: 2,
            elevation_rad: -0.017_453_3,
            laser_id: 7,
            return_select: 2,
            ..ScanHeader::default()
        };
        let r = [
            ScanReturn {
                angle_rad: 0.1,
                range_m: 3.25,
                intensity: 40,
                return_type: 1,
                ..ScanReturn::default()
            },
            ScanReturn::default(),
        ];
        let (h2, r2) = scan(&convert::scan(&h, &r)).unwrap();
        assert_eq!(h2, h);
        assert_eq!(r2, r);
    }

    #[test]
    fn damaged_messages_say_what_is_wrong() {
        let h = PointsHeader::default();
        let pts = [Point {
            x: 1.0,
            intensity: 3,
            ..Point::default()
        }];
        let good: Value = serde_json::from_slice(&convert::points(&h, &pts)).unwrap();
        let with = |f: &dyn Fn(&mut Value)| {
            let mut v = good.clone();
            f(&mut v);
            points(&serde_json::to_vec(&v).unwrap())
                .unwrap_err()
                .to_string()
        };
        assert!(with(&|v| v["point_stride"] = 16.into()).contains("stride 16"));
        assert!(
            with(&|v| {
                v.as_object_mut().unwrap().remove("mimnav");
            })
            .contains("older than replay")
        );
        assert!(with(&|v| v["data"] = "AAAA".into()).contains("whole number"));
        assert!(with(&|v| v["data"] = "!!".into()).contains("not base64"));
        assert!(with(&|v| v["mimnav"]["packet_count"] = (-1).into()).contains("packet_count"));
        let nan = {
            let mut b = vec![0u8; POINT_STRIDE];
            b[..4].copy_from_slice(&f32::NAN.to_le_bytes());
            convert::base64(&b)
        };
        assert!(with(&|v| v["data"] = nan.clone().into()).contains("not finite"));
        assert!(points(b"{").unwrap_err().to_string().contains("not JSON"));
        let scan_msg = serde_json::json!({"seq": 1, "stamp_ns": 1, "rx_mono_ns": 1,
            "elevation_rad": 0.0, "laser_id": 0, "return_select": 1,
            "angle_rad": [0.0], "range_m": [], "intensity": [0], "return_type": [0]});
        assert!(
            scan(&serde_json::to_vec(&scan_msg).unwrap())
                .unwrap_err()
                .to_string()
                .contains("differ in length")
        );
        assert!(
            odom(br#"{"mimnav": {"seq": 1}}"#)
                .unwrap_err()
                .to_string()
                .contains("stamp_ns")
        );
    }
}
