//! The decoder against independent reference decodes of real VLP-16 captures.
//!
//! `../shared/data/velodyne/reference/NAME.points.csv.gz` holds every capture decoded by
//! velodyne-decoder 3.1.0 (min range 0.1 m, max range 200 m, no cut angle). The comparison rules
//! are those of `../shared/data/velodyne/README.md`: frames, laser id, raw distance, intensity and
//! return type exactly; azimuth within 0.01°; x, y, z within 1 mm once velodyne-decoder's
//! per-laser vertical offset is taken out of z. The captures are read from the shared folder,
//! never copied into the project; where the folder is missing the test says so and passes.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

use mimnav_shared::topics::Point;
use mimnav_velodyne::capture::CaptureReader;
use mimnav_velodyne::config::VelodyneConfig;
use mimnav_velodyne::revolution::{Assembler, AssemblerConfig, max_points_per_revolution};

fn data_dir() -> Option<PathBuf> {
    let dir = match std::env::var_os("MIMNAV_SHARED_DATA") {
        Some(d) => PathBuf::from(d).join("velodyne"),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/velodyne"),
    };
    if dir.join("README.md").exists() {
        Some(dir)
    } else {
        println!(
            "SKIP: no shared VLP-16 captures at {} (set MIMNAV_SHARED_DATA)",
            dir.display()
        );
        None
    }
}

struct RefPoint {
    frame: usize,
    x: f64,
    y: f64,
    intensity: u8,
    time: f64,
    return_type: u8,
    laser_id: u8,
    azimuth_deg: f64,
    distance_raw: u16,
    z_no_offset: f64,
}

fn read_reference(path: &Path) -> Vec<RefPoint> {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let reader = BufReader::new(flate2::read::GzDecoder::new(file));
    let mut lines = reader.lines();
    let header = lines.next().expect("header").expect("utf-8");
    let cols: Vec<&str> = header.split(',').collect();
    let col = |name: &str| cols.iter().position(|c| *c == name).expect(name);
    let (cf, cx, cy, ci, ct, cr, cl, ca, cd, cz) = (
        col("frame"),
        col("x"),
        col("y"),
        col("intensity"),
        col("time"),
        col("return_type"),
        col("laser_id"),
        col("azimuth_deg"),
        col("distance_raw"),
        col("z_no_offset"),
    );
    lines
        .map(|l| {
            let l = l.expect("line");
            let f: Vec<&str> = l.split(',').collect();
            let num = |i: usize| f[i].parse::<f64>().unwrap_or_else(|e| panic!("{l}: {e}"));
            RefPoint {
                frame: num(cf) as usize,
                x: num(cx),
                y: num(cy),
                intensity: num(ci) as u8,
                time: num(ct),
                return_type: num(cr) as u8,
                laser_id: num(cl) as u8,
                azimuth_deg: num(ca),
                distance_raw: num(cd) as u16,
                z_no_offset: num(cz),
            }
        })
        .collect()
}

struct Frame {
    stamp_ns: u64,
    points: Vec<Point>,
}

fn decode_capture(path: &Path, accept_0x21: bool) -> (Vec<Frame>, u64) {
    let config = AssemblerConfig {
        velodyne: VelodyneConfig {
            min_range_m: 0.1,
            max_range_m: 200.0,
            accept_product_0x21: accept_0x21,
            ..VelodyneConfig::default()
        },
        max_duration_ns: 150_000_000,
        max_points: max_points_per_revolution(600.0, 0.15),
    };
    let mut asm = Assembler::new(config);
    let mut reader = CaptureReader::open(path).expect("open");
    let mut frames = Vec::new();
    let mut errors = 0u64;
    let keep = |r: &mimnav_velodyne::revolution::Revolution| Frame {
        stamp_ns: r.header.stamp_ns,
        points: r.points.clone(),
    };
    while let Some(d) = reader.next().expect("capture reads whole") {
        if d.payload.len() != 1206 {
            continue;
        }
        match asm.push(d.payload, d.ts_ns, 0) {
            Ok(Some(rev)) => frames.push(keep(rev)),
            Ok(None) => {}
            Err(e) => {
                errors += 1;
                eprintln!("{}: decode error {e}", path.display());
            }
        }
    }
    if let Some(rev) = asm.finish() {
        frames.push(keep(rev));
    }
    (frames, errors)
}

