//! The Kobuki byte stream: finding, checking and splitting frames, and writing them.
//!
//! A frame (protocol specification, "Structure of Bytestream"):
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 1 | header 0, `0xAA` |
//! | 1 | 1 | header 1, `0x55` |
//! | 2 | 1 | length `n` of the payload, 3 or more |
//! | 3 | n | payload: sub-payloads, each `id: u8`, `len: u8`, `len` data bytes |
//! | 3 + n | 1 | checksum: XOR of the length byte and every payload byte |
//!
//! So the XOR of every byte from the length to the checksum is zero. Both directions (commands
//! to the base, feedback from it) use this framing; multi-byte fields are little-endian.
//!
//! [`FrameParser`] is fed chunks as a serial port returns them (any size, cut anywhere). It
//! keeps at most one frame's bytes ([`MAX_FRAME`]) between calls, whatever the chunk size.
//! After a rejected frame it searches again from the byte after the rejected `0xAA`, not past
//! the length the frame claimed: a damaged or cut-short frame must not hide the good frame
//! that follows it. Every discarded byte is counted in [`FrameStats`] under its reason.

use std::fmt;

/// First header byte of every frame.
pub const HEADER0: u8 = 0xAA;
/// Second header byte of every frame.
pub const HEADER1: u8 = 0x55;
/// Smallest payload length the specification allows (one sub-payload with one data byte).
pub const MIN_PAYLOAD: usize = 3;
/// Largest payload: the length field is one byte.
pub const MAX_PAYLOAD: usize = 255;
/// Bytes of a frame around its payload: two header bytes, the length and the checksum.
pub const OVERHEAD: usize = 4;
/// Largest frame on the wire.
pub const MAX_FRAME: usize = MAX_PAYLOAD + OVERHEAD;

/// XOR of `bytes`: a frame's checksum is that of its length byte and payload.
pub fn xor(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0, |a, b| a ^ b)
}

/// One sub-payload of a frame's payload: an identifier and its data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SubPayload<'a> {
    /// Identifier (the sub-payload's header byte).
    pub id: u8,
    /// Offset of the identifier byte in the payload.
    pub offset: usize,
    /// The data bytes (the sub-payload's length byte says how many).
    pub data: &'a [u8],
}

/// A frame whose checksum matched and whose sub-payloads exactly fill its payload.
#[derive(Clone, PartialEq, Eq)]
pub struct Frame {
    bytes: [u8; MAX_PAYLOAD],
    len: u8,
    offset: u64,
}

impl Frame {
    /// The payload (the bytes between the length and the checksum).
    pub fn payload(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len)]
    }

    /// Offset in the stream fed to the parser of this frame's first header byte.
    pub fn stream_offset(&self) -> u64 {
        self.offset
    }

    /// Bytes the frame took on the wire.
    pub fn wire_len(&self) -> usize {
        usize::from(self.len) + OVERHEAD
    }

    /// The sub-payloads in order. The parser checked that they fill the payload exactly.
    pub fn subpayloads(&self) -> SubPayloads<'_> {
        SubPayloads {
            payload: self.payload(),
            pos: 0,
        }
    }

    /// A frame of `payload` as a stream would carry it, checked as the parser checks it.
    pub fn from_payload(payload: &[u8]) -> Result<Frame, FrameError> {
        let len = u8::try_from(payload.len())
            .map_err(|_| FrameError::PayloadTooLong { len: payload.len() })?;
        if payload.len() < MIN_PAYLOAD {
            return Err(FrameError::BadLength { at: 0, len });
        }
        check_layout(payload, 0)?;
        let mut bytes = [0; MAX_PAYLOAD];
        bytes[..payload.len()].copy_from_slice(payload);
        Ok(Frame {
            bytes,
            len,
            offset: 0,
        })
    }
}

impl fmt::Debug for Frame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Frame")
            .field("offset", &self.offset)
            .field("payload", &self.payload())
            .finish()
    }
}

/// Iterator over a checked payload's sub-payloads (see [`Frame::subpayloads`]).
#[derive(Debug, Clone)]
pub struct SubPayloads<'a> {
    payload: &'a [u8],
    pos: usize,
}

impl<'a> Iterator for SubPayloads<'a> {
    type Item = SubPayload<'a>;

