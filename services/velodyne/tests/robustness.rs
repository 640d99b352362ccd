//! Nothing panics on any input, and bad input is reported precisely.
//!
//! Property tests feed arbitrary bytes to the packet parser, the assembler and the capture
//! reader, and damage well-formed captures (truncation, flipped bytes) to check that the reader
//! reports the file and byte offset instead of failing somewhere else.

use std::io::Write;
use std::net::Ipv4Addr;

use mimnav_shared::topics::{return_mode, return_type};
use mimnav_velodyne::capture::{CaptureError, CaptureReader, PcapDatagramWriter};
use mimnav_velodyne::config::ScanReturnSelect;
use mimnav_velodyne::packet::{
    BLOCKS, CHANNELS, DataPacket, PositionPacket, encode_data_packet, encode_position_packet,
};
use mimnav_velodyne::revolution::{Assembler, AssemblerConfig};
use proptest::prelude::*;

type Blocks = [(u16, [(u16, u8); CHANNELS]); BLOCKS];

fn blocks_strategy() -> impl Strategy<Value = Blocks> {
    let block = (
        0u16..36000,
        prop::array::uniform32((0u16..=u16::MAX, any::<u8>())),
    );
    prop::array::uniform12(block)
}

fn temp_path(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("mimnav-robustness-{}-{name}", std::process::id()))
}

/// Removes a test's file even when an assertion fails first.
struct Cleanup(std::path::PathBuf);

impl Drop for Cleanup {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

fn write_capture(path: &std::path::Path, payloads: &[Vec<u8>]) {
    let file = std::fs::File::create(path).expect("create");
    let mut w = PcapDatagramWriter::new(std::io::BufWriter::new(file)).expect("header");
    let src = (Ipv4Addr::new(192, 168, 1, 201), 2368);
    let dst = (Ipv4Addr::new(255, 255, 255, 255), 2368);
    for (i, p) in payloads.iter().enumerate() {
        w.write(
            1_700_000_000_000_000_000 + i as u64 * 1_327_000,
            src,
            dst,
            p,
        )
        .expect("write");
    }
    w.into_inner().flush().expect("flush");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, .. ProptestConfig::default() })]

    #[test]
    fn arbitrary_datagrams_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..1400)) {
        let _ = DataPacket::parse(&bytes, true);
        let _ = PositionPacket::parse(&bytes);
        let mut asm = Assembler::new(AssemblerConfig::default());
        let _ = asm.push(&bytes, 0, 0);
        let _ = asm.finish();
    }

    #[test]
    fn arbitrary_packets_decode_within_bounds(
        blocks in blocks_strategy(),
        mode in prop::sample::select(vec![return_mode::STRONGEST, return_mode::LAST, return_mode::DUAL]),
        ts in any::<u32>(),
    ) {
        let bytes = encode_data_packet(ts, mode, 0x22, &blocks);
        let mut asm = Assembler::new(AssemblerConfig::default());
        prop_assert!(asm.push(&bytes, 1_700_000_000_000_000_000, 0).is_ok());
        let rev = asm.finish().expect("one packet");
        prop_assert!(rev.points.len() <= BLOCKS * CHANNELS);
        prop_assert_eq!(rev.header.point_count as usize, rev.points.len());
        prop_assert_eq!(
            rev.header.strongest_count + rev.header.last_count + rev.header.both_count,
            rev.header.point_count
        );
        for p in &rev.points {
            prop_assert!(p.distance_raw != 0);
            prop_assert!(p.azimuth_cdeg < 36000);
            prop_assert!(p.laser_id < 16 && p.ring < 16);
            prop_assert!(p.return_type >= 1 && p.return_type <= 3);
            let d = p.distance_m();
            prop_assert!(((p.x * p.x + p.y * p.y + p.z * p.z).sqrt() - d).abs() < 1e-3 * d.max(1.0));
        }
        // one scan return per firing of the scan laser: 24 per packet single, 12 dual
        let firings = if mode == return_mode::DUAL { 12 } else { 24 };
        prop_assert_eq!(rev.scan.len(), firings);
    }

    #[test]
    fn arbitrary_files_never_panic_the_reader(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        let path = temp_path("arbitrary.pcap");
        let _cleanup = Cleanup(path.clone());
        std::fs::write(&path, &bytes).expect("write");
        if let Ok(mut r) = CaptureReader::open(&path) {
            for _ in 0..1000 {
                match r.next() {
                    Ok(Some(_)) => {}
                    Ok(None) | Err(_) => break,
                }
            }
        }
    }

    #[test]
    fn damaged_captures_report_file_and_offset(
        cut in 24usize..3000,
        flip in prop::option::of((24usize..3000, any::<u8>())),
    ) {
        let payloads: Vec<Vec<u8>> = (0..3u8).map(|i| vec![i; 1206]).collect();
        let path = temp_path(&format!("damaged-{cut}.pcap"));
        let _cleanup = Cleanup(path.clone());
        write_capture(&path, &payloads);
        let mut bytes = std::fs::read(&path).expect("read");
        let full_len = bytes.len();
        if let Some((at, v)) = flip
            && at < bytes.len() { bytes[at] ^= v | 1; }
        bytes.truncate(cut.min(full_len));
        std::fs::write(&path, &bytes).expect("write");
        let mut r = CaptureReader::open(&path).expect("header intact");
        let mut n = 0;
        loop {
            match r.next() {
                Ok(Some(d)) => { n += 1; prop_assert!(d.offset < bytes.len() as u64); }
                Ok(None) => break,
                Err(CaptureError::Truncated { offset, missing, path: p }) => {
                    prop_assert_eq!(&p, &path);
                    prop_assert_eq!(offset as usize + missing, bytes.len());
                    break;
                }
                Err(CaptureError::Corrupt { offset, .. })
                | Err(CaptureError::ImpossibleLength { offset, .. }) => {
                    prop_assert!(offset < bytes.len() as u64);
                    break;
                }
                Err(e) => prop_assert!(false, "unexpected {e}"),
            }
        }
        prop_assert!(n <= payloads.len() + 1);
    }
}

