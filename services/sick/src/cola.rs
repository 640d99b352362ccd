//! CoLa framing: finding telegrams in the TCP byte stream and writing them.
//!
//! - **CoLa-A** (ASCII): `STX` (0x02), the telegram's text, `ETX` (0x03). The text never holds
//!   an `STX` or `ETX`.
//! - **CoLa-B** (binary): the four bytes `0x02 0x02 0x02 0x02`, the payload's length as a
//!   big-endian `u32`, the payload, and a checksum byte that is the XOR of every payload byte.
//!
//! [`Framer`] takes the stream in whatever pieces the socket gives and hands out whole payloads.
//! Everything that is not part of a good telegram is counted by reason ([`FrameStats`]) and
//! named ([`FrameError`]); after an error the framer looks for the next start, so one damaged
//! telegram costs that telegram only.

/// Which CoLa dialect a connection speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Dialect {
    /// CoLa-A: ASCII tokens between `STX` and `ETX`.
    ColaA,
    /// CoLa-B: binary, `0x02020202`, length, payload, XOR checksum.
    ColaB,
}

impl Dialect {
    /// The name used in the config and the logs.
    pub fn name(self) -> &'static str {
        match self {
            Dialect::ColaA => "cola_a",
            Dialect::ColaB => "cola_b",
        }
    }
}

/// `STX`, the start of a CoLa-A telegram.
pub const STX: u8 = 0x02;
/// `ETX`, the end of a CoLa-A telegram.
pub const ETX: u8 = 0x03;
/// The start of a CoLa-B telegram.
pub const COLA_B_MAGIC: [u8; 4] = [0x02; 4];

/// The longest telegram accepted, bytes: an LMS5xx's five echoes with remission at 0.1667° in
/// CoLa-A (10 channels × 1 141 values × up to 5 characters) is about 60 kB.
pub const DEFAULT_MAX_TELEGRAM: usize = 256 * 1024;

/// Why bytes of the stream were thrown away.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// Bytes before a telegram's start (a stream joined mid-telegram, line noise).
    #[error("{0} bytes outside a telegram")]
    Garbage(usize),
    /// A telegram longer than the limit: its start was dropped and the framer looks for the next.
    #[error("a telegram longer than {limit} bytes (CoLa-B length field {declared:?})")]
    Oversize {
        /// The limit.
        limit: usize,
        /// The length a CoLa-B header declared; `None` for CoLa-A (no `ETX` within the limit).
        declared: Option<u32>,
    },
    /// A CoLa-B checksum that is not the XOR of the payload.
    #[error("CoLa-B checksum 0x{got:02X}, the payload's XOR is 0x{want:02X} ({len} bytes)")]
    Checksum {
        /// The checksum byte received.
        got: u8,
        /// The XOR of the payload.
        want: u8,
        /// The payload's length.
        len: usize,
    },
    /// A CoLa-A telegram with an `STX` inside (the previous one lost its `ETX`).
    #[error("a CoLa-A telegram of {0} bytes without its ETX (a new STX came first)")]
    Unterminated(usize),
}

impl FrameError {
    /// A short name for the counters and the logs.
    pub fn kind(&self) -> &'static str {
        match self {
            FrameError::Garbage(_) => "garbage",
            FrameError::Oversize { .. } => "oversize",
            FrameError::Checksum { .. } => "bad_checksum",
            FrameError::Unterminated(_) => "unterminated",
        }
    }
}

/// What the framer has seen.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FrameStats {
    /// Good telegrams handed out.
    pub telegrams: u64,
    /// Bytes outside any telegram.
    pub garbage_bytes: u64,
    /// Telegrams over the length limit.
    pub oversize: u64,
    /// CoLa-B telegrams with a wrong checksum.
    pub bad_checksum: u64,
    /// CoLa-A telegrams cut by a new `STX`.
    pub unterminated: u64,
}

/// Finds telegrams in a CoLa byte stream.
#[derive(Debug)]
pub struct Framer {
    dialect: Dialect,
    max: usize,
    buf: Vec<u8>,
    /// Bytes of `buf` already handed out or thrown away.
    start: usize,
    stats: FrameStats,
}

