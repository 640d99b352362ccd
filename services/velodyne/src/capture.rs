//! Reading UDP datagrams from capture files: pcap (either byte order, µs or ns) and pcapng, with
//! Ethernet (and 802.1Q / 802.1ad VLAN tags), Linux SLL and SLL2, BSD loopback and raw IP link
//! layers.
//!
//! The file format is parsed by the `pcap-file` crate; this module streams the file through it
//! with a bounded buffer (captures can be larger than memory), tracks the byte offset of every
//! record so a corrupt or truncated file is reported as "file, offset, what", and peels the link,
//! IP and UDP headers itself. Each record's length is read from its header and checked before
//! anything more is read (issue 23 item 7): a pcap record longer than [`MAX_RECORD_LEN`], a
//! pcapng block longer than [`MAX_BLOCK_LEN`] or shorter than its header, or either longer than
//! what is left of the file, is refused at once; the buffer never holds more than one record
//! and a chunk. A link type the reader cannot peel is refused by name
//! ([`CaptureError::UnsupportedLinkType`]). The UDP payload length comes from the UDP header (bounded by the
//! captured bytes), never from the IPv4 total length: VeloView writes a fixed 1234 there even in
//! 554-byte position-packet frames.

use std::fs::File;
use std::io::{self, Read};
use std::net::IpAddr;
use std::path::{Path, PathBuf};

use pcap_file::pcap::PcapParser;
use pcap_file::pcapng::{Block, PcapNgParser};
use pcap_file::{DataLink, PcapError};

/// The longest pcap record (captured bytes) accepted: 256 KiB, libpcap's largest snapshot
/// length (`MAXIMUM_SNAPLEN`). A VLP-16 frame is 1 248 bytes (1 290 with a cooked header).
pub const MAX_RECORD_LEN: u32 = 256 * 1024;
/// The longest pcapng block accepted, header and options included: 16 MiB. A packet block
/// holds at most [`MAX_RECORD_LEN`] captured bytes besides.
pub const MAX_BLOCK_LEN: u32 = 16 * 1024 * 1024;

/// Why a capture cannot be read (further).
#[derive(Debug, thiserror::Error)]
pub enum CaptureError {
    /// The file could not be opened or read.
    #[error("{path}: {source}")]
    Io {
        /// The capture.
        path: PathBuf,
        /// What the OS said.
        source: io::Error,
    },
    /// The file does not start with a pcap or pcapng header.
    #[error("{path}: not a pcap or pcapng capture ({detail})")]
    NotACapture {
        /// The capture.
        path: PathBuf,
        /// What is wrong with the header.
        detail: String,
    },
    /// A record is malformed; nothing after it can be trusted.
    #[error("{path}: corrupt record at byte offset {offset}: {detail}")]
    Corrupt {
        /// The capture.
        path: PathBuf,
        /// Byte offset of the record in the file.
        offset: u64,
        /// What is wrong.
        detail: String,
    },
    /// A record or block whose length field cannot be right, refused before reading it.
    #[error(
        "{path}: impossible record at byte offset {offset}: {what} {length} bytes long, more than {limit}"
    )]
    ImpossibleLength {
        /// The capture.
        path: PathBuf,
        /// Byte offset of the record in the file.
        offset: u64,
        /// What the length is of (`pcap record`, `pcapng block`, `pcapng packet`).
        what: &'static str,
        /// The length written.
        length: u64,
        /// What it may be at most, and why.
        limit: String,
    },
    /// A link layer the reader cannot peel: nothing in the capture could be replayed.
    #[error(
        "{path}: link type {linktype} is not supported (supported: Ethernet 1, raw IP 101/12/14/228/229, BSD loopback 0/108, Linux SLL 113 and SLL2 276)"
    )]
    UnsupportedLinkType {
        /// The capture.
        path: PathBuf,
        /// The link type (LINKTYPE_*) number.
        linktype: u32,
    },
    /// The file ends in the middle of a record (a capture cut short).
    #[error(
        "{path}: truncated: the record at byte offset {offset} is incomplete ({missing} bytes of the file remain)"
    )]
    Truncated {
        /// The capture.
        path: PathBuf,
        /// Byte offset of the incomplete record.
        offset: u64,
        /// Bytes left in the file from that offset.
        missing: usize,
    },
}

