//! The three real `LMDscandata` telegrams of `../shared/data/sick/` (a TiM5xx's one-shot and
//! streamed scans, an LMS1xx's streamed scan), decoded to the values their README gives: its
//! table (command, serial, points, start angle, step, channels) is read from the README itself,
//! and the hand-checked values its list names (first and last distances, first remission) are
//! asserted here. Each telegram also goes through the driver's session as the bytes of a TCP
//! stream, through the conversion to REP-103, and back and forth through CoLa-B.

use std::path::{Path, PathBuf};

use mimnav_sick::cola::{Dialect, Framer};
use mimnav_sick::convert::{Converter, Echo, SickMount};
use mimnav_sick::scandata::ScanData;
use mimnav_sick::session::{Event, Session, SessionConfig};

fn data_dir() -> Option<PathBuf> {
    let dir = match std::env::var_os("MIMNAV_SHARED_DATA") {
        Some(d) => PathBuf::from(d).join("sick"),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/sick"),
    };
    if dir.join("README.md").exists() {
        Some(dir)
    } else {
        println!(
            "SKIP: no shared SICK telegrams at {} (set MIMNAV_SHARED_DATA)",
            dir.display()
        );
        None
    }
}

/// One row of the README's table.
#[derive(Debug)]
struct Row {
    file: String,
    command: String,
    serial: u32,
    points: usize,
    start_deg: f64,
    step_deg: f64,
    channels: Vec<String>,
}

/// The README's table, read from the README.
fn table(dir: &Path) -> Vec<Row> {
    let text = std::fs::read_to_string(dir.join("README.md")).expect("README.md");
    let mut rows: Vec<Row> = Vec::new();
    for line in text.lines().filter(|l| l.starts_with("| `")) {
        let cells: Vec<&str> = line.trim_matches('|').split('|').map(str::trim).collect();
        let unquote = |s: &str| s.split('`').nth(1).unwrap_or("").to_string();
        // "same device": the row above's serial
        let serial = match cells[2].split("0x").nth(1) {
            Some(h) => {
                u32::from_str_radix(h.trim_end_matches(|c: char| !c.is_ascii_hexdigit()), 16)
                    .expect("hex serial")
            }
            None if cells[2].contains("same device") => rows.last().expect("a row above").serial,
            None => panic!("no serial in {:?}", cells[2]),
        };
        let deg = |s: &str| -> f64 {
            s.trim_end_matches('°')
                .parse()
                .unwrap_or_else(|_| panic!("{s:?}"))
        };
        rows.push(Row {
            file: unquote(cells[0]),
            command: unquote(cells[1]),
            serial,
            points: cells[3].parse().expect("points"),
            start_deg: deg(cells[4]),
            step_deg: deg(cells[5]),
            channels: cells[6].split(',').map(|c| c.trim().to_string()).collect(),
        });
    }
    assert_eq!(rows.len(), 3, "the README's table has three telegrams");
    rows
}

/// The telegram's text between STX and ETX.
fn payload(dir: &Path, file: &str) -> Vec<u8> {
    let bytes = std::fs::read(dir.join(file)).expect("telegram");
    let mut f = Framer::new(Dialect::ColaA, 1 << 16);
    f.push(&bytes);
    let p = f.next().expect("a telegram").expect("framed").to_vec();
    assert!(f.next().is_none(), "{file}: one telegram");
    p
}

fn parse(p: &[u8]) -> ScanData {
    let mut s = ScanData::default();
    s.parse_a(p).expect("parses");
    s
}

#[test]
fn the_readmes_table_matches_every_decoded_telegram() {
    let Some(dir) = data_dir() else { return };
    for row in table(&dir) {
        let p = payload(&dir, &row.file);
        assert!(p.starts_with(row.command.as_bytes()), "{}", row.file);
        let s = parse(&p);
        assert_eq!(s.serial, row.serial, "{}", row.file);
        assert_eq!(s.device_status, [0, 0], "{}: the device was fine", row.file);
        let names: Vec<&str> = s.channels().iter().map(|c| c.name_str()).collect();
        assert_eq!(names, row.channels, "{}", row.file);
        for c in s.channels() {
            assert_eq!(c.values.len(), row.points, "{} {}", row.file, c.name_str());
            assert_eq!(
                f64::from(c.start_angle) * 1e-4,
                row.start_deg,
                "{}",
                row.file
            );
            assert_eq!(f64::from(c.step) * 1e-4, row.step_deg, "{}", row.file);
            assert_eq!((c.scale, c.offset), (1.0, 0.0), "{}", row.file);
        }
        // the decoded last value lies at start + (count − 1) · step: 225° for both scanners
        let d = s.channel(b"DIST1").expect("DIST1");
        let last = i64::from(d.start_angle) + (d.values.len() as i64 - 1) * i64::from(d.step);
        assert_eq!(last, 2_250_000, "{}", row.file);
    }
}

