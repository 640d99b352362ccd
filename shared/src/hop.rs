//! Counting what one hop of the pipeline lost: the samples of an input topic a service never
//! saw, from the gaps in their sequence numbers (issue 23, the soak).
//!
//! Every topic's publisher numbers its samples 0, 1, 2, … (`seq` in each header). A subscriber's
//! buffer is small and overflows safely (the oldest sample goes, see [`crate::ipc`]), so a
//! service that falls behind loses samples without an error anywhere; the next sample it takes
//! then skips numbers. [`Hop`] counts those skipped numbers. The first sample sets the start (a
//! service started after its publisher did not lose what was sent before it subscribed), and a
//! sequence that goes back means the publisher restarted: counted as a restart, not a loss.

use std::fmt;
use std::time::Instant;

use crate::faults::Faults;

/// The received and dropped samples of one input topic.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Hop {
    received: u64,
    dropped: u64,
    restarts: u64,
    last: Option<u64>,
}

impl Hop {
    /// A hop that has seen nothing yet.
    pub fn new() -> Self {
        Hop::default()
    }

    /// Takes the sample numbered `seq`; returns how many samples before it were never seen
    /// (0 when none).
    pub fn see(&mut self, seq: u64) -> u64 {
        let gap = match self.last {
            Some(last) if seq > last => seq - last - 1,
            Some(_) => {
                self.restarts += 1;
                0
            }
            None => 0,
        };
        self.received += 1;
        self.dropped += gap;
        self.last = Some(seq);
        gap
    }

    /// Samples taken.
    pub fn received(&self) -> u64 {
        self.received
    }

    /// Samples never seen: the gaps in the sequence.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Times the sequence went back (its publisher restarted).
    pub fn restarts(&self) -> u64 {
        self.restarts
    }

    /// `N in, M dropped` (with the restarts, if any), naming the samples `what` (plural).
    pub fn describe<'a>(&'a self, what: &'a str) -> impl fmt::Display + 'a {
        Described(self, what)
    }
}

/// Counts a gap of `lost` samples (the difference of [`Hop::dropped`] across one sample) as a
/// fault of `kind` in `faults` — a rate-limited warning naming the topic and the reader —;
/// nothing when `lost` is 0.
pub fn record_drops(
    faults: &mut Faults,
    kind: &'static str,
    now: Instant,
    lost: u64,
    (what, topic, reader): (&str, &str, &str),
) {
    if lost > 0 {
        let detail = format_args!(
            "{lost} {what} on {topic} never reached the {reader} (overwritten while it was busy)"
        );
        faults.record(kind, now, detail);
    }
}

/// The latencies of one hop over a reporting interval (issue 27: per-hop latency in the
/// periodic statistics): microseconds pushed as samples pass, percentiles read and cleared by
/// the periodic line. Holds at most [`Latencies::CAPACITY`] samples an interval (100 s of
/// revolutions at 10 Hz); later ones still count in the maximum and the count.
#[derive(Debug, Clone, Default)]
pub struct Latencies {
    samples: Vec<u32>,
    count: u64,
    max: u32,
}

impl Latencies {
    /// Samples kept for the percentiles per interval.
    pub const CAPACITY: usize = 1024;

    /// An empty window (allocated once).
    pub fn new() -> Self {
        Latencies {
            samples: Vec::with_capacity(Self::CAPACITY),
            count: 0,
            max: 0,
        }
    }

    /// One sample, µs.
    pub fn push(&mut self, us: u64) {
        let us = us.min(u64::from(u32::MAX)) as u32;
        self.count += 1;
        self.max = self.max.max(us);
        if self.samples.len() < Self::CAPACITY {
            self.samples.push(us);
        }
    }

    /// Samples since the last [`Latencies::take`].
    pub fn count(&self) -> u64 {
        self.count
    }

    /// `p50 X µs, p99 Y µs, max Z µs over N` (nearest rank) and a fresh window; `None` when
    /// there was no sample.
    pub fn take(&mut self) -> Option<String> {
        if self.count == 0 {
            return None;
        }
        self.samples.sort_unstable();
        let rank = |q: f64| {
            let n = self.samples.len();
            self.samples[((q * n as f64).ceil() as usize).clamp(1, n) - 1]
        };
        let shown = format!(
            "p50 {} µs, p99 {} µs, max {} µs over {}",
            rank(0.5),
            rank(0.99),
            self.max,
            self.count
        );
        self.samples.clear();
        (self.count, self.max) = (0, 0);
        Some(shown)
    }
}

