//! One regression test for each crash the fuzz targets found (`fuzz/`, docs/testing.md), named
//! after it, with the input the fuzzer saved.

use std::path::Path;

use mimnav_velodyne::capture::{CaptureReader, FrameSkip, udp_in_frame};

/// The fuzzer's input (target `capture`, 2026-11-25, after 1.9 M executions): a pcap file whose
/// second record holds an Ethernet frame with an IPv4 header and only 7 bytes of UDP header.
const UDP_HEADER_CUT_SHORT: &str = "d4c3b2a1020004000400000000000000ffff000001000000715fb1558bbe0a00290000002a020000ffffffffffff6076880000000800450004d200004000ff11b4aae7a801c8ffffff7420ff20f40208000000000000000800000000000000000000000000558bbe0a000d0000002a020000ffffffffffff60000000000000000000000000";

fn unhex(s: &str) -> Vec<u8> {
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).expect("hex"))
        .collect()
}

/// A frame whose UDP header is cut short (6 or 7 bytes: the ports and the length, no checksum)
/// panicked in `udp_in_frame` (slice `udp[8..8]` of a 7-byte header); it is now a truncated
/// frame, counted and passed over.
#[test]
fn fuzz_capture_udp_header_cut_short() {
    for udp_bytes in 0..8 {
        // raw IPv4 (link type 101): a 20-byte header with protocol UDP, then the short header
        let mut frame = vec![
            0x45, 0, 0, 0, 0, 0, 0x40, 0, 64, 17, 0, 0, 192, 168, 1, 201, 192, 168, 1, 77,
        ];
        frame.extend((0..udp_bytes).map(|i| [0x09, 0x40, 0x09, 0x40, 0x04, 0xBE, 0, 0][i]));
        assert_eq!(
            udp_in_frame(101, &frame).err(),
            Some(FrameSkip::Truncated),
            "{udp_bytes} bytes of UDP header"
        );
    }
    let bytes = unhex(UDP_HEADER_CUT_SHORT);
    let len = bytes.len() as u64;
    let mut reader = CaptureReader::from_reader(
        Box::new(std::io::Cursor::new(bytes)),
        Path::new("crash.pcap"),
        Some(len),
    )
    .expect("a pcap header");
    while let Ok(Some(_)) = reader.next() {}
    assert!(
        reader
            .skipped()
            .iter()
            .any(|(k, _)| *k == FrameSkip::Truncated.kind()),
        "{:?}",
        reader.skipped()
    );
}
