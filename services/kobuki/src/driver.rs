//! The `mimnav-kobuki` service's logic, without I/O: bytes read from the base's serial port
//! come in, the stack's `odom` and `base/state` go out, and `cmd_vel` goes to the base as Base
//! Control through the [`Safety`] gate. The service's `main.rs` owns the port, the clock and
//! the topics; everything it decides is here, so the tests drive it the same way.
//!
//! - Each feedback frame's Basic Sensor Data (with the Inertial Sensor Data's heading unless
//!   `kobuki.use_gyro` is off) advances the [`Odometry`] and gives one `odom` sample (REP-105
//!   odometry frame: x forward at start, yaw counter-clockwise, wrapped to ±π; velocity from the
//!   base's own clock) and one `base/state` sample (bumpers, cliffs, wheel drops, buttons,
//!   charger, battery, over-current, and why motion is refused).
//! - A frame rejected (bad checksum, bad length, sub-payloads that overrun) or a sub-payload of
//!   the wrong length is counted in `BaseState::rejected` and handed to the caller to log.
//! - [`Driver::command`] is what to write now: Base Control of the gate's decision — zero once
//!   the command's `valid_until_mono_ns` has passed, zero for forward motion while a bumper or
//!   cliff is active, zero for everything while a wheel is dropped or the feedback is stale.
//! - [`Driver::link_down`] when the port is gone: `base/state` says so, the odometry keeps its
//!   pose and takes the next frame's encoders as where the base is ([`Odometry::resync`]), and
//!   the gate forgets the hazards, so nothing moves until fresh feedback has come.

use mimnav_shared::topics::{self, BaseState, base_halt, base_kind, base_link};

use crate::command::{BaseControl, Command, request};
use crate::feedback::{Feedback, SubPayloadError};
use crate::frame::{FrameError, FrameParser, FrameStats};
use crate::odometry::{Odometry, wrap_pi};
use crate::safety::{CmdVel, Decision, Hazards, Reason, Safety, SafetyConfig};

/// The driver's settings (`[kobuki]` of the config).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriverConfig {
    /// The gate's settings (feedback older than its timeout stops the base).
    pub safety: SafetyConfig,
    /// Heading from the gyro (true) or from the wheels alone.
    pub use_gyro: bool,
}

impl Default for DriverConfig {
    fn default() -> Self {
        DriverConfig {
            safety: SafetyConfig::default(),
            use_gyro: true,
        }
    }
}

/// What one batch of bytes produced, in order.
#[derive(Debug, Clone, PartialEq)]
pub enum Update {
    /// A feedback frame's odometry.
    Odom(topics::Odometry),
    /// A feedback frame's state.
    State(BaseState),
    /// A frame the parser rejected.
    Rejected(FrameError),
    /// A sub-payload of a good frame that could not be decoded (the rest of the frame was).
    Malformed(SubPayloadError),
    /// The base's versions and unique id (answering the Request Extra sent on connecting).
    Identified {
        /// Hardware version (major, minor, patch).
        hardware: (u8, u8, u8),
        /// Firmware version (major, minor, patch).
        firmware: (u8, u8, u8),
        /// Unique device id.
        id: [u32; 3],
    },
}

/// The driver; see the module documentation.
#[derive(Debug)]
pub struct Driver {
    config: DriverConfig,
    parser: FrameParser,
    odom: Odometry,
    safety: Safety,
    state: BaseState,
    odom_seq: u64,
    out: Vec<u8>,
    identity: Identity,
}

/// The answers to the Request Extra gathered so far: hardware and firmware versions, unique id.
type Identity = (Option<(u8, u8, u8)>, Option<(u8, u8, u8)>, Option<[u32; 3]>);

impl Driver {
    /// A driver that has heard nothing: its link is down and it commands a stop.
    pub fn new(config: DriverConfig) -> Self {
        Driver {
            config,
            parser: FrameParser::new(),
            odom: Odometry::new(),
            safety: Safety::new(config.safety),
            state: BaseState {
                base: base_kind::KOBUKI,
                link: base_link::DOWN,
                halted: base_halt::LINK_DOWN | base_halt::COMMAND_EXPIRED,
                battery_v: f32::NAN,
                ..BaseState::default()
            },
            odom_seq: 0,
            out: Vec::with_capacity(64),
            identity: (None, None, None),
        }
    }