/// One UDP datagram from a capture.
#[derive(Debug, Clone, Copy)]
pub struct Datagram<'a> {
    /// Capture timestamp, ns since the Unix epoch.
    pub ts_ns: u64,
    /// Source address.
    pub src: IpAddr,
    /// UDP destination port.
    pub dst_port: u16,
    /// The UDP payload.
    pub payload: &'a [u8],
    /// Byte offset of the datagram's record in the file.
    pub offset: u64,
}

/// Why a frame of a capture carries no UDP datagram. Such frames are counted and passed over.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameSkip {
    /// Not IPv4 or IPv6 (ARP, LLDP, …).
    NotIp,
    /// IP, but not UDP.
    NotUdp,
    /// An IP fragment (VLP-16 datagrams are never fragmented).
    Fragment,
    /// The frame ends inside a header.
    Truncated,
    /// A link-layer type this reader does not know.
    UnsupportedLinkType(u32),
}

impl FrameSkip {
    /// Stable counter name.
    pub fn kind(&self) -> &'static str {
        match self {
            FrameSkip::NotIp => "frame_not_ip",
            FrameSkip::NotUdp => "frame_not_udp",
            FrameSkip::Fragment => "frame_ip_fragment",
            FrameSkip::Truncated => "frame_truncated",
            FrameSkip::UnsupportedLinkType(_) => "frame_unsupported_link_type",
        }
    }
}

/// A UDP datagram found inside a link-layer frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UdpView<'a> {
    /// Source address.
    pub src: IpAddr,
    /// Destination port.
    pub dst_port: u16,
    /// Payload.
    pub payload: &'a [u8],
}

/// Peels the link, IP and UDP headers off `frame` captured with link type `linktype`.
pub fn udp_in_frame(linktype: u32, frame: &[u8]) -> Result<UdpView<'_>, FrameSkip> {
    let (ethertype, ip) = match linktype {
        // Ethernet, with any number of VLAN tags
        1 => {
            let mut at = 12;
            loop {
                let et = be16(frame, at).ok_or(FrameSkip::Truncated)?;
                if et == 0x8100 || et == 0x88A8 || et == 0x9100 {
                    at += 4;
                } else {
                    break (Some(et), frame.get(at + 2..).ok_or(FrameSkip::Truncated)?);
                }
            }
        }
        // BSD loopback: 4-byte address family in host order; the IP version tells the rest
        0 | 108 => (None, frame.get(4..).ok_or(FrameSkip::Truncated)?),
        // raw IP (12 and 14 are the historical numbers on some systems)
        101 | 12 | 14 | 228 | 229 => (None, frame),
        // Linux cooked capture v1: protocol at 14
        113 => (
            Some(be16(frame, 14).ok_or(FrameSkip::Truncated)?),
            frame.get(16..).unwrap_or(&[]),
        ),
        // Linux cooked capture v2: protocol at 0
        276 => (
            Some(be16(frame, 0).ok_or(FrameSkip::Truncated)?),
            frame.get(20..).unwrap_or(&[]),
        ),
        other => return Err(FrameSkip::UnsupportedLinkType(other)),
    };
    match ethertype {
        Some(0x0800) | Some(0x86DD) | None => {}
        Some(_) => return Err(FrameSkip::NotIp),
    }
    let version = ip.first().ok_or(FrameSkip::Truncated)? >> 4;
    let (src, udp) = match version {
        4 => {
            let ihl = usize::from(ip[0] & 0x0F) * 4;
            if ihl < 20 || ip.len() < ihl {
                return Err(FrameSkip::Truncated);
            }
            let flags_frag = be16(ip, 6).ok_or(FrameSkip::Truncated)?;
            if flags_frag & 0x3FFF != 0 {
                return Err(FrameSkip::Fragment);
            }
            if ip[9] != 17 {
                return Err(FrameSkip::NotUdp);
            }
            let src = IpAddr::from([ip[12], ip[13], ip[14], ip[15]]);
            (src, &ip[ihl..])
        }
        6 => {
            if ip.len() < 40 {
                return Err(FrameSkip::Truncated);
            }
            match ip[6] {
                17 => {}
                44 => return Err(FrameSkip::Fragment),
                _ => return Err(FrameSkip::NotUdp),
            }
            let mut a = [0u8; 16];
            a.copy_from_slice(&ip[8..24]);
            (IpAddr::from(a), &ip[40..])
        }
        _ => return Err(FrameSkip::NotIp),
    };
    // a UDP header cut short: 6 or 7 bytes hold the ports and the length but no payload
    if udp.len() < 8 {
        return Err(FrameSkip::Truncated);
    }
    let dst_port = be16(udp, 2).ok_or(FrameSkip::Truncated)?;
    let udp_len = usize::from(be16(udp, 4).ok_or(FrameSkip::Truncated)?);
    let available = udp.len().saturating_sub(8);
    // Trust the UDP length when it fits the captured bytes; otherwise take what was captured.
    let len = if udp_len >= 8 && udp_len - 8 <= available {
        udp_len - 8
    } else {
        available
    };
    Ok(UdpView {
        src,
        dst_port,
        payload: &udp[8..8 + len],
    })
}

