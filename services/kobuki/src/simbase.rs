//! A simulated Kobuki base speaking the protocol from the base's side, and a loop serving it
//! on a serial port (a pseudo-terminal in tests).
//!
//! [`SimBase`] parses command frames with the same [`FrameParser`] as the driver, drives its
//! two wheels from the last Base Control (through [`BaseControl::wheel_speeds`], the base's
//! reading of speed and radius), limits each wheel's speed (and, if set, acceleration),
//! integrates the exact differential-drive pose, and writes feedback frames: Basic Sensor Data
//! (timestamp, hazard bits, encoders from each wheel's travel, PWM, battery), Docking IR,
//! Inertial Sensor Data (the true heading as the gyro reports it, wrapped to ±180°, plus a
//! settable offset), Cliff, Current and General Purpose Input; and the versions and unique id
//! in the frame after a Request Extra.
//!
//! It does not model: wheel slip, encoder or gyro noise and drift, the motor controller's
//! response (the wheels reach the commanded speed at once, or at the set acceleration),
//! the firmware's own reaction to wheel drop, the docking IR, charging, battery drain, or
//! the raw 3-axis gyro sub-payload. Cliff ADC and motor current values are plausible
//! placeholders, not measurements.
//!
//! [`serve`] runs a base on a port at 50 Hz by the host's clock (the base's timestamp follows
//! it); [`spawn_on_pty`] starts it on a thread on a fresh pseudo-terminal pair
//! (`serialport::TTYPort::pair`) and returns the path a driver opens. [`Controls`] presses
//! bumpers, sets cliffs and wheel drops, stops the loop or "unplugs" the base (closes the
//! pseudo-terminal's master side, as pulling the USB cable removes the device).

use std::io;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU8, AtomicU32, AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::command::{BaseControl, Command, SoundSequence, request};
use crate::feedback::{
    BasicSensorData, CliffSensorData, Feedback, InertialSensorData, MotorCurrent, Version, id,
};
use crate::frame::{FrameParser, FrameStats, encode_frame, push_subpayload};
use crate::odometry::wrap_pi;
use crate::{M_PER_TICK, WHEEL_BASE_M};

/// The base's feedback period (50 Hz, specification "Feedback Packets").
pub const FEEDBACK_PERIOD: Duration = Duration::from_millis(20);

/// The simulated base's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct SimBaseConfig {
    /// Distance between the wheels, m.
    pub wheel_base_m: f64,
    /// Wheel travel per encoder tick, m.
    pub m_per_tick: f64,
    /// Fastest a wheel turns, m/s (the Kobuki's maximum translational speed, 0.7 m/s, from
    /// its user guide; larger commands are scaled down keeping the turn's radius).
    pub max_wheel_speed_mps: f64,
    /// Fastest a wheel's speed changes, m/s²; `None`: at once.
    pub max_wheel_accel_mps2: Option<f64>,
    /// Battery voltage reported, 0.1 V.
    pub battery_dv: u8,
    /// The base's clock at the start, ms.
    pub start_timestamp_ms: u16,
    /// Encoders at the start (left, right), ticks.
    pub start_encoders: (u16, u16),
    /// The gyro's reading when the true heading is 0, 0.01°.
    pub gyro_offset_cdeg: i16,
    /// Hardware version reported after a Request Extra.
    pub hardware_version: Version,
    /// Firmware version reported after a Request Extra.
    pub firmware_version: Version,
    /// Unique device id reported after a Request Extra.
    pub unique_device_id: [u32; 3],
}

impl Default for SimBaseConfig {
    fn default() -> Self {
        SimBaseConfig {
            wheel_base_m: WHEEL_BASE_M,
            m_per_tick: M_PER_TICK,
            max_wheel_speed_mps: 0.7,
            max_wheel_accel_mps2: None,
            battery_dv: 165,
            start_timestamp_ms: 0,
            start_encoders: (0, 0),
            gyro_offset_cdeg: 0,
            hardware_version: Version {
                major: 1,
                minor: 0,
                patch: 4,
            },
            firmware_version: Version {
                major: 1,
                minor: 2,
                patch: 0,
            },
            unique_device_id: [0x4D49_4D4E, 0x4156_0000, 0x0000_0001],
        }
    }
}

