//! The scanner's side of the protocol: an emulated SICK that answers a driver's requests as
//! the operating instructions describe and writes its scans as `LMDscandata` telegrams. The
//! simulator's SICK (`mimnav-sim` with `[sim.sick]`, `mimnav foliage-eval --sensor sick`) and
//! the tests' scanner are this type behind a TCP socket; what it measures is the caller's.
//!
//! It keeps the state a real one keeps: the user level (`SetAccessMode` with the client's
//! password), the scan mode (`mLMPsetscancfg`, refused with the device's result codes for a
//! mode the model lacks, and with `sFA 1` before logging in), remission on or off
//! (`LMDscandatacfg`), the echo filter (`FREchoFilter`), `Run`, and whether scans are streamed
//! (`sEN LMDscandata`). Anything else is answered `sFA 2` or `sFA 3` (unknown method or
//! variable), as a scanner does.

use crate::cola::{Args, Dialect, Framer, frame};
use crate::command::CLIENT_PASSWORD;
use crate::config::Model;
use crate::scandata::{Channel, ScanData};

/// An emulated scanner.
#[derive(Debug)]
pub struct Device {
    dialect: Dialect,
    model: Model,
    framer: Framer,
    logged_in: bool,
    streaming: bool,
    remission: bool,
    echo_filter: u8,
    frequency: u32,
    resolution: u32,
    start: i32,
    stop: i32,
    scan: ScanData,
    /// Device status bytes sent with every scan (tests set an error here).
    pub status: [u8; 2],
    /// Requests answered.
    pub requests: u64,
}

/// Where a scan's values lie: what a caller must measure for [`Device::scan_telegram`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geometry {
    /// The first measurement's device angle, degrees (90° is straight ahead).
    pub start_deg: f64,
    /// Degrees between measurements.
    pub step_deg: f64,
    /// Measurements per scan.
    pub count: usize,
    /// Scans per second.
    pub frequency_hz: f64,
}

impl Device {
    /// A `model` speaking `dialect`, in its default mode, not streaming.
    pub fn new(model: Model, dialect: Dialect, serial: u32) -> Self {
        let spec = model.spec();
        let (f, s) = spec.modes[0];
        let mut scan = ScanData::default();
        (scan.version, scan.device_number, scan.serial) = (1, 1, serial);
        Device {
            dialect,
            model,
            framer: Framer::new(dialect, 64 * 1024),
            logged_in: false,
            streaming: false,
            remission: true,
            echo_filter: if spec.echoes > 1 { 2 } else { 0 },
            frequency: (f * 100.0).round() as u32,
            resolution: (s * 10_000.0).round() as u32,
            start: (spec.field_deg.0 * 10_000.0).round() as i32,
            stop: (spec.field_deg.1 * 10_000.0).round() as i32,
            scan,
            status: [0, 0],
            requests: 0,
        }
    }

    /// True after `sEN LMDscandata 1`.
    pub fn streaming(&self) -> bool {
        self.streaming
    }

    /// Drops the connection's state (a new client must log in and start the stream again).
    pub fn disconnect(&mut self) {
        self.framer.reset();
        self.logged_in = false;
        self.streaming = false;
    }

    /// The scan's geometry in the current mode.
    pub fn geometry(&self) -> Geometry {
        // 190° at 1/6° (1 667 in the device's units): 1 141 measurements, as an LMS5xx sends
        let span = f64::from(self.stop - self.start) / f64::from(self.resolution.max(1));
        let count = span.round() as usize + 1;
        Geometry {
            start_deg: f64::from(self.start) * 1e-4,
            step_deg: f64::from(self.resolution) * 1e-4,
            count,
            frequency_hz: f64::from(self.frequency) * 0.01,
        }
    }