#[test]
fn the_hand_checked_values() {
    let Some(dir) = data_dir() else { return };
    let tim = parse(&payload(&dir, "tim5xx_single_scan.cola"));
    let d = tim.channel(b"DIST1").expect("DIST1");
    // 0x116 and 0x458 mm
    assert_eq!((d.values[0], d.values[270]), (278, 1112));
    let r = tim.channel(b"RSSI1").expect("RSSI1");
    assert_eq!((r.bits, r.values[0]), (8, 154));
    // 15 Hz (1/100 Hz units), the counters as sent
    assert_eq!(tim.scan_frequency, 1500);
    assert_eq!((tim.telegram_counter, tim.scan_counter), (0x2AD8, 0x2ADD));
    let lms = parse(&payload(&dir, "lms1xx_scan.cola"));
    let d = lms.channel(b"DIST1").expect("DIST1");
    assert_eq!(d.values[0], 659);
    assert_eq!(lms.scan_frequency, 5000, "50 Hz at 0.5°");
    // values 0–3 mark no echo or an error on this class: they are no return
    assert!(d.values.iter().any(|&v| (1..=3).contains(&v)));
}

#[test]
fn conversion_to_rep103_puts_the_first_value_behind_right() {
    let Some(dir) = data_dir() else { return };
    let tim = parse(&payload(&dir, "tim5xx_single_scan.cola"));
    let conv = Converter {
        mount: SickMount::default(),
        echo: Echo::Last,
        min_range_m: 0.05,
        max_range_m: 10.0,
    };
    let mut out = Vec::new();
    let c = conv.convert(&tim, &mut out).expect("converts");
    assert_eq!(c.count, 271);
    // −45° device = −135° REP-103; 225° device = 135°
    assert!((out[0].angle_rad.to_degrees() + 135.0).abs() < 1e-3);
    assert!((out[270].angle_rad.to_degrees() - 135.0).abs() < 1e-3);
    assert_eq!((out[0].range_m, out[0].intensity), (0.278, 154));
    assert_eq!(out[270].range_m, 1.112);
    let lms = parse(&payload(&dir, "lms1xx_scan.cola"));
    let lms_conv = Converter {
        max_range_m: 20.0,
        ..conv
    };
    let c = lms_conv.convert(&lms, &mut out).expect("converts");
    let raw = lms.channel(b"DIST1").expect("DIST1");
    let no_echo = raw
        .values
        .iter()
        .filter(|&&v| !(50..=20_000).contains(&v))
        .count();
    assert!(raw.values.iter().filter(|&&v| v <= 3).count() > 0);
    assert_eq!(
        c.count - c.valid,
        no_echo,
        "0–3 mm and beyond the range are no return"
    );
}

#[test]
fn streamed_as_tcp_bytes_through_the_session_and_round_tripped_through_cola_b() {
    let Some(dir) = data_dir() else { return };
    for file in [
        "tim5xx_single_scan.cola",
        "tim5xx_continuous_scan.cola",
        "lms1xx_scan.cola",
    ] {
        let bytes = std::fs::read(dir.join(file)).expect("telegram");
        let mut s = Session::new(SessionConfig {
            dialect: Dialect::ColaA,
            requests: vec![],
            answer_timeout_ns: 1_000_000_000,
            silence_ns: 1_000_000_000,
            max_telegram: 1 << 16,
        });
        // the telegram three times, in 7-byte pieces, as a socket may hand it over
        let stream: Vec<u8> = bytes.iter().chain(&bytes).chain(&bytes).copied().collect();
        let mut scans = Vec::new();
        for piece in stream.chunks(7) {
            s.receive(piece, 0, &mut Vec::new(), |e| match e {
                Event::Scan(sd) => scans.push(sd.clone()),
                other => panic!("{file}: {other:?}"),
            });
        }
        assert_eq!(scans.len(), 3, "{file}");
        let a = &scans[0];
        assert_eq!(a, &scans[2]);
        let mut b = Vec::new();
        a.encode(Dialect::ColaB, b"sSN", &mut b);
        let mut back = ScanData::default();
        back.parse_b(&b).expect("CoLa-B parses");
        assert_eq!(&back, a, "{file}: CoLa-B keeps every field");
        // and the CoLa-A writer gives what the scanner sent, up to the trailing blocks
        let mut text = Vec::new();
        a.encode(Dialect::ColaA, b"sSN", &mut text);
        let mut again = ScanData::default();
        again.parse_a(&text).expect("CoLa-A parses");
        assert_eq!(&again, a, "{file}");
    }
}