/// Longest integration step, s: [`SimBase::step`] splits longer ones.
const MAX_SUBSTEP_S: f64 = 0.005;

/// The simulated base; see the module documentation.
#[derive(Debug, Clone)]
pub struct SimBase {
    config: SimBaseConfig,
    parser: FrameParser,
    command: BaseControl,
    /// Left and right wheel speeds now, m/s.
    wheels: (f64, f64),
    /// Left and right wheel travel since the start, m.
    travel: (f64, f64),
    /// True pose: x, y (m), yaw (rad, unwrapped).
    pose: (f64, f64, f64),
    clock_s: f64,
    bumper: u8,
    cliff: u8,
    wheel_drop: u8,
    battery_dv: u8,
    extra_requested: u16,
    last_sound: Option<SoundSequence>,
    commands: u64,
    command_errors: u64,
}

impl SimBase {
    /// A base at rest at the origin, heading along x.
    pub fn new(config: SimBaseConfig) -> Self {
        SimBase {
            battery_dv: config.battery_dv,
            config,
            parser: FrameParser::new(),
            command: BaseControl::STOP,
            wheels: (0.0, 0.0),
            travel: (0.0, 0.0),
            pose: (0.0, 0.0, 0.0),
            clock_s: 0.0,
            bumper: 0,
            cliff: 0,
            wheel_drop: 0,
            extra_requested: 0,
            last_sound: None,
            commands: 0,
            command_errors: 0,
        }
    }

    /// Takes bytes from the driver: every complete command frame in them is applied.
    pub fn receive(&mut self, bytes: &[u8]) {
        let mut cmds = Vec::new();
        let mut errors = 0;
        self.parser.push_with(bytes, |frame| {
            for c in Command::decode_all(&frame) {
                match c {
                    Ok(c) => cmds.push(c),
                    Err(_) => errors += 1,
                }
            }
        });
        self.command_errors += errors;
        for c in cmds {
            self.apply(c);
        }
    }

    /// Applies one command.
    pub fn apply(&mut self, command: Command) {
        self.commands += 1;
        match command {
            Command::BaseControl(b) => self.command = b,
            Command::SoundSequence(s) => self.last_sound = Some(s),
            Command::RequestExtra(flags) => self.extra_requested |= flags,
        }
    }

    /// The wheel speeds the current command asks for, after the speed limit.
    fn target_wheels(&self) -> (f64, f64) {
        let (l, r) = self.command.wheel_speeds(self.config.wheel_base_m);
        let max = self.config.max_wheel_speed_mps;
        let top = l.abs().max(r.abs());
        if top > max && top > 0.0 {
            (l * max / top, r * max / top)
        } else {
            (l, r)
        }
    }

