//! The bodies of the `cargo fuzz` targets in `fuzz/fuzz_targets/`, as plain functions, so that
//! the same code runs under libFuzzer (nightly, `cargo fuzz run TARGET`) and in the workspace's
//! ordinary test run (`tests/smoke.rs`: every target over its seed corpus and a few thousand
//! mutations of it from a fixed seed, on stable).
//!
//! Each body must return on any input without panicking, without unbounded allocation and
//! without hanging; a panic is a crash the fuzzer reports. Each also asserts what must hold of
//! what the library returned.
//!
//! [`seeds`] builds the seed corpora at run time from the real captures in
//! `../shared/data/velodyne` (never copied into the repository) and the repository's `config/`.
#![deny(missing_docs)]

use std::cell::RefCell;
use std::collections::HashMap;
use std::io::Cursor;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use mimnav_config::Config;
use mimnav_shared::faults::Faults;
use mimnav_sim::world::WorldFile;
use mimnav_sim::{Sim, SimSettings};
use mimnav_velodyne::capture::CaptureReader;
use mimnav_velodyne::config::{ScanReturnSelect, VelodyneConfig};
use mimnav_velodyne::driver::Driver;
use mimnav_velodyne::revolution::{AssemblerConfig, Revolution};

/// The fuzz targets, by the name of their file in `fuzz/fuzz_targets/`.
pub const TARGETS: [&str; 6] = [
    "velodyne_stream",
    "capture",
    "config",
    "world",
    "kobuki_frames",
    "sick_cola",
];

/// Runs the body of target `name` on `data`.
pub fn run(name: &str, data: &[u8]) {
    match name {
        "velodyne_stream" => velodyne_stream(data),
        "capture" => capture(data),
        "config" => config(data),
        "world" => world(data),
        "kobuki_frames" => kobuki_frames(data),
        "sick_cola" => sick_cola(data),
        _ => panic!("no fuzz target {name}"),
    }
}

/// Bytes of a datagram record's header in a [`velodyne_stream`] input.
pub const RECORD_HEADER: usize = 7;
/// Bytes of the settings at the start of a [`velodyne_stream`] input.
pub const STREAM_HEADER: usize = 4;

/// The VLP-16 driver's step: packet validation, decoding, the revolution assembler and the
/// position-packet parser, over a sequence of datagrams with timestamps.
///
/// Input: 4 bytes of settings (`flags`, cut azimuth as u16 LE in 0.01°, rpm byte), then records
/// of `len: u16 LE`, `dt: i32 LE` (ns from the previous datagram's host time, may go back),
/// `port: u8` (0: data port, 1: position port, else that port), and `len` payload bytes (fewer
/// if the input ends). `flags`: bit 0 accept product 0x21, bit 1 cut at the azimuth, bit 2 the
/// scan takes the strongest return, bit 3 min range 0, bits 4–7 the scan laser.
pub fn velodyne_stream(data: &[u8]) {
    let Some((&[flags, az_lo, az_hi, rpm], mut rest)) = data.split_first_chunk::<STREAM_HEADER>()
    else {
        return;
    };
    let mut v = VelodyneConfig {
        accept_product_0x21: flags & 1 != 0,
        cut_azimuth_deg: (flags & 2 != 0)
            .then(|| f64::from(u16::from_le_bytes([az_lo, az_hi]) % 36000) / 100.0),
        scan_return: if flags & 4 != 0 {
            ScanReturnSelect::Strongest
        } else {
            ScanReturnSelect::Last
        },
        scan_laser: flags >> 4,
        rpm: 300.0 + 900.0 * f64::from(rpm) / 255.0,
        ..VelodyneConfig::default()
    };
    if flags & 8 != 0 {
        v.min_range_m = 0.0;
    }
    v.validate().expect("the fuzzer's settings are valid");
    let config = AssemblerConfig::from_config(&v);
    let max_points = config.max_points;
    let cut = flags & 2 != 0;
    let key = [flags, az_lo * u8::from(cut), az_hi * u8::from(cut), rpm];
    let mut driver = new_driver(&key, config, &v);
    let mut faults = Faults::new(Duration::from_secs(3600));
    let now = Instant::now();
    let (mut host_ns, mut mono_ns) = (1_700_000_000_000_000_000_u64, 0_u64);
    let source = || String::from("fuzz");
    while let Some((head, tail)) = rest.split_first_chunk::<RECORD_HEADER>() {
        let len = usize::from(u16::from_le_bytes([head[0], head[1]])).min(tail.len());
        let dt = i32::from_le_bytes([head[2], head[3], head[4], head[5]]);
        let port = match head[6] {
            0 => v.data_port,
            1 => v.position_port,
            p => u16::from(p),
        };
        let (payload, after) = tail.split_at(len);
        rest = after;
        host_ns = host_ns.saturating_add_signed(i64::from(dt));
        mono_ns = mono_ns.saturating_add(u64::from(dt.unsigned_abs()));
        let kind = driver.kind(payload.len(), port);
        if let Some(rev) =
            driver.on_datagram(payload, kind, (host_ns, mono_ns), now, &mut faults, &source)
        {
            check_revolution(rev, max_points);
        }
    }
    if let Some(rev) = driver.finish() {
        check_revolution(rev, max_points);
    }
}