    /// The port was (re)opened: the bytes to write first — a stop, and a Request Extra for the
    /// versions and the unique id (named in the log once they come).
    pub fn connected(&mut self) -> &[u8] {
        self.parser.reset();
        self.out.clear();
        let flags =
            request::HARDWARE_VERSION | request::FIRMWARE_VERSION | request::UNIQUE_DEVICE_ID;
        let commands = [
            Command::BaseControl(BaseControl::STOP),
            Command::RequestExtra(flags),
        ];
        // two short sub-payloads always fit a frame
        Command::encode_all(&commands, &mut self.out).expect("a 10-byte payload fits a frame");
        &self.out
    }

    /// The port is gone (unplugged, closed, silent): returns the state to publish.
    pub fn link_down(&mut self, now_mono_ns: u64) -> BaseState {
        if self.state.link == base_link::UP {
            self.state.link_losses += 1;
        }
        self.state.link = base_link::DOWN;
        self.odom.resync();
        self.safety = Safety::new(self.config.safety);
        self.state.halted = base_halt::LINK_DOWN | base_halt::COMMAND_EXPIRED;
        self.state.seq += 1;
        self.state.rx_mono_ns = now_mono_ns;
        self.state
    }

    /// Takes the planner's latest command (it replaces the last; it stops being valid at its
    /// `valid_until_mono_ns`).
    pub fn set_command(&mut self, c: &topics::VelocityCommand) {
        self.safety.set_command(CmdVel {
            v: f64::from(c.v),
            w: f64::from(c.omega),
            valid_until_ns: c.valid_until_mono_ns,
        });
    }

    /// Feeds bytes read from the port at `now_mono_ns` (`CLOCK_MONOTONIC`) and `now_real_ns`
    /// (the Unix epoch, the stack's sensor clock); `on` gets what they produced. Returns how
    /// many feedback frames they completed.
    pub fn receive(
        &mut self,
        bytes: &[u8],
        now_mono_ns: u64,
        now_real_ns: u64,
        mut on: impl FnMut(Update),
    ) -> usize {
        let mut feedback = 0;
        let Driver {
            parser,
            odom,
            safety,
            state,
            odom_seq,
            identity,
            config,
            ..
        } = self;
        for frame in parser.push(bytes) {
            let frame = match frame {
                Ok(f) => f,
                Err(e) => {
                    state.rejected += 1;
                    on(Update::Rejected(e));
                    continue;
                }
            };
            let fb = Feedback::decode(&frame);
            for e in fb.errors.iter() {
                state.rejected += 1;
                on(Update::Malformed(e.clone()));
            }
            if let Some(v) = fb.hardware_version {
                identity.0 = Some((v.major, v.minor, v.patch));
            }
            if let Some(v) = fb.firmware_version {
                identity.1 = Some((v.major, v.minor, v.patch));
            }
            if let Some(id) = fb.unique_device_id {
                identity.2 = Some(id);
            }
            if let (Some(hardware), Some(firmware), Some(id)) = *identity {
                on(Update::Identified {
                    hardware,
                    firmware,
                    id,
                });
                // said once per connection
                *identity = (None, None, None);
            }
            let Some(basic) = fb.basic else {
                continue;
            };
            feedback += 1;
            let inertial = fb.inertial.filter(|_| config.use_gyro);
            let est = odom.update(&basic, inertial.as_ref());
            *odom_seq += 1;
            on(Update::Odom(topics::Odometry {
                seq: *odom_seq,
                stamp_ns: now_real_ns,
                rx_mono_ns: now_mono_ns,
                x: est.x,
                y: est.y,
                yaw: wrap_pi(est.yaw),
                v: est.v as f32,
                omega: est.w as f32,
            }));
            safety.set_hazards(Hazards::from_basic(&basic, now_mono_ns));
            state.link = base_link::UP;
            state.seq += 1;
            state.rx_mono_ns = now_mono_ns;
            state.base_stamp_ms = u32::from(basic.timestamp_ms);
            state.battery_v = basic.battery_volts() as f32;
            state.bumper = basic.bumper;
            state.cliff = basic.cliff;
            state.wheel_drop = basic.wheel_drop;
            state.buttons = basic.buttons;
            state.charger = basic.charger;
            state.over_current = basic.over_current;
            state.halted = halted(state, safety.decide(now_mono_ns).reason);
            on(Update::State(*state));
        }
        feedback
    }

    /// What to send the base at `now_mono_ns`: the gate's decision and its Base Control frame.
    pub fn command(&mut self, now_mono_ns: u64) -> (Decision, &[u8]) {
        let d = self.safety.decide(now_mono_ns);
        self.state.halted = halted(&self.state, d.reason);
        self.out.clear();
        Command::BaseControl(BaseControl::from_twist(d.v, d.w))
            .encode(&mut self.out)
            .expect("a 4-byte payload fits a frame");
        (d, &self.out)
    }

