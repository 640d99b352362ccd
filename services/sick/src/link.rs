//! The driver's connection to a scanner over TCP: connect, run the [`Session`], turn every
//! scan into returns and a [`ScanHeader`], and start again with back-off when anything fails.
//! The only module with I/O; it blocks, so the service runs it on a thread of its own.
//!
//! **Back-off.** After a failed connection (refused, timed out, a refused request, a lost or
//! silent link) the next attempt waits `sick.reconnect_min_s`, doubled after each further
//! failure up to `sick.reconnect_max_s` (0.5 s by default), and back to the minimum once a
//! scan arrives. A scanner that comes back is therefore streaming again within the longest wait
//! plus its start-up exchange and one scan period: well under a second at the defaults.
//!
//! **Time.** `stamp_ns` is the scan's start: the host's clock when its telegram arrived, less
//! the time the device says passed between the scan's start and the telegram's transmission
//! (both in its own µs clock), so the network's delay (sub-millisecond on a robot's Ethernet)
//! is the only error. `seq` follows the device's scan counter, so scans the device made but
//! the driver never got show as gaps to a subscriber; a counter that jumps back (the scanner
//! restarted) or far ahead continues by one.

use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use mimnav_shared::ipc::{monotonic_ns, realtime_ns};
use mimnav_shared::topics::{ScanHeader, ScanReturn};

use crate::config::SickConfig;
use crate::convert::Converter;
use crate::scandata::ScanData;
use crate::session::{Event, Session};
use crate::status;

/// What the link tells its owner.
#[derive(Debug)]
pub enum LinkEvent<'a> {
    /// A scan, converted.
    Scan {
        /// The `lidar/scan2d` header.
        header: ScanHeader,
        /// The returns.
        returns: &'a [ScanReturn],
    },
    /// Connected; the start-up requests are on their way.
    Connected(SocketAddr),
    /// Every start-up request was answered.
    Streaming,
    /// The connection was given up (or could not be made); the next attempt is after `retry`.
    Down {
        /// Why.
        why: String,
        /// The wait before the next attempt.
        retry: Duration,
    },
    /// The device status changed: `None` is fine, else what it says.
    DeviceStatus(Option<String>),
    /// Something counted: a damaged telegram, an unexpected answer, a scan that did not convert.
    Fault {
        /// A short name for the counters (`bad_checksum`, `truncated`, …).
        kind: &'static str,
        /// What and where.
        what: String,
    },
}

/// A connection to a scanner, kept up.
#[derive(Debug)]
pub struct Link {
    host: String,
    port: u16,
    connect_timeout: Duration,
    reconnect_min: Duration,
    reconnect_max: Duration,
    session: Session,
    converter: Converter,
    returns: Vec<ScanReturn>,
    buf: Vec<u8>,
    seq: u64,
    last_counter: Option<u16>,
    status: [u8; 2],
    backoff: Duration,
}

/// How long a blocking read waits before the link checks its timers and the stop flag.
const READ_SLICE: Duration = Duration::from_millis(20);

impl Link {
    /// A link with `[sick]`'s settings.
    pub fn new(cfg: &SickConfig) -> Self {
        let secs = Duration::from_secs_f64;
        Link {
            host: cfg.host.clone(),
            port: cfg.port,
            connect_timeout: secs(cfg.connect_timeout_s),
            reconnect_min: secs(cfg.reconnect_min_s),
            reconnect_max: secs(cfg.reconnect_max_s),
            session: Session::new(cfg.session()),
            converter: cfg.converter(),
            returns: Vec::with_capacity(cfg.max_returns()),
            buf: vec![0; 64 * 1024],
            seq: 0,
            last_counter: None,
            status: [0, 0],
            backoff: secs(cfg.reconnect_min_s),
        }
    }

