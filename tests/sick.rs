//! `mimnav-sick` as a process against an emulated SICK on a loopback TCP port (issue 26): the
//! login and start sequence, streamed scans (the real TiM5xx telegrams of `../shared/data/sick`
//! where that folder is, else the emulator's own), then damaged telegrams of every class,
//! partial reads, a disconnect and a scanner that is away for a while. Every damaged telegram
//! is counted under its name, nothing crashes, and scans flow again within a second of the
//! scanner coming back.

use std::io::{ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::PathBuf;
use std::process::Stdio;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use mimnav_shared::ipc::{self, PrivateDomain};
use mimnav_sick::cola::{Dialect, frame};
use mimnav_sick::config::Model;
use mimnav_sick::device::Device;

use crate::util::{Proc, bin, config_args, lines_of};

/// What the test asks of the emulated scanner.
#[derive(Default)]
struct Plan {
    /// Closed: no listener, no client (connections are refused).
    down: AtomicBool,
    /// Write in pieces of this many bytes (0: whole).
    pieces: AtomicUsize,
    /// Bytes written before the next scan.
    inject: Mutex<Vec<Vec<u8>>>,
    /// Drop the client now.
    hang_up: AtomicBool,
    /// Scans written.
    scans: AtomicUsize,
    /// Connections accepted.
    accepted: AtomicUsize,
    /// The device status's second byte sent with the emulator's own scans (2: pollution warning).
    status: AtomicUsize,
    stop: AtomicBool,
}

struct Scanner {
    port: u16,
    plan: Arc<Plan>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Drop for Scanner {
    fn drop(&mut self) {
        self.plan.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The real TiM5xx telegram streamed after `sEN LMDscandata 1`, framed, if the shared data is
/// here.
fn real_tim() -> Option<Vec<u8>> {
    let dir = match std::env::var_os("MIMNAV_SHARED_DATA") {
        Some(d) => PathBuf::from(d).join("sick"),
        None => crate::util::root().join("../shared/data/sick"),
    };
    let t = std::fs::read(dir.join("tim5xx_continuous_scan.cola")).ok();
    if t.is_none() {
        println!(
            "SKIP the real telegrams: none at {} (the emulator's own scans are streamed)",
            dir.display()
        );
    }
    t
}

fn write_all(c: &mut TcpStream, bytes: &[u8], pieces: usize) -> std::io::Result<()> {
    if pieces == 0 {
        return c.write_all(bytes);
    }
    // one segment each (TCP_NODELAY): the driver's reads see pieces, not whole telegrams
    for p in bytes.chunks(pieces) {
        c.write_all(p)?;
    }
    Ok(())
}

fn scanner(model: Model, dialect: Dialect, real: Option<Vec<u8>>) -> Scanner {
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
    let port = listener.local_addr().expect("addr").port();
    let plan = Arc::new(Plan::default());
    let p = Arc::clone(&plan);
    let thread = std::thread::spawn(move || {
        let mut listener = Some(listener);
        let mut dev = Device::new(model, dialect, 0x0107_375C);
        let period = Duration::from_secs_f64(1.0 / dev.geometry().frequency_hz);
        let mut client: Option<TcpStream> = None;
        let (mut next, mut buf, mut out) = (Instant::now(), [0u8; 4096], Vec::new());
        let mut t_us = 0u32;
        while !p.stop.load(Ordering::Relaxed) {
            if p.down.load(Ordering::Relaxed) {
                (listener, client) = (None, None);
                std::thread::sleep(Duration::from_millis(5));
                continue;
            }
            if p.hang_up.swap(false, Ordering::Relaxed) {
                client = None;
            }
            let l = listener.get_or_insert_with(|| {
                // the same port again (std sets SO_REUSEADDR)
                TcpListener::bind(("127.0.0.1", port)).expect("rebind")
            });
            l.set_nonblocking(true).expect("nonblocking");
            if let Ok((c, _)) = l.accept() {
                c.set_nonblocking(true).expect("nonblocking");
                c.set_nodelay(true).expect("nodelay");
                dev.disconnect();
                p.accepted.fetch_add(1, Ordering::Relaxed);
                client = Some(c);
            }
            let Some(c) = client.as_mut() else {
                std::thread::sleep(Duration::from_millis(2));
                continue;
            };
            match c.read(&mut buf) {
                Ok(0) => {
                    client = None;
                    continue;
                }
                Ok(n) => dev.receive(&buf[..n], &mut out),
                Err(e) if e.kind() == ErrorKind::WouldBlock => {}
                Err(_) => {
                    client = None;
                    continue;
                }
            }
            let pieces = p.pieces.load(Ordering::Relaxed);
            c.set_nonblocking(false).expect("blocking");
            let mut ok = write_all(c, &std::mem::take(&mut out), 0).is_ok();
            if ok && dev.streaming() && Instant::now() >= next {
                next += period;
                for bad in std::mem::take(&mut *p.inject.lock().expect("lock")) {
                    ok &= write_all(c, &bad, pieces).is_ok();
                }
                let mut scan = Vec::new();
                match &real {
                    Some(t) => scan.extend_from_slice(t),
                    None => {
                        dev.status = [0, p.status.load(Ordering::Relaxed) as u8];
                        let g = dev.geometry();
                        t_us = t_us.wrapping_add(period.as_micros() as u32);
                        let d: Vec<u16> = (0..g.count).map(|i| 1000 + i as u16).collect();
                        let r = vec![100u16; g.count];
                        dev.scan_telegram(t_us, &[d], &[r], &mut scan);
                    }
                }
                ok &= write_all(c, &scan, pieces).is_ok();
                p.scans.fetch_add(1, Ordering::Relaxed);
            }
            if ok {
                c.set_nonblocking(true).expect("nonblocking");
            } else {
                client = None;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
    });
    Scanner {
        port,
        plan,
        thread: Some(thread),
    }
}

/// A received scan: its count, its seq and each return's (bearing, range, intensity).
type Got = (u32, u64, Vec<(f32, f32, u8)>);

/// The service, its stderr lines, and a subscriber of `lidar/scan2d`.
struct Service {
    proc: Proc,
    log: std::sync::mpsc::Receiver<String>,
    _node: iceoryx2::node::Node<ipc::Svc>,
    scans: ipc::ScanSubscriber,
    _domain: PrivateDomain,
}

fn service(tag: &str, port: u16, extra: &[&str]) -> Service {
    let domain = PrivateDomain::new(tag);
    // the subscriber first: no history, every scan after it counts
    let node = ipc::node(&domain.config(), "sick-test").expect("node");
    let scans = ipc::scan_subscriber(&node).expect("lidar/scan2d");
    let mut args = config_args(&domain);
    for s in [
        "foliage.source=\"sick\"".to_string(),
        "sick.host=\"127.0.0.1\"".into(),
        format!("sick.port={port}"),
        "sick.reconnect_min_s=0.05".into(),
    ]
    .into_iter()
    .chain(extra.iter().map(|s| s.to_string()))
    {
        args.extend(["--set".into(), s]);
    }
    let mut proc = Proc::start(
        std::process::Command::new(bin("mimnav-sick"))
            .args(&args)
            .env("MIMNAV_LOG", "info")
            .stderr(Stdio::piped()),
    );
    let log = lines_of(proc.0.stderr.take().expect("stderr"));
    Service {
        proc,
        log,
        _node: node,
        scans,
        _domain: domain,
    }
}

impl Service {
    /// Scans received within `within`, at least `n` (stops at `n`): (count, seq) of each.
    fn scans(&self, n: usize, within: Duration) -> Vec<Got> {
        let until = Instant::now() + within;
        let mut got = Vec::new();
        while got.len() < n && Instant::now() < until {
            match self.scans.receive() {
                Ok(Some(s)) => {
                    let h = *s.user_header();
                    let r = s
                        .payload()
                        .iter()
                        .map(|r| (r.angle_rad, r.range_m, r.intensity))
                        .collect();
                    got.push((h.count, h.seq, r));
                }
                _ => std::thread::sleep(Duration::from_millis(1)),
            }
        }
        got
    }

    /// Stops the service; its closing line's fault counts.
    fn stop(mut self) -> (String, Vec<String>) {
        let status = self.proc.terminate(Duration::from_secs(5));
        assert!(
            status.is_some_and(|s| s.success()),
            "mimnav-sick exits cleanly on SIGTERM: {status:?}"
        );
        let lines: Vec<String> = self.log.try_iter().collect();
        let faults = lines
            .iter()
            .rev()
            .find(|l| l.contains("sick stopped"))
            .cloned()
            .unwrap_or_else(|| panic!("no closing line in {lines:#?}"));
        (faults, lines)
    }
}

fn count(faults: &str, kind: &str) -> u64 {
    faults
        .split_whitespace()
        .find_map(|w| w.strip_prefix(kind)?.strip_prefix('='))
        .and_then(|n| {
            n.trim_end_matches(|c: char| !c.is_ascii_digit())
                .parse()
                .ok()
        })
        .unwrap_or(0)
}

/// A CoLa-A scan whose `field` token (by index after the command) is replaced.
fn damaged_a(good: &[u8], token: usize, with: &str) -> Vec<u8> {
    let text = String::from_utf8_lossy(&good[1..good.len() - 1]).into_owned();
    let mut t: Vec<String> = text.split(' ').map(str::to_string).collect();
    t[token] = with.to_string();
    let mut v = Vec::new();
    frame(Dialect::ColaA, t.join(" ").as_bytes(), &mut v);
    v
}

#[test]
fn sick_cola_a_real_telegrams_damage_and_a_scanner_that_goes_away() {
    let real = real_tim();
    let mut dev = Device::new(Model::Tim5xx, Dialect::ColaA, 1);
    let g = dev.geometry();
    let good = match &real {
        Some(t) => t.clone(),
        None => {
            let mut v = Vec::new();
            dev.scan_telegram(0, &[vec![500; g.count]], &[], &mut v);
            v
        }
    };
    let sc = scanner(Model::Tim5xx, Dialect::ColaA, real.clone());
    let s = service(
        "sick-a",
        sc.port,
        &["sick.protocol=\"cola_a\"", "sick.model=\"tim5xx\""],
    );
    let first = s.scans(10, Duration::from_secs(10));
    assert_eq!(first.len(), 10, "scans flow after the start-up exchange");
    for (n, _, r) in &first {
        assert_eq!(*n, 271, "a TiM5xx scan: 271 measurements");
        assert_eq!(r.len(), 271);
    }
    if real.is_some() {
        // the real telegram's first value: 0x1B8 mm at -45° device = -135° REP-103
        let (a, d, _) = first[0].2[0];
        assert!(
            (a.to_degrees() + 135.0).abs() < 1e-3 && (d - 0.440).abs() < 1e-6,
            "{a} {d}"
        );
    }

    // every class of damage, each before a good scan; then the same scans in 3-byte pieces
    let text = |t: &[u8]| t.to_vec();
    let mut bad = vec![
        text(b"line noise outside any telegram"),
        // an STX whose telegram never ends before the next STX
        text(b"\x02sSN LMDscandata 1 1 107"),
        // cut inside the distances
        {
            let mut v = good[..good.len() / 2].to_vec();
            v.push(0x03);
            v
        },
        // a serial that is not hex
        damaged_a(&good, 4, "10G375C"),
        // 10 001 values claimed (0x2711), more than any scanner sends
        damaged_a(&good, 25, "2711"),
        // not a scan and not an answer to anything
        text(b"\x02sXX nonsense\x03"),
    ];
    sc.plan.inject.lock().expect("lock").append(&mut bad);
    sc.plan.pieces.store(3, Ordering::Relaxed);
    let more = s.scans(10, Duration::from_secs(10));
    assert_eq!(
        more.len(),
        10,
        "scans go on between damaged telegrams and in pieces"
    );
    sc.plan.pieces.store(0, Ordering::Relaxed);

    // a disconnect: back at once
    sc.plan.hang_up.store(true, Ordering::Relaxed);
    let again = s.scans(5, Duration::from_secs(5));
    assert_eq!(again.len(), 5, "scans after the scanner hung up");

    // the scanner away for 1.5 s (connections refused), then back: scans within a second
    sc.plan.down.store(true, Ordering::Relaxed);
    std::thread::sleep(Duration::from_millis(1500));
    while s.scans.receive().ok().flatten().is_some() {}
    sc.plan.down.store(false, Ordering::Relaxed);
    let back = Instant::now();
    let resumed = s.scans(1, Duration::from_secs(5));
    let took = back.elapsed();
    assert_eq!(resumed.len(), 1, "scans after the scanner came back");
    println!("scans again {took:?} after the scanner came back");
    assert!(took <= Duration::from_secs(1), "{took:?}");
    assert!(sc.plan.accepted.load(Ordering::Relaxed) >= 3);

    let (faults, lines) = s.stop();
    println!("{faults}");
    for kind in [
        "garbage",
        "unterminated",
        "truncated",
        "bad_number",
        "oversize",
        "unexpected",
    ] {
        assert!(
            count(&faults, kind) >= 1,
            "{kind} counted: {faults}\n{lines:#?}"
        );
    }
    assert!(count(&faults, "link_down") >= 2, "{faults}");
}

#[test]
fn sick_cola_b_multi_echo_checksums_and_oversize_lengths() {
    let sc = scanner(Model::Lms5xx, Dialect::ColaB, None);
    let s = service(
        "sick-b",
        sc.port,
        &[
            "sick.protocol=\"cola_b\"",
            "sick.model=\"lms5xx\"",
            "sick.echo=\"last\"",
        ],
    );
    let first = s.scans(5, Duration::from_secs(10));
    assert_eq!(first.len(), 5, "LMS5xx scans over CoLa-B");
    let (n, _, r) = &first[0];
    // 190° at 1/6°: 1 141 measurements; the emulator's i-th distance is 1000 + i mm
    assert_eq!(*n, 1141);
    assert!((r[10].1 - 1.010).abs() < 1e-6, "{:?}", r[10]);
    // device -5° + 10/6° = REP-103 -93.33°
    assert!((r[10].0.to_degrees() + 93.333).abs() < 1e-2, "{:?}", r[10]);
    // consecutive seq: the device's scan counter has no gap
    assert!(first.windows(2).all(|w| w[1].1 == w[0].1 + 1));

    let mut good = Vec::new();
    frame(Dialect::ColaB, b"sEA LMDscandata \x01", &mut good);
    let mut bad_sum = good.clone();
    let last = bad_sum.len() - 1;
    bad_sum[last] ^= 0x55;
    let huge = vec![2, 2, 2, 2, 0x7F, 0xFF, 0xFF, 0xFF];
    sc.plan
        .inject
        .lock()
        .expect("lock")
        .extend([bad_sum, huge, b"\x00\x01garbage".to_vec()]);
    let more = s.scans(5, Duration::from_secs(10));
    assert_eq!(more.len(), 5);
    // the device reports a dirty window: named in the log, the scans go on
    sc.plan.status.store(2, Ordering::Relaxed);
    assert_eq!(s.scans(5, Duration::from_secs(10)).len(), 5);
    sc.plan.status.store(0, Ordering::Relaxed);
    assert_eq!(s.scans(5, Duration::from_secs(10)).len(), 5);
    let (faults, lines) = s.stop();
    let told = |what: &str| lines.iter().any(|l| l.contains(what));
    assert!(told("pollution warning (clean the window)"), "{lines:#?}");
    assert!(told("no fault any more"), "{lines:#?}");
    println!("{faults}");
    for kind in ["bad_checksum", "oversize", "garbage"] {
        assert!(count(&faults, kind) >= 1, "{kind} counted: {faults}");
    }
}

#[test]
fn sick_refuses_to_run_when_the_vlp16_is_the_foliage_source() {
    let domain = PrivateDomain::new("sick-source");
    let out = std::process::Command::new(bin("mimnav-sick"))
        .args(config_args(&domain))
        .output()
        .expect("run mimnav-sick");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("foliage.source"), "{err}");
}
