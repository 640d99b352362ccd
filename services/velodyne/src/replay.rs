//! Pacing a capture replay by its timestamps.
//!
//! [`Pacer`] turns capture timestamps into the instants at which the datagrams should be sent:
//! real time times a speed factor, or as fast as possible. The capture's clock is followed
//! through a virtual clock that only moves forward and at most `max_gap_ns` per datagram, so a
//! capture with out-of-order timestamps or a long pause does not stall the replay.

use std::time::{Duration, Instant};

/// Replay pacing.
#[derive(Debug, Clone)]
pub struct Pacer {
    speed: Option<f64>,
    max_gap_ns: u64,
    anchor: Option<Instant>,
    last_capture_ns: u64,
    virtual_ns: u64,
}

impl Pacer {
    /// `speed`: `Some(factor)` replays at `factor` × real time (factor > 0), `None` as fast as
    /// possible. Gaps between datagrams longer than `max_gap_ns` (capture time) are shortened to it.
    pub fn new(speed: Option<f64>, max_gap_ns: u64) -> Self {
        Pacer {
            speed,
            max_gap_ns,
            anchor: None,
            last_capture_ns: 0,
            virtual_ns: 0,
        }
    }

    /// Starts over (a looped replay): the next datagram is due at once.
    pub fn restart(&mut self) {
        self.anchor = None;
        self.virtual_ns = 0;
    }

    /// When the datagram stamped `capture_ns` is due, given that it is `now`.
    pub fn due(&mut self, capture_ns: u64, now: Instant) -> Instant {
        let Some(speed) = self.speed else { return now };
        let anchor = match self.anchor {
            None => {
                self.anchor = Some(now);
                self.last_capture_ns = capture_ns;
                return now;
            }
            Some(a) => a,
        };
        let step = capture_ns
            .saturating_sub(self.last_capture_ns)
            .min(self.max_gap_ns);
        self.last_capture_ns = capture_ns;
        self.virtual_ns += step;
        anchor + Duration::from_secs_f64(self.virtual_ns as f64 * 1e-9 / speed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn real_time_at_double_speed() {
        let t0 = Instant::now();
        let mut p = Pacer::new(Some(2.0), 1_000_000_000);
        assert_eq!(p.due(10_000_000_000, t0), t0);
        assert_eq!(p.due(10_100_000_000, t0), t0 + Duration::from_millis(50));
        assert_eq!(p.due(10_300_000_000, t0), t0 + Duration::from_millis(150));
    }

    #[test]
    fn gaps_are_capped_and_time_never_runs_backwards() {
        let t0 = Instant::now();
        let mut p = Pacer::new(Some(1.0), 1_000_000_000);
        p.due(0, t0);
        // a 60 s pause counts as 1 s
        assert_eq!(p.due(60_000_000_000, t0), t0 + Duration::from_secs(1));
        // a timestamp from the past is due at once after the previous one
        assert_eq!(p.due(30_000_000_000, t0), t0 + Duration::from_secs(1));
        p.restart();
        let t1 = t0 + Duration::from_secs(5);
        assert_eq!(p.due(0, t1), t1);
    }

    #[test]
    fn as_fast_as_possible_is_always_due() {
        let t0 = Instant::now();
        let mut p = Pacer::new(None, 1);
        assert_eq!(p.due(5, t0), t0);
        assert_eq!(p.due(5_000_000_000, t0), t0);
    }
}