    fn next(&mut self) -> Option<SubPayload<'a>> {
        let rest = self.payload.get(self.pos..)?;
        let (&[id, len], tail) = rest.split_first_chunk::<2>()?;
        let data = tail.get(..usize::from(len))?;
        let offset = self.pos;
        self.pos += 2 + data.len();
        Some(SubPayload { id, offset, data })
    }
}

/// Checks that the sub-payloads of `payload` fill it exactly; `at` is the frame's offset.
fn check_layout(payload: &[u8], at: u64) -> Result<(), FrameError> {
    let mut pos = 0;
    while pos < payload.len() {
        let remaining = payload.len() - pos;
        let id = payload[pos];
        let Some(&len) = payload.get(pos + 1) else {
            return Err(FrameError::SubPayloadOverrun {
                at,
                offset: pos,
                id,
                len: None,
                remaining: remaining - 1,
            });
        };
        if usize::from(len) > remaining - 2 {
            return Err(FrameError::SubPayloadOverrun {
                at,
                offset: pos,
                id,
                len: Some(len),
                remaining: remaining - 2,
            });
        }
        pos += 2 + usize::from(len);
    }
    Ok(())
}

/// Why bytes that began with the two header bytes were not taken as a frame, or why a frame
/// could not be written. The parser skips the rejected `0xAA` and searches on.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// The checksum byte is not the XOR of the length and payload bytes: the frame was damaged
    /// on the wire, or the header was a `0xAA 0x55` inside other data.
    #[error(
        "frame at stream byte {at}: checksum byte is 0x{found:02x}, the XOR of its length and payload is 0x{expected:02x}"
    )]
    BadChecksum {
        /// Stream offset of the frame's `0xAA`.
        at: u64,
        /// The XOR of the length and payload bytes.
        expected: u8,
        /// The checksum byte received.
        found: u8,
    },
    /// The length byte is below the specification's minimum of 3.
    #[error("frame at stream byte {at}: payload length {len}, below the protocol's minimum of 3")]
    BadLength {
        /// Stream offset of the frame's `0xAA`.
        at: u64,
        /// The length byte received.
        len: u8,
    },
    /// The checksum matched but a sub-payload's length runs past the end of the payload (or
    /// the payload ends after an identifier byte): the sub-payloads do not fill the payload.
    #[error(
        "frame at stream byte {at}: sub-payload 0x{id:02x} at payload byte {offset} claims {} data bytes, {remaining} remain in the payload",
        len.map_or_else(|| "its length byte and".to_string(), |l| l.to_string())
    )]
    SubPayloadOverrun {
        /// Stream offset of the frame's `0xAA`.
        at: u64,
        /// Offset of the sub-payload's identifier in the payload.
        offset: usize,
        /// The sub-payload's identifier.
        id: u8,
        /// Its length byte; `None` when the payload ends before it.
        len: Option<u8>,
        /// Payload bytes left after the identifier and length bytes.
        remaining: usize,
    },
    /// A payload to be written is longer than the one-byte length field can say.
    #[error("a payload of {len} bytes does not fit a frame (at most 255)")]
    PayloadTooLong {
        /// Bytes of the payload.
        len: usize,
    },
}

/// What the parser found in the bytes fed to it, by kind. Every byte fed is counted once:
/// `bytes == garbage_bytes + frame_bytes + rejected_headers() + pending` (see
/// [`FrameParser::pending`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FrameStats {
    /// Bytes fed to the parser.
    pub bytes: u64,
    /// Frames yielded.
    pub frames: u64,
    /// Bytes of the frames yielded.
    pub frame_bytes: u64,
    /// Bytes outside any frame (before the first, between frames, the rest of a rejected one).
    pub garbage_bytes: u64,
    /// Frames rejected for their checksum ([`FrameError::BadChecksum`]).
    pub bad_checksum: u64,
    /// Frames rejected for a length below 3 ([`FrameError::BadLength`]).
    pub bad_length: u64,
    /// Frames rejected because their sub-payloads do not fill the payload
    /// ([`FrameError::SubPayloadOverrun`]).
    pub bad_subpayload: u64,
}

impl FrameStats {
    /// Headers rejected, of every kind: each discarded one byte (its `0xAA`).
    pub fn rejected_headers(&self) -> u64 {
        self.bad_checksum + self.bad_length + self.bad_subpayload
    }