fn be16(b: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_be_bytes([*b.get(at)?, *b.get(at + 1)?]))
}

enum Format {
    Pcap { parser: PcapParser, linktype: u32 },
    PcapNg { parser: PcapNgParser },
}

/// Streams the UDP datagrams of a capture file in file order.
pub struct CaptureReader {
    path: PathBuf,
    file: Box<dyn Read + Send>,
    buf: Vec<u8>,
    /// Start of unparsed data in `buf`.
    pos: usize,
    /// File offset of `buf[0]`.
    buf_offset: u64,
    eof: bool,
    format: Format,
    payload: Vec<u8>,
    skipped: Vec<(&'static str, u64)>,
    file_len: u64,
    /// The file is a regular file: `file_len` bounds what a record can need.
    regular: bool,
    /// Bytes read from the file so far.
    bytes_read: u64,
    /// Datagrams returned so far (this pass).
    delivered: u64,
}

const READ_CHUNK: usize = 1 << 20;
/// Bytes of a record's header that hold its length: 16 for pcap, 12 for a pcapng block (24
/// with an enhanced packet block's captured length).
const RECORD_HEADER_LEN: usize = 24;

impl CaptureReader {
    /// Opens `path` and reads its file header.
    pub fn open(path: &Path) -> Result<Self, CaptureError> {
        let io_err = |source| CaptureError::Io {
            path: path.to_path_buf(),
            source,
        };
        let file = File::open(path).map_err(io_err)?;
        let meta = file.metadata().map_err(io_err)?;
        let len = meta.is_file().then_some(meta.len());
        let mut reader = Self::from_reader(Box::new(file), path, len)?;
        reader.file_len = meta.len();
        Ok(reader)
    }