/// A new driver of `config`: a clone of one made before for the same settings `key` (the
/// clone starts as `Driver::new` would, its buffers not reserved). Building
/// the decoder's tables costs about 1 ms, fifty times the rest of a typical input.
fn new_driver(key: &[u8], config: AssemblerConfig, v: &VelodyneConfig) -> Driver {
    thread_local! {
        static MADE: RefCell<HashMap<Vec<u8>, Driver>> = RefCell::new(HashMap::new());
    }
    MADE.with_borrow_mut(|made| {
        if let Some(d) = made.get(key) {
            return d.clone();
        }
        let d = Driver::new(config, v.data_port, v.position_port);
        // at most 64 kept (18 MiB of tables)
        if made.len() >= 64 {
            made.clear();
        }
        made.insert(key.to_vec(), d.clone());
        d
    })
}

fn check_revolution(rev: &Revolution, max_points: usize) {
    assert!(
        rev.header.packet_count > 0,
        "an empty revolution was published"
    );
    assert!(
        rev.points.len() <= max_points,
        "{} points, more than the capacity {max_points}",
        rev.points.len()
    );
    assert!(
        rev.scan.len() <= max_points,
        "{} scan returns, more than {max_points}",
        rev.scan.len()
    );
    for p in &rev.points {
        assert!(
            p.x.is_finite() && p.y.is_finite() && p.z.is_finite(),
            "{p:?}"
        );
        assert!(p.azimuth_cdeg < 36000, "{p:?}");
    }
}

/// The capture reader (pcap in either byte order, µs or ns, and pcapng; every link layer it
/// peels) over a file's bytes, read once with its length known (a regular file) and once
/// streamed (a pipe).
pub fn capture(data: &[u8]) {
    for len in [Some(data.len() as u64), None] {
        let Ok(mut reader) = CaptureReader::from_reader(
            Box::new(Cursor::new(data.to_vec())),
            Path::new("fuzz.pcap"),
            len,
        ) else {
            continue;
        };
        let mut datagrams = 0_usize;
        while let Ok(Some(d)) = reader.next() {
            datagrams += 1;
            // every record is at least 12 bytes: a datagram per record at most
            assert!(datagrams <= data.len() / 12, "more datagrams than records");
            assert!(d.payload.len() <= data.len());
            assert!(d.offset < data.len() as u64);
        }
        assert!(reader.bytes_read() <= data.len() as u64);
    }
}

/// The repository's config file: robot profiles are looked up beside it.
pub fn config_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/mimnav.toml")
}

/// Separates the config text from `--set` overrides (one a line) in a [`config`] input.
pub const OVERRIDES_MARK: &str = "\n#--set\n";

