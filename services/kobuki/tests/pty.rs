//! The simulated base on a real pseudo-terminal: the test is the driver, opening the slave
//! side by its path as a service opens `/dev/kobuki`, writing Base Control frames and reading
//! feedback through the crate's frame parser. Linux only (`serialport::TTYPort::pair`).
#![cfg(target_os = "linux")]

use std::io::{ErrorKind, Read, Write};
use std::time::{Duration, Instant};

use mimnav_kobuki::M_PER_TICK;
use mimnav_kobuki::command::{BaseControl, Command};
use mimnav_kobuki::feedback::{Feedback, bumper};
use mimnav_kobuki::frame::FrameParser;
use mimnav_kobuki::simbase::{ServeEnd, SimBase, SimBaseConfig, SimHandle, spawn_on_pty};
use serialport::TTYPort;

/// The driver's end: a port opened by path and a frame parser.
struct Driver {
    port: TTYPort,
    parser: FrameParser,
    /// Feedback frames received, in order, with their host receive time.
    received: Vec<(Instant, Feedback)>,
}

impl Driver {
    fn open(sim: &SimHandle) -> Driver {
        let port = serialport::new(sim.path(), 115_200)
            .timeout(Duration::from_millis(10))
            .open_native()
            .expect("open the pseudo-terminal by its path");
        Driver {
            port,
            parser: FrameParser::new(),
            received: Vec::new(),
        }
    }

    fn send(&mut self, c: Command) {
        let mut bytes = Vec::new();
        c.encode(&mut bytes).unwrap();
        self.port.write_all(&bytes).unwrap();
        self.port.flush().unwrap();
    }

    /// Reads until `until`, keeping every feedback frame.
    fn read_until(&mut self, until: Instant) {
        let mut buf = [0u8; 256];
        while Instant::now() < until {
            match self.port.read(&mut buf) {
                Ok(n) => {
                    let now = Instant::now();
                    for f in self.parser.push(&buf[..n]).flatten() {
                        self.received.push((now, Feedback::decode(&f)));
                    }
                }
                Err(e) if e.kind() == ErrorKind::TimedOut => {}
                Err(e) => panic!("reading the pseudo-terminal: {e}"),
            }
        }
    }

    /// Reads until `n` feedback frames have been received in all, or panics after `limit`.
    fn read_frames(&mut self, n: usize, limit: Duration) {
        let end = Instant::now() + limit;
        while self.received.len() < n {
            assert!(
                Instant::now() < end,
                "only {} frames in {limit:?}",
                self.received.len()
            );
            self.read_until(Instant::now() + Duration::from_millis(5));
        }
    }
}

fn start(config: SimBaseConfig) -> (SimHandle, Driver) {
    let sim = spawn_on_pty(SimBase::new(config)).expect("a pseudo-terminal pair");
    let driver = Driver::open(&sim);
    (sim, driver)
}

/// Driving at 0.2 m/s: by the base's own clock the encoders advance 0.2 m/s × 11 724.4 ticks/m
/// to within 3 ticks over a second (the timestamp's 1 ms rounding is 2.3 ticks); by the host's
/// clock, a Base Control held for 1 s moves each wheel 2345 ticks to within 10 % (the command
/// takes effect at the base's next 20 ms step, and the two shared cores can delay the test's
/// reads and writes by tens of milliseconds).
#[test]
fn driving_at_0_2_for_1_s_moves_the_encoders_by_the_matching_ticks() {
    // start the encoders just below their wrap to cross it on the way
    let (sim, mut d) = start(SimBaseConfig {
        start_encoders: (64_000, 65_000),
        start_timestamp_ms: 65_000,
        ..SimBaseConfig::default()
    });
    d.read_frames(3, Duration::from_secs(2));
    let before = d.received.last().unwrap().1.basic.unwrap();
    let t0 = Instant::now();
    d.send(Command::BaseControl(BaseControl::from_twist(0.2, 0.0)));
    d.read_until(t0 + Duration::from_secs(1));
    d.send(Command::BaseControl(BaseControl::STOP));
    d.read_until(Instant::now() + Duration::from_millis(200));
    let after = d.received.last().unwrap().1.basic.unwrap();
    let per_m = 1.0 / M_PER_TICK;
    let expected = 0.2 * per_m;
    for (b, a, side) in [
        (before.left_encoder, after.left_encoder, "left"),
        (before.right_encoder, after.right_encoder, "right"),
    ] {
        let ticks = f64::from(a.wrapping_sub(b) as i16);
        println!("{side}: {ticks} ticks by the host's 1 s, expected {expected:.1}");
        assert!(
            (ticks - expected).abs() < 0.1 * expected,
            "{side}: {ticks} ticks, expected {expected:.0} ± 10 %"
        );
    }

    // by the base's clock: frames while moving at full speed (left PWM positive both ends)
    let moving: Vec<_> = d
        .received
        .iter()
        .filter_map(|(_, f)| f.basic)
        .filter(|b| b.left_pwm > 0)
        .collect();
    assert!(moving.len() > 30, "{} frames while moving", moving.len());
    let (first, last) = (moving[1], moving[moving.len() - 1]);
    let dt_ms = f64::from(last.timestamp_ms.wrapping_sub(first.timestamp_ms));
    let ticks = f64::from(last.left_encoder.wrapping_sub(first.left_encoder));
    let expected = 0.2 * dt_ms / 1000.0 * per_m;
    assert!(
        (ticks - expected).abs() <= 3.0,
        "{ticks} ticks in {dt_ms} ms by the base's clock, expected {expected:.1} ± 3"
    );
    println!("{ticks} ticks in {dt_ms} ms by the base's clock, expected {expected:.1}");
    assert!(dt_ms > 800.0, "{dt_ms} ms of motion");
    let (x, _, _) = sim.stop().0.pose();
    assert!((x - 0.2).abs() < 0.02, "true x {x}");
    assert_eq!(d.parser.stats().garbage_bytes, 0);
    assert_eq!(d.parser.stats().rejected_headers(), 0);
}