    /// Adds `other` to these counts.
    pub fn add(&mut self, other: &FrameStats) {
        self.bytes += other.bytes;
        self.frames += other.frames;
        self.frame_bytes += other.frame_bytes;
        self.garbage_bytes += other.garbage_bytes;
        self.bad_checksum += other.bad_checksum;
        self.bad_length += other.bad_length;
        self.bad_subpayload += other.bad_subpayload;
    }
}

/// The streaming frame finder. Feed it chunks with [`FrameParser::push`] and drain the
/// returned iterator; bytes of a frame cut between chunks wait inside (at most [`MAX_FRAME`]).
#[derive(Debug, Clone)]
pub struct FrameParser {
    /// Bytes not yet taken: always a prefix of a possible frame (starts with `0xAA`, then
    /// `0x55`, ...), never longer than a whole frame of the length it announces.
    buf: [u8; MAX_FRAME],
    len: usize,
    /// Stream offset of `buf[0]`.
    offset: u64,
    stats: FrameStats,
}

impl Default for FrameParser {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameParser {
    /// A parser at the start of a stream.
    pub fn new() -> Self {
        FrameParser {
            buf: [0; MAX_FRAME],
            len: 0,
            offset: 0,
            stats: FrameStats::default(),
        }
    }

    /// The counts so far.
    pub fn stats(&self) -> &FrameStats {
        &self.stats
    }

    /// Bytes held waiting for the rest of a frame.
    pub fn pending(&self) -> usize {
        self.len
    }

    /// Forgets a partly received frame (e.g. after reopening the port); its bytes are counted
    /// as garbage.
    pub fn reset(&mut self) {
        self.stats.garbage_bytes += self.len as u64;
        self.offset += self.len as u64;
        self.len = 0;
    }

    /// Feeds `chunk`; the iterator yields each frame completed in it, in order, and an error
    /// for each rejected header. Bytes of the chunk not consumed when the iterator is dropped
    /// are consumed (and their frames counted, not returned) by the drop.
    pub fn push<'p, 'c>(&'p mut self, chunk: &'c [u8]) -> Frames<'p, 'c> {
        Frames {
            parser: self,
            chunk,
        }
    }

    /// Feeds `chunk` and calls `on_frame` for each frame completed; errors are only counted.
    pub fn push_with(&mut self, chunk: &[u8], mut on_frame: impl FnMut(Frame)) {
        self.push(chunk).flatten().for_each(&mut on_frame);
    }

    /// Drops the first `n` held bytes (as garbage or a rejected header, counted by the caller).
    fn discard(&mut self, n: usize) {
        self.buf.copy_within(n..self.len, 0);
        self.len -= n;
        self.offset += n as u64;
    }

    /// Drops held bytes up to the next `0xAA`, counting them as garbage.
    fn skip_garbage(&mut self) {
        let n = self.buf[..self.len]
            .iter()
            .position(|&b| b == HEADER0)
            .unwrap_or(self.len);
        if n > 0 {
            self.stats.garbage_bytes += n as u64;
            self.discard(n);
        }
    }

    /// Tries to take a frame from the held bytes. `None`: more bytes are needed.
    fn try_frame(&mut self) -> Option<Result<Frame, FrameError>> {
        loop {
            self.skip_garbage();
            if self.len < 2 {
                return None;
            }
            if self.buf[1] != HEADER1 {
                // the 0xAA is not a header: garbage too
                self.stats.garbage_bytes += 1;
                self.discard(1);
                continue;
            }
            if self.len < 3 {
                return None;
            }
            let at = self.offset;
            let n = usize::from(self.buf[2]);
            if n < MIN_PAYLOAD {
                self.stats.bad_length += 1;
                self.discard(1);
                return Some(Err(FrameError::BadLength { at, len: n as u8 }));
            }
            let total = n + OVERHEAD;
            if self.len < total {
                return None;
            }
            let found = self.buf[total - 1];
            let expected = xor(&self.buf[2..total - 1]);
            if found != expected {
                self.stats.bad_checksum += 1;
                self.discard(1);
                return Some(Err(FrameError::BadChecksum {
                    at,
                    expected,
                    found,
                }));
            }
            let payload = &self.buf[3..3 + n];
            if let Err(e) = check_layout(payload, at) {
                self.stats.bad_subpayload += 1;
                self.discard(1);
                return Some(Err(e));
            }
            let mut bytes = [0; MAX_PAYLOAD];
            bytes[..n].copy_from_slice(payload);
            let frame = Frame {
                bytes,
                len: n as u8,
                offset: at,
            };
            self.stats.frames += 1;
            self.stats.frame_bytes += total as u64;
            self.discard(total);
            return Some(Ok(frame));
        }
    }