/// The config loader: `Config::from_toml` over the text (lossily UTF-8), with the `--set`
/// overrides after [`OVERRIDES_MARK`], and every value derived from a config it accepts.
pub fn config(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    let (file, sets) = text.split_once(OVERRIDES_MARK).unwrap_or((&text, ""));
    let overrides: Vec<String> = sets.lines().take(16).map(String::from).collect();
    if let Ok(c) = Config::from_toml(file, &config_path(), &overrides) {
        let _ = c.sim_settings();
        let _ = c.mapper_params();
        let _ = c.map_step();
        let _ = c.planner_params();
        let _ = c.pilot();
        let _ = c.scan_step();
        let assembler = AssemblerConfig::from_config(&c.velodyne);
        assert!(assembler.max_points > 0);
    }
}

/// The world loader: `WorldFile::parse` (the TOML and every check), `compile`, and a simulator
/// built on the scene casting a few packets and driving.
pub fn world(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    let Ok(w) = WorldFile::parse(&text, "fuzz") else {
        return;
    };
    let scene = w.compile();
    let _ = scene.hidden_in_grass();
    let mut sim = Sim::new(
        scene,
        SimSettings::default(),
        1,
        mimnav_sim::DEFAULT_EPOCH_NS,
    );
    sim.set_command(0.3, 0.5);
    for _ in 0..2 {
        let step = sim.step();
        assert_eq!(step.data.len(), mimnav_shared::topics::DATA_PACKET_LEN);
    }
    let odom = sim.odometry(0, 0);
    let _ = odom;
    let _ = sim.summary(false, 0);
}

/// A chunked-stream input (of [`kobuki_frames`] and [`sick_cola`]): `k`, the low 4 bits of
/// `head`, chunk sizes (a byte each, 0 read as 256) at the start of `rest`, then the stream;
/// the stream and its chunks, the sizes taken in turn (one chunk when `k` is 0).
fn chunked(head: u8, rest: &[u8]) -> (&[u8], Vec<&[u8]>) {
    let k = usize::from(head & 0x0F).min(rest.len());
    let (cuts, stream) = rest.split_at(k);
    let size = |i: usize| match cuts.get(i % cuts.len().max(1)) {
        None => stream.len().max(1),
        Some(0) => 256,
        Some(&c) => usize::from(c),
    };
    let (mut left, mut chunks) = (stream, Vec::new());
    while !left.is_empty() {
        let (chunk, tail) = left.split_at(size(chunks.len()).min(left.len()));
        chunks.push(chunk);
        left = tail;
    }
    (stream, chunks)
}

/// Most chunk sizes a [`kobuki_frames`] input sets.
pub const KOBUKI_MAX_CUTS: usize = 15;

