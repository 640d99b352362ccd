//! The requests a driver sends (log in, configure, run, stream) and the answers it gets, in
//! both dialects, and the device's own error codes.
//!
//! | request | CoLa-A | answer |
//! |---|---|---|
//! | [`Request::Login`] | `sMN SetAccessMode 03 F4724744` | `sAN SetAccessMode 1` (0: refused) |
//! | [`Request::ScanConfig`] | `sMN mLMPsetscancfg +2500 +1 +5000 -450000 +2250000` | `sAN mLMPsetscancfg 0 …` (non-zero: refused) |
//! | [`Request::OutputConfig`] | `sWN LMDscandatacfg 01 00 1 1 0 00 00 0 0 0 0 +1` | `sWA LMDscandatacfg` |
//! | [`Request::EchoFilter`] | `sWN FREchoFilter 1` | `sWA FREchoFilter` |
//! | [`Request::Run`] | `sMN Run` | `sAN Run 1` |
//! | [`Request::Stream`] | `sEN LMDscandata 1` | `sEA LMDscandata 1`, then `sSN LMDscandata …` |
//! | [`Request::ReadScan`] | `sRN LMDscandata` | `sRA LMDscandata …` |
//!
//! Any request may be answered `sFA` and an error code ([`sopas_error`]). In CoLa-B the command
//! and its name are the same text, followed by a space and the arguments in binary (big-endian,
//! the listing's sizes).

use std::io::Write;

use crate::cola::{Args, Dialect};

/// The "authorised client" level and its password hash (SICK's documented default, `client`).
pub const CLIENT_LEVEL: u8 = 3;
/// The authorised client's password hash.
pub const CLIENT_PASSWORD: u32 = 0xF472_4744;

/// A request to the scanner.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Request {
    /// `SetAccessMode`: log in at `level` with the password's hash.
    Login {
        /// User level (3: authorised client).
        level: u8,
        /// Password hash.
        password: u32,
    },
    /// `mLMPsetscancfg`: scan frequency (1/100 Hz), angular resolution (1/10 000°) and the
    /// scanned sector (1/10 000°, device angles), one sector.
    ScanConfig {
        /// Scan frequency, 1/100 Hz.
        frequency: u32,
        /// Angular step, 1/10 000°.
        resolution: u32,
        /// First angle, 1/10 000°.
        start: i32,
        /// Last angle, 1/10 000°.
        stop: i32,
    },
    /// `LMDscandatacfg`: what each scan telegram holds: remission or not, in 8 or 16 bits; no
    /// encoder, position, name, comment or time; every scan.
    OutputConfig {
        /// Send remission (`RSSI` channels).
        remission: bool,
        /// 16-bit remission (else 8-bit).
        remission_16bit: bool,
    },
    /// `FREchoFilter` (LMS5xx): 0 first echo, 1 all echoes, 2 last echo.
    EchoFilter(u8),
    /// `Run`: leave the configuration mode and measure.
    Run,
    /// `sEN LMDscandata`: stream every scan (true) or stop (false).
    Stream(bool),
    /// `sRN LMDscandata`: one scan.
    ReadScan,
}

impl Request {
    /// The command type and name, e.g. (`sMN`, `SetAccessMode`).
    pub fn command(&self) -> (&'static str, &'static str) {
        match self {
            Request::Login { .. } => ("sMN", "SetAccessMode"),
            Request::ScanConfig { .. } => ("sMN", "mLMPsetscancfg"),
            Request::OutputConfig { .. } => ("sWN", "LMDscandatacfg"),
            Request::EchoFilter(_) => ("sWN", "FREchoFilter"),
            Request::Run => ("sMN", "Run"),
            Request::Stream(_) => ("sEN", "LMDscandata"),
            Request::ReadScan => ("sRN", "LMDscandata"),
        }
    }