/// One step of [`Framer::next`].
pub type Next<'a> = Option<Result<&'a [u8], FrameError>>;

impl Framer {
    /// A framer for `dialect` refusing telegrams longer than `max_telegram` bytes.
    pub fn new(dialect: Dialect, max_telegram: usize) -> Self {
        Framer {
            dialect,
            max: max_telegram.max(16),
            buf: Vec::with_capacity(64 * 1024),
            start: 0,
            stats: FrameStats::default(),
        }
    }

    /// The dialect.
    pub fn dialect(&self) -> Dialect {
        self.dialect
    }

    /// What was seen so far.
    pub fn stats(&self) -> FrameStats {
        self.stats
    }

    /// Bytes held, waiting for the rest of a telegram.
    pub fn pending(&self) -> usize {
        self.buf.len() - self.start
    }

    /// Forgets what is held (a new connection starts clean).
    pub fn reset(&mut self) {
        self.buf.clear();
        self.start = 0;
    }

    /// Adds bytes from the stream; call [`Framer::next`] until it gives `None`.
    pub fn push(&mut self, bytes: &[u8]) {
        if self.start > 0 && self.start == self.buf.len() {
            self.buf.clear();
            self.start = 0;
        } else if self.start > self.buf.capacity() / 2 {
            self.buf.drain(..self.start);
            self.start = 0;
        }
        self.buf.extend_from_slice(bytes);
    }

    /// The next telegram's payload (CoLa-A: the text between `STX` and `ETX`; CoLa-B: the
    /// payload without length and checksum), an error for bytes thrown away, or `None` when
    /// more bytes are needed.
    #[allow(clippy::should_implement_trait)]
    pub fn next(&mut self) -> Next<'_> {
        match self.dialect {
            Dialect::ColaA => self.next_a(),
            Dialect::ColaB => self.next_b(),
        }
    }

    fn garbage(&mut self, n: usize) -> FrameError {
        self.start += n;
        self.stats.garbage_bytes += n as u64;
        FrameError::Garbage(n)
    }

    fn next_a(&mut self) -> Next<'_> {
        let held = &self.buf[self.start..];
        if held.is_empty() {
            return None;
        }
        if held[0] != STX {
            let n = held.iter().position(|&b| b == STX).unwrap_or(held.len());
            return Some(Err(self.garbage(n)));
        }
        let body = &held[1..];
        let end = body.iter().position(|&b| b == ETX || b == STX);
        match end {
            Some(i) if body[i] == STX => {
                // the telegram lost its ETX: drop it, resynchronise on the new STX
                self.start += 1 + i;
                self.stats.unterminated += 1;
                Some(Err(FrameError::Unterminated(1 + i)))
            }
            Some(i) if i + 2 > self.max => {
                self.start += i + 2;
                self.stats.oversize += 1;
                Some(Err(FrameError::Oversize {
                    limit: self.max,
                    declared: None,
                }))
            }
            Some(i) => {
                let from = self.start + 1;
                self.start += i + 2;
                self.stats.telegrams += 1;
                Some(Ok(&self.buf[from..from + i]))
            }
            None if held.len() > self.max => {
                // no ETX within the limit: drop what is held up to the next STX
                let n = body
                    .iter()
                    .position(|&b| b == STX)
                    .map_or(held.len(), |i| i + 1);
                self.start += n;
                self.stats.oversize += 1;
                Some(Err(FrameError::Oversize {
                    limit: self.max,
                    declared: None,
                }))
            }
            None => None,
        }
    }

    fn next_b(&mut self) -> Next<'_> {
        let held = &self.buf[self.start..];
        if held.is_empty() {
            return None;
        }
        // the magic, or as much of it as has arrived
        let m = held.len().min(4);
        if held[..m] != COLA_B_MAGIC[..m] {
            let n = find_magic(held).unwrap_or_else(|| {
                // keep a tail that may be the magic's beginning
                held.len()
                    - held
                        .iter()
                        .rev()
                        .take(3)
                        .take_while(|&&b| b == 0x02)
                        .count()
            });
            let n = n.max(1);
            return Some(Err(self.garbage(n)));
        }
        if held.len() < 8 {
            return None;
        }
        let declared = u32::from_be_bytes([held[4], held[5], held[6], held[7]]);
        let len = declared as usize;
        if len + 9 > self.max {
            // a stray 0x02 before the magic reads as a huge length: move on by one byte and
            // search the next start from there
            self.start += 1;
            self.stats.oversize += 1;
            return Some(Err(FrameError::Oversize {
                limit: self.max,
                declared: Some(declared),
            }));
        }
        if held.len() < len + 9 {
            return None;
        }
        let payload = &held[8..8 + len];
        let want = xor(payload);
        let got = held[8 + len];
        if got != want {
            // the length may be what was damaged: resynchronise from the next byte
            self.start += 1;
            self.stats.bad_checksum += 1;
            return Some(Err(FrameError::Checksum { got, want, len }));
        }
        let from = self.start + 8;
        self.start += len + 9;
        self.stats.telegrams += 1;
        Some(Ok(&self.buf[from..from + len]))
    }
}