/// The Kobuki frame finder over a byte stream cut into chunks, and everything downstream of
/// it: feedback and command decoding, odometry and the simulated base's command intake.
///
/// Input: `k` (low 4 bits of the first byte), then `k` chunk sizes (a byte each, 0 read as
/// 256), then the stream, fed in chunks of those sizes in turn (one chunk when `k` is 0).
/// Asserts: every frame yielded is in the stream at its offset with both header bytes, a
/// zero XOR from its length to its checksum and sub-payloads that fill its payload; the
/// result and the counts are the same as for the whole stream in one chunk; at most one
/// frame's bytes are held; every byte fed is counted once; odometry stays finite.
pub fn kobuki_frames(data: &[u8]) {
    use mimnav_kobuki::command::Command;
    use mimnav_kobuki::feedback::Feedback;
    use mimnav_kobuki::frame::{Frame, FrameParser, HEADER0, HEADER1, MAX_FRAME, xor};
    use mimnav_kobuki::odometry::Odometry;
    use mimnav_kobuki::simbase::{SimBase, SimBaseConfig};

    let Some((&head, rest)) = data.split_first() else {
        return;
    };
    let (stream, chunks) = chunked(head, rest);
    let accounted = |p: &FrameParser| {
        let s = p.stats();
        assert_eq!(
            s.bytes,
            s.garbage_bytes + s.frame_bytes + s.rejected_headers() + p.pending() as u64,
            "the counts do not add up: {s:?}, {} pending",
            p.pending()
        );
    };
    let mut parser = FrameParser::new();
    let mut out = Vec::new();
    for chunk in chunks {
        out.extend(parser.push(chunk));
        assert!(parser.pending() <= MAX_FRAME);
        accounted(&parser);
    }
    assert_eq!(parser.stats().bytes, stream.len() as u64);
    let mut whole = FrameParser::new();
    let whole_out: Vec<_> = whole.push(stream).collect();
    assert_eq!(out, whole_out, "the result depends on the chunking");
    assert_eq!(parser.stats(), whole.stats());
    let frames: Vec<&Frame> = out.iter().flatten().collect();
    assert_eq!(frames.len() as u64, parser.stats().frames);
    let mut odometry = Odometry::new();
    for f in frames {
        let at = usize::try_from(f.stream_offset()).expect("an offset inside the input");
        let wire = &stream[at..at + f.wire_len()];
        assert_eq!(&wire[..2], &[HEADER0, HEADER1]);
        assert_eq!(xor(&wire[2..]), 0, "a frame yielded with a bad checksum");
        assert_eq!(&wire[3..wire.len() - 1], f.payload());
        assert!(Frame::from_payload(f.payload()).is_ok());
        let fb = Feedback::decode(f);
        let subs = f.subpayloads().count();
        assert!(fb.skipped as usize + fb.unknown as usize + fb.errors.len() <= subs);
        if let Some(b) = &fb.basic {
            let e = odometry.update(b, fb.inertial.as_ref());
            assert!(
                [e.x, e.y, e.yaw, e.v, e.w].iter().all(|v| v.is_finite()),
                "{e:?}"
            );
        }
        assert_eq!(Command::decode_all(f).count(), subs);
    }
    let mut base = SimBase::new(SimBaseConfig::default());
    base.receive(stream);
    base.step(0.02);
    let (x, y, yaw) = base.pose();
    assert!(x.is_finite() && y.is_finite() && yaw.is_finite());
}

/// Seeds of [`kobuki_frames`]: the simulated base's feedback and a driver's commands, whole,
/// with garbage, damaged and cut.
fn kobuki_seeds() -> Vec<(String, Vec<u8>)> {
    use mimnav_kobuki::command::{BaseControl, Command, SoundSequence};
    use mimnav_kobuki::simbase::{SimBase, SimBaseConfig};

    let mut base = SimBase::new(SimBaseConfig::default());
    let mut feedback = Vec::new();
    let mut bytes = Vec::new();
    Command::encode_all(
        &[
            Command::BaseControl(BaseControl::from_twist(0.3, 0.5)),
            Command::RequestExtra(0x0B),
        ],
        &mut bytes,
    )
    .expect("two commands fit a frame");
    base.receive(&bytes);
    for _ in 0..4 {
        base.step(0.02);
        base.feedback_frame(&mut feedback);
    }
    let mut commands = Vec::new();
    for (v, w) in [(0.2, 0.0), (0.0, 1.0), (-0.1, 0.3)] {
        Command::BaseControl(BaseControl::from_twist(v, w))
            .encode(&mut commands)
            .expect("a command fits a frame");
    }
    Command::SoundSequence(SoundSequence::Error)
        .encode(&mut commands)
        .expect("a command fits a frame");
    let mut noisy = vec![0x00, 0xAA, 0xAA, 0x55, 0x02];
    noisy.extend(&feedback);
    let n = noisy.len();
    noisy[n / 2] ^= 0x40;
    let cut = feedback[..feedback.len() - 30].to_vec();
    [
        ("feedback-whole", vec![0], feedback.clone()),
        ("feedback-cut-7-1-64", vec![3, 7, 1, 64], feedback),
        ("commands-cut-5", vec![1, 5], commands),
        ("noisy-cut-13-2", vec![2, 13, 2], noisy),
        ("cut-short-cut-255", vec![1, 255], cut),
    ]
    .into_iter()
    .map(|(name, head, stream)| {
        let mut v = head;
        v.extend(stream);
        (name.to_string(), v)
    })
    .collect()
}

