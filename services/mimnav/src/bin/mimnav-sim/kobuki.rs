//! `sim.base = "kobuki"`: the simulated robot's base is a Kobuki on a pseudo-terminal
//! ([`mimnav_kobuki::simbase`]), and `mimnav-kobuki` drives it as it drives a Turtlebot 2's.
//!
//! The simulator makes a pty pair and the symlink `sim.kobuki_link` to its device. Every step
//! it reads the command bytes waiting (Base Control from `mimnav-kobuki`), and every 20 ms of
//! sensor time it advances the simulated base by that time and writes a feedback frame
//! (encoders and gyro from the base's own motion). The simulator's robot follows the base's
//! wheel speeds (within the robot's limits), so the odometry `mimnav-kobuki` publishes comes
//! from the protocol, not from the simulator's true pose; the difference is the odometry's
//! error, as on a real base (`mimnav demo --base kobuki` prints it). The base's wheel speeds
//! change no faster than the robot's `max_linear_accel` and `max_angular_accel` allow.

use std::io::{ErrorKind, Read, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use mimnav_kobuki::simbase::{FEEDBACK_PERIOD, SimBase, SimBaseConfig};
use mimnav_shared::config::RobotProfile;
use mimnav_shared::service::Health;
use serialport::{SerialPort, TTYPort};

/// The simulated Kobuki on its pty.
pub struct PtyBase {
    master: TTYPort,
    // held open so the master never reads a hang-up before mimnav-kobuki opens the device
    _slave: TTYPort,
    link: PathBuf,
    base: SimBase,
    last_ns: Option<u64>,
    next_ns: u64,
    buf: Vec<u8>,
    out: Vec<u8>,
    /// Feedback frames written.
    pub frames: u64,
}

impl PtyBase {
    /// A base on a new pty, reached through the symlink `link` (an existing symlink there is
    /// replaced; anything else there is an error).
    pub fn open(link: &Path, robot: &RobotProfile) -> Result<PtyBase> {
        // the wheels change speed no faster than the robot's linear and angular limits allow,
        // so the simulator's robot, which follows the wheels within those limits, keeps up
        let half_base = mimnav_kobuki::WHEEL_BASE_M / 2.0;
        let max_accel_mps2 = robot
            .max_linear_accel
            .min(robot.max_angular_accel * half_base);
        let (mut master, slave) =
            TTYPort::pair().context("cannot create a pseudo-terminal pair")?;
        master
            .set_timeout(std::time::Duration::ZERO)
            .context("pty: cannot set its timeout")?;
        let device = slave
            .name()
            .context("the pseudo-terminal has no device name")?;
        if let Some(dir) = link.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("sim.kobuki_link: cannot create {}", dir.display()))?;
        }
        match std::fs::symlink_metadata(link) {
            Ok(m) if m.file_type().is_symlink() => std::fs::remove_file(link)
                .with_context(|| format!("sim.kobuki_link: cannot replace {}", link.display()))?,
            Ok(_) => anyhow::bail!(
                "sim.kobuki_link: {} exists and is not a symlink: not replacing it",
                link.display()
            ),
            Err(_) => {}
        }
        std::os::unix::fs::symlink(&device, link).with_context(|| {
            format!(
                "sim.kobuki_link: cannot link {} to {device}",
                link.display()
            )
        })?;
        tracing::info!(link = %link.display(), %device, "simulated Kobuki on a pty");
        Ok(PtyBase {
            master,
            _slave: slave,
            link: link.to_path_buf(),
            base: SimBase::new(SimBaseConfig {
                max_wheel_accel_mps2: Some(max_accel_mps2),
                ..SimBaseConfig::default()
            }),
            last_ns: None,
            next_ns: 0,
            buf: vec![0; 1024],
            out: Vec::with_capacity(128),
            frames: 0,
        })
    }

    /// At sensor time `now_ns`: takes the commands waiting and, when a feedback period has
    /// passed, moves the base and writes its feedback. Returns the base's wheel speeds as
    /// (v, ω) for the simulator's robot to follow.
    pub fn step(&mut self, now_ns: u64, h: &mut Health) -> (f64, f64) {
        loop {
            match self.master.read(&mut self.buf) {
                Ok(0) => break,
                Ok(n) => self.base.receive(&self.buf[..n]),
                Err(e)
                    if matches!(
                        e.kind(),
                        ErrorKind::TimedOut | ErrorKind::WouldBlock | ErrorKind::Interrupted
                    ) =>
                {
                    break;
                }
                // no driver has the device open (yet, or any more): nothing to read
                Err(_) => break,
            }
        }
        let last = *self.last_ns.get_or_insert(now_ns);
        if now_ns >= self.next_ns {
            self.base.step(now_ns.saturating_sub(last) as f64 * 1e-9);
            self.last_ns = Some(now_ns);
            self.next_ns = now_ns + FEEDBACK_PERIOD.as_nanos() as u64;
            self.out.clear();
            self.base.feedback_frame(&mut self.out);
            // with no one reading, the pty's buffer fills: old feedback is worth nothing, so a
            // frame that does not fit is dropped (and counted)
            match self.master.write(&self.out) {
                Ok(n) if n == self.out.len() => self.frames += 1,
                Ok(_) | Err(_) => {
                    let what = "the pty's buffer is full (no one reads the simulated Kobuki)";
                    h.faults
                        .record("kobuki_feedback_dropped", Instant::now(), what);
                }
            }
            let _ = self.master.flush();
        }
        self.base.velocity()
    }
}

impl Drop for PtyBase {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.link);
    }
}
