//! The gate between the last velocity command and what is sent to the base.
//!
//! [`Safety::decide`] is a pure function of what the gate was told (the last command with its
//! expiry, the latest hazard bits with their time) and the time now:
//! - no command, or its `valid_until_ns` has passed: stop;
//! - a non-finite command: stop;
//! - no feedback yet, or the latest is older than [`SafetyConfig::feedback_timeout_ns`]: stop
//!   (the bumper and cliff state are unknown);
//! - a wheel dropped: stop, whatever the command (the base is lifted or a wheel hangs over an
//!   edge; no motion is known to be safe);
//! - a bumper pressed or a cliff seen: forward motion (`v > 0`) is refused and the whole
//!   command replaced by a stop (an arc is not turned into a turn in place the planner did not
//!   ask for); reversing (`v < 0`, with or without turning) and turning in place (`v == 0`)
//!   pass, so the robot can back away from what it hit. The bumpers and cliff sensors are at
//!   the front, so reversing moves away from both;
//! - otherwise the command passes.

use crate::feedback::BasicSensorData;

/// A velocity command with the time it stops being valid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CmdVel {
    /// Forward speed, m/s.
    pub v: f64,
    /// Turn rate, rad/s, counter-clockwise.
    pub w: f64,
    /// Monotonic time, ns, after which the command must no longer drive the base.
    pub valid_until_ns: u64,
}

/// The hazard bits of a Basic Sensor Data, with the host time they were received.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Hazards {
    /// Bumper bits.
    pub bumper: u8,
    /// Cliff bits.
    pub cliff: u8,
    /// Wheel-drop bits.
    pub wheel_drop: u8,
    /// Monotonic time of receipt, ns.
    pub stamp_ns: u64,
}

impl Hazards {
    /// The hazards of `basic`, received at `stamp_ns`.
    pub fn from_basic(basic: &BasicSensorData, stamp_ns: u64) -> Hazards {
        Hazards {
            bumper: basic.bumper,
            cliff: basic.cliff,
            wheel_drop: basic.wheel_drop,
            stamp_ns,
        }
    }
}

/// Why the gate sent what it sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reason {
    /// The command passed unchanged.
    Pass,
    /// No command has been received.
    NoCommand,
    /// The command's validity has passed.
    Expired,
    /// The command was not finite.
    NotFinite,
    /// No feedback yet, or too old to know the bumpers and cliffs.
    FeedbackStale,
    /// A wheel is dropped: every motion refused.
    WheelDrop,
    /// A bumper is pressed: forward motion refused.
    Bumper,
    /// A cliff is seen: forward motion refused.
    Cliff,
}

/// The gate's output: the velocity to send and why.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decision {
    /// Forward speed to send, m/s.
    pub v: f64,
    /// Turn rate to send, rad/s.
    pub w: f64,
    /// Why.
    pub reason: Reason,
}

impl Decision {
    fn stop(reason: Reason) -> Decision {
        Decision {
            v: 0.0,
            w: 0.0,
            reason,
        }
    }

    /// Whether the command was changed.
    pub fn overridden(&self) -> bool {
        self.reason != Reason::Pass
    }
}

/// The gate's settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SafetyConfig {
    /// Feedback older than this is treated as unknown hazards, ns. The base sends feedback
    /// every 20 ms; the default allows ten frames to be lost.
    pub feedback_timeout_ns: u64,
}

impl Default for SafetyConfig {
    fn default() -> Self {
        SafetyConfig {
            feedback_timeout_ns: 200_000_000,
        }
    }
}

/// The gate: see the module documentation.
#[derive(Debug, Clone, Default)]
pub struct Safety {
    config: SafetyConfig,
    cmd: Option<CmdVel>,
    hazards: Option<Hazards>,
}

impl Safety {
    /// A gate with no command and no feedback: it stops the base.
    pub fn new(config: SafetyConfig) -> Self {
        Safety {
            config,
            cmd: None,
            hazards: None,
        }
    }

    /// Takes a new command, replacing the last one.
    pub fn set_command(&mut self, cmd: CmdVel) {
        self.cmd = Some(cmd);
    }

    /// Takes the latest hazards.
    pub fn set_hazards(&mut self, hazards: Hazards) {
        self.hazards = Some(hazards);
    }

    /// The latest hazards, if any.
    pub fn hazards(&self) -> Option<&Hazards> {
        self.hazards.as_ref()
    }