    /// Reads a capture from `file`, named `path` in errors. `len` is its length in bytes when
    /// known (a regular file, a byte slice): a record longer than what is left is then refused
    /// before it is read. `None` streams it like a pipe. The fuzz targets read byte slices so.
    pub fn from_reader(
        mut file: Box<dyn Read + Send>,
        path: &Path,
        len: Option<u64>,
    ) -> Result<Self, CaptureError> {
        let io_err = |source| CaptureError::Io {
            path: path.to_path_buf(),
            source,
        };
        let (file_len, regular) = (len.unwrap_or(0), len.is_some());
        let mut head = Vec::with_capacity(READ_CHUNK);
        (&mut file)
            .take(64 * 1024)
            .read_to_end(&mut head)
            .map_err(io_err)?;
        let not_capture = |detail: String| CaptureError::NotACapture {
            path: path.to_path_buf(),
            detail,
        };
        if head.len() < 4 {
            return Err(not_capture(format!(
                "the file is {} bytes long",
                head.len()
            )));
        }
        let (rest_len, format) = if head[..4] == [0x0A, 0x0D, 0x0D, 0x0A] {
            let (rest, parser) =
                PcapNgParser::new(&head).map_err(|e| not_capture(format!("pcapng header: {e}")))?;
            (rest.len(), Format::PcapNg { parser })
        } else {
            let (rest, parser) = PcapParser::new(&head).map_err(|e| {
                not_capture(format!(
                    "magic {:02x}{:02x}{:02x}{:02x}: {e}",
                    head[0], head[1], head[2], head[3]
                ))
            })?;
            let linktype = u32::from(parser.header().datalink);
            if !link_type_supported(parser.header().datalink) {
                return Err(CaptureError::UnsupportedLinkType {
                    path: path.to_path_buf(),
                    linktype,
                });
            }
            (rest.len(), Format::Pcap { parser, linktype })
        };
        let bytes_read = head.len() as u64;
        Ok(CaptureReader {
            path: path.to_path_buf(),
            file,
            pos: head.len() - rest_len,
            eof: false,
            buf: head,
            buf_offset: 0,
            format,
            payload: Vec::with_capacity(2048),
            skipped: Vec::new(),
            file_len,
            regular,
            bytes_read,
            delivered: 0,
        })
    }

    /// Bytes read from the file so far (a damaged record is refused without reading the rest).
    pub fn bytes_read(&self) -> u64 {
        self.bytes_read
    }

    /// The capture's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The file's size in bytes.
    pub fn file_len(&self) -> u64 {
        self.file_len
    }

    /// Byte offset of the next record.
    pub fn offset(&self) -> u64 {
        self.buf_offset + self.pos as u64
    }

    /// Frames passed over because they carry no UDP datagram, by kind.
    pub fn skipped(&self) -> &[(&'static str, u64)] {
        &self.skipped
    }

    fn count_skip(&mut self, kind: &'static str) {
        match self.skipped.iter_mut().find(|(k, _)| *k == kind) {
            Some((_, n)) => *n += 1,
            None => self.skipped.push((kind, 1)),
        }
    }

    /// Makes at least `want` unparsed bytes available, unless the file ends first.
    fn fill(&mut self, want: usize) -> Result<(), CaptureError> {
        if self.buf.len() - self.pos >= want || self.eof {
            return Ok(());
        }
        // drop what was parsed
        self.buf.drain(..self.pos);
        self.buf_offset += self.pos as u64;
        self.pos = 0;
        while self.buf.len() < want && !self.eof {
            let old = self.buf.len();
            let chunk = want.max(READ_CHUNK);
            self.buf.resize(old + chunk, 0);
            let n = loop {
                match self.file.read(&mut self.buf[old..]) {
                    Ok(n) => break n,
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                    Err(source) => {
                        self.buf.truncate(old);
                        return Err(CaptureError::Io {
                            path: self.path.clone(),
                            source,
                        });
                    }
                }
            };
            self.buf.truncate(old + n);
            self.bytes_read += n as u64;
            if n == 0 {
                self.eof = true;
            }
        }
        Ok(())
    }

    /// The end of the file: `Ok(None)`, unless every packet of it was on a link layer the
    /// reader cannot peel (a pcapng file names its link types per interface, so that is known
    /// only at its end).
    fn end_of_file(&self) -> Result<Option<Datagram<'_>>, CaptureError> {
        let unsupported = FrameSkip::UnsupportedLinkType(0).kind();
        let skipped_all = self.skipped.iter().any(|(k, _)| *k == unsupported);
        if self.delivered == 0
            && skipped_all
            && let Format::PcapNg { parser } = &self.format
            && let Some(iface) = parser
                .interfaces()
                .iter()
                .find(|i| !link_type_supported(i.linktype))
        {
            return Err(CaptureError::UnsupportedLinkType {
                path: self.path.clone(),
                linktype: u32::from(iface.linktype),
            });
        }
        Ok(None)
    }