/// The SICK driver's session over a CoLa byte stream cut into chunks: the framer (CoLa-A or
/// CoLa-B), the answers to the start-up requests, `LMDscandata` parsing and the conversion to
/// returns.
///
/// Input: a flags byte (bit 7: CoLa-B; bit 6: the LMS5xx's start-up requests are pending, else
/// none; low 4 bits: `k`), then `k` chunk sizes (a byte each, 0 read as 256), then the stream.
/// Asserts: the events are the same whatever the chunking (but for how bytes outside any
/// telegram are reported: each piece of them as it arrives); at most one telegram's bytes are
/// held; every scan parsed has at most [`mimnav_sick::scandata::MAX_CHANNELS`] channels of at
/// most [`mimnav_sick::scandata::MAX_VALUES`] values, writes back to a telegram that parses to
/// the same scan, and converts to one return per value with a finite bearing in (−π, π] and a
/// finite range that is 0 or within the configured limits.
pub fn sick_cola(data: &[u8]) {
    use mimnav_sick::SickConfig;
    use mimnav_sick::cola::Dialect;
    use mimnav_sick::config::Model;
    use mimnav_sick::scandata::{MAX_CHANNELS, MAX_VALUES, ScanData};
    use mimnav_sick::session::{Event, Session};

    let Some((&head, rest)) = data.split_first() else {
        return;
    };
    let dialect = if head & 0x80 != 0 {
        Dialect::ColaB
    } else {
        Dialect::ColaA
    };
    let cfg = SickConfig {
        protocol: dialect,
        model: Model::Lms5xx,
        max_telegram_bytes: 64 * 1024,
        ..SickConfig::default()
    };
    let mut sc = cfg.session();
    if head & 0x40 == 0 {
        sc.requests.clear();
    }
    let (stream, chunks) = chunked(head, rest);
    let conv = cfg.converter();
    let mut returns = Vec::new();
    let mut run = |pieces: &mut dyn Iterator<Item = &[u8]>| {
        let mut s = Session::new(sc.clone());
        let mut out = Vec::new();
        s.begin(0, &mut out);
        let mut events = Vec::new();
        for p in pieces {
            s.receive(p, 1, &mut out, |e| {
                if let Event::Scan(sd) = &e {
                    let chans = sd.channels();
                    assert!(chans.len() <= MAX_CHANNELS);
                    assert!(chans.iter().all(|c| c.values.len() <= MAX_VALUES));
                    let mut wire = Vec::new();
                    sd.encode(dialect, b"sSN", &mut wire);
                    let mut back = ScanData::default();
                    back.parse(dialect, &wire)
                        .expect("a scan written back parses");
                    assert_eq!(&back, *sd, "a scan written back parses to itself");
                    if let Ok(c) = conv.convert(sd, &mut returns) {
                        assert_eq!(c.count, returns.len());
                        for r in &returns {
                            let a = r.angle_rad;
                            assert!(a.is_finite() && a > -std::f32::consts::PI - 1e-6);
                            assert!(a <= std::f32::consts::PI + 1e-6, "{a}");
                            assert!(
                                r.range_m == 0.0
                                    || (r.range_m >= conv.min_range_m - 1e-3
                                        && r.range_m.is_finite())
                            );
                        }
                    }
                }
                match &e {
                    Event::Frame(mimnav_sick::cola::FrameError::Garbage(_)) => {}
                    // a scan by its counter and a digest of its channels (its Debug is long)
                    Event::Scan(sd) => events.push(format!(
                        "scan {} {:?}",
                        sd.scan_counter,
                        sd.channels()
                            .iter()
                            .map(|c| (
                                c.name,
                                c.values.len(),
                                c.values.iter().fold(0u64, |a, &v| {
                                    a.wrapping_mul(31).wrapping_add(u64::from(v))
                                })
                            ))
                            .collect::<Vec<_>>()
                    )),
                    _ => events.push(format!("{e:?}")),
                }
            });
            assert!(s.frame_stats().telegrams <= stream.len() as u64);
            assert!(
                s.pending() <= cfg.max_telegram_bytes,
                "{} bytes held",
                s.pending()
            );
        }
        (events, s.stats().scans, out)
    };
    let (a, sa, oa) = run(&mut chunks.iter().copied());
    let (b, sb, ob) = run(&mut std::iter::once(stream));
    assert_eq!(a, b, "the events depend on the chunking");
    assert_eq!((sa, oa), (sb, ob));
}