    /// Runs until `stop` is set: connects, streams, reconnects.
    pub fn run(&mut self, stop: &AtomicBool, mut on: impl FnMut(LinkEvent<'_>)) {
        while !stop.load(Ordering::Relaxed) {
            let why = match self.connect() {
                Ok(mut stream) => {
                    if let Ok(a) = stream.peer_addr() {
                        on(LinkEvent::Connected(a));
                    }
                    self.stream(&mut stream, stop, &mut on)
                }
                Err(e) => e,
            };
            if stop.load(Ordering::Relaxed) {
                break;
            }
            let retry = self.backoff;
            on(LinkEvent::Down { why, retry });
            self.backoff = (self.backoff * 2).min(self.reconnect_max);
            let until = Instant::now() + retry;
            while !stop.load(Ordering::Relaxed) && Instant::now() < until {
                std::thread::sleep((until - Instant::now()).min(READ_SLICE));
            }
        }
    }

    fn connect(&self) -> Result<TcpStream, String> {
        let target = format!("{}:{}", self.host, self.port);
        let addrs: Vec<SocketAddr> = (self.host.as_str(), self.port)
            .to_socket_addrs()
            .map_err(|e| format!("{target}: cannot resolve: {e}"))?
            .collect();
        let mut last = format!("{target}: no address");
        for a in addrs {
            match TcpStream::connect_timeout(&a, self.connect_timeout) {
                Ok(s) => {
                    let _ = s.set_nodelay(true);
                    s.set_read_timeout(Some(READ_SLICE))
                        .map_err(|e| format!("{target}: {e}"))?;
                    s.set_write_timeout(Some(self.connect_timeout))
                        .map_err(|e| format!("{target}: {e}"))?;
                    return Ok(s);
                }
                Err(e) => last = format!("{target}: cannot connect: {e}"),
            }
        }
        Err(last)
    }

    /// Streams until the connection fails; returns why.
    fn stream(
        &mut self,
        stream: &mut TcpStream,
        stop: &AtomicBool,
        on: &mut impl FnMut(LinkEvent<'_>),
    ) -> String {
        let mut out = Vec::with_capacity(256);
        self.session.begin(monotonic_ns(), &mut out);
        self.last_counter = None;
        loop {
            if !out.is_empty() {
                if let Err(e) = stream.write_all(&out) {
                    return format!("writing to the scanner: {e}");
                }
                out.clear();
            }
            if stop.load(Ordering::Relaxed) {
                return "stopping".into();
            }
            let n = match stream.read(&mut self.buf) {
                Ok(0) => return "the scanner closed the connection".into(),
                Ok(n) => n,
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => 0,
                Err(e) if e.kind() == ErrorKind::Interrupted => 0,
                Err(e) => return format!("reading from the scanner: {e}"),
            };
            let (mono, real) = (monotonic_ns(), realtime_ns());
            let mut refused = None;
            if n > 0 {
                let Link {
                    session,
                    converter,
                    returns,
                    buf,
                    seq,
                    last_counter,
                    status,
                    backoff,
                    reconnect_min,
                    ..
                } = self;
                session.receive(&buf[..n], mono, &mut out, |e| match e {
                    Event::Scan(sd) => {
                        if sd.device_status != *status {
                            *status = sd.device_status;
                            on(LinkEvent::DeviceStatus(status::describe(*status)));
                        }
                        match converter.convert(sd, returns) {
                            Ok(_) => {
                                *seq = next_seq(*seq, last_counter, sd.scan_counter);
                                *backoff = *reconnect_min;
                                let header = header(sd, *seq, real, mono, returns.len(), converter);
                                on(LinkEvent::Scan { header, returns });
                            }
                            Err(e) => on(LinkEvent::Fault {
                                kind: "convert_failed",
                                what: e.to_string(),
                            }),
                        }
                    }
                    Event::Answered(r) => {
                        let (kind, name) = r.command();
                        tracing::debug!("{kind} {name} answered");
                    }
                    Event::Streaming => on(LinkEvent::Streaming),
                    Event::Refused { why, .. } => refused = Some(why),
                    Event::Unexpected(what) => on(LinkEvent::Fault {
                        kind: "unexpected",
                        what,
                    }),
                    Event::Frame(e) => on(LinkEvent::Fault {
                        kind: e.kind(),
                        what: e.to_string(),
                    }),
                    Event::BadScan(e) => on(LinkEvent::Fault {
                        kind: e.kind,
                        what: e.to_string(),
                    }),
                });
            }
            if let Some(why) = refused {
                return format!("the scanner refused {why}");
            }
            if let Err(e) = self.session.check(monotonic_ns()) {
                return e.to_string();
            }
        }
    }
}

/// The next `seq`: by the device's scan counter's step when it is plausible, else by one.
fn next_seq(seq: u64, last: &mut Option<u16>, counter: u16) -> u64 {
    let step = match last.replace(counter) {
        Some(prev) => {
            let d = counter.wrapping_sub(prev);
            if (1..1000).contains(&d) {
                u64::from(d)
            } else {
                1
            }
        }
        None => 1,
    };
    seq + step
}

fn header(
    sd: &ScanData,
    seq: u64,
    real_ns: u64,
    mono_ns: u64,
    count: usize,
    c: &Converter,
) -> ScanHeader {
    let took_us = sd
        .time_of_transmission_us
        .wrapping_sub(sd.time_since_startup_us);
    // a transmission more than a second after the scan's start is a device clock oddity
    let took_ns = if took_us < 1_000_000 {
        u64::from(took_us) * 1000
    } else {
        0
    };
    ScanHeader {
        seq,
        stamp_ns: real_ns.saturating_sub(took_ns),
        rx_mono_ns: mono_ns,
        count: count as u32,
        elevation_rad: 0.0,
        laser_id: 0,
        return_select: c.echo.return_type(),
        reserved: [0; 6],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seq_follows_the_scan_counter_and_survives_its_oddities() {
        let mut last = None;
        let s = next_seq(0, &mut last, 65_534);
        assert_eq!(s, 1);
        let s = next_seq(s, &mut last, 65_535);
        assert_eq!(s, 2);
        // wraps; two scans missed
        let s = next_seq(s, &mut last, 2);
        assert_eq!(s, 5);
        // the scanner restarted: by one
        let s = next_seq(s, &mut last, 0);
        assert_eq!(s, 6);
    }
}