    /// The length of the record at the start of the unparsed bytes (at file `offset`), read
    /// from its header and checked: at most [`MAX_RECORD_LEN`] captured bytes, a pcapng block
    /// of 12 bytes to [`MAX_BLOCK_LEN`], and within what is left of the file.
    fn record_len(&self, offset: u64) -> Result<usize, CaptureError> {
        let head = &self.buf[self.pos..];
        let left = if self.regular {
            self.file_len.saturating_sub(offset)
        } else {
            u64::MAX
        };
        let truncated = || CaptureError::Truncated {
            path: self.path.clone(),
            offset,
            missing: if self.regular {
                usize::try_from(left).unwrap_or(usize::MAX)
            } else {
                head.len()
            },
        };
        let impossible = |what, length: u64, limit: String| CaptureError::ImpossibleLength {
            path: self.path.clone(),
            offset,
            what,
            length,
            limit,
        };
        let word = |at: usize, e: pcap_file::Endianness| -> Option<u32> {
            let b: [u8; 4] = head.get(at..at + 4)?.try_into().ok()?;
            Some(match e {
                pcap_file::Endianness::Big => u32::from_be_bytes(b),
                pcap_file::Endianness::Little => u32::from_le_bytes(b),
            })
        };
        let need = match &self.format {
            Format::Pcap { parser, .. } => {
                let e = parser.header().endianness;
                let incl = word(8, e).ok_or_else(truncated)?;
                if incl > MAX_RECORD_LEN {
                    return Err(impossible(
                        "pcap record",
                        u64::from(incl),
                        format!("{MAX_RECORD_LEN} (the largest snapshot length)"),
                    ));
                }
                16 + u64::from(incl)
            }
            Format::PcapNg { parser } => {
                let mut e = parser.section().endianness;
                let kind = word(0, e).ok_or_else(truncated)?;
                if kind == 0x0A0D_0D0A {
                    // a new section: its byte-order magic says how to read its length
                    let magic = head.get(8..12).ok_or_else(truncated)?;
                    e = match magic {
                        [0x1A, 0x2B, 0x3C, 0x4D] => pcap_file::Endianness::Big,
                        [0x4D, 0x3C, 0x2B, 0x1A] => pcap_file::Endianness::Little,
                        _ => {
                            return Err(CaptureError::Corrupt {
                                path: self.path.clone(),
                                offset,
                                detail: format!(
                                    "section header with byte-order magic {magic:02x?}"
                                ),
                            });
                        }
                    };
                }
                let len = word(4, e).ok_or_else(truncated)?;
                if !(12..=MAX_BLOCK_LEN).contains(&len) || len % 4 != 0 {
                    return Err(impossible(
                        "pcapng block",
                        u64::from(len),
                        format!("{MAX_BLOCK_LEN} (or under 12, or not a multiple of 4)"),
                    ));
                }
                // enhanced (6) and obsolete (2) packet blocks: the captured length at byte 20
                if (kind == 6 || kind == 2)
                    && let Some(captured) = word(20, e)
                    && captured > MAX_RECORD_LEN.min(len)
                {
                    return Err(impossible(
                        "pcapng packet",
                        u64::from(captured),
                        format!(
                            "{} (the largest snapshot length, and its block's length)",
                            MAX_RECORD_LEN.min(len)
                        ),
                    ));
                }
                u64::from(len)
            }
        };
        if need > left {
            return Err(truncated());
        }
        usize::try_from(need).map_err(|_| truncated())
    }

