//! Reading the socket in batches while a revolution's end is far (issue 27: the stack at the
//! sensor's rate within a few percent of a core).
//!
//! A VLP-16 sends a datagram every 1.33 ms (0.66 ms in dual-return mode), and a driver that
//! sleeps on its socket wakes for every one: on the development machine about half the driver's
//! CPU time was the kernel switching to it and back (`perf`: `finish_task_switch`). Nothing
//! needs a datagram the moment it arrives except the revolution's last one, which the mapper and
//! the planner wait for. So while the revolution has more than `velodyne.pace_ms` and
//! [`GUARD`] left to turn, the driver reads what has queued and then sleeps for `pace_ms`
//! (several datagrams wait in the kernel's buffer meanwhile); closer to the end it wakes for
//! each datagram again. The turn left is measured in azimuth, and the rate it turns at is the
//! configured `velodyne.rpm` or, if faster, the rate the azimuth was seen to advance.

use std::time::{Duration, Instant};

/// How much of the revolution is read datagram by datagram besides the pause: the last packet's
/// age when the socket is read (at most a pause) and the rate's error fit in it.
pub const GUARD: Duration = Duration::from_millis(2);

/// When the driver may pause between reads of its socket.
#[derive(Debug, Clone)]
pub struct Pace {
    pause: Duration,
    /// The configured rate, 0.01° per second.
    configured: f64,
    /// The rate seen last, 0.01° per second.
    seen: f64,
    /// When the socket was last read and the turn left then.
    last: Option<(Instant, u32)>,
}

impl Pace {
    /// Pauses of `pause_ms` (0: none) for a sensor turning at `rpm`.
    pub fn new(pause_ms: f64, rpm: f64) -> Self {
        let pause_ms = if pause_ms.is_finite() { pause_ms } else { 0.0 };
        Pace {
            pause: Duration::from_secs_f64(pause_ms.clamp(0.0, 1000.0) * 1e-3),
            configured: rpm.max(1.0) * 36000.0 / 60.0,
            seen: 0.0,
            last: None,
        }
    }

    /// The socket was read empty at `now`, with `left_cdeg` of the revolution still to turn:
    /// how long to sleep before reading it again, or `None` to wait for the next datagram.
    pub fn pause(&mut self, now: Instant, left_cdeg: u32) -> Option<Duration> {
        if self.pause.is_zero() {
            return None;
        }
        if let Some((then, left)) = self.last
            && left_cdeg < left
        {
            let dt = now.saturating_duration_since(then).as_secs_f64();
            if dt >= 1e-3 {
                self.seen = f64::from(left - left_cdeg) / dt;
            }
        }
        self.last = Some((now, left_cdeg));
        let to_end = f64::from(left_cdeg) / self.configured.max(self.seen);
        (to_end > (self.pause + GUARD).as_secs_f64()).then_some(self.pause)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Duration = Duration::from_millis(1);

    #[test]
    fn pauses_while_the_end_is_far_and_wakes_for_each_datagram_near_it() {
        // 600 rpm: 360 000 cdeg/s, 360 cdeg per ms
        let mut p = Pace::new(2.0, 600.0);
        let t = Instant::now();
        // 8.3 ms to go, then 6.3, then 4.3: more than the pause and the guard
        assert_eq!(p.pause(t, 3_000), Some(2 * MS));
        assert_eq!(p.pause(t + 2 * MS, 2_280), Some(2 * MS));
        assert_eq!(p.pause(t + 4 * MS, 1_560), Some(2 * MS));
        // 2.3 ms: within them
        assert_eq!(p.pause(t + 6 * MS, 840), None);
        assert_eq!(p.pause(t + 7 * MS, 480), None);
    }

    #[test]
    fn a_sensor_turning_faster_than_configured_is_paced_by_what_is_seen() {
        // configured 300 rpm (180 cdeg/ms), turning at 600 (360 cdeg/ms)
        let mut p = Pace::new(2.0, 300.0);
        let t = Instant::now();
        assert!(p.pause(t, 20_000).is_some());
        // 2 ms later the turn has advanced 720 cdeg; 1 500 left: 4.2 ms at the configured
        // rate, 2.1 ms at the rate seen
        assert!(p.pause(t + 2 * MS, 19_280).is_some());
        assert_eq!(p.pause(t + 4 * MS, 18_560 - 17_000), None);
    }

    #[test]
    fn a_new_turn_or_no_pause_configured() {
        let mut p = Pace::new(0.0, 600.0);
        assert_eq!(p.pause(Instant::now(), 36_000), None);
        let mut p = Pace::new(f64::NAN, 600.0);
        assert_eq!(p.pause(Instant::now(), 36_000), None);
        // the turn left jumps up when a revolution completes: no rate is read from it
        let mut p = Pace::new(2.0, 600.0);
        let t = Instant::now();
        assert!(p.pause(t, 200).is_none());
        assert_eq!(p.pause(t + 2 * MS, 35_500), Some(2 * MS));
    }
}