    /// What to send at `now_ns`.
    pub fn decide(&self, now_ns: u64) -> Decision {
        let Some(cmd) = self.cmd else {
            return Decision::stop(Reason::NoCommand);
        };
        if now_ns > cmd.valid_until_ns {
            return Decision::stop(Reason::Expired);
        }
        if !(cmd.v.is_finite() && cmd.w.is_finite()) {
            return Decision::stop(Reason::NotFinite);
        }
        let Some(h) = self.hazards else {
            return Decision::stop(Reason::FeedbackStale);
        };
        if now_ns.saturating_sub(h.stamp_ns) > self.config.feedback_timeout_ns {
            return Decision::stop(Reason::FeedbackStale);
        }
        if h.wheel_drop != 0 {
            return Decision::stop(Reason::WheelDrop);
        }
        if cmd.v > 0.0 {
            if h.bumper != 0 {
                return Decision::stop(Reason::Bumper);
            }
            if h.cliff != 0 {
                return Decision::stop(Reason::Cliff);
            }
        }
        Decision {
            v: cmd.v,
            w: cmd.w,
            reason: Reason::Pass,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u64 = 1_000_000;

    fn gate(v: f64, w: f64, bumper: u8, cliff: u8, drop: u8) -> Safety {
        let mut s = Safety::new(SafetyConfig::default());
        s.set_command(CmdVel {
            v,
            w,
            valid_until_ns: 1000 * MS,
        });
        s.set_hazards(Hazards {
            bumper,
            cliff,
            wheel_drop: drop,
            stamp_ns: 900 * MS,
        });
        s
    }

    #[test]
    fn passes_when_clear_and_stops_after_expiry() {
        let s = gate(0.3, 0.1, 0, 0, 0);
        let d = s.decide(950 * MS);
        assert_eq!((d.v, d.w, d.reason), (0.3, 0.1, Reason::Pass));
        assert!(!d.overridden());
        // valid up to and including valid_until
        assert_eq!(s.decide(1000 * MS).reason, Reason::Pass);
        assert_eq!(s.decide(1000 * MS + 1).reason, Reason::Expired);
        assert_eq!(s.decide(1000 * MS + 1).v, 0.0);
    }

    #[test]
    fn nothing_known_stops() {
        let s = Safety::new(SafetyConfig::default());
        assert_eq!(s.decide(0).reason, Reason::NoCommand);
        let mut s = Safety::default();
        s.set_command(CmdVel {
            v: 0.1,
            w: 0.0,
            valid_until_ns: u64::MAX,
        });
        assert_eq!(s.decide(0).reason, Reason::FeedbackStale);
        let s = gate(0.1, 0.0, 0, 0, 0);
        // feedback 200 ms old is still fresh, 200 ms + 1 ns is not
        assert_eq!(s.decide(900 * MS + 100 * MS).reason, Reason::Pass);
        let mut t = gate(0.1, 0.0, 0, 0, 0);
        t.set_command(CmdVel {
            v: 0.1,
            w: 0.0,
            valid_until_ns: 2000 * MS,
        });
        assert_eq!(t.decide(1100 * MS + 1).reason, Reason::FeedbackStale);
        assert_eq!(
            gate(f64::NAN, 0.0, 0, 0, 0).decide(0).reason,
            Reason::NotFinite
        );
    }

    #[test]
    fn bumper_and_cliff_refuse_forward_only() {
        for (b, c, reason) in [(2, 0, Reason::Bumper), (0, 4, Reason::Cliff)] {
            // forward, forward arcs: stopped whole
            for w in [0.0, 0.5, -0.5] {
                let d = gate(0.2, w, b, c, 0).decide(950 * MS);
                assert_eq!((d.v, d.w, d.reason), (0.0, 0.0, reason));
            }
            // reverse, reverse arcs and turning in place pass
            for (v, w) in [(-0.1, 0.0), (-0.1, 0.4), (0.0, 1.0), (0.0, -1.0)] {
                let d = gate(v, w, b, c, 0).decide(950 * MS);
                assert_eq!((d.v, d.w, d.reason), (v, w, Reason::Pass));
            }
        }
    }

    #[test]
    fn wheel_drop_refuses_everything() {
        for (v, w) in [(0.2, 0.0), (-0.1, 0.0), (0.0, 1.0)] {
            let d = gate(v, w, 0, 0, 1).decide(950 * MS);
            assert_eq!((d.v, d.w, d.reason), (0.0, 0.0, Reason::WheelDrop));
        }
    }
}