    /// The next UDP datagram, `Ok(None)` at the end of the file.
    #[allow(clippy::should_implement_trait)]
    pub fn next(&mut self) -> Result<Option<Datagram<'_>>, CaptureError> {
        loop {
            // the record's header first: its length is checked before the record is read
            self.fill(RECORD_HEADER_LEN)?;
            if self.buf.len() == self.pos && self.eof {
                return self.end_of_file();
            }
            let offset = self.offset();
            let need = self.record_len(offset)?;
            let (consumed, found) = {
                self.fill(need)?;
                let avail = &self.buf[self.pos..];
                let parsed = parse_record(&mut self.format, avail);
                match parsed {
                    Ok((rest_len, rec)) => (avail.len() - rest_len, rec),
                    Err(PcapError::IncompleteBuffer) if avail.len() >= need => {
                        return Err(CaptureError::Corrupt {
                            path: self.path.clone(),
                            offset,
                            detail: format!("its contents run past its length ({need} bytes)"),
                        });
                    }
                    Err(PcapError::IncompleteBuffer) => {
                        return Err(CaptureError::Truncated {
                            path: self.path.clone(),
                            offset,
                            missing: avail.len(),
                        });
                    }
                    Err(e) => {
                        return Err(CaptureError::Corrupt {
                            path: self.path.clone(),
                            offset,
                            detail: e.to_string(),
                        });
                    }
                }
            };
            self.pos += consumed;
            let Some((ts_ns, linktype, frame_range)) = found else {
                continue;
            };
            let frame = &self.buf[self.pos - consumed..self.pos][frame_range];
            match udp_in_frame(linktype, frame) {
                Ok(udp) => {
                    self.payload.clear();
                    self.payload.extend_from_slice(udp.payload);
                    let (src, dst_port) = (udp.src, udp.dst_port);
                    self.delivered += 1;
                    return Ok(Some(Datagram {
                        ts_ns,
                        src,
                        dst_port,
                        payload: &self.payload,
                        offset,
                    }));
                }
                Err(skip) => self.count_skip(skip.kind()),
            }
        }
    }
}

/// A packet record: (timestamp ns, link type, range of the frame within the record's bytes).
type Record = Option<(u64, u32, std::ops::Range<usize>)>;

/// Parses one record at the start of `avail`; returns the remaining length and the packet it
/// held, if it was a packet.
fn parse_record(format: &mut Format, avail: &[u8]) -> Result<(usize, Record), PcapError> {
    let base = avail.as_ptr() as usize;
    let range_of = |data: &[u8]| {
        let start = data.as_ptr() as usize - base;
        start..start + data.len()
    };
    match format {
        Format::Pcap { parser, linktype } => {
            let (rest, pkt) = parser.next_packet(avail)?;
            let ts = pkt.timestamp.as_nanos().min(u128::from(u64::MAX)) as u64;
            Ok((rest.len(), Some((ts, *linktype, range_of(&pkt.data)))))
        }
        Format::PcapNg { parser } => {
            let (rest, block) = parser.next_block(avail)?;
            let rec = match &block {
                Block::EnhancedPacket(epb) => {
                    let iface = parser
                        .interfaces()
                        .get(epb.interface_id as usize)
                        .ok_or(PcapError::InvalidInterfaceId(epb.interface_id))?;
                    let ts = scale_pcapng_ts(epb.timestamp.as_nanos() as u64, ts_resolution(iface));
                    Some((ts, u32::from(iface.linktype), range_of(&epb.data)))
                }
                Block::SimplePacket(spb) => {
                    let iface = parser
                        .interfaces()
                        .first()
                        .ok_or(PcapError::InvalidInterfaceId(0))?;
                    Some((0, u32::from(iface.linktype), range_of(&spb.data)))
                }
                Block::Packet(pb) => {
                    let iface = parser
                        .interfaces()
                        .get(usize::from(pb.interface_id))
                        .ok_or(PcapError::InvalidInterfaceId(u32::from(pb.interface_id)))?;
                    let ts = scale_pcapng_ts(pb.timestamp, ts_resolution(iface));
                    Some((ts, u32::from(iface.linktype), range_of(&pb.data)))
                }
                _ => None,
            };
            Ok((rest.len(), rec))
        }
    }
}