/// Seeds of [`sick_cola`]: the real telegrams of `../shared/data/sick` (when there), an
/// emulated LMS5xx's answers and multi-echo scans in both dialects, damaged and cut.
fn sick_seeds() -> Vec<(String, Vec<u8>)> {
    use mimnav_sick::cola::Dialect;
    use mimnav_sick::config::Model;
    use mimnav_sick::device::Device;
    use mimnav_sick::session::Session;

    let mut v = Vec::new();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/sick");
    for f in [
        "tim5xx_single_scan.cola",
        "tim5xx_continuous_scan.cola",
        "lms1xx_scan.cola",
    ] {
        if let Ok(b) = std::fs::read(dir.join(f)) {
            let mut s = vec![0x02, 7, 200];
            s.extend(&b);
            v.push((format!("real-{f}"), s));
        }
    }
    for (bit, d) in [(0u8, Dialect::ColaA), (0x80, Dialect::ColaB)] {
        let cfg = mimnav_sick::SickConfig {
            protocol: d,
            model: Model::Lms5xx,
            ..mimnav_sick::SickConfig::default()
        };
        let mut dev = Device::new(Model::Lms5xx, d, 7);
        let mut s = Session::new(cfg.session());
        let (mut to_dev, mut answers) = (Vec::new(), Vec::new());
        s.begin(0, &mut to_dev);
        for _ in 0..8 {
            let mut a = Vec::new();
            dev.receive(&std::mem::take(&mut to_dev), &mut a);
            s.receive(&a, 0, &mut to_dev, |_| {});
            answers.extend(a);
        }
        // a short scan keeps the seeds small: 60 values an echo
        let g = dev.geometry();
        let echoes: Vec<Vec<u16>> = (0..3)
            .map(|e| {
                (0..g.count)
                    .map(|i| (1000 + 300 * e + i % 97) as u16)
                    .collect()
            })
            .collect();
        let mut scan = Vec::new();
        dev.scan_telegram(1234, &echoes, &echoes, &mut scan);
        let name = d.name();
        let mut whole = vec![bit | 0x40 | 2, 13, 1];
        whole.extend(&answers);
        whole.extend(&scan[..scan.len().min(4000)]);
        v.push((format!("{name}-answers-and-scan"), whole));
        let mut damaged = vec![bit, 0];
        damaged.extend(b"xx");
        damaged.extend(&scan);
        let n = damaged.len();
        damaged[n / 3] ^= 0x11;
        v.push((format!("{name}-damaged"), damaged));
    }
    v
}

/// `../shared/data/velodyne` beside the repository, where the real captures are.
pub fn captures_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/velodyne")
}

/// The repository's `config/` folder.
pub fn config_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config")
}

/// The real captures (`*.pcap` in [`captures_dir`]), sorted; empty when the folder is missing.
pub fn real_captures() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(captures_dir())
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "pcap"))
        .collect();
    v.sort();
    v
}

/// Packets of a real capture in a [`velodyne_stream`] window.
const WINDOW: usize = 12;
/// Bytes of a real capture kept as a [`capture`] seed.
const CAPTURE_SEED_BYTES: usize = 24 * 1024;

/// The seed corpus of target `name`, as (file name, bytes). Made at run time from the real
/// captures (none when [`captures_dir`] is missing) and the repository's config files.
pub fn seeds(name: &str) -> Vec<(String, Vec<u8>)> {
    match name {
        "velodyne_stream" => velodyne_seeds(),
        "capture" => capture_seeds(),
        "config" => config_seeds(),
        "world" => world_seeds(),
        "kobuki_frames" => kobuki_seeds(),
        "sick_cola" => sick_seeds(),
        _ => panic!("no fuzz target {name}"),
    }
}