fn find_magic(b: &[u8]) -> Option<usize> {
    b.windows(4).position(|w| w == COLA_B_MAGIC)
}

/// Writes a telegram's arguments after its command and name: in CoLa-A each as a space and
/// its text, in CoLa-B one space and then each in binary (big-endian, its size). Requests,
/// answers and scans are all written through it.
pub(crate) struct Args<'a> {
    dialect: Dialect,
    out: &'a mut Vec<u8>,
    /// CoLa-B: the space before the binary arguments is written.
    spaced: bool,
}

impl<'a> Args<'a> {
    /// Arguments appended to `out`, which holds the command and its name.
    pub(crate) fn new(dialect: Dialect, out: &'a mut Vec<u8>) -> Self {
        Args {
            dialect,
            out,
            spaced: false,
        }
    }

    fn binary(&mut self, bytes: &[u8]) {
        if !self.spaced {
            self.out.push(b' ');
            self.spaced = true;
        }
        self.out.extend_from_slice(bytes);
    }

    /// An unsigned argument of `size` bytes: hex in CoLa-A, `width` digits at least.
    pub(crate) fn hex(&mut self, v: u32, size: usize, width: usize) -> &mut Self {
        match self.dialect {
            Dialect::ColaA => {
                use std::io::Write;
                let _ = write!(self.out, " {v:0width$X}");
            }
            Dialect::ColaB => self.binary(&v.to_be_bytes()[4 - size..]),
        }
        self
    }

    /// A signed argument of `size` bytes: decimal with its sign in CoLa-A.
    pub(crate) fn dec(&mut self, v: i64, size: usize) -> &mut Self {
        match self.dialect {
            Dialect::ColaA => {
                use std::io::Write;
                let _ = write!(self.out, " {v:+}");
            }
            Dialect::ColaB => self.binary(&v.to_be_bytes()[8 - size..]),
        }
        self
    }

    /// A fixed text (a channel's name): a token in CoLa-A, its bytes in CoLa-B.
    pub(crate) fn text(&mut self, t: &[u8]) -> &mut Self {
        match self.dialect {
            Dialect::ColaA => {
                self.out.push(b' ');
                self.out.extend_from_slice(t);
            }
            Dialect::ColaB => self.binary(t),
        }
        self
    }
}

/// The XOR of every byte: CoLa-B's checksum.
pub fn xor(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0, |a, b| a ^ b)
}