    /// Advances the base by `dt_s` seconds (ignored unless finite and positive).
    pub fn step(&mut self, dt_s: f64) {
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return;
        }
        let n = (dt_s / MAX_SUBSTEP_S).ceil().max(1.0);
        let h = dt_s / n;
        let target = self.target_wheels();
        for _ in 0..n as u64 {
            self.wheels = match self.config.max_wheel_accel_mps2 {
                None => target,
                Some(a) => {
                    let dv = a * h;
                    (
                        self.wheels.0 + (target.0 - self.wheels.0).clamp(-dv, dv),
                        self.wheels.1 + (target.1 - self.wheels.1).clamp(-dv, dv),
                    )
                }
            };
            let (dl, dr) = (self.wheels.0 * h, self.wheels.1 * h);
            self.travel.0 += dl;
            self.travel.1 += dr;
            let d = (dl + dr) / 2.0;
            let dyaw = (dr - dl) / self.config.wheel_base_m;
            let (x, y, yaw) = self.pose;
            // exact on an arc of constant wheel speeds
            let (dx, dy) = if dyaw.abs() < 1e-12 {
                (d * yaw.cos(), d * yaw.sin())
            } else {
                let r = d / dyaw;
                (
                    r * ((yaw + dyaw).sin() - yaw.sin()),
                    -r * ((yaw + dyaw).cos() - yaw.cos()),
                )
            };
            self.pose = (x + dx, y + dy, yaw + dyaw);
        }
        self.clock_s += dt_s;
    }

    /// True pose: x, y (m), yaw (rad, counter-clockwise, unwrapped).
    pub fn pose(&self) -> (f64, f64, f64) {
        self.pose
    }

    /// True velocity: forward m/s, turn rate rad/s.
    pub fn velocity(&self) -> (f64, f64) {
        let (l, r) = self.wheels;
        ((l + r) / 2.0, (r - l) / self.config.wheel_base_m)
    }

    /// Each wheel's travel since the start, m (left, right).
    pub fn wheel_travel(&self) -> (f64, f64) {
        self.travel
    }

    /// Seconds simulated.
    pub fn clock_s(&self) -> f64 {
        self.clock_s
    }

    /// The last Base Control received.
    pub fn command(&self) -> BaseControl {
        self.command
    }

    /// The last Sound Sequence received.
    pub fn last_sound(&self) -> Option<SoundSequence> {
        self.last_sound
    }

    /// Commands applied, and command sub-payloads received but not understood.
    pub fn command_counts(&self) -> (u64, u64) {
        (self.commands, self.command_errors)
    }

    /// The command parser's counts.
    pub fn frame_stats(&self) -> &FrameStats {
        self.parser.stats()
    }

    /// Sets the pressed bumpers ([`crate::feedback::bumper`] bits).
    pub fn set_bumper(&mut self, bits: u8) {
        self.bumper = bits;
    }

    /// Sets the cliff sensors that see a cliff ([`crate::feedback::cliff`] bits).
    pub fn set_cliff(&mut self, bits: u8) {
        self.cliff = bits;
    }

    /// Sets the dropped wheels ([`crate::feedback::wheel_drop`] bits).
    pub fn set_wheel_drop(&mut self, bits: u8) {
        self.wheel_drop = bits;
    }

    /// Sets the battery voltage reported, 0.1 V.
    pub fn set_battery_dv(&mut self, dv: u8) {
        self.battery_dv = dv;
    }

    /// The encoders now (left, right), ticks, wrapping.
    pub fn encoders(&self) -> (u16, u16) {
        let tick = |m: f64, start: u16| {
            let t = (m / self.config.m_per_tick).round() as i64;
            (i64::from(start) + t) as u16
        };
        (
            tick(self.travel.0, self.config.start_encoders.0),
            tick(self.travel.1, self.config.start_encoders.1),
        )
    }

    /// The base's clock now, ms, wrapping.
    pub fn timestamp_ms(&self) -> u16 {
        (i64::from(self.config.start_timestamp_ms) + (self.clock_s * 1000.0).round() as i64) as u16
    }

    /// The feedback the base would send now. Takes the pending Request Extra: its answers are
    /// in this feedback only.
    pub fn feedback(&mut self) -> Feedback {
        let (left, right) = self.encoders();
        let (vl, vr) = self.wheels;
        let max = self.config.max_wheel_speed_mps;
        let pwm = |v: f64| (100.0 * v / max).clamp(-100.0, 100.0).round() as i8;
        let (_, w) = self.velocity();
        let angle =
            wrap_pi(self.pose.2).to_degrees() * 100.0 + f64::from(self.config.gyro_offset_cdeg);
        let angle = (angle + 18000.0).rem_euclid(36000.0) - 18000.0;
        let extra = std::mem::take(&mut self.extra_requested);
        Feedback {
            basic: Some(BasicSensorData {
                timestamp_ms: self.timestamp_ms(),
                bumper: self.bumper,
                wheel_drop: self.wheel_drop,
                cliff: self.cliff,
                left_encoder: left,
                right_encoder: right,
                left_pwm: pwm(vl),
                right_pwm: pwm(vr),
                buttons: 0,
                charger: 0,
                battery_dv: self.battery_dv,
                over_current: 0,
            }),
            inertial: Some(InertialSensorData {
                angle_cdeg: angle.round() as i16,
                angle_rate_cdeg_s: (w.to_degrees() * 100.0).round() as i16,
            }),
            cliff: Some(CliffSensorData {
                adc: [0, 1, 2].map(|k| if self.cliff & (1 << k) != 0 { 20 } else { 1800 }),
            }),
            current: Some(MotorCurrent {
                current_10ma: [vl, vr].map(|v| (5.0 + 20.0 * v.abs()).round() as u8),
            }),
            hardware_version: (extra & request::HARDWARE_VERSION != 0)
                .then_some(self.config.hardware_version),
            firmware_version: (extra & request::FIRMWARE_VERSION != 0)
                .then_some(self.config.firmware_version),
            unique_device_id: (extra & request::UNIQUE_DEVICE_ID != 0)
                .then_some(self.config.unique_device_id),
            ..Feedback::default()
        }
    }

    /// Appends the feedback frame the base would send now to `out` (see
    /// [`SimBase::feedback`]), with the Docking IR and General Purpose Input sub-payloads a
    /// real base also sends (zeros here).
    pub fn feedback_frame(&mut self, out: &mut Vec<u8>) {
        let fb = self.feedback();
        let mut payload = Vec::with_capacity(96);
        // at most 17 + 9 + 5 + 8 + 4 + 6 + 6 + 14 + 18 = 87 bytes: always fits
        let fits = fb
            .encode_payload(&mut payload)
            .and_then(|()| push_subpayload(&mut payload, id::DOCKING_IR, &[0; 3]))
            .and_then(|()| push_subpayload(&mut payload, id::GENERAL_PURPOSE_INPUT, &[0; 16]))
            .and_then(|()| encode_frame(&payload, out));
        debug_assert!(fits.is_ok(), "{fits:?}");
    }
}