    /// The latest state (what the last feedback said, and the last decision's halts).
    pub fn state(&self) -> &BaseState {
        &self.state
    }

    /// The parser's counts since the service started.
    pub fn frame_stats(&self) -> &FrameStats {
        self.parser.stats()
    }

    /// The odometry's latest estimate.
    pub fn odometry(&self) -> &Odometry {
        &self.odom
    }
}

/// The `base_halt` bits of a state and the gate's latest reason.
fn halted(s: &BaseState, reason: Reason) -> u16 {
    let mut h = 0;
    if s.bumper != 0 {
        h |= base_halt::BUMPER;
    }
    if s.cliff != 0 {
        h |= base_halt::CLIFF;
    }
    if s.wheel_drop != 0 {
        h |= base_halt::WHEEL_DROP;
    }
    if s.over_current != 0 {
        h |= base_halt::OVER_CURRENT;
    }
    if s.link != base_link::UP {
        h |= base_halt::LINK_DOWN;
    }
    if matches!(
        reason,
        Reason::NoCommand | Reason::Expired | Reason::NotFinite
    ) {
        h |= base_halt::COMMAND_EXPIRED;
    }
    if reason == Reason::FeedbackStale {
        h |= base_halt::LINK_DOWN;
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::feedback::bumper;
    use crate::simbase::{SimBase, SimBaseConfig};

    const MS: u64 = 1_000_000;

    fn cmd(v: f32, omega: f32, valid_until_mono_ns: u64) -> topics::VelocityCommand {
        topics::VelocityCommand {
            v,
            omega,
            valid_until_mono_ns,
            ..Default::default()
        }
    }

    /// The driver and the simulated base joined by their bytes, 20 ms a cycle.
    struct Loop {
        base: SimBase,
        driver: Driver,
        now: u64,
        odom: Vec<topics::Odometry>,
        states: Vec<BaseState>,
        rejected: usize,
    }

    impl Loop {
        fn new() -> Self {
            let mut l = Loop {
                base: SimBase::new(SimBaseConfig::default()),
                driver: Driver::new(DriverConfig::default()),
                now: 1_000 * MS,
                odom: Vec::new(),
                states: Vec::new(),
                rejected: 0,
            };
            let hello = l.driver.connected().to_vec();
            l.base.receive(&hello);
            l
        }

        /// One 20 ms period: the base moves and sends feedback (damaged by `damage`), the
        /// driver reads it and answers with its command.
        fn cycle(&mut self, damage: impl Fn(&mut Vec<u8>)) -> Decision {
            self.base.step(0.02);
            self.now += 20 * MS;
            let mut wire = Vec::new();
            self.base.feedback_frame(&mut wire);
            damage(&mut wire);
            let Loop {
                driver,
                odom,
                states,
                rejected,
                now,
                ..
            } = self;
            driver.receive(&wire, *now, *now, |u| match u {
                Update::Odom(o) => odom.push(o),
                Update::State(s) => states.push(s),
                Update::Rejected(_) | Update::Malformed(_) => *rejected += 1,
                Update::Identified { .. } => {}
            });
            let (d, bytes) = self.driver.command(self.now);
            let bytes = bytes.to_vec();
            self.base.receive(&bytes);
            d
        }
    }

    #[test]
    fn the_base_follows_cmd_vel_and_odometry_follows_the_base() {
        let mut l = Loop::new();
        for _ in 0..50 {
            let valid = l.now + 200 * MS;
            l.driver.set_command(&cmd(0.2, 0.3, valid));
            let d = l.cycle(|_| {});
            assert!(d.reason == Reason::Pass || l.odom.len() < 2, "{d:?}");
        }
        let (x, y, yaw) = l.base.pose();
        let o = l.odom.last().expect("odometry");
        assert!(
            (o.x - x).abs() < 0.01 && (o.y - y).abs() < 0.01 && (o.yaw - yaw).abs() < 0.01,
            "odom ({}, {}, {}) base ({x}, {y}, {yaw})",
            o.x,
            o.y,
            o.yaw
        );
        assert!(x > 0.15, "it drove: {x}");
        assert!(
            (o.v - 0.2).abs() < 0.02 && (o.omega - 0.3).abs() < 0.03,
            "{o:?}"
        );
        let s = l.states.last().expect("state");
        assert_eq!((s.link, s.halted), (base_link::UP, 0), "{s:?}");
        assert_eq!(l.rejected, 0);
    }

    #[test]
    fn a_command_past_its_validity_stops_the_base_at_once() {
        let mut l = Loop::new();
        let valid = l.now + 100 * MS;
        l.driver.set_command(&cmd(0.3, 0.0, valid));
        for _ in 0..10 {
            l.cycle(|_| {});
        }
        // 200 ms later: the command expired after 100 ms
        let (d, _) = l.driver.command(l.now);
        assert_eq!((d.v, d.w, d.reason), (0.0, 0.0, Reason::Expired));
        assert_eq!(l.base.command(), BaseControl::STOP);
        assert!(l.driver.state().halted & base_halt::COMMAND_EXPIRED != 0);
    }

    #[test]
    fn a_bumper_stops_forward_motion_within_one_feedback_period() {
        let mut l = Loop::new();
        for _ in 0..10 {
            let valid = l.now + 200 * MS;
            l.driver.set_command(&cmd(0.3, 0.0, valid));
            l.cycle(|_| {});
        }
        assert_ne!(l.base.command(), BaseControl::STOP);
        l.base.set_bumper(bumper::CENTRAL);
        let valid = l.now + 200 * MS;
        l.driver.set_command(&cmd(0.3, 0.0, valid));
        // the first frame the base sends after the press carries it; the answer is a stop
        let d = l.cycle(|_| {});
        assert_eq!(d.reason, Reason::Bumper);
        assert_eq!(l.base.command(), BaseControl::STOP);
        let s = l.states.last().expect("state");
        assert_eq!(s.bumper, bumper::CENTRAL);
        assert!(s.halted & base_halt::BUMPER != 0);
        // backing off is allowed
        l.driver.set_command(&cmd(-0.1, 0.0, l.now + 200 * MS));
        let d = l.cycle(|_| {});
        assert_eq!(d.reason, Reason::Pass);
    }

    #[test]
    fn damaged_frames_are_counted_and_the_good_ones_still_drive_odometry() {
        let mut l = Loop::new();
        let mut k = 0;
        for _ in 0..40 {
            let valid = l.now + 200 * MS;
            l.driver.set_command(&cmd(0.2, 0.0, valid));
            k += 1;
            let broken = k % 4 == 0;
            l.cycle(|w| {
                if broken {
                    // a flipped byte in the payload: the checksum no longer holds
                    let i = w.len() / 2;
                    w[i] ^= 0x5a;
                }
            });
        }
        assert_eq!(l.rejected, 10, "{:?}", l.driver.frame_stats());
        assert_eq!(l.driver.state().rejected, 10);
        assert_eq!(l.odom.len(), 30);
        // the encoders are absolute: the frames lost cost no distance
        let (x, _, _) = l.base.pose();
        let o = l.odom.last().expect("odometry");
        assert!((o.x - x).abs() < 0.005, "{} against {x}", o.x);
    }

    #[test]
    fn a_lost_link_stops_everything_until_feedback_is_back_and_keeps_the_pose() {
        let mut l = Loop::new();
        for _ in 0..25 {
            let valid = l.now + 200 * MS;
            l.driver.set_command(&cmd(0.2, 0.0, valid));
            l.cycle(|_| {});
        }
        let before = *l.odom.last().expect("odometry");
        let s = l.driver.link_down(l.now);
        assert_eq!((s.link, s.link_losses), (base_link::DOWN, 1));
        assert!(s.halted & base_halt::LINK_DOWN != 0);
        // a fresh command, but no feedback since: stop
        l.driver.set_command(&cmd(0.2, 0.0, l.now + 200 * MS));
        let (d, _) = l.driver.command(l.now);
        assert_eq!(d.reason, Reason::FeedbackStale);
        // the base comes back switched off and on: encoders and gyro from zero
        l.base = SimBase::new(SimBaseConfig::default());
        let hello = l.driver.connected().to_vec();
        l.base.receive(&hello);
        l.cycle(|_| {});
        let after = *l.odom.last().expect("odometry");
        assert!(
            (after.x - before.x).abs() < 1e-9 && (after.yaw - before.yaw).abs() < 1e-9,
            "{before:?} {after:?}"
        );
        l.driver.set_command(&cmd(0.2, 0.0, l.now + 200 * MS));
        let d = l.cycle(|_| {});
        assert_eq!(d.reason, Reason::Pass);
        assert_eq!(l.driver.state().link, base_link::UP);
    }

    #[test]
    fn a_non_finite_command_is_a_stop() {
        let mut l = Loop::new();
        l.cycle(|_| {});
        l.driver.set_command(&cmd(f32::NAN, 0.0, l.now + 200 * MS));
        let (d, _) = l.driver.command(l.now);
        assert_eq!((d.v, d.w, d.reason), (0.0, 0.0, Reason::NotFinite));
    }
}