    /// How many bytes to take from a chunk next: enough to complete what is held, and no
    /// more than fits.
    fn wanted(&self) -> usize {
        match self.len {
            0..=2 => 3 - self.len,
            _ => (usize::from(self.buf[2]).max(MIN_PAYLOAD) + OVERHEAD).saturating_sub(self.len),
        }
        .max(1)
    }
}

/// The frames completed by one chunk: see [`FrameParser::push`].
#[derive(Debug)]
pub struct Frames<'p, 'c> {
    parser: &'p mut FrameParser,
    chunk: &'c [u8],
}

impl Iterator for Frames<'_, '_> {
    type Item = Result<Frame, FrameError>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if let Some(item) = self.parser.try_frame() {
                return Some(item);
            }
            if self.chunk.is_empty() {
                return None;
            }
            let p = &mut *self.parser;
            if p.len == 0 {
                // fast path: skip garbage straight in the chunk, up to the next 0xAA
                let skip = self
                    .chunk
                    .iter()
                    .position(|&b| b == HEADER0)
                    .unwrap_or(self.chunk.len());
                if skip > 0 {
                    p.stats.bytes += skip as u64;
                    p.stats.garbage_bytes += skip as u64;
                    p.offset += skip as u64;
                    self.chunk = &self.chunk[skip..];
                    continue;
                }
            }
            let take = p.wanted().min(self.chunk.len()).min(MAX_FRAME - p.len);
            let (head, tail) = self.chunk.split_at(take);
            p.buf[p.len..p.len + take].copy_from_slice(head);
            p.len += take;
            p.stats.bytes += take as u64;
            self.chunk = tail;
        }
    }
}

impl Drop for Frames<'_, '_> {
    fn drop(&mut self) {
        // consume the rest of the chunk so that no byte fed is lost
        for _ in self.by_ref() {}
    }
}

/// Appends a sub-payload (`id`, length, `data`) to `payload`. `data` longer than 255 bytes is
/// an error, as is a payload that no longer fits a frame.
pub fn push_subpayload(payload: &mut Vec<u8>, id: u8, data: &[u8]) -> Result<(), FrameError> {
    let len = u8::try_from(data.len()).map_err(|_| FrameError::PayloadTooLong {
        len: payload.len() + 2 + data.len(),
    })?;
    if payload.len() + 2 + data.len() > MAX_PAYLOAD {
        return Err(FrameError::PayloadTooLong {
            len: payload.len() + 2 + data.len(),
        });
    }
    payload.push(id);
    payload.push(len);
    payload.extend_from_slice(data);
    Ok(())
}