/// A bumper press shows in the first frame the base starts after the press, which is the next
/// frame received or the one after (the frame being written as the press happens may predate
/// it); releasing it likewise.
#[test]
fn a_bumper_press_shows_in_the_next_feedback_frame() {
    let (sim, mut d) = start(SimBaseConfig::default());
    d.read_frames(2, Duration::from_secs(2));
    let controls = sim.controls().clone();
    for (bits, name) in [(bumper::CENTRAL | bumper::LEFT, "press"), (0, "release")] {
        // read what was sent before, then press
        d.read_until(Instant::now() + Duration::from_millis(30));
        controls.set_bumper(bits);
        let sent = controls.frames_sent() as usize;
        // frames are numbered from 0 in the order sent, and none is lost on the pty
        d.read_frames(sent + 2, Duration::from_secs(1));
        assert!(d.received.len() >= sent + 2);
        for (k, (_, f)) in d.received.iter().enumerate().skip(sent + 1) {
            assert_eq!(
                f.basic.unwrap().bumper,
                bits,
                "{name}: frame {k}, pressed after {sent}"
            );
        }
    }
    let (_, end) = sim.stop();
    assert_eq!(end.unwrap(), ServeEnd::Stopped);
}

/// Unplugging closes the master side: the driver's reads fail at once (a hang-up), and the
/// serving loop ends with `Unplugged`.
#[test]
fn unplugging_closes_the_port() {
    let (sim, mut d) = start(SimBaseConfig::default());
    d.read_frames(2, Duration::from_secs(2));
    sim.controls().unplug();
    let end = Instant::now() + Duration::from_secs(2);
    let mut buf = [0u8; 256];
    let err = loop {
        assert!(
            Instant::now() < end,
            "reads still succeed 2 s after the unplug"
        );
        match d.port.read(&mut buf) {
            Ok(0) => break ErrorKind::UnexpectedEof,
            Ok(_) => {}
            Err(e) if e.kind() == ErrorKind::TimedOut => {}
            Err(e) => break e.kind(),
        }
    };
    assert_ne!(err, ErrorKind::TimedOut);
    let (_, served) = sim.stop();
    assert_eq!(served.unwrap(), ServeEnd::Unplugged);
}

/// The base answers a Request Extra in its next frame, and counts what it did not understand.
#[test]
fn request_extra_over_the_pty() {
    use mimnav_kobuki::command::request;
    let (sim, mut d) = start(SimBaseConfig::default());
    d.read_frames(1, Duration::from_secs(2));
    d.port.write_all(&[0x00, 0xAA, 0x13]).unwrap();
    d.send(Command::RequestExtra(
        request::HARDWARE_VERSION | request::FIRMWARE_VERSION | request::UNIQUE_DEVICE_ID,
    ));
    let end = Instant::now() + Duration::from_secs(1);
    while !d.received.iter().any(|(_, f)| f.firmware_version.is_some()) {
        assert!(Instant::now() < end, "no versions within 1 s");
        d.read_until(Instant::now() + Duration::from_millis(10));
    }
    let f = &d
        .received
        .iter()
        .find(|(_, f)| f.hardware_version.is_some())
        .unwrap()
        .1;
    let config = SimBaseConfig::default();
    assert_eq!(f.hardware_version, Some(config.hardware_version));
    assert_eq!(f.unique_device_id, Some(config.unique_device_id));
    let (base, _) = sim.stop();
    assert_eq!(base.command_counts(), (1, 0));
    assert_eq!(base.frame_stats().garbage_bytes, 3);
}
