//! The simulated SICK served over TCP (`sim.sick = true`, issue 26): what `mimnav-sick`
//! connects to in place of a scanner. Wiring only: the protocol is the emulated scanner's
//! ([`Device`]), the measurements the simulator's ([`SickScanner`], cast from the robot's pose
//! of the moment).
//!
//! Non-blocking, polled from the simulator's loop after every packet: nothing a client does
//! can hold the simulation up. One client at a time: a new connection replaces the current one
//! (a driver that gave up and reconnects must not find its old, half-dead socket in the way),
//! and each client starts with a fresh protocol state ([`Device::disconnect`]: it logs in and
//! starts the stream again). While the client streams, a scan is sent every period of the
//! scanner's mode in simulated time. A client that closes, fails, or leaves what was sent to it
//! untaken for `sim.sick_stall_s` (or piles up more than [`MAX_PENDING`] bytes) is dropped and
//! counted; the warnings are rate-limited by the service's fault counters.

use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use mimnav_config::Config;
use mimnav_shared::service::Health;
use mimnav_sick::device::Device;
use mimnav_sim::Sim;
use mimnav_sim::sick::{SickScan, SickScanner};

/// A client holding more than this, unsent, is dropped as stalled (about 40 LMS1xx scans).
pub const MAX_PENDING: usize = 1 << 20;

struct Client {
    stream: TcpStream,
    peer: SocketAddr,
    /// Bytes not yet taken by the client.
    pending: Vec<u8>,
    /// When the client last took bytes (or connected).
    progress: Instant,
}

/// The listening scanner.
pub struct SickServer {
    listener: TcpListener,
    client: Option<Client>,
    device: Device,
    scanner: SickScanner,
    scan: SickScan,
    next_scan_ns: Option<u64>,
    stall: Duration,
    buf: Vec<u8>,
    /// Clients accepted, clients dropped, scans sent.
    pub stats: (u64, u64, u64),
}

impl SickServer {
    /// Listens at `sim.sick_bind`:`sim.sick_port` for a scanner set up as `[sick]` says.
    pub fn open(config: &Config) -> Result<Self> {
        let at = SocketAddr::new(config.sim.sick_bind, config.sim.sick_port);
        config
            .sick
            .mode()
            .map_err(|e| anyhow::anyhow!("[sick]: {e}"))?;
        let listener = TcpListener::bind(at)
            .with_context(|| format!("sim.sick: cannot listen on {at} (sim.sick_port)"))?;
        listener
            .set_nonblocking(true)
            .context("sim.sick: cannot make the listener non-blocking")?;
        let sick = &config.sick;
        tracing::info!(%at, model = sick.model.spec().name, "simulated SICK listening");
        Ok(SickServer {
            listener,
            client: None,
            device: Device::new(sick.model, sick.protocol, config.sim.seed as u32),
            scanner: SickScanner::new(sick, &config.sim, config.sim.seed),
            scan: SickScan::default(),
            next_scan_ns: None,
            stall: Duration::from_secs_f64(config.sim.sick_stall_s),
            buf: vec![0; 64 * 1024],
            stats: (0, 0, 0),
        })
    }

    /// Accepts, reads the client's requests and answers them, sends a scan when one is due at
    /// the simulator's time, writes what the socket takes. Never blocks.
    pub fn poll(&mut self, sim: &Sim, h: &mut Health) {
        self.accept(h);
        let Some(c) = self.client.as_mut() else {
            return;
        };
        let now = Instant::now();
        // the requests
        let mut gone = None;
        for _ in 0..16 {
            match c.stream.read(&mut self.buf) {
                Ok(0) => {
                    gone = Some("closed the connection".to_string());
                    break;
                }
                Ok(n) => self.device.receive(&self.buf[..n], &mut c.pending),
                Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => {
                    gone = Some(format!("failed: {e}"));
                    break;
                }
            }
        }
        // a scan when one is due
        if gone.is_none() && self.device.streaming() {
            let t = sim.now_ns();
            let g = self.device.geometry();
            let period = (1e9 / g.frequency_hz.max(1e-3)) as u64;
            let due = *self.next_scan_ns.get_or_insert(t);
            if t >= due {
                sim.sick_scan(&mut self.scanner, &g, &mut self.scan);
                let time_us = (t / 1000) as u32;
                self.device.scan_telegram(
                    time_us,
                    &self.scan.echoes,
                    &self.scan.remission,
                    &mut c.pending,
                );
                self.stats.2 += 1;
                // behind by more than a period (a slow host): on from now, no burst
                let next = due + period;
                self.next_scan_ns = Some(if next <= t { t + period } else { next });
            }
        } else {
            self.next_scan_ns = None;
        }
        // what the socket takes
        while gone.is_none() && !c.pending.is_empty() {
            match c.stream.write(&c.pending) {
                Ok(0) => gone = Some("takes nothing".to_string()),
                Ok(n) => {
                    c.pending.drain(..n);
                    c.progress = now;
                }
                Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => gone = Some(format!("failed: {e}")),
            }
        }
        if gone.is_none() && !c.pending.is_empty() {
            if c.pending.len() > MAX_PENDING {
                gone = Some(format!("left {} bytes untaken", c.pending.len()));
            } else if now.duration_since(c.progress) > self.stall {
                gone = Some(format!("took nothing for {:?}", self.stall));
            }
        }
        if c.pending.is_empty() {
            c.progress = now;
        }
        if let Some(why) = gone {
            let peer = c.peer;
            self.drop_client(h, format_args!("SICK client {peer} {why}: dropped"));
        }
    }

    fn accept(&mut self, h: &mut Health) {
        loop {
            match self.listener.accept() {
                Ok((stream, peer)) => {
                    if let Err(e) = stream
                        .set_nonblocking(true)
                        .and_then(|()| stream.set_nodelay(true))
                    {
                        h.faults.record(
                            "sick_client_failed",
                            Instant::now(),
                            format_args!("SICK client {peer}: {e}"),
                        );
                        continue;
                    }
                    if let Some(old) = &self.client {
                        let old = old.peer;
                        self.drop_client(
                            h,
                            format_args!("SICK client {old} replaced by {peer}: dropped"),
                        );
                    }
                    self.device.disconnect();
                    self.next_scan_ns = None;
                    self.stats.0 += 1;
                    tracing::info!(%peer, "SICK client connected");
                    self.client = Some(Client {
                        stream,
                        peer,
                        pending: Vec::new(),
                        progress: Instant::now(),
                    });
                }
                Err(e) if e.kind() == ErrorKind::WouldBlock => return,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => {
                    h.faults.record(
                        "sick_accept_failed",
                        Instant::now(),
                        format_args!("SICK listener: {e}"),
                    );
                    return;
                }
            }
        }
    }

    fn drop_client(&mut self, h: &mut Health, why: std::fmt::Arguments<'_>) {
        self.client = None;
        self.device.disconnect();
        self.next_scan_ns = None;
        self.stats.1 += 1;
        h.faults.record("sick_client_dropped", Instant::now(), why);
    }
}