/// What a test or tool can change in a base while [`serve`] runs it on another thread.
#[derive(Debug, Default)]
pub struct Controls {
    stop: AtomicBool,
    unplug: AtomicBool,
    bumper: AtomicU8,
    cliff: AtomicU8,
    wheel_drop: AtomicU8,
    frames_sent: AtomicU64,
    /// The last Base Control received: speed (high 16 bits) and radius (low 16 bits).
    commanded: AtomicU32,
}

impl Controls {
    /// Ends the loop; the port stays open until the loop's caller drops it.
    pub fn stop(&self) {
        self.stop.store(true, Ordering::SeqCst);
    }

    /// Ends the loop and closes the port, as unplugging the base does.
    pub fn unplug(&self) {
        self.unplug.store(true, Ordering::SeqCst);
    }

    /// Presses bumpers (bits; 0 releases them). Frames started after this carry it.
    pub fn set_bumper(&self, bits: u8) {
        self.bumper.store(bits, Ordering::SeqCst);
    }

    /// Sets the cliff bits.
    pub fn set_cliff(&self, bits: u8) {
        self.cliff.store(bits, Ordering::SeqCst);
    }

    /// Sets the wheel-drop bits.
    pub fn set_wheel_drop(&self, bits: u8) {
        self.wheel_drop.store(bits, Ordering::SeqCst);
    }

    /// Feedback frames written so far.
    pub fn frames_sent(&self) -> u64 {
        self.frames_sent.load(Ordering::SeqCst)
    }