    /// Requests from the driver; the answers go to `out`, framed.
    pub fn receive(&mut self, bytes: &[u8], out: &mut Vec<u8>) {
        self.framer.push(bytes);
        let mut requests = Vec::new();
        while let Some(r) = self.framer.next() {
            if let Ok(p) = r {
                requests.push(p.to_vec());
            }
        }
        for p in requests {
            self.requests += 1;
            let answer = self.answer(&p);
            frame(self.dialect, &answer, out);
        }
    }

    fn answer(&mut self, p: &[u8]) -> Vec<u8> {
        let d = self.dialect;
        let is = |prefix: &[u8]| p.starts_with(prefix);
        let rest = |prefix: &[u8]| p.get(prefix.len()..).unwrap_or(&[]);
        if is(b"sMN SetAccessMode") {
            let args = read_args(d, rest(b"sMN SetAccessMode"), &[1, 4]);
            let ok = args.is_some_and(|v| v[1] as u32 == CLIENT_PASSWORD);
            self.logged_in = ok;
            reply(d, "sAN SetAccessMode", &[(u32::from(ok), 1)])
        } else if is(b"sMN mLMPsetscancfg") {
            if !self.logged_in {
                return reply(d, "sFA", &[(1, 1)]);
            }
            let Some(v) = read_args(d, rest(b"sMN mLMPsetscancfg"), &[4, 2, 4, 4, 4]) else {
                return reply(d, "sFA", &[(5, 1)]);
            };
            let spec = self.model.spec();
            let (f, res) = (v[0] as f64 * 0.01, v[2] as f64 * 1e-4);
            let fits = |a: f64, b: f64| (a - b).abs() <= 1e-3 * b;
            let code = if !spec.configurable {
                return reply(d, "sFA", &[(2, 1)]);
            } else if !spec.modes.iter().any(|m| fits(f, m.0)) {
                1
            } else if !spec.modes.iter().any(|m| fits(f, m.0) && fits(res, m.1)) {
                2
            } else {
                self.frequency = v[0] as u32;
                self.resolution = v[2] as u32;
                0
            };
            let (start, stop) = (self.start as u32, self.stop as u32);
            // the result, then the mode in force: frequency, sectors, step, field
            let (freq, step) = (self.frequency, self.resolution);
            let mode = [
                (code, 1),
                (freq, 4),
                (1, 2),
                (step, 4),
                (start, 4),
                (stop, 4),
            ];
            reply(d, "sAN mLMPsetscancfg", &mode)
        } else if is(b"sWN LMDscandatacfg") {
            if !self.logged_in {
                return reply(d, "sFA", &[(0x0A, 1)]);
            }
            if let Some(v) = read_args(d, rest(b"sWN LMDscandatacfg"), &[1, 1, 1, 1]) {
                self.remission = v[2] != 0;
            }
            reply(d, "sWA LMDscandatacfg", &[])
        } else if is(b"sWN FREchoFilter") {
            if !self.logged_in || self.model.spec().echoes < 2 {
                let code = if self.logged_in { 3 } else { 0x0A };
                return reply(d, "sFA", &[(code, 1)]);
            }
            if let Some(v) = read_args(d, rest(b"sWN FREchoFilter"), &[1]) {
                self.echo_filter = (v[0] as u8).min(2);
            }
            reply(d, "sWA FREchoFilter", &[])
        } else if is(b"sMN Run") {
            reply(d, "sAN Run", &[(1, 1)])
        } else if is(b"sEN LMDscandata") {
            let on = read_args(d, rest(b"sEN LMDscandata"), &[1]).is_some_and(|v| v[0] != 0);
            self.streaming = on;
            reply(d, "sEA LMDscandata", &[(u32::from(on), 1)])
        } else if is(b"sRN") || is(b"sWN") {
            reply(d, "sFA", &[(3, 1)])
        } else {
            reply(d, "sFA", &[(2, 1)])
        }
    }