/// One service's hop, for its periodic line: from a revolution's last packet to the sample
/// reaching the service, the service's own work, and from that packet to what it sent.
#[derive(Debug, Clone, Default)]
pub struct HopLatency {
    arrived: Latencies,
    work: Latencies,
    sent: Latencies,
}

impl HopLatency {
    /// Empty windows.
    pub fn new() -> Self {
        HopLatency {
            arrived: Latencies::new(),
            work: Latencies::new(),
            sent: Latencies::new(),
        }
    }

    /// One sample: the last packet's `rx_ns`, the sample's arrival here, the work, µs, and the
    /// output sent (monotonic ns).
    pub fn push(&mut self, rx_ns: u64, arrived_ns: u64, work_us: u64, sent_ns: u64) {
        self.arrived.push(arrived_ns.saturating_sub(rx_ns) / 1000);
        self.work.push(work_us);
        self.sent.push(sent_ns.saturating_sub(rx_ns) / 1000);
    }

    /// `latency per hop: last packet → {what} here …; {work} …; last packet → {output} …` and
    /// fresh windows; `None` without a sample.
    pub fn take(&mut self, what: &str, work: &str, output: &str) -> Option<String> {
        let sent = self.sent.take()?;
        let arrived = self.arrived.take().unwrap_or_default();
        let w = self.work.take().unwrap_or_default();
        Some(format!(
            "latency per hop: last packet → {what} here {arrived}; {work} {w}; last packet → \
             {output} {sent}"
        ))
    }
}

struct Described<'a>(&'a Hop, &'a str);

impl fmt::Display for Described<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Described(h, what) = self;
        write!(f, "{} {what} in, {} dropped", h.received, h.dropped)?;
        if h.restarts > 0 {
            write!(f, ", {} publisher restarts", h.restarts)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_gap_in_the_sequence_is_counted_as_dropped_samples() {
        let mut h = Hop::new();
        assert_eq!([h.see(0), h.see(1), h.see(4), h.see(5)], [0, 0, 2, 0]);
        assert_eq!((h.received(), h.dropped(), h.restarts()), (4, 2, 0));
        assert_eq!(h.describe("maps").to_string(), "4 maps in, 2 dropped");
    }

    #[test]
    fn a_late_start_is_no_loss_and_a_restart_is_counted_apart() {
        let mut h = Hop::new();
        // subscribed while the publisher was at 100
        assert_eq!(h.see(100), 0);
        // the publisher restarted from 0
        assert_eq!((h.see(0), h.see(1)), (0, 0));
        assert_eq!((h.received(), h.dropped(), h.restarts()), (3, 0, 1));
        assert_eq!(
            h.describe("scans").to_string(),
            "3 scans in, 0 dropped, 1 publisher restarts"
        );
    }

    #[test]
    fn latencies_give_nearest_rank_percentiles_and_start_afresh() {
        let mut l = Latencies::new();
        assert_eq!(l.take(), None);
        for us in (1..=200).rev() {
            l.push(us);
        }
        assert_eq!(
            l.take().as_deref(),
            Some("p50 100 µs, p99 198 µs, max 200 µs over 200")
        );
        assert_eq!(l.count(), 0);
        // past the capacity the maximum and the count still see every sample
        for _ in 0..Latencies::CAPACITY {
            l.push(5);
        }
        l.push(9_000);
        let shown = l.take().expect("samples");
        assert!(shown.ends_with("max 9000 µs over 1025"), "{shown}");
    }

    #[test]
    fn a_hop_line_names_its_three_spans() {
        let mut h = HopLatency::new();
        assert_eq!(h.take("map", "planning", "cmd_vel"), None);
        h.push(1_000_000, 1_300_000, 400, 1_700_000);
        assert_eq!(
            h.take("map", "planning", "cmd_vel").as_deref(),
            Some(
                "latency per hop: last packet → map here p50 300 µs, p99 300 µs, max 300 µs over 1; \
                 planning p50 400 µs, p99 400 µs, max 400 µs over 1; last packet → cmd_vel p50 700 \
                 µs, p99 700 µs, max 700 µs over 1"
            )
        );
    }

    #[test]
    fn the_same_number_twice_is_a_restart_and_the_largest_number_does_not_overflow() {
        let mut h = Hop::new();
        h.see(u64::MAX);
        assert_eq!(h.see(u64::MAX), 0);
        assert_eq!(h.restarts(), 1);
    }
}