fn compare(name: &str, accept_0x21: bool) {
    let Some(dir) = data_dir() else { return };
    let (frames, errors) = decode_capture(&dir.join(format!("{name}.pcap")), accept_0x21);
    assert_eq!(errors, 0, "{name}: decode errors");
    let reference = read_reference(&dir.join(format!("reference/{name}.points.csv.gz")));
    let ref_frames = reference.last().map(|p| p.frame + 1).unwrap_or(0);
    assert_eq!(frames.len(), ref_frames, "{name}: frame count");
    assert!(!frames.is_empty(), "{name}: no frame checked");
    let mut at = 0;
    let mut checked = 0usize;
    for (fi, frame) in frames.iter().enumerate() {
        let refs: Vec<&RefPoint> = reference[at..]
            .iter()
            .take_while(|p| p.frame == fi)
            .collect();
        at += refs.len();
        assert_eq!(
            frame.points.len(),
            refs.len(),
            "{name}: frame {fi} point count"
        );
        let mut dt: Option<f64> = None;
        for (i, (p, r)) in frame.points.iter().zip(&refs).enumerate() {
            let ctx = || format!("{name}: frame {fi} point {i}");
            assert_eq!(p.laser_id, r.laser_id, "{} laser", ctx());
            assert_eq!(p.distance_raw, r.distance_raw, "{} distance", ctx());
            assert_eq!(p.intensity, r.intensity, "{} intensity", ctx());
            assert_eq!(p.return_type, r.return_type, "{} return type", ctx());
            let az = f64::from(p.azimuth_cdeg) * 0.01;
            let daz = ((az - r.azimuth_deg + 540.0) % 360.0 - 180.0).abs();
            assert!(
                daz <= 0.01 + 1e-6,
                "{} azimuth {az} vs {}",
                ctx(),
                r.azimuth_deg
            );
            assert!(
                (f64::from(p.x) - r.x).abs() <= 1e-3,
                "{} x {} vs {}",
                ctx(),
                p.x,
                r.x
            );
            assert!(
                (f64::from(p.y) - r.y).abs() <= 1e-3,
                "{} y {} vs {}",
                ctx(),
                p.y,
                r.y
            );
            let dz = (f64::from(p.z) - r.z_no_offset).abs();
            assert!(dz <= 1e-3, "{} z {} vs {}", ctx(), p.z, r.z_no_offset);
            // Our times count from the frame's first packet, the reference's from its last: the
            // difference is one constant per frame.
            let d = f64::from(p.time_offset_ns) * 1e-9 - r.time;
            let d0 = *dt.get_or_insert(d);
            assert!(
                (d - d0).abs() < 1e-6,
                "{} time {} vs {}",
                ctx(),
                p.time_offset_ns,
                r.time
            );
            checked += 1;
        }
        let _ = frame.stamp_ns;
    }
    assert_eq!(at, reference.len());
    println!(
        "{name}: {} frames, {checked} points identical to the reference",
        frames.len()
    );
}

#[test]
fn dual_return_capture_matches_reference() {
    compare("vlp16_dual_nebula", false);
}

#[test]
fn strongest_einride_matches_reference() {
    compare("vlp16_strongest_einride", false);
}

#[test]
fn strongest_with_gps_matches_reference() {
    compare("vlp16_strongest_gps_mrpt", false);
}

#[test]
fn veloview_2018_matches_reference() {
    compare("vlp16_strongest_2018", false);
}

#[test]
fn product_0x21_matches_reference_when_allowed() {
    compare("vlp16_strongest_product0x21_2014", true);
}

#[test]
fn product_0x21_is_refused_by_default() {
    let Some(dir) = data_dir() else { return };
    let (frames, errors) =
        decode_capture(&dir.join("vlp16_strongest_product0x21_2014.pcap"), false);
    assert_eq!(errors, 84, "every data packet refused");
    assert!(frames.is_empty());
}

#[test]
fn single_packet_matches_reference() {
    compare("vlp16_single_packet", false);
}

#[test]
fn position_packet_capture_gives_pps_and_gprmc_time() {
    use mimnav_velodyne::packet::{PositionPacket, PpsStatus};
    let Some(dir) = data_dir() else { return };
    let mut reader = CaptureReader::open(&dir.join("vlp16_position_packet.pcap")).expect("open");
    let d = reader.next().expect("reads").expect("one datagram");
    assert_eq!((d.dst_port, d.payload.len()), (8308, 512));
    let p = PositionPacket::parse(d.payload).expect("position packet");
    assert_eq!(p.pps, PpsStatus::Locked);
    assert!(p.nmea.starts_with("$GPRMC,"), "{}", p.nmea);
    // 2015-07-23 (the README's date for this capture)
    let t = p.gprmc_unix_s().expect("valid GPRMC");
    assert!((1_437_609_600.0..1_437_696_000.0).contains(&t), "{t}");
    // the sensor's own timestamp agrees with the GPRMC time within the hour
    let sensor_s = f64::from(p.timestamp_us) * 1e-6;
    assert!(
        (t.rem_euclid(3600.0) - sensor_s).abs() < 2.0,
        "{t} vs {sensor_s}"
    );
    assert!(reader.next().expect("reads").is_none());
}

/// Issue 23 item 5 (the position packet is checked: PPS status, NMEA sentence, checksum): every
/// position packet of the real captures still passes, with a GPS (GPRMC, PPS locked) and
/// without one (an empty NMEA field).
#[test]
fn every_position_packet_of_the_real_captures_passes_the_checks() {
    use mimnav_velodyne::packet::{POSITION_PACKET_LEN, PositionPacket};
    let Some(dir) = data_dir() else { return };
    for (name, expected, with_gps) in [
        ("vlp16_position_packet", 1, true),
        ("vlp16_strongest_gps_mrpt", 57, true),
        ("vlp16_strongest_product0x21_2014", 16, false),
    ] {
        let mut reader = CaptureReader::open(&dir.join(format!("{name}.pcap"))).expect("open");
        let mut n = 0;
        while let Some(d) = reader.next().expect("reads") {
            if d.payload.len() != POSITION_PACKET_LEN {
                continue;
            }
            let p = PositionPacket::parse(d.payload)
                .unwrap_or_else(|e| panic!("{name} byte offset {}: {e}", d.offset));
            assert_eq!(p.gprmc_unix_s().is_some(), with_gps, "{name}: {}", p.nmea);
            n += 1;
        }
        assert_eq!(n, expected, "{name}: position packets");
    }
}