    /// A scan telegram, framed, appended to `out`: `echoes` holds the distances (mm) of each
    /// echo, nearest first, `remission` their remission (8-bit), each of
    /// [`Geometry::count`] values; `time_us` is the device's clock at the scan's start.
    pub fn scan_telegram(
        &mut self,
        time_us: u32,
        echoes: &[Vec<u16>],
        remission: &[Vec<u16>],
        out: &mut Vec<u8>,
    ) {
        let g = self.geometry();
        let n = self.echo_filter_pick(echoes.len());
        let s = &mut self.scan;
        s.device_status = self.status;
        s.telegram_counter = s.telegram_counter.wrapping_add(1);
        s.scan_counter = s.scan_counter.wrapping_add(1);
        s.time_since_startup_us = time_us;
        s.time_of_transmission_us = time_us.wrapping_add((1e6 / g.frequency_hz) as u32);
        s.scan_frequency = self.frequency;
        s.measurement_frequency = (g.count as f64 * g.frequency_hz / 100.0).round() as u32;
        s.clear_channels();
        let mut add = |name: [u8; 5], bits: u8, values: &[u16]| {
            s.push_channel(Channel {
                name,
                bits,
                scale: 1.0,
                offset: 0.0,
                start_angle: self.start,
                step: self.resolution as u16,
                values: values.iter().copied().take(g.count).collect(),
            });
        };
        for (k, e) in n.iter().enumerate() {
            add(b"DIST1".map_last(b'1' + k as u8), 16, &echoes[*e]);
        }
        if self.remission {
            for (k, e) in n.iter().enumerate() {
                if let Some(r) = remission.get(*e) {
                    add(b"RSSI1".map_last(b'1' + k as u8), 8, r);
                }
            }
        }
        let mut p = Vec::with_capacity(8 * g.count * (1 + usize::from(self.remission)));
        self.scan.encode(self.dialect, b"sSN", &mut p);
        frame(self.dialect, &p, out);
    }

    /// The echoes a telegram sends, by index into the measured ones.
    fn echo_filter_pick(&self, measured: usize) -> Vec<usize> {
        match (self.echo_filter, measured) {
            (_, 0) => vec![],
            (1, n) => (0..n.min(usize::from(self.model.spec().echoes))).collect(),
            (2, n) => vec![n - 1],
            _ => vec![0],
        }
    }
}

trait MapLast {
    fn map_last(self, b: u8) -> Self;
}

impl MapLast for [u8; 5] {
    fn map_last(mut self, b: u8) -> Self {
        self[4] = b;
        self
    }
}

/// Reads a request's arguments: `sizes` in bytes (CoLa-B, big-endian; 4-byte ones signed) or
/// one token each (CoLa-A: hex, or decimal with a sign).
fn read_args(d: Dialect, rest: &[u8], sizes: &[usize]) -> Option<Vec<i64>> {
    match d {
        Dialect::ColaA => {
            let text = std::str::from_utf8(rest).ok()?;
            let toks: Vec<&str> = text.split_whitespace().collect();
            if toks.len() < sizes.len() {
                return None;
            }
            toks.iter()
                .take(sizes.len())
                .map(|t| {
                    if let Some(x) = t.strip_prefix('+') {
                        x.parse().ok()
                    } else if t.starts_with('-') {
                        t.parse().ok()
                    } else {
                        i64::from_str_radix(t, 16).ok()
                    }
                })
                .collect()
        }
        Dialect::ColaB => {
            let mut b = rest.strip_prefix(b" ")?;
            let mut v = Vec::new();
            for &n in sizes {
                let (x, tail) = (b.get(..n)?, b.get(n..)?);
                let u = x.iter().fold(0i64, |a, &y| a << 8 | i64::from(y));
                v.push(if n == 4 {
                    i64::from(u as u32 as i32)
                } else {
                    u
                });
                b = tail;
            }
            Some(v)
        }
    }
}