#[test]
fn truncated_capture_names_the_record() {
    let payloads: Vec<Vec<u8>> = (0..3u8).map(|i| vec![i; 1206]).collect();
    let path = temp_path("truncated.pcap");
    let _cleanup = Cleanup(path.clone());
    write_capture(&path, &payloads);
    let bytes = std::fs::read(&path).expect("read");
    // cut the third record in half: 24-byte header + 2 × (16 + 1248) = 2552
    std::fs::write(&path, &bytes[..2552 + 700]).expect("write");
    let mut r = CaptureReader::open(&path).expect("open");
    assert!(r.next().expect("first").is_some());
    assert!(r.next().expect("second").is_some());
    let e = r.next().expect_err("third is cut");
    let msg = e.to_string();
    assert!(msg.contains("byte offset 2552"), "{msg}");
    assert!(msg.contains(&path.display().to_string()), "{msg}");
}

#[test]
fn missing_and_foreign_files_are_named() {
    let e = CaptureReader::open(std::path::Path::new("/nonexistent/x.pcap"))
        .err()
        .expect("missing");
    assert!(e.to_string().contains("/nonexistent/x.pcap"), "{e}");
    let path = temp_path("text.pcap");
    let _cleanup = Cleanup(path.clone());
    std::fs::write(&path, "this is not a capture at all, just text\n").expect("write");
    let e = CaptureReader::open(&path).err().expect("not a capture");
    assert!(
        e.to_string().contains("not a pcap or pcapng capture"),
        "{e}"
    );
}

fn channels(d: u16, r: u8) -> [(u16, u8); CHANNELS] {
    [(d, r); CHANNELS]
}