    /// The last Base Control the base received.
    pub fn commanded(&self) -> BaseControl {
        let bits = self.commanded.load(Ordering::SeqCst);
        BaseControl {
            speed_mm_s: (bits >> 16) as u16 as i16,
            radius_mm: bits as u16 as i16,
        }
    }
}

/// How [`serve`] ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ServeEnd {
    /// [`Controls::stop`] was called.
    Stopped,
    /// [`Controls::unplug`] was called and the port closed.
    Unplugged,
    /// The other side of the port closed (a read returned end of file or a hang-up).
    PeerClosed,
}

/// Why [`serve`] failed.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// Reading commands from the port failed.
    #[error("simulated base: reading commands from {port}: {source}")]
    Read {
        /// The port's name.
        port: String,
        /// The error.
        source: io::Error,
    },
    /// Writing feedback to the port failed.
    #[error("simulated base: writing feedback to {port}: {source}")]
    Write {
        /// The port's name.
        port: String,
        /// The error.
        source: io::Error,
    },
    /// Creating the pseudo-terminal pair failed.
    #[error("simulated base: creating a pseudo-terminal pair: {0}")]
    Pty(#[from] serialport::Error),
    /// Starting the thread failed.
    #[error("simulated base: starting its thread: {0}")]
    Thread(io::Error),
}

/// Runs `base` on `port` until [`Controls`] ends it: reads command bytes as they come, and
/// every `period` (the base's is [`FEEDBACK_PERIOD`]) advances the base by the time elapsed
/// and writes a feedback frame. The hazard bits in `controls` replace the base's own.
pub fn serve<P: serialport::SerialPort>(
    mut port: P,
    base: &mut SimBase,
    controls: &Controls,
    period: Duration,
) -> Result<ServeEnd, ServeError> {
    let name = port.name().unwrap_or_else(|| "the port".to_string());
    let mut buf = [0u8; 512];
    let mut out = Vec::with_capacity(128);
    let mut last = Instant::now();
    let mut next = last + period;
    loop {
        if controls.unplug.load(Ordering::SeqCst) {
            drop(port);
            return Ok(ServeEnd::Unplugged);
        }
        if controls.stop.load(Ordering::SeqCst) {
            return Ok(ServeEnd::Stopped);
        }
        let now = Instant::now();
        if now >= next {
            base.set_bumper(controls.bumper.load(Ordering::SeqCst));
            base.set_cliff(controls.cliff.load(Ordering::SeqCst));
            base.set_wheel_drop(controls.wheel_drop.load(Ordering::SeqCst));
            base.step((now - last).as_secs_f64());
            last = now;
            out.clear();
            base.feedback_frame(&mut out);
            port.write_all(&out)
                .and_then(|()| port.flush())
                .map_err(|source| ServeError::Write {
                    port: name.clone(),
                    source,
                })?;
            controls.frames_sent.fetch_add(1, Ordering::SeqCst);
            next += period;
            if next <= now {
                // after a stall, carry on at the period rather than catch up in a burst
                next = now + period;
            }
        }
        let wait = next
            .saturating_duration_since(Instant::now())
            .max(Duration::from_millis(1));
        // the port's timeout bounds the read; setting it only stores it
        let _ = port.set_timeout(wait);
        match port.read(&mut buf) {
            // end of file, or (serialport's poll) a hang-up: no one has the other side open
            Ok(0) => return Ok(ServeEnd::PeerClosed),
            Err(e) if e.kind() == io::ErrorKind::BrokenPipe => return Ok(ServeEnd::PeerClosed),
            Ok(n) => {
                base.receive(&buf[..n]);
                let c = base.command();
                let bits = u32::from(c.speed_mm_s as u16) << 16 | u32::from(c.radius_mm as u16);
                controls.commanded.store(bits, Ordering::SeqCst);
            }
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::TimedOut
                        | io::ErrorKind::WouldBlock
                        | io::ErrorKind::Interrupted
                ) => {}
            Err(source) => {
                return Err(ServeError::Read { port: name, source });
            }
        }
    }
}