/// The interface's `if_tsresol` option (default 6: microseconds).
fn ts_resolution(
    iface: &pcap_file::pcapng::blocks::interface_description::InterfaceDescriptionBlock<'_>,
) -> u8 {
    use pcap_file::pcapng::blocks::interface_description::InterfaceDescriptionOption;
    iface
        .options
        .iter()
        .find_map(|o| match o {
            InterfaceDescriptionOption::IfTsResol(r) => Some(*r),
            _ => None,
        })
        .unwrap_or(6)
}

/// Converts a pcapng timestamp in units of `resol` (10^-r s, or 2^-r s with the top bit set) to
/// ns. pcap-file 2 hands the raw unit count over as if it were nanoseconds.
fn scale_pcapng_ts(units: u64, resol: u8) -> u64 {
    let units = u128::from(units);
    let ns = if resol & 0x80 != 0 {
        let shift = u32::from(resol & 0x7F).min(127);
        (units * 1_000_000_000) >> shift
    } else {
        let r = u32::from(resol).min(30);
        if r <= 9 {
            units * 10u128.pow(9 - r)
        } else {
            units / 10u128.pow(r - 9)
        }
    };
    ns.min(u128::from(u64::MAX)) as u64
}

/// Writes UDP datagrams to a classic pcap file (Ethernet, IPv4, µs timestamps, little-endian),
/// the way a sensor's traffic looks when captured with tcpdump. The simulator and the tests use
/// it to make captures.
pub struct PcapDatagramWriter<W: std::io::Write> {
    inner: pcap_file::pcap::PcapWriter<W>,
    frame: Vec<u8>,
    ip_id: u16,
}

impl<W: std::io::Write> PcapDatagramWriter<W> {
    /// Writes the file header.
    pub fn new(out: W) -> Result<Self, PcapError> {
        let header = pcap_file::pcap::PcapHeader {
            endianness: pcap_file::Endianness::Little,
            ..Default::default()
        };
        Ok(PcapDatagramWriter {
            inner: pcap_file::pcap::PcapWriter::with_header(out, header)?,
            frame: Vec::with_capacity(1600),
            ip_id: 0,
        })
    }

    /// Appends one datagram from `src` to `dst` stamped `ts_ns` (ns since the Unix epoch).
    pub fn write(
        &mut self,
        ts_ns: u64,
        src: (std::net::Ipv4Addr, u16),
        dst: (std::net::Ipv4Addr, u16),
        payload: &[u8],
    ) -> Result<(), PcapError> {
        let udp_len = u16::try_from(payload.len() + 8)
            .map_err(|_| PcapError::InvalidField("datagram longer than 65527 bytes"))?;
        let f = &mut self.frame;
        f.clear();
        f.extend_from_slice(&[0xFF; 6]); // destination MAC: broadcast, as the sensor sends
        f.extend_from_slice(&[0x60, 0x76, 0x88, 0x00, 0x00, 0x01]); // a Velodyne OUI
        f.extend_from_slice(&0x0800u16.to_be_bytes());
        let ip_start = f.len();
        f.extend_from_slice(&[0x45, 0]);
        f.extend_from_slice(&(udp_len + 20).to_be_bytes());
        f.extend_from_slice(&self.ip_id.to_be_bytes());
        f.extend_from_slice(&[0x40, 0, 64, 17, 0, 0]);
        f.extend_from_slice(&src.0.octets());
        f.extend_from_slice(&dst.0.octets());
        let sum = !ones_complement_sum(&f[ip_start..ip_start + 20]);
        f[ip_start + 10..ip_start + 12].copy_from_slice(&sum.to_be_bytes());
        f.extend_from_slice(&src.1.to_be_bytes());
        f.extend_from_slice(&dst.1.to_be_bytes());
        f.extend_from_slice(&udp_len.to_be_bytes());
        f.extend_from_slice(&[0, 0]); // no UDP checksum, as the VLP-16 sends
        f.extend_from_slice(payload);
        self.ip_id = self.ip_id.wrapping_add(1);
        let packet = pcap_file::pcap::PcapPacket::new(
            std::time::Duration::from_nanos(ts_ns),
            f.len() as u32,
            f,
        );
        self.inner.write_packet(&packet)?;
        Ok(())
    }