#[test]
fn dual_pairs_follow_the_sensor_rules() {
    let mut blocks: Blocks = [(0, channels(0, 0)); BLOCKS];
    for (b, blk) in blocks.iter_mut().enumerate() {
        blk.0 = ((b / 2) * 20) as u16;
    }
    // pair 0: identical → one "both" return per channel
    blocks[0].1 = channels(1000, 10);
    blocks[1].1 = channels(1000, 10);
    // pair 1: last behind strongest → two returns, last first
    blocks[2].1 = channels(2000, 5);
    blocks[3].1 = channels(1500, 40);
    // pair 2: strongest block empty, last has a return
    blocks[4].1 = channels(800, 7);
    let bytes = encode_data_packet(0, return_mode::DUAL, 0x22, &blocks);
    let mut asm = Assembler::new(AssemblerConfig::default());
    asm.push(&bytes, 0, 0).expect("valid");
    let rev = asm.finish().expect("partial revolution");
    let h = rev.header;
    assert_eq!(
        (h.both_count, h.last_count, h.strongest_count),
        (32, 64, 32)
    );
    let p = &rev.points;
    assert_eq!(p[0].return_type, return_type::BOTH);
    assert_eq!(
        (p[32].return_type, p[32].distance_raw),
        (return_type::LAST, 2000)
    );
    assert_eq!(
        (p[33].return_type, p[33].distance_raw),
        (return_type::STRONGEST, 1500)
    );
    assert_eq!(
        (p[96].return_type, p[96].distance_raw),
        (return_type::LAST, 800)
    );
    // the scan takes the last return by default (velodyne.scan_return = "last")
    let cos = (1.0f32).to_radians().cos();
    let scan = &rev.scan;
    assert_eq!(scan.len(), 12);
    assert!((scan[0].range_m - 2.0 * cos).abs() < 1e-3);
    assert_eq!(scan[2].return_type, return_type::LAST);
    assert!((scan[2].range_m - 4.0 * cos).abs() < 1e-3);
    assert_eq!(scan[4].return_type, return_type::LAST);
    assert!((scan[4].range_m - 1.6 * cos).abs() < 1e-3);
    // and the strongest when asked: pair 2 has none
    let mut strongest = AssemblerConfig::default();
    strongest.velodyne.scan_return = ScanReturnSelect::Strongest;
    let mut asm = Assembler::new(strongest);
    asm.push(&bytes, 0, 0).expect("valid");
    let scan = &asm.finish().expect("partial revolution").scan;
    assert!((scan[0].range_m - 2.0 * cos).abs() < 1e-3);
    assert_eq!(scan[2].return_type, return_type::STRONGEST);
    assert!((scan[2].range_m - 3.0 * cos).abs() < 1e-3);
    assert_eq!((scan[4].range_m, scan[4].return_type), (0.0, 0));
}

#[test]
fn revolutions_are_cut_at_the_configured_azimuth() {
    // single-return stream at 600 rpm: 0.2° per block, 2.4° per packet
    let mut cfg = AssemblerConfig::default();
    cfg.velodyne.cut_azimuth_deg = Some(90.0);
    cfg.max_duration_ns = 1_000_000_000;
    let mut asm = Assembler::new(cfg);
    let mut cuts = Vec::new();
    for k in 0..400u32 {
        let mut blocks: Blocks = [(0, channels(500, 9)); BLOCKS];
        for (b, blk) in blocks.iter_mut().enumerate() {
            blk.0 = ((k * 240 + b as u32 * 20) % 36000) as u16;
        }
        let bytes = encode_data_packet(k * 1327, return_mode::STRONGEST, 0x22, &blocks);
        let host = 1_700_000_000_000_000_000 + u64::from(k) * 1_327_000;
        if let Some(rev) = asm.push(&bytes, host, 0).expect("valid") {
            cuts.push((
                k,
                rev.header.packet_count,
                rev.points.last().map(|p| p.azimuth_cdeg),
            ));
        }
    }
    // the stream starts at 0°: the first revolution is the partial one up to 90°, then every
    // revolution is a full turn of 150 packets (2.4° each) ending just past 90°
    assert_eq!(cuts.len(), 3, "{cuts:?}");
    assert_eq!(cuts[0].1, 38, "{cuts:?}");
    assert_eq!((cuts[1].1, cuts[2].1), (150, 150), "{cuts:?}");
    for (_, _, last_az) in &cuts {
        let az = last_az.expect("points");
        assert!((9000..9000 + 240).contains(&az), "cut near 90°: {az}");
    }
}