    /// The answer's command type (`sAN`, `sWA`, `sEA`, `sRA`).
    pub fn answer_type(&self) -> &'static str {
        match self.command().0 {
            "sMN" => "sAN",
            "sWN" => "sWA",
            "sEN" => "sEA",
            _ => "sRA",
        }
    }

    /// Appends the request's payload (no framing) in `dialect`.
    pub fn encode(&self, dialect: Dialect, out: &mut Vec<u8>) {
        let (kind, name) = self.command();
        let _ = write!(out, "{kind} {name}");
        let mut a = Args::new(dialect, out);
        match *self {
            Request::Login { level, password } => {
                a.hex(u32::from(level), 1, 2);
                a.hex(password, 4, 8);
            }
            Request::ScanConfig {
                frequency,
                resolution,
                start,
                stop,
            } => {
                a.dec(i64::from(frequency), 4);
                a.dec(1, 2);
                a.dec(i64::from(resolution), 4);
                a.dec(i64::from(start), 4);
                a.dec(i64::from(stop), 4);
            }
            Request::OutputConfig {
                remission,
                remission_16bit,
            } => {
                a.hex(1, 1, 2); // output channel 1 …
                a.hex(0, 1, 2); // … of two bytes
                a.hex(u32::from(remission), 1, 1);
                a.hex(u32::from(remission_16bit), 1, 1);
                a.hex(0, 1, 1); // unit of remission: digits
                a.hex(0, 1, 2); // encoder: none …
                a.hex(0, 1, 2); // … of two bytes
                for _ in 0..4 {
                    a.hex(0, 1, 1); // position, device name, comment, time: none
                }
                a.dec(1, 2); // every scan
            }
            Request::EchoFilter(f) => _ = a.hex(u32::from(f), 1, 1),
            Request::Run | Request::ReadScan => {}
            Request::Stream(on) => _ = a.hex(u32::from(on), 1, 1),
        }
    }
}

/// An answer from the scanner (anything but a scan).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Answer {
    /// `sAN`, `sWA`, `sEA`, `sRA`, `sFA`, …
    pub kind: [u8; 3],
    /// The method or variable (empty for `sFA`).
    pub name: String,
    /// The first argument (a method's result, an event's state, `sFA`'s error code).
    pub first: Option<u32>,
}

impl Answer {
    /// Parses an answer's payload; `None` when it is not one (too short, not ASCII where the
    /// command should be).
    pub fn parse(dialect: Dialect, p: &[u8]) -> Option<Answer> {
        if p.len() < 3 || !p[..3].iter().all(u8::is_ascii_alphabetic) {
            return None;
        }
        let kind = [p[0], p[1], p[2]];
        let rest = p.get(4..).unwrap_or(&[]);
        if &kind == b"sFA" {
            let first = match dialect {
                Dialect::ColaA => std::str::from_utf8(rest)
                    .ok()
                    .and_then(|t| u32::from_str_radix(t.trim(), 16).ok()),
                Dialect::ColaB => {
                    let r = p.get(3..).unwrap_or(&[]);
                    let r = r.strip_prefix(b" ").unwrap_or(r);
                    (!r.is_empty() && r.len() <= 4)
                        .then(|| r.iter().fold(0u32, |a, &b| a << 8 | u32::from(b)))
                }
            };
            return Some(Answer {
                kind,
                name: String::new(),
                first,
            });
        }
        let end = rest.iter().position(|&b| b == b' ').unwrap_or(rest.len());
        let name = std::str::from_utf8(&rest[..end]).ok()?.to_string();
        let args = rest.get(end + 1..).unwrap_or(&[]);
        let first = match dialect {
            Dialect::ColaA => {
                let t = args.split(|&b| b == b' ').next().unwrap_or(&[]);
                std::str::from_utf8(t).ok().and_then(|t| {
                    t.strip_prefix('+')
                        .map_or_else(|| u32::from_str_radix(t, 16).ok(), |d| d.parse().ok())
                })
            }
            Dialect::ColaB => args.first().map(|&b| u32::from(b)),
        };
        Some(Answer { kind, name, first })
    }

    /// The kind as text.
    pub fn kind_str(&self) -> &str {
        std::str::from_utf8(&self.kind).unwrap_or("???")
    }
}