/// A base served on its own thread on a pseudo-terminal: see [`spawn_on_pty`].
#[derive(Debug)]
pub struct SimHandle {
    controls: Arc<Controls>,
    thread: JoinHandle<(SimBase, Result<ServeEnd, ServeError>)>,
    path: String,
    /// The slave side kept open so that the master does not read end of file before the
    /// driver opens the path.
    _slave: serialport::TTYPort,
}

impl SimHandle {
    /// The path of the pseudo-terminal a driver opens, e.g. `/dev/pts/3`.
    pub fn path(&self) -> &str {
        &self.path
    }

    /// The running base's controls.
    pub fn controls(&self) -> &Arc<Controls> {
        &self.controls
    }

    /// Stops the loop (unless it ended already) and returns the base and how the loop ended.
    pub fn stop(self) -> (SimBase, Result<ServeEnd, ServeError>) {
        self.controls.stop();
        match self.thread.join() {
            Ok(r) => r,
            Err(panic) => std::panic::resume_unwind(panic),
        }
    }
}

/// Starts `base` on a thread on a new pseudo-terminal pair at the base's 50 Hz; the driver
/// opens [`SimHandle::path`] as it would open `/dev/kobuki`.
pub fn spawn_on_pty(base: SimBase) -> Result<SimHandle, ServeError> {
    let (master, slave) = serialport::TTYPort::pair()?;
    let path = serialport::SerialPort::name(&slave).unwrap_or_default();
    let controls = Arc::new(Controls::default());
    let c = Arc::clone(&controls);
    let thread = std::thread::Builder::new()
        .name("kobuki-simbase".into())
        .spawn(move || {
            let mut base = base;
            let r = serve(master, &mut base, &c, FEEDBACK_PERIOD);
            (base, r)
        })
        .map_err(ServeError::Thread)?;
    Ok(SimHandle {
        controls,
        thread,
        path,
        _slave: slave,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::feedback::bumper;
    use crate::odometry::Odometry;

    fn drive(base: &mut SimBase, v: f64, w: f64) {
        let mut bytes = Vec::new();
        Command::BaseControl(BaseControl::from_twist(v, w))
            .encode(&mut bytes)
            .unwrap();
        base.receive(&bytes);
    }

    fn decode(base: &mut SimBase) -> Feedback {
        let mut out = Vec::new();
        base.feedback_frame(&mut out);
        let mut p = FrameParser::new();
        let frames: Vec<_> = p.push(&out).flatten().collect();
        assert_eq!(frames.len(), 1);
        Feedback::decode(&frames[0])
    }

    #[test]
    fn straight_one_second_at_0_2() {
        let mut base = SimBase::new(SimBaseConfig::default());
        drive(&mut base, 0.2, 0.0);
        for _ in 0..50 {
            base.step(0.02);
        }
        let (x, y, yaw) = base.pose();
        assert!((x - 0.2).abs() < 1e-9 && y.abs() < 1e-12 && yaw.abs() < 1e-12);
        let fb = decode(&mut base);
        let b = fb.basic.unwrap();
        // 0.2 m at 11724.4 ticks/m
        assert_eq!((b.left_encoder, b.right_encoder), (2345, 2345));
        assert_eq!(b.timestamp_ms, 1000);
        assert_eq!(fb.skipped, 2);
        assert_eq!(fb.unknown, 0);
    }

    #[test]
    fn turning_in_place_and_the_gyro() {
        let mut base = SimBase::new(SimBaseConfig {
            gyro_offset_cdeg: 17000,
            ..SimBaseConfig::default()
        });
        let mut odo = Odometry::new();
        let fb = decode(&mut base);
        odo.update(&fb.basic.unwrap(), fb.inertial.as_ref());
        drive(&mut base, 0.0, 1.0);
        for _ in 0..200 {
            base.step(0.02);
            let fb = decode(&mut base);
            odo.update(&fb.basic.unwrap(), fb.inertial.as_ref());
        }
        let yaw = base.pose().2;
        // ω·b/2 = 115 mm/s exactly: 1 rad/s for 4 s
        assert!((yaw - 4.0).abs() < 1e-9, "{yaw}");
        let e = odo.estimate();
        assert!((e.yaw - 4.0).abs() < 2e-4, "{e:?}");
        assert!(e.x.abs() < 1e-3 && e.y.abs() < 1e-3, "{e:?}");
        assert!((e.w - 1.0).abs() < 0.01, "{e:?}");
    }

    #[test]
    fn arc_matches_odometry_and_truth() {
        let mut base = SimBase::new(SimBaseConfig {
            start_encoders: (65000, 100),
            start_timestamp_ms: 65000,
            ..SimBaseConfig::default()
        });
        let mut odo = Odometry::new();
        let fb = decode(&mut base);
        odo.update(&fb.basic.unwrap(), fb.inertial.as_ref());
        drive(&mut base, 0.3, -0.4);
        for _ in 0..250 {
            base.step(0.02);
            let fb = decode(&mut base);
            odo.update(&fb.basic.unwrap(), fb.inertial.as_ref());
        }
        let (x, y, yaw) = base.pose();
        let e = odo.estimate();
        assert!(
            (e.x - x).abs() < 5e-3 && (e.y - y).abs() < 5e-3 && (e.yaw - yaw).abs() < 1e-3,
            "{e:?} vs {:?}",
            base.pose()
        );
        let (v, w) = base.velocity();
        assert!((v - 0.3).abs() < 2e-3 && (w + 0.4).abs() < 2e-2, "{v} {w}");
    }

    #[test]
    fn speed_limit_keeps_the_radius_and_accel_limit_ramps() {
        let mut base = SimBase::new(SimBaseConfig::default());
        drive(&mut base, 2.0, 0.0);
        base.step(0.1);
        assert!((base.velocity().0 - 0.7).abs() < 1e-12);
        let mut base = SimBase::new(SimBaseConfig {
            max_wheel_accel_mps2: Some(1.0),
            ..SimBaseConfig::default()
        });
        drive(&mut base, 0.5, 0.0);
        base.step(0.1);
        assert!((base.velocity().0 - 0.1).abs() < 1e-9);
        base.step(1.0);
        assert!((base.velocity().0 - 0.5).abs() < 1e-9);
    }

    #[test]
    fn hazards_battery_sound_and_request_extra() {
        let mut base = SimBase::new(SimBaseConfig::default());
        base.set_bumper(bumper::CENTRAL);
        base.set_cliff(crate::feedback::cliff::LEFT);
        base.set_battery_dv(120);
        let mut bytes = Vec::new();
        Command::encode_all(
            &[
                Command::SoundSequence(SoundSequence::Button),
                Command::RequestExtra(request::FIRMWARE_VERSION | request::UNIQUE_DEVICE_ID),
            ],
            &mut bytes,
        )
        .unwrap();
        // cut across two reads, garbage before
        base.receive(&[0x00, 0xAA]);
        base.receive(&bytes[..5]);
        base.receive(&bytes[5..]);
        assert_eq!(base.last_sound(), Some(SoundSequence::Button));
        let fb = decode(&mut base);
        let b = fb.basic.unwrap();
        assert_eq!((b.bumper, b.cliff, b.battery_dv), (bumper::CENTRAL, 4, 120));
        assert_eq!(fb.cliff.unwrap().adc, [1800, 1800, 20]);
        assert_eq!(
            fb.firmware_version,
            Some(SimBaseConfig::default().firmware_version)
        );
        assert!(fb.unique_device_id.is_some() && fb.hardware_version.is_none());
        // answered once
        assert!(decode(&mut base).firmware_version.is_none());
        assert_eq!(base.command_counts(), (2, 0));
        assert_eq!(base.frame_stats().garbage_bytes, 2);
    }
}