#[test]
fn gaps_and_mode_changes_cut_early() {
    use mimnav_shared::topics::cut_reason;
    let mut asm = Assembler::new(AssemblerConfig::default());
    let blocks: Blocks = [(100, channels(500, 9)); BLOCKS];
    let a = encode_data_packet(0, return_mode::STRONGEST, 0x22, &blocks);
    let b = encode_data_packet(1327, return_mode::DUAL, 0x22, &blocks);
    let c = encode_data_packet(2_000_000, return_mode::DUAL, 0x22, &blocks);
    assert!(asm.push(&a, 0, 0).expect("a").is_none());
    let r = asm
        .push(&b, 1_327_000, 0)
        .expect("b")
        .expect("mode change cuts");
    assert_eq!(
        (r.header.cut_reason, r.header.packet_count),
        (cut_reason::MODE_CHANGE, 1)
    );
    let r = asm
        .push(&c, 2_000_000_000, 0)
        .expect("c")
        .expect("a 2 s gap cuts");
    assert_eq!(r.header.cut_reason, cut_reason::DURATION);
    let r = asm.finish().expect("the last packet");
    assert_eq!(
        (r.header.cut_reason, r.header.seq),
        (cut_reason::END_OF_STREAM, 2)
    );
}

#[test]
fn position_packets_round_trip() {
    // the checksum is the XOR of the bytes between `$` and `*`
    let s = "$GPRMC,214107,A,3707.8060,N,12139.2696,W,000.0,000.0,230715,013.9,E,D*0A";
    let bytes = encode_position_packet(3_667_108_343 % 3_600_000_000, 2, s);
    let p = PositionPacket::parse(&bytes).expect("position");
    assert_eq!(p.nmea, s);
    assert_eq!(p.pps, mimnav_velodyne::packet::PpsStatus::Locked);
    assert_eq!(p.gprmc_unix_s(), Some(1_437_687_667.0));
}

/// Issue 23 item 7: a pcap record whose length field says 0xFFFFFFFF or 0x7FFFFFF0 was reported
/// as "truncated" only after the rest of the file had been read into memory (834 MB of RSS for
/// a 305 MB capture). It is refused from its header, naming the offset and the length, with no
/// more of the file read than the chunk the header came in.
#[test]
fn issue23_7_impossible_record_lengths_are_refused_before_reading() {
    // 16 000 records of 1 264 bytes: a 20 MB capture
    let payloads: Vec<Vec<u8>> = (0..16_000u32).map(|i| vec![i as u8; 1206]).collect();
    let path = temp_path("impossible.pcap");
    let _cleanup = Cleanup(path.clone());
    write_capture(&path, &payloads);
    let good = std::fs::read(&path).expect("read");
    assert!(good.len() > 20_000_000);
    for length in [0xFFFF_FFFFu32, 0x7FFF_FFF0, 256 * 1024 + 1] {
        let mut bytes = good.clone();
        // the second record: 24-byte file header + 16 + 1248; its incl_len at +8
        let at = 24 + 16 + 1248;
        bytes[at + 8..at + 12].copy_from_slice(&length.to_le_bytes());
        std::fs::write(&path, &bytes).expect("write");
        let mut r = CaptureReader::open(&path).expect("open");
        assert!(r.next().expect("the first record is intact").is_some());
        let e = r.next().expect_err("impossible length");
        match &e {
            CaptureError::ImpossibleLength {
                offset,
                length: l,
                what,
                ..
            } => {
                assert_eq!(
                    (*offset, *l, *what),
                    (at as u64, u64::from(length), "pcap record")
                );
            }
            other => panic!("{length:#x}: {other}"),
        }
        let shown = e.to_string();
        assert!(shown.contains(&format!("byte offset {at}")), "{shown}");
        assert!(shown.contains("262144"), "{shown}");
        // one chunk (1 MiB) and the header, not the 20 MB file
        assert!(
            r.bytes_read() <= 2 << 20,
            "{length:#x}: {} bytes read of {}",
            r.bytes_read(),
            bytes.len()
        );
    }
    // a possible length that runs past the end of the file: truncated, said at once
    let mut bytes = good[..24 + 3 * 1264].to_vec();
    let at = 24 + 2 * 1264;
    bytes[at + 8..at + 12].copy_from_slice(&200_000u32.to_le_bytes());
    std::fs::write(&path, &bytes).expect("write");
    let mut r = CaptureReader::open(&path).expect("open");
    assert!(r.next().expect("first").is_some() && r.next().expect("second").is_some());
    match r.next() {
        Err(CaptureError::Truncated {
            offset, missing, ..
        }) => {
            assert_eq!(
                (offset as usize, offset as usize + missing),
                (at, bytes.len())
            );
        }
        other => panic!("{:?}", other.map(|d| d.map(|d| d.offset))),
    }
}