/// An answer: `text` (the answer's command and name) and its unsigned arguments (value, bytes).
fn reply(d: Dialect, text: &str, args: &[(u32, usize)]) -> Vec<u8> {
    let mut p = text.as_bytes().to_vec();
    let mut a = Args::new(d, &mut p);
    for &(v, size) in args {
        a.hex(v, size, 1);
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::SickConfig;
    use crate::session::{Event, Session};

    /// A driver's session and an emulated scanner talking through buffers.
    fn talk(model: Model, dialect: Dialect) -> (Session, Device, Vec<String>) {
        let cfg = SickConfig {
            model,
            protocol: dialect,
            ..SickConfig::default()
        };
        let mut s = Session::new(cfg.session());
        let mut dev = Device::new(model, dialect, 0xA037B9);
        let (mut to_dev, mut to_drv) = (Vec::new(), Vec::new());
        let mut log = Vec::new();
        s.begin(0, &mut to_dev);
        for _ in 0..10 {
            dev.receive(&std::mem::take(&mut to_dev), &mut to_drv);
            s.receive(&std::mem::take(&mut to_drv), 1, &mut to_dev, |e| {
                log.push(format!("{e:?}"));
            });
        }
        (s, dev, log)
    }

    #[test]
    fn a_driver_logs_in_configures_and_streams_in_both_dialects() {
        for d in [Dialect::ColaA, Dialect::ColaB] {
            for m in [Model::Lms1xx, Model::Lms5xx, Model::Tim5xx, Model::Tim7xx] {
                let (s, mut dev, log) = talk(m, d);
                assert!(s.streaming(), "{m:?} {d:?}: {log:?}");
                assert!(dev.streaming(), "{m:?} {d:?}");
                let g = dev.geometry();
                let echoes = vec![vec![1234u16; g.count], vec![2345u16; g.count]];
                let rssi = vec![vec![77u16; g.count], vec![88u16; g.count]];
                let mut wire = Vec::new();
                dev.scan_telegram(5, &echoes, &rssi, &mut wire);
                let mut s = s;
                let mut got = None;
                s.receive(&wire, 2, &mut Vec::new(), |e| {
                    if let Event::Scan(sd) = e {
                        got = Some(sd.clone());
                    }
                });
                let sd = got.expect("a scan");
                let dist: Vec<&[u8; 5]> = sd.channels().iter().map(|c| &c.name).collect();
                match m {
                    // LMS5xx: every echo, as the driver asked
                    Model::Lms5xx => {
                        assert_eq!(dist, [b"DIST1", b"DIST2", b"RSSI1", b"RSSI2"])
                    }
                    _ => assert_eq!(dist, [b"DIST1", b"RSSI1"]),
                }
                assert_eq!(sd.channels()[0].values.len(), g.count);
            }
        }
    }

    #[test]
    fn a_wrong_password_or_mode_is_refused_by_the_device() {
        let mut dev = Device::new(Model::Lms1xx, Dialect::ColaA, 1);
        let mut out = Vec::new();
        dev.receive(
            b"\x02sMN mLMPsetscancfg +5000 +1 +2500 -450000 +2250000\x03",
            &mut out,
        );
        assert_eq!(out, b"\x02sFA 1\x03");
        out.clear();
        dev.receive(b"\x02sMN SetAccessMode 03 12345678\x03", &mut out);
        assert_eq!(out, b"\x02sAN SetAccessMode 0\x03");
        out.clear();
        dev.receive(b"\x02sMN SetAccessMode 03 F4724744\x03", &mut out);
        dev.receive(
            b"\x02sMN mLMPsetscancfg +5000 +1 +2500 -450000 +2250000\x03",
            &mut out,
        );
        let text = String::from_utf8_lossy(&out).into_owned();
        assert!(
            text.ends_with("\x02sAN mLMPsetscancfg 2 9C4 1 9C4 FFF92230 225510\x03"),
            "{text}"
        );
        assert_eq!(dev.geometry().count, 1081);
    }
}