/// The datagrams of a capture: (host ns, destination port, payload).
fn datagrams(path: &Path) -> Vec<(u64, u16, Vec<u8>)> {
    let mut out = Vec::new();
    let Ok(mut r) = CaptureReader::open(path) else {
        return out;
    };
    while let Ok(Some(d)) = r.next() {
        out.push((d.ts_ns, d.dst_port, d.payload.to_vec()));
    }
    out
}

fn stem(p: &Path) -> String {
    p.file_stem()
        .unwrap_or_default()
        .to_string_lossy()
        .into_owned()
}

/// Encodes datagrams as a [`velodyne_stream`] input.
pub fn encode_stream(flags: u8, cut_cdeg: u16, rpm: u8, dgrams: &[(u64, u16, Vec<u8>)]) -> Vec<u8> {
    let mut out = vec![flags];
    out.extend_from_slice(&cut_cdeg.to_le_bytes());
    out.push(rpm);
    let mut prev = dgrams.first().map_or(0, |d| d.0);
    for (ts, port, payload) in dgrams {
        let dt = ts.wrapping_sub(prev) as i64;
        prev = *ts;
        out.extend_from_slice(&(payload.len() as u16).to_le_bytes());
        out.extend_from_slice(
            &(dt.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32).to_le_bytes(),
        );
        out.push(match port {
            2368 => 0,
            8308 => 1,
            p => *p as u8,
        });
        out.extend_from_slice(payload);
    }
    out
}

fn velodyne_seeds() -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    for path in real_captures() {
        let d = datagrams(&path);
        // a few windows per capture, spread over it; the cut azimuth is the middle packet's so
        // that a revolution is completed inside the window
        let windows = d.len().div_ceil(WINDOW).min(6);
        for w in 0..windows {
            let start = (w * d.len() / windows.max(1)).min(d.len().saturating_sub(WINDOW));
            let win = &d[start..(start + WINDOW).min(d.len())];
            let mid = &win[win.len() / 2].2;
            let cut = if mid.len() == 1206 {
                u16::from_le_bytes([mid[2], mid[3]])
            } else {
                0
            };
            let flags = [0x02 | 0xE0, 0x01 | 0x04 | 0x90, 0x08 | 0x02][w % 3];
            out.push((
                format!("{}-{w}", stem(&path)),
                encode_stream(flags, cut, 77, win),
            ));
        }
    }
    out
}

fn capture_seeds() -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    for path in real_captures() {
        let Ok(bytes) = std::fs::read(&path) else {
            continue;
        };
        // the head of the file: the header and the first records, the last one cut short
        out.push((
            format!("{}.pcap", stem(&path)),
            bytes[..bytes.len().min(CAPTURE_SEED_BYTES)].to_vec(),
        ));
        // the same first records as pcapng, and as a whole pcap file of them
        if let Some((ng, pcap)) = rewrite(&bytes, 6) {
            out.push((format!("{}.pcapng", stem(&path)), ng));
            out.push((format!("{}-6.pcap", stem(&path)), pcap));
        }
    }
    out
}

/// The first `n` packets of pcap `bytes` as a pcapng file (a section, an interface of the same
/// link type, enhanced packet blocks) and as a whole pcap file.
fn rewrite(bytes: &[u8], n: usize) -> Option<(Vec<u8>, Vec<u8>)> {
    use pcap_file::pcap::{PcapReader, PcapWriter};
    use pcap_file::pcapng::PcapNgWriter;
    use pcap_file::pcapng::blocks::enhanced_packet::EnhancedPacketBlock;
    use pcap_file::pcapng::blocks::interface_description::InterfaceDescriptionBlock;
    let mut reader = PcapReader::new(Cursor::new(bytes)).ok()?;
    let header = reader.header();
    let mut ng = PcapNgWriter::new(Vec::new()).ok()?;
    ng.write_pcapng_block(InterfaceDescriptionBlock {
        linktype: header.datalink,
        snaplen: header.snaplen,
        options: vec![],
    })
    .ok()?;
    let mut pcap = PcapWriter::with_header(Vec::new(), header).ok()?;
    for _ in 0..n {
        let Some(Ok(pkt)) = reader.next_packet() else {
            break;
        };
        pcap.write_packet(&pkt).ok()?;
        ng.write_pcapng_block(EnhancedPacketBlock {
            interface_id: 0,
            timestamp: pkt.timestamp,
            original_len: pkt.orig_len,
            data: pkt.data.clone(),
            options: vec![],
        })
        .ok()?;
    }
    Some((ng.into_inner(), pcap.into_writer()))
}