/// A pcapng capture of `n` VLP-16-sized datagrams on one Ethernet interface.
fn pcapng_capture(n: usize) -> Vec<u8> {
    use pcap_file::pcapng::PcapNgWriter;
    use pcap_file::pcapng::blocks::enhanced_packet::EnhancedPacketBlock;
    use pcap_file::pcapng::blocks::interface_description::InterfaceDescriptionBlock;
    let mut w = PcapNgWriter::new(Vec::new()).expect("section");
    w.write_pcapng_block(InterfaceDescriptionBlock::new(
        pcap_file::DataLink::ETHERNET,
        0xFFFF,
    ))
    .expect("interface");
    let mut frame = vec![0xFF; 6];
    frame.extend_from_slice(&[0x60, 0x76, 0x88, 0, 0, 1, 0x08, 0x00]);
    frame.extend_from_slice(&[
        0x45, 0, 0x04, 0xD2, 0, 0, 0x40, 0, 64, 17, 0, 0, 192, 168, 1, 201, 255, 255, 255, 255,
    ]);
    frame.extend_from_slice(&[0x09, 0x40, 0x09, 0x40, 0x04, 0xBE, 0, 0]);
    frame.extend_from_slice(&[7u8; 1206]);
    for i in 0..n {
        w.write_pcapng_block(EnhancedPacketBlock {
            interface_id: 0,
            timestamp: std::time::Duration::from_micros(1_700_000_000_000_000 + i as u64),
            original_len: frame.len() as u32,
            data: std::borrow::Cow::Borrowed(&frame),
            options: vec![],
        })
        .expect("packet");
    }
    w.into_inner()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, .. ProptestConfig::default() })]

    /// Issue 23 item 7: whatever 32-bit word of a pcapng capture's first blocks is overwritten
    /// with whatever value (the length fields included), the reader never panics, never reads
    /// past the file, and an error names an offset inside it.
    #[test]
    fn issue23_7_damaged_pcapng_words_are_refused_with_an_offset_in_the_file(
        word in 0usize..700,
        value in prop_oneof![
            any::<u32>(),
            Just(0xFFFF_FFF0u32),
            Just(0x7FFF_FFF0),
            Just(0xFFFF_FFFF),
            Just(0),
            Just(12),
        ],
    ) {
        let mut bytes = pcapng_capture(2);
        if word * 4 + 4 <= bytes.len() {
            bytes[word * 4..word * 4 + 4].copy_from_slice(&value.to_le_bytes());
        }
        let path = temp_path(&format!("damaged-{word}-{value:x}.pcapng"));
        let _cleanup = Cleanup(path.clone());
        std::fs::write(&path, &bytes).expect("write");
        let Ok(mut r) = CaptureReader::open(&path) else {
            return Ok(()); // the section header itself was damaged: refused on opening
        };
        for _ in 0..100 {
            match r.next() {
                Ok(Some(d)) => prop_assert!(d.offset < bytes.len() as u64),
                Ok(None) => break,
                Err(CaptureError::Truncated { offset, missing, .. }) => {
                    prop_assert_eq!(offset as usize + missing, bytes.len());
                    break;
                }
                Err(CaptureError::Corrupt { offset, .. })
                | Err(CaptureError::ImpossibleLength { offset, .. }) => {
                    prop_assert!(offset < bytes.len() as u64);
                    break;
                }
                Err(CaptureError::UnsupportedLinkType { .. }) => break,
                Err(e) => prop_assert!(false, "unexpected {e}"),
            }
        }
        prop_assert!(r.bytes_read() <= bytes.len() as u64);
    }
}
