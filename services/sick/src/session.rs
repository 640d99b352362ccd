//! One connection to a scanner, without I/O: the start-up requests in order, each sent when
//! the previous one is answered, then the stream of scans. The service reads the socket and
//! gives [`Session::receive`] the bytes; what to write back comes out in a buffer; the events
//! (a scan, an answer, a refusal, a damaged telegram) go to a callback. [`Session::check`]
//! says when the connection must be given up: an answer that does not come, a scanner that
//! stops streaming.

use crate::cola::{Dialect, FrameError, Framer, frame};
use crate::command::{Answer, Request, scancfg_error, sopas_error};
use crate::scandata::{SCAN_COMMANDS, ScanData, ScanError};

/// A session's settings ([`crate::SickConfig::session`]).
#[derive(Debug, Clone, PartialEq)]
pub struct SessionConfig {
    /// The dialect.
    pub dialect: Dialect,
    /// The requests sent after connecting, in order; the last should start the stream.
    pub requests: Vec<Request>,
    /// An answer must come within this, ns.
    pub answer_timeout_ns: u64,
    /// No scan for this long while streaming gives the connection up, ns.
    pub silence_ns: u64,
    /// The longest telegram accepted, bytes.
    pub max_telegram: usize,
}

/// What happened in [`Session::receive`].
#[derive(Debug)]
pub enum Event<'a> {
    /// A scan, parsed.
    Scan(&'a ScanData),
    /// A start-up request was answered as hoped.
    Answered(Request),
    /// Every start-up request is answered: scans should flow.
    Streaming,
    /// The scanner refused a start-up request: the connection should be given up (and tried
    /// again later: a refused login or scan configuration is a setting to fix).
    Refused {
        /// The request.
        request: Request,
        /// Why, in the device's words where it has some.
        why: String,
    },
    /// A telegram that is not a scan and answers nothing asked (counted, ignored).
    Unexpected(String),
    /// Bytes thrown away by the framer.
    Frame(FrameError),
    /// A telegram that claimed to be a scan and did not parse.
    BadScan(ScanError),
}

/// Why a connection must be given up.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Stalled {
    /// A start-up request went unanswered.
    #[error("no answer to {0} within {1} ms")]
    NoAnswer(String, u64),
    /// Streaming, but no scan came.
    #[error("no scan for {0} ms")]
    Silent(u64),
}

/// Counters of one session (kept over reconnections by the caller if it wishes).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SessionStats {
    /// Scans parsed.
    pub scans: u64,
    /// Scan telegrams that did not parse.
    pub bad_scans: u64,
    /// Answers to start-up requests.
    pub answers: u64,
    /// Telegrams answering nothing asked.
    pub unexpected: u64,
}

/// One connection's protocol state.
#[derive(Debug)]
pub struct Session {
    cfg: SessionConfig,
    framer: Framer,
    scan: ScanData,
    /// The request waiting for its answer (an index into `cfg.requests`); `len` when all are
    /// answered.
    step: usize,
    asked_ns: u64,
    last_scan_ns: u64,
    stats: SessionStats,
}

impl Session {
    /// A session with `cfg`; nothing is sent before [`Session::begin`].
    pub fn new(cfg: SessionConfig) -> Self {
        Session {
            framer: Framer::new(cfg.dialect, cfg.max_telegram),
            step: cfg.requests.len(),
            cfg,
            scan: ScanData::default(),
            asked_ns: 0,
            last_scan_ns: 0,
            stats: SessionStats::default(),
        }
    }

    /// The dialect.
    pub fn dialect(&self) -> Dialect {
        self.cfg.dialect
    }

    /// Counters.
    pub fn stats(&self) -> SessionStats {
        self.stats
    }

    /// The framer's counters.
    pub fn frame_stats(&self) -> crate::cola::FrameStats {
        self.framer.stats()
    }

    /// Bytes held, waiting for the rest of a telegram (never more than the longest telegram
    /// accepted once [`Session::receive`] returns).
    pub fn pending(&self) -> usize {
        self.framer.pending()
    }

    /// True once every start-up request is answered.
    pub fn streaming(&self) -> bool {
        self.step >= self.cfg.requests.len()
    }

    /// A new connection: forgets what was held and writes the first request to `out`.
    pub fn begin(&mut self, now_ns: u64, out: &mut Vec<u8>) {
        self.framer.reset();
        self.step = 0;
        self.last_scan_ns = now_ns;
        self.ask(now_ns, out);
    }