/// Appends `payload` framed in `dialect` to `out`.
pub fn frame(dialect: Dialect, payload: &[u8], out: &mut Vec<u8>) {
    match dialect {
        Dialect::ColaA => {
            out.push(STX);
            out.extend_from_slice(payload);
            out.push(ETX);
        }
        Dialect::ColaB => {
            out.extend_from_slice(&COLA_B_MAGIC);
            out.extend_from_slice(&(payload.len() as u32).to_be_bytes());
            out.extend_from_slice(payload);
            out.push(xor(payload));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn all(f: &mut Framer) -> Vec<Result<Vec<u8>, FrameError>> {
        let mut v = Vec::new();
        while let Some(r) = f.next() {
            v.push(r.map(<[u8]>::to_vec));
        }
        v
    }

    #[test]
    fn cola_a_telegrams_come_out_whatever_the_pieces() {
        let mut wire = Vec::new();
        frame(Dialect::ColaA, b"sAN Run 1", &mut wire);
        frame(Dialect::ColaA, b"sEA LMDscandata 1", &mut wire);
        for cut in 0..wire.len() {
            let mut f = Framer::new(Dialect::ColaA, 1024);
            f.push(&wire[..cut]);
            let mut got = all(&mut f);
            f.push(&wire[cut..]);
            got.extend(all(&mut f));
            let ok: Vec<Vec<u8>> = got.into_iter().map(|r| r.expect("good")).collect();
            assert_eq!(
                ok,
                vec![b"sAN Run 1".to_vec(), b"sEA LMDscandata 1".to_vec()]
            );
        }
    }

    #[test]
    fn cola_a_garbage_and_a_lost_etx_cost_only_their_telegram() {
        let mut f = Framer::new(Dialect::ColaA, 1024);
        f.push(b"xx\x02sSN half\x02sAN Run 1\x03");
        let got = all(&mut f);
        assert_eq!(got[0], Err(FrameError::Garbage(2)));
        assert_eq!(got[1], Err(FrameError::Unterminated(9)));
        assert_eq!(got[2], Ok(b"sAN Run 1".to_vec()));
        let s = f.stats();
        assert_eq!((s.telegrams, s.garbage_bytes, s.unterminated), (1, 2, 1));
    }

    #[test]
    fn cola_a_without_etx_is_dropped_at_the_limit() {
        let mut f = Framer::new(Dialect::ColaA, 32);
        f.push(&[STX]);
        f.push(&[b'7'; 40]);
        assert!(matches!(f.next(), Some(Err(FrameError::Oversize { .. }))));
        f.push(b"\x02sAN Run 1\x03");
        let got = all(&mut f);
        assert_eq!(got.last(), Some(&Ok(b"sAN Run 1".to_vec())));
    }

    #[test]
    fn cola_b_checks_the_checksum_and_resynchronises() {
        let mut wire = Vec::new();
        frame(Dialect::ColaB, b"sAN Run \x01", &mut wire);
        let mut bad = wire.clone();
        let last = bad.len() - 1;
        bad[last] ^= 0xFF;
        let mut f = Framer::new(Dialect::ColaB, 1024);
        f.push(&bad);
        f.push(&wire);
        let got = all(&mut f);
        assert!(matches!(got[0], Err(FrameError::Checksum { len: 9, .. })));
        assert_eq!(got.last(), Some(&Ok(b"sAN Run \x01".to_vec())));
        assert_eq!(f.stats().telegrams, 1);
        assert_eq!(f.stats().bad_checksum, 1);
    }

    #[test]
    fn cola_b_oversize_length_is_refused_without_waiting() {
        let mut f = Framer::new(Dialect::ColaB, 1024);
        f.push(&[2, 2, 2, 2, 0xFF, 0xFF, 0xFF, 0xFF]);
        assert!(matches!(
            f.next(),
            Some(Err(FrameError::Oversize {
                declared: Some(0xFFFF_FFFF),
                ..
            }))
        ));
        let mut wire = Vec::new();
        frame(Dialect::ColaB, b"sEA LMDscandata \x01", &mut wire);
        f.push(&wire);
        let got = all(&mut f);
        assert_eq!(got.last(), Some(&Ok(b"sEA LMDscandata \x01".to_vec())));
    }

    #[test]
    fn cola_b_pieces_byte_by_byte() {
        let mut wire = b"\x01\x02".to_vec();
        frame(Dialect::ColaB, b"sSN x", &mut wire);
        let mut f = Framer::new(Dialect::ColaB, 1024);
        let mut got = Vec::new();
        for b in &wire {
            f.push(std::slice::from_ref(b));
            got.extend(all(&mut f));
        }
        let ok: Vec<Vec<u8>> = got.into_iter().filter_map(Result::ok).collect();
        assert_eq!(ok, vec![b"sSN x".to_vec()]);
    }
}