fn toml_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    for e in rd.flatten() {
        let p = e.path();
        if p.is_dir() {
            toml_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "toml") {
            out.push(p);
        }
    }
}

fn named_tomls(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files = Vec::new();
    toml_files(dir, &mut files);
    files.sort();
    files
        .into_iter()
        .filter_map(|p| {
            let name = p
                .strip_prefix(config_dir())
                .ok()?
                .to_string_lossy()
                .replace('/', "_");
            Some((name, std::fs::read(&p).ok()?))
        })
        .collect()
}

fn config_seeds() -> Vec<(String, Vec<u8>)> {
    let mut out: Vec<(String, Vec<u8>)> = named_tomls(&config_dir())
        .into_iter()
        .filter(|(n, _)| !n.starts_with("worlds"))
        .collect();
    if let Some((_, main)) = out.iter().find(|(n, _)| n == "mimnav.toml").cloned() {
        let mut with_sets = main;
        with_sets.extend_from_slice(OVERRIDES_MARK.as_bytes());
        with_sets.extend_from_slice(
            b"velodyne.rpm=1200\nsim.grass_blades=true\nrobot.profile=\"spot\"\n",
        );
        out.push(("mimnav-with-set.toml".into(), with_sets));
    }
    out.push(("empty.toml".into(), Vec::new()));
    out
}

fn world_seeds() -> Vec<(String, Vec<u8>)> {
    named_tomls(&config_dir().join("worlds"))
}

/// A small deterministic generator (xorshift64*) for the smoke test's mutations.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    /// A generator from `seed` (0 is replaced).
    pub fn new(seed: u64) -> Self {
        Rng(seed.max(1))
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in `0..n` (`n` > 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

/// Mutates `data` as libFuzzer's simplest mutators do: 1 to 4 of flipping a bit, writing an
/// interesting value (0, 0xFF, 0x7F, 0x80, a little-endian 0xFFFFFFFF), erasing, duplicating or
/// inserting a range of bytes, and cutting the tail.
pub fn mutate(data: &mut Vec<u8>, rng: &mut Rng) {
    for _ in 0..1 + rng.below(4) {
        let len = data.len();
        match rng.below(7) {
            0 if len > 0 => {
                let i = rng.below(len);
                data[i] ^= 1 << rng.below(8);
            }
            1 if len > 0 => {
                let i = rng.below(len);
                data[i] = [0, 0xFF, 0x7F, 0x80, b'=', b'[', b'"', b'\n'][rng.below(8)];
            }
            2 if len >= 4 => {
                let i = rng.below(len - 3);
                data[i..i + 4].copy_from_slice(&[0xFF, 0xFF, 0xFF, [0xFF, 0x7F][rng.below(2)]]);
            }
            3 if len > 0 => {
                let i = rng.below(len);
                let n = rng.below((len - i).min(64)) + 1;
                data.drain(i..i + n);
            }
            4 if len > 0 => {
                let i = rng.below(len);
                let n = rng.below((len - i).min(64)) + 1;
                let chunk = data[i..i + n].to_vec();
                let at = rng.below(len + 1);
                data.splice(at..at, chunk);
            }
            5 => {
                let at = rng.below(len + 1);
                let n = rng.below(16) + 1;
                let bytes: Vec<u8> = (0..n).map(|_| rng.next_u64() as u8).collect();
                data.splice(at..at, bytes);
            }
            _ if len > 0 => data.truncate(rng.below(len)),
            _ => data.push(rng.next_u64() as u8),
        }
    }
}
