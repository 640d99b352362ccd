//! Capture formats the reader must take: pcapng with several interfaces and timestamp
//! resolutions, classic pcap in either byte order and resolution, and the link layers drivers
//! meet in practice (Ethernet, Linux SLL, raw IP).

use std::borrow::Cow;
use std::time::Duration;

use mimnav_velodyne::capture::{CaptureError, CaptureReader};
use pcap_file::DataLink;
use pcap_file::pcap::{PcapHeader, PcapPacket, PcapWriter};
use pcap_file::pcapng::PcapNgWriter;
use pcap_file::pcapng::blocks::enhanced_packet::EnhancedPacketBlock;
use pcap_file::pcapng::blocks::interface_description::{
    InterfaceDescriptionBlock, InterfaceDescriptionOption,
};
use pcap_file::{Endianness, TsResolution};

fn ipv4_udp(payload: &[u8], dst_port: u16) -> Vec<u8> {
    let mut ip = vec![
        0x45, 0, 0, 0, 0, 0, 0x40, 0, 64, 17, 0, 0, 192, 168, 1, 201, 192, 168, 1, 77,
    ];
    let total = (20 + 8 + payload.len()) as u16;
    ip[2..4].copy_from_slice(&total.to_be_bytes());
    ip.extend_from_slice(&2368u16.to_be_bytes());
    ip.extend_from_slice(&dst_port.to_be_bytes());
    ip.extend_from_slice(&((payload.len() + 8) as u16).to_be_bytes());
    ip.extend_from_slice(&[0, 0]);
    ip.extend_from_slice(payload);
    ip
}

fn ethernet(ip: &[u8]) -> Vec<u8> {
    let mut f = vec![0xFF; 6];
    f.extend_from_slice(&[0x60, 0x76, 0x88, 0, 0, 1, 0x08, 0x00]);
    f.extend_from_slice(ip);
    f
}

fn sll(ip: &[u8]) -> Vec<u8> {
    let mut f = vec![
        0, 0, 0, 1, 0, 6, 0x60, 0x76, 0x88, 0, 0, 1, 0, 0, 0x08, 0x00,
    ];
    f.extend_from_slice(ip);
    f
}

fn temp(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("mimnav-formats-{}-{name}", std::process::id()))
}

#[test]
fn pcapng_with_two_interfaces_and_resolutions() {
    let path = temp("two.pcapng");
    let file = std::fs::File::create(&path).expect("create");
    let mut w = PcapNgWriter::new(file).expect("section");
    w.write_pcapng_block(InterfaceDescriptionBlock::new(DataLink::ETHERNET, 0xFFFF))
        .expect("if0");
    w.write_pcapng_block(InterfaceDescriptionBlock {
        linktype: DataLink::LINUX_SLL,
        snaplen: 0xFFFF,
        options: vec![InterfaceDescriptionOption::IfTsResol(9)],
    })
    .expect("if1");
    let a = ethernet(&ipv4_udp(&[1u8; 1206], 2368));
    let b = sll(&ipv4_udp(&[2u8; 512], 8308));
    // pcap-file takes the raw count of the interface's units
    w.write_pcapng_block(EnhancedPacketBlock {
        interface_id: 0,
        timestamp: Duration::from_nanos(1_700_000_000_123_456), // µs units
        original_len: a.len() as u32,
        data: Cow::Borrowed(&a),
        options: vec![],
    })
    .expect("epb0");
    w.write_pcapng_block(EnhancedPacketBlock {
        interface_id: 1,
        timestamp: Duration::from_nanos(1_700_000_000_123_456_789), // ns units
        original_len: b.len() as u32,
        data: Cow::Borrowed(&b),
        options: vec![],
    })
    .expect("epb1");
    drop(w);
    let mut r = CaptureReader::open(&path).expect("open");
    let d = r.next().expect("read").expect("first");
    assert_eq!(
        (d.ts_ns, d.dst_port, d.payload.len(), d.payload[0]),
        (1_700_000_000_123_456_000, 2368, 1206, 1)
    );
    let d = r.next().expect("read").expect("second");
    assert_eq!(
        (d.ts_ns, d.dst_port, d.payload.len(), d.payload[0]),
        (1_700_000_000_123_456_789, 8308, 512, 2)
    );
    assert!(r.next().expect("read").is_none());
    std::fs::remove_file(&path).ok();
}

#[test]
fn big_endian_nanosecond_pcap_with_raw_ip() {
    let path = temp("be.pcap");
    let file = std::fs::File::create(&path).expect("create");
    let header = PcapHeader {
        endianness: Endianness::Big,
        ts_resolution: TsResolution::NanoSecond,
        datalink: DataLink::RAW,
        ..PcapHeader::default()
    };
    let mut w = PcapWriter::with_header(file, header).expect("header");
    let ip = ipv4_udp(&[3u8; 1206], 2368);
    let ts = Duration::new(1_600_000_000, 987_654_321);
    w.write_packet(&PcapPacket::new(ts, ip.len() as u32, &ip))
        .expect("packet");
    drop(w);
    let mut r = CaptureReader::open(&path).expect("open");
    let d = r.next().expect("read").expect("datagram");
    assert_eq!(
        (d.ts_ns, d.payload.len(), d.payload[0]),
        (1_600_000_000_987_654_321, 1206, 3)
    );
    assert_eq!(d.src, std::net::IpAddr::from([192, 168, 1, 201]));
    std::fs::remove_file(&path).ok();
}