/// The name of a SOPAS error code (`sFA`), from SICK's CoLa documentation.
pub fn sopas_error(code: u32) -> &'static str {
    match code {
        1 => "access denied (log in first)",
        2 => "unknown method",
        3 => "unknown variable",
        4 => "local condition failed (e.g. not in configuration mode)",
        5 => "invalid data",
        6 => "unknown error",
        7 => "buffer overflow",
        8 => "buffer underflow",
        9 => "unknown type",
        0x0A => "variable write access denied",
        0x0B => "unknown command for the name server",
        0x0C => "unknown CoLa command",
        0x0D => "method server busy",
        0x0E => "flex array out of bounds",
        0x0F => "unknown event",
        0x10 => "CoLa-A value overflow",
        0x11 => "invalid CoLa-A character",
        _ => "undocumented error code",
    }
}

/// The meaning of `mLMPsetscancfg`'s result.
pub fn scancfg_error(code: u32) -> &'static str {
    match code {
        0 => "no error",
        1 => "frequency not supported",
        2 => "resolution not supported",
        3 => "resolution and scan area not supported",
        4 => "scan area not supported",
        _ => "other error",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(r: Request) -> String {
        let mut v = Vec::new();
        r.encode(Dialect::ColaA, &mut v);
        String::from_utf8(v).expect("ascii")
    }

    #[test]
    fn cola_a_requests_are_the_documented_text() {
        let login = Request::Login {
            level: CLIENT_LEVEL,
            password: CLIENT_PASSWORD,
        };
        assert_eq!(text(login), "sMN SetAccessMode 03 F4724744");
        let cfg = Request::ScanConfig {
            frequency: 2500,
            resolution: 5000,
            start: -450_000,
            stop: 2_250_000,
        };
        assert_eq!(
            text(cfg),
            "sMN mLMPsetscancfg +2500 +1 +5000 -450000 +2250000"
        );
        let out = Request::OutputConfig {
            remission: true,
            remission_16bit: false,
        };
        assert_eq!(text(out), "sWN LMDscandatacfg 01 00 1 0 0 00 00 0 0 0 0 +1");
        assert_eq!(text(Request::Stream(true)), "sEN LMDscandata 1");
        assert_eq!(text(Request::Run), "sMN Run");
    }

    #[test]
    fn cola_b_requests_put_binary_arguments_after_one_space() {
        let mut v = Vec::new();
        Request::Login {
            level: 3,
            password: CLIENT_PASSWORD,
        }
        .encode(Dialect::ColaB, &mut v);
        assert_eq!(v, b"sMN SetAccessMode \x03\xF4\x72\x47\x44");
        v.clear();
        Request::Stream(true).encode(Dialect::ColaB, &mut v);
        assert_eq!(v, b"sEN LMDscandata \x01");
        v.clear();
        Request::ScanConfig {
            frequency: 2500,
            resolution: 5000,
            start: -450_000,
            stop: 2_250_000,
        }
        .encode(Dialect::ColaB, &mut v);
        let args = &v[b"sMN mLMPsetscancfg ".len()..];
        assert_eq!(args.len(), 4 + 2 + 4 + 4 + 4);
        assert_eq!(&args[10..14], &(-450_000i32).to_be_bytes());
    }

    #[test]
    fn answers_parse_in_both_dialects() {
        let a = Answer::parse(Dialect::ColaA, b"sAN SetAccessMode 1").expect("answer");
        assert_eq!(
            (a.kind_str(), a.name.as_str(), a.first),
            ("sAN", "SetAccessMode", Some(1))
        );
        let a = Answer::parse(Dialect::ColaB, b"sEA LMDscandata \x01").expect("answer");
        assert_eq!((a.name.as_str(), a.first), ("LMDscandata", Some(1)));
        let a = Answer::parse(Dialect::ColaA, b"sFA A").expect("error");
        assert_eq!(a.first, Some(10));
        assert_eq!(sopas_error(10), "variable write access denied");
        let a = Answer::parse(Dialect::ColaA, b"sWA LMDscandatacfg").expect("answer");
        assert_eq!(a.first, None);
        assert!(Answer::parse(Dialect::ColaA, b"\x01\x02").is_none());
    }
}
