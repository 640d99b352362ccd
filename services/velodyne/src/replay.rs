//! Replaying a capture, paced by its timestamps.
//!
//! [`Replay`] reads a capture once or in a loop and says when each datagram is due.
//! [`Pacer`] turns capture timestamps into the instants at which the datagrams should be sent:
//! real time times a speed factor, or as fast as possible. The capture's clock is followed
//! through a virtual clock that only moves forward and at most `max_gap_ns` per datagram, so a
//! capture with out-of-order timestamps or a long pause does not stall the replay.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::capture::{CaptureError, CaptureReader, Datagram};

/// A capture replayed once or in a loop, paced by a [`Pacer`]: each datagram comes with the
/// instant it is due.
pub struct Replay {
    path: PathBuf,
    reader: CaptureReader,
    pacer: Pacer,
    looping: bool,
    pass_ended: bool,
}

/// What [`Replay::next`] gives.
pub enum Next<'a> {
    /// A datagram, and when it is due.
    Datagram(Datagram<'a>, Instant),
    /// A pass over the capture ended; with `looping`, the next call starts the next pass.
    PassEnded,
    /// The replay is over (the last pass of one that does not loop ended).
    Finished,
}

impl Replay {
    /// Opens `path` for a replay at `speed` × real time (`None`: as fast as possible), gaps
    /// shortened to `max_gap_ns`, in a loop or once.
    pub fn open(
        path: &Path,
        speed: Option<f64>,
        max_gap_ns: u64,
        looping: bool,
    ) -> Result<Self, CaptureError> {
        let reader = CaptureReader::open(path)?;
        tracing::info!(file = %path.display(), bytes = reader.file_len(), "replaying capture");
        Ok(Replay {
            path: path.to_path_buf(),
            reader,
            pacer: Pacer::new(speed, max_gap_ns),
            looping,
            pass_ended: false,
        })
    }

    /// The capture's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The next datagram and when it is due (it being `now`), or the end of a pass; after the
    /// end of the last pass, [`Next::Finished`].
    pub fn next(&mut self, now: Instant) -> Result<Next<'_>, CaptureError> {
        if self.pass_ended {
            for (kind, n) in self.reader.skipped() {
                tracing::info!(kind, count = n, "frames without a UDP datagram passed over");
            }
            if !self.looping {
                return Ok(Next::Finished);
            }
            self.reader = CaptureReader::open(&self.path)?;
            self.pacer.restart();
            self.pass_ended = false;
        }
        let pacer = &mut self.pacer;
        match self.reader.next()? {
            Some(d) => {
                let due = pacer.due(d.ts_ns, now);
                Ok(Next::Datagram(d, due))
            }
            None => {
                self.pass_ended = true;
                Ok(Next::PassEnded)
            }
        }
    }
}

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