    fn ask(&mut self, now_ns: u64, out: &mut Vec<u8>) {
        if let Some(r) = self.cfg.requests.get(self.step) {
            let mut p = Vec::with_capacity(64);
            r.encode(self.cfg.dialect, &mut p);
            frame(self.cfg.dialect, &p, out);
            self.asked_ns = now_ns;
        }
    }

    /// Bytes from the socket: requests to write go to `out`, events to `on`.
    pub fn receive(
        &mut self,
        bytes: &[u8],
        now_ns: u64,
        out: &mut Vec<u8>,
        mut on: impl FnMut(Event<'_>),
    ) {
        self.framer.push(bytes);
        loop {
            let payload = match self.framer.next() {
                None => break,
                Some(Err(e)) => {
                    on(Event::Frame(e));
                    continue;
                }
                Some(Ok(p)) => p,
            };
            if SCAN_COMMANDS.iter().any(|c| payload.starts_with(c)) {
                match self.scan.parse(self.cfg.dialect, payload) {
                    Ok(()) => {
                        self.stats.scans += 1;
                        self.last_scan_ns = now_ns;
                        on(Event::Scan(&self.scan));
                    }
                    Err(e) => {
                        self.stats.bad_scans += 1;
                        on(Event::BadScan(e));
                    }
                }
                continue;
            }
            let dialect = self.cfg.dialect;
            let Some(answer) = Answer::parse(dialect, payload) else {
                self.stats.unexpected += 1;
                let shown = String::from_utf8_lossy(&payload[..payload.len().min(32)]);
                on(Event::Unexpected(format!("not a CoLa telegram: {shown:?}")));
                continue;
            };
            let Some(&request) = self.cfg.requests.get(self.step) else {
                self.stats.unexpected += 1;
                on(Event::Unexpected(describe(&answer)));
                continue;
            };
            match judge(&request, &answer) {
                Verdict::Ok => {
                    self.stats.answers += 1;
                    self.step += 1;
                    on(Event::Answered(request));
                    if self.streaming() {
                        self.last_scan_ns = now_ns;
                        on(Event::Streaming);
                    } else {
                        self.ask(now_ns, out);
                    }
                }
                Verdict::Refused(why) => {
                    self.stats.answers += 1;
                    on(Event::Refused { request, why });
                }
                Verdict::Other => {
                    self.stats.unexpected += 1;
                    on(Event::Unexpected(describe(&answer)));
                }
            }
        }
    }

    /// Whether the connection must be given up at `now_ns`.
    pub fn check(&self, now_ns: u64) -> Result<(), Stalled> {
        if let Some(r) = self.cfg.requests.get(self.step) {
            if now_ns.saturating_sub(self.asked_ns) > self.cfg.answer_timeout_ns {
                let (kind, name) = r.command();
                return Err(Stalled::NoAnswer(
                    format!("{kind} {name}"),
                    self.cfg.answer_timeout_ns / 1_000_000,
                ));
            }
        } else if now_ns.saturating_sub(self.last_scan_ns) > self.cfg.silence_ns {
            return Err(Stalled::Silent(self.cfg.silence_ns / 1_000_000));
        }
        Ok(())
    }
}

enum Verdict {
    Ok,
    Refused(String),
    Other,
}

fn describe(a: &Answer) -> String {
    format!("{} {} {:?}", a.kind_str(), a.name, a.first)
}

/// Is `a` the answer to `r`, and a good one?
fn judge(r: &Request, a: &Answer) -> Verdict {
    if &a.kind == b"sFA" {
        let code = a.first.unwrap_or(0);
        let (kind, name) = r.command();
        return Verdict::Refused(format!(
            "{kind} {name}: device error {code:#X}: {}",
            sopas_error(code)
        ));
    }
    let (_, name) = r.command();
    if a.kind_str() != r.answer_type() || a.name != name {
        return Verdict::Other;
    }
    match r {
        Request::Login { .. } if a.first != Some(1) => {
            Verdict::Refused("SetAccessMode: the password was refused".into())
        }
        Request::ScanConfig { .. } if a.first.is_some_and(|c| c != 0) => {
            let c = a.first.unwrap_or(0);
            Verdict::Refused(format!("mLMPsetscancfg: {}", scancfg_error(c)))
        }
        Request::Run if a.first == Some(0) => Verdict::Refused("Run: refused".into()),
        Request::Stream(true) if a.first == Some(0) => {
            Verdict::Refused("sEN LMDscandata: refused".into())
        }
        _ => Verdict::Ok,
    }
}