#[test]
fn frames_without_udp_are_counted_not_returned() {
    let path = temp("mixed.pcap");
    let file = std::fs::File::create(&path).expect("create");
    let mut w = PcapWriter::new(file).expect("header");
    let mut arp = vec![0xFF; 12];
    arp.extend_from_slice(&[0x08, 0x06]);
    arp.extend_from_slice(&[0u8; 28]);
    let udp = ethernet(&ipv4_udp(&[4u8; 1206], 2368));
    for f in [&arp, &udp, &arp] {
        w.write_packet(&PcapPacket::new(Duration::from_secs(1), f.len() as u32, f))
            .expect("write");
    }
    drop(w);
    let mut r = CaptureReader::open(&path).expect("open");
    assert_eq!(r.next().expect("read").expect("udp").payload[0], 4);
    assert!(r.next().expect("read").is_none());
    assert_eq!(r.skipped(), &[("frame_not_ip", 2)]);
    std::fs::remove_file(&path).ok();
}

/// Issue 23 item 7: a pcapng block whose length field says 0xFFFFFFF0 was read to the end of the
/// file before being called "truncated". It is refused from its header, naming the offset and
/// the length, without reading the rest of the file; so is a packet block claiming more
/// captured bytes than a record can hold.
#[test]
fn issue23_7_impossible_pcapng_block_lengths_are_refused_before_reading() {
    let path = temp("impossible.pcapng");
    let file = std::fs::File::create(&path).expect("create");
    let mut w = PcapNgWriter::new(std::io::BufWriter::new(file)).expect("section");
    w.write_pcapng_block(InterfaceDescriptionBlock::new(DataLink::ETHERNET, 0xFFFF))
        .expect("if0");
    let frame = ethernet(&ipv4_udp(&[1u8; 1206], 2368));
    for i in 0..16_000u64 {
        w.write_pcapng_block(EnhancedPacketBlock {
            interface_id: 0,
            timestamp: Duration::from_nanos(1_700_000_000_000_000 + i),
            original_len: frame.len() as u32,
            data: Cow::Borrowed(&frame),
            options: vec![],
        })
        .expect("epb");
    }
    drop(w);
    let good = std::fs::read(&path).expect("read");
    assert!(good.len() > 20_000_000);
    // the first packet block follows the section (28 bytes) and interface (20) blocks
    let block = 28 + 20;
    let block_len = u32::from_le_bytes(good[block + 4..block + 8].try_into().expect("4 bytes"));
    let second = block + block_len as usize;
    for (at, value, what) in [
        (second + 4, 0xFFFF_FFF0u32, "pcapng block"),
        (second + 4, 0x7FFF_FFF0, "pcapng block"),
        (second + 4, 7, "pcapng block"),
        (second + 20, 0x00FF_FFF0, "pcapng packet"),
    ] {
        let mut bytes = good.clone();
        bytes[at..at + 4].copy_from_slice(&value.to_le_bytes());
        std::fs::write(&path, &bytes).expect("write");
        let mut r = CaptureReader::open(&path).expect("open");
        assert!(r.next().expect("the first block is intact").is_some());
        match r.next() {
            Err(CaptureError::ImpossibleLength {
                offset,
                length,
                what: w,
                ..
            }) => assert_eq!((offset, length, w), (second as u64, u64::from(value), what)),
            other => panic!("{value:#x}: {:?}", other.map(|d| d.map(|d| d.offset))),
        }
        assert!(
            r.bytes_read() <= 2 << 20,
            "{value:#x}: {} bytes read of {}",
            r.bytes_read(),
            bytes.len()
        );
    }
    std::fs::remove_file(&path).ok();
}

/// Issue 23 item 7: a capture on a link layer the reader cannot peel replayed nothing and exited
/// 0. A pcap file says its link type in its header: refused on opening. A pcapng file says it
/// per interface: refused at its end when none of its packets could be read.
#[test]
fn issue23_7_an_unknown_link_type_is_refused_by_name() {
    let path = temp("bluetooth.pcap");
    let file = std::fs::File::create(&path).expect("create");
    let header = PcapHeader {
        datalink: DataLink::from(201u32), // Bluetooth HCI H4 with phdr
        ..PcapHeader::default()
    };
    let mut w = PcapWriter::with_header(file, header).expect("header");
    let ip = ipv4_udp(&[3u8; 1206], 2368);
    w.write_packet(&PcapPacket::new(
        Duration::from_secs(1),
        ip.len() as u32,
        &ip,
    ))
    .expect("packet");
    drop(w);
    match CaptureReader::open(&path) {
        Err(e @ CaptureError::UnsupportedLinkType { linktype: 201, .. }) => {
            let shown = e.to_string();
            assert!(shown.contains("link type 201 is not supported"), "{shown}");
            assert!(shown.contains("bluetooth.pcap"), "{shown}");
        }
        Err(e) => panic!("{e}"),
        Ok(_) => panic!("opened"),
    }
    std::fs::remove_file(&path).ok();

    let path = temp("bluetooth.pcapng");
    let file = std::fs::File::create(&path).expect("create");
    let mut w = PcapNgWriter::new(file).expect("section");
    w.write_pcapng_block(InterfaceDescriptionBlock::new(
        DataLink::from(201u32),
        0xFFFF,
    ))
    .expect("if0");
    w.write_pcapng_block(EnhancedPacketBlock {
        interface_id: 0,
        timestamp: Duration::from_nanos(1),
        original_len: ip.len() as u32,
        data: Cow::Borrowed(&ip),
        options: vec![],
    })
    .expect("epb");
    drop(w);
    let mut r = CaptureReader::open(&path).expect("the header is fine");
    match r.next() {
        Err(CaptureError::UnsupportedLinkType { linktype: 201, .. }) => {}
        other => panic!("{:?}", other.map(|d| d.map(|d| d.offset))),
    }
    std::fs::remove_file(&path).ok();
}