    /// The underlying writer (flush it before use).
    pub fn into_inner(self) -> W {
        self.inner.into_writer()
    }
}

fn ones_complement_sum(b: &[u8]) -> u16 {
    let mut sum: u32 = b
        .chunks(2)
        .map(|c| u32::from(u16::from_be_bytes([c[0], *c.get(1).unwrap_or(&0)])))
        .sum();
    while sum > 0xFFFF {
        sum = (sum & 0xFFFF) + (sum >> 16);
    }
    sum as u16
}

/// Tells whether `link` is a link type [`udp_in_frame`] understands.
pub fn link_type_supported(link: DataLink) -> bool {
    matches!(
        u32::from(link),
        0 | 1 | 12 | 14 | 101 | 108 | 113 | 228 | 229 | 276
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ipv4_udp(payload: &[u8], total_len_field: u16) -> Vec<u8> {
        let mut ip = vec![
            0x45, 0, 0, 0, 0, 0, 0x40, 0, 64, 17, 0, 0, 192, 168, 1, 201, 255, 255, 255, 255,
        ];
        ip[2..4].copy_from_slice(&total_len_field.to_be_bytes());
        let udp_len = (payload.len() + 8) as u16;
        ip.extend_from_slice(&2368u16.to_be_bytes());
        ip.extend_from_slice(&2368u16.to_be_bytes());
        ip.extend_from_slice(&udp_len.to_be_bytes());
        ip.extend_from_slice(&[0, 0]);
        ip.extend_from_slice(payload);
        ip
    }

    #[test]
    fn ethernet_vlan_and_bogus_ipv4_length() {
        let payload = [7u8; 512];
        let mut frame = vec![0xFF; 12];
        frame.extend_from_slice(&[0x81, 0x00, 0x00, 0x05]); // VLAN 5
        frame.extend_from_slice(&[0x08, 0x00]);
        frame.extend(ipv4_udp(&payload, 1234)); // VeloView's fixed total length
        let udp = udp_in_frame(1, &frame).expect("udp");
        assert_eq!(udp.payload.len(), 512);
        assert_eq!(udp.dst_port, 2368);
        assert_eq!(udp.src, IpAddr::from([192, 168, 1, 201]));
    }

    #[test]
    fn linux_sll_and_raw_ip() {
        let payload = [1u8; 1206];
        let mut sll = vec![0u8; 14];
        sll.extend_from_slice(&[0x08, 0x00]);
        sll.extend(ipv4_udp(&payload, 1234));
        assert_eq!(udp_in_frame(113, &sll).expect("sll").payload.len(), 1206);
        let raw = ipv4_udp(&payload, 1234);
        assert_eq!(udp_in_frame(101, &raw).expect("raw").payload.len(), 1206);
    }

    #[test]
    fn non_udp_frames_are_named() {
        let mut arp = vec![0xFF; 12];
        arp.extend_from_slice(&[0x08, 0x06, 0, 1]);
        assert_eq!(udp_in_frame(1, &arp), Err(FrameSkip::NotIp));
        let mut tcp = ipv4_udp(&[0; 4], 32);
        tcp[9] = 6;
        assert_eq!(udp_in_frame(101, &tcp), Err(FrameSkip::NotUdp));
        assert_eq!(udp_in_frame(1, &[0; 5]), Err(FrameSkip::Truncated));
        assert_eq!(
            udp_in_frame(147, &[0; 64]),
            Err(FrameSkip::UnsupportedLinkType(147))
        );
    }

    #[test]
    fn pcapng_timestamp_units() {
        assert_eq!(scale_pcapng_ts(1_500_000, 6), 1_500_000_000);
        assert_eq!(scale_pcapng_ts(1_500_000_000, 9), 1_500_000_000);
        assert_eq!(scale_pcapng_ts(1 << 20, 0x80 | 20), 1_000_000_000);
    }
}