/// Appends a frame carrying `payload` (sub-payloads already laid out) to `out`.
pub fn encode_frame(payload: &[u8], out: &mut Vec<u8>) -> Result<(), FrameError> {
    let len = u8::try_from(payload.len())
        .map_err(|_| FrameError::PayloadTooLong { len: payload.len() })?;
    out.reserve(payload.len() + OVERHEAD);
    out.extend_from_slice(&[HEADER0, HEADER1, len]);
    out.extend_from_slice(payload);
    out.push(len ^ xor(payload));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frame of one sub-payload `id` with `data`.
    fn frame(id: u8, data: &[u8]) -> Vec<u8> {
        let mut p = Vec::new();
        push_subpayload(&mut p, id, data).unwrap();
        let mut out = Vec::new();
        encode_frame(&p, &mut out).unwrap();
        out
    }

    fn parse_all(parser: &mut FrameParser, bytes: &[u8]) -> Vec<Result<Frame, FrameError>> {
        parser.push(bytes).collect()
    }

    fn payloads(items: &[Result<Frame, FrameError>]) -> Vec<Vec<u8>> {
        items
            .iter()
            .filter_map(|r| r.as_ref().ok().map(|f| f.payload().to_vec()))
            .collect()
    }

    fn check_accounting(p: &FrameParser) {
        let s = p.stats();
        assert_eq!(
            s.bytes,
            s.garbage_bytes + s.frame_bytes + s.rejected_headers() + p.pending() as u64,
            "{s:?}, pending {}",
            p.pending()
        );
    }

    #[test]
    fn encodes_the_base_control_example() {
        // Base Control, speed 100 mm/s, radius 0: AA 55 06 01 04 64 00 00 00 checksum
        let bytes = frame(0x01, &[0x64, 0x00, 0x00, 0x00]);
        assert_eq!(
            bytes,
            [
                0xAA,
                0x55,
                0x06,
                0x01,
                0x04,
                0x64,
                0x00,
                0x00,
                0x00,
                0x06 ^ 0x01 ^ 0x04 ^ 0x64
            ]
        );
        assert_eq!(xor(&bytes[2..]), 0);
    }

    #[test]
    fn round_trip_and_offsets() {
        let mut p = FrameParser::new();
        let mut stream = vec![1, 2, 3];
        stream.extend(frame(0x01, &[9; 15]));
        stream.extend(frame(0x04, &[0xAA, 0x55, 3, 4, 5, 6, 7]));
        let items = parse_all(&mut p, &stream);
        assert_eq!(items.len(), 2);
        let f = items[1].as_ref().unwrap();
        assert_eq!(f.stream_offset(), 3 + 21);
        let subs: Vec<_> = f.subpayloads().collect();
        assert_eq!(subs.len(), 1);
        assert_eq!(subs[0].id, 0x04);
        assert_eq!(subs[0].data, &[0xAA, 0x55, 3, 4, 5, 6, 7]);
        assert_eq!(p.stats().garbage_bytes, 3);
        assert_eq!(p.stats().frames, 2);
        check_accounting(&p);
    }

    #[test]
    fn byte_by_byte_equals_whole() {
        let mut stream = Vec::new();
        for i in 0..5u8 {
            stream.extend([0xAA, i, 0x55]);
            stream.extend(frame(i, &[i; 7]));
        }
        let mut whole = FrameParser::new();
        let a = payloads(&parse_all(&mut whole, &stream));
        let mut bytewise = FrameParser::new();
        let mut b = Vec::new();
        for byte in &stream {
            b.extend(payloads(&parse_all(
                &mut bytewise,
                std::slice::from_ref(byte),
            )));
        }
        assert_eq!(a.len(), 5);
        assert_eq!(a, b);
        assert_eq!(whole.stats(), bytewise.stats());
        check_accounting(&bytewise);
    }

    #[test]
    fn wrong_checksum_is_rejected_and_the_next_frame_found() {
        let mut bad = frame(0x01, &[1, 2, 3, 4]);
        let last = bad.len() - 1;
        bad[last] ^= 0x10;
        let mut stream = bad.clone();
        stream.extend(frame(0x02, &[5, 6]));
        let mut p = FrameParser::new();
        let items = parse_all(&mut p, &stream);
        assert!(matches!(
            items[0],
            Err(FrameError::BadChecksum { at: 0, found, expected }) if found == expected ^ 0x10
        ));
        assert_eq!(payloads(&items), vec![vec![0x02, 2, 5, 6]]);
        assert_eq!(p.stats().bad_checksum, 1);
        // the rest of the bad frame after its 0xAA is garbage
        assert_eq!(p.stats().garbage_bytes, bad.len() as u64 - 1);
        check_accounting(&p);
        let msg = items[0].as_ref().unwrap_err().to_string();
        assert!(
            msg.contains("stream byte 0") && msg.contains("checksum"),
            "{msg}"
        );
    }

    #[test]
    fn damaged_byte_inside_a_frame() {
        let mut damaged = frame(0x01, &[1, 2, 3, 4, 5, 6]);
        damaged[5] = 0xAA; // a header byte appears inside the data
        let mut stream = damaged;
        stream.extend(frame(0x03, &[7, 8, 9]));
        let mut p = FrameParser::new();
        let items = parse_all(&mut p, &stream);
        assert_eq!(payloads(&items), vec![vec![0x03, 3, 7, 8, 9]]);
        assert_eq!(p.stats().bad_checksum, 1);
        check_accounting(&p);
    }

    #[test]
    fn a_length_running_past_the_data_does_not_hide_the_next_frame() {
        // a frame cut short after 3 of its 17 payload bytes (the port dropped the rest)
        let long = frame(0x01, &[0x11; 15]);
        let mut stream = long[..6].to_vec();
        let good = frame(0x04, &[1, 2, 3, 4, 5, 6, 7]);
        stream.extend(&good);
        stream.extend(frame(0x05, &[1, 2, 3, 4, 5, 6]));
        let mut p = FrameParser::new();
        let items = parse_all(&mut p, &stream);
        // the cut frame's claimed 21 bytes swallow the start of the good one: rejected by its
        // checksum, and the search goes on from the byte after its header
        assert!(matches!(
            items[0],
            Err(FrameError::BadChecksum { at: 0, .. })
        ));
        assert_eq!(
            payloads(&items),
            vec![
                good[3..good.len() - 1].to_vec(),
                vec![0x05, 6, 1, 2, 3, 4, 5, 6]
            ]
        );
        check_accounting(&p);
    }

    #[test]
    fn partial_frame_waits_for_the_rest() {
        let f = frame(0x01, &[3; 15]);
        let mut p = FrameParser::new();
        assert!(parse_all(&mut p, &f[..10]).is_empty());
        assert_eq!(p.pending(), 10);
        let items = parse_all(&mut p, &f[10..]);
        assert_eq!(items.len(), 1);
        assert_eq!(p.pending(), 0);
        check_accounting(&p);
    }

    #[test]
    fn short_length_and_bad_layout_are_rejected() {
        let mut p = FrameParser::new();
        // length 2: below the minimum
        let items = parse_all(&mut p, &[0xAA, 0x55, 0x02, 0x01, 0x00, 0x03]);
        assert_eq!(items, vec![Err(FrameError::BadLength { at: 0, len: 2 })]);
        // checksum right, but the sub-payload claims 9 bytes of 2
        let payload = [0x01, 0x09, 0x00, 0x00];
        let mut bytes = Vec::new();
        encode_frame(&payload, &mut bytes).unwrap();
        let items = parse_all(&mut p, &bytes);
        assert_eq!(
            items,
            vec![Err(FrameError::SubPayloadOverrun {
                at: 6,
                offset: 0,
                id: 1,
                len: Some(9),
                remaining: 2
            })]
        );
        assert_eq!(p.stats().bad_length, 1);
        assert_eq!(p.stats().bad_subpayload, 1);
        check_accounting(&p);
        assert!(Frame::from_payload(&payload).is_err());
        assert!(Frame::from_payload(&[0x01, 0x01, 0x00]).is_ok());
    }

    #[test]
    fn garbage_only_and_lone_headers() {
        let mut p = FrameParser::new();
        let items = parse_all(&mut p, &[0x00, 0xAA, 0xAA, 0x54, 0xAA]);
        assert!(items.is_empty());
        // the last 0xAA may start a frame
        assert_eq!(p.pending(), 1);
        assert_eq!(p.stats().garbage_bytes, 4);
        check_accounting(&p);
        p.reset();
        assert_eq!(p.pending(), 0);
        check_accounting(&p);
    }

    #[test]
    fn dropping_the_iterator_consumes_the_chunk() {
        let mut stream = frame(1, &[1]);
        stream.extend(frame(2, &[2]));
        let mut p = FrameParser::new();
        let first = p.push(&stream).next();
        assert!(first.is_some_and(|r| r.is_ok()));
        assert_eq!(p.stats().frames, 2);
        check_accounting(&p);
    }

    #[test]
    fn encoder_limits() {
        let mut payload = Vec::new();
        assert!(push_subpayload(&mut payload, 1, &[0; 253]).is_ok());
        assert!(push_subpayload(&mut payload, 1, &[]).is_err());
        let mut out = Vec::new();
        assert!(encode_frame(&[0; 256], &mut out).is_err());
        assert!(out.is_empty());
    }

    mod streams {
        use super::*;
        use proptest::prelude::*;

        /// A piece of a stream: garbage, or a valid frame of 1 to 4 sub-payloads.
        #[derive(Debug, Clone)]
        enum Piece {
            Garbage(Vec<u8>),
            Frame(Vec<u8>),
        }

        fn valid_frame() -> impl Strategy<Value = Vec<u8>> {
            prop::collection::vec(
                (any::<u8>(), prop::collection::vec(any::<u8>(), 1..40)),
                1..5,
            )
            .prop_map(|subs| {
                let mut payload = Vec::new();
                for (id, data) in subs {
                    push_subpayload(&mut payload, id, &data).unwrap();
                }
                let mut out = Vec::new();
                encode_frame(&payload, &mut out).unwrap();
                out
            })
        }

        /// Garbage that cannot start a header (no 0xAA), or any bytes at all.
        fn piece(clean_garbage: bool) -> impl Strategy<Value = Piece> {
            let byte = if clean_garbage {
                prop_oneof![0u8..0xAA, 0xABu8..=0xFF].boxed()
            } else {
                prop_oneof![any::<u8>(), Just(0xAAu8), Just(0x55u8)].boxed()
            };
            prop_oneof![
                prop::collection::vec(byte, 0..30).prop_map(Piece::Garbage),
                valid_frame().prop_map(Piece::Frame),
            ]
        }

        fn stream(pieces: &[Piece]) -> (Vec<u8>, Vec<Vec<u8>>, u64) {
            let mut bytes = Vec::new();
            let mut frames = Vec::new();
            let mut garbage = 0;
            for p in pieces {
                match p {
                    Piece::Garbage(g) => {
                        bytes.extend(g);
                        garbage += g.len() as u64;
                    }
                    Piece::Frame(f) => {
                        bytes.extend(f);
                        frames.push(f[3..f.len() - 1].to_vec());
                    }
                }
            }
            (bytes, frames, garbage)
        }

        /// Feeds `bytes` in chunks of the sizes in `cuts` (cycled), collecting what comes out.
        fn feed(bytes: &[u8], cuts: &[usize]) -> (FrameParser, Vec<Result<Frame, FrameError>>) {
            let mut p = FrameParser::new();
            let mut out = Vec::new();
            let mut rest = bytes;
            let mut k = 0;
            while !rest.is_empty() {
                let n = cuts[k % cuts.len()].min(rest.len());
                k += 1;
                let (chunk, tail) = rest.split_at(n);
                out.extend(p.push(chunk));
                assert!(p.pending() <= MAX_FRAME);
                rest = tail;
            }
            (p, out)
        }

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(512))]

            /// Valid frames between garbage that holds no header byte, cut anywhere: exactly
            /// the frames, in order, and every other byte counted as garbage.
            #[test]
            fn yields_exactly_the_valid_frames(
                pieces in prop::collection::vec(piece(true), 0..20),
                cuts in prop::collection::vec(1usize..80, 1..10),
            ) {
                let (bytes, frames, garbage) = stream(&pieces);
                let (p, out) = feed(&bytes, &cuts);
                prop_assert!(out.iter().all(|r| r.is_ok()), "{out:?}");
                prop_assert_eq!(payloads(&out), frames.clone());
                prop_assert_eq!(p.stats().garbage_bytes, garbage);
                prop_assert_eq!(p.stats().frames, frames.len() as u64);
                prop_assert_eq!(p.pending(), 0);
                check_accounting(&p);
            }

            /// Any bytes at all, with valid frames among them, cut anywhere: no panic, the same
            /// result whatever the cuts, every frame yielded checks, and the counts add up.
            #[test]
            fn any_stream_is_handled_the_same_whatever_the_cuts(
                pieces in prop::collection::vec(piece(false), 0..20),
                cuts in prop::collection::vec(1usize..80, 1..10),
            ) {
                let (bytes, _, _) = stream(&pieces);
                let (p, out) = feed(&bytes, &cuts);
                let (whole, whole_out) = feed(&bytes, &[usize::MAX]);
                prop_assert_eq!(&out, &whole_out);
                prop_assert_eq!(p.stats(), whole.stats());
                for f in out.iter().flatten() {
                    let at = f.stream_offset() as usize;
                    let wire = &bytes[at..at + f.wire_len()];
                    prop_assert_eq!(&wire[..2], &[HEADER0, HEADER1]);
                    prop_assert_eq!(xor(&wire[2..]), 0);
                    prop_assert_eq!(&wire[3..wire.len() - 1], f.payload());
                    prop_assert!(Frame::from_payload(f.payload()).is_ok());
                }
                check_accounting(&p);
            }
        }
    }
}
