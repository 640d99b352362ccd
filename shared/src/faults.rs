//! Counting runtime faults and logging them at a limited rate.
//!
//! Bad input never stops a service: a wrong-sized datagram, a corrupt packet or a stale input is
//! counted by kind and skipped. The first fault of a kind is logged at once; after that at most
//! one line per kind per interval, saying how many happened since the last line. Nothing is lost
//! silently: the totals are in every statistics line and available to the caller.

use std::fmt::Display;
use std::time::{Duration, Instant};

#[derive(Debug, Clone)]
struct Entry {
    kind: &'static str,
    total: u64,
    unreported: u64,
    last_report: Option<Instant>,
}

/// Fault counters with rate-limited warnings.
#[derive(Debug, Clone)]
pub struct Faults {
    interval: Duration,
    entries: Vec<Entry>,
}

impl Faults {
    /// Logs each kind at most once per `interval`.
    pub fn new(interval: Duration) -> Self {
        Faults {
            interval,
            entries: Vec::new(),
        }
    }

    /// Counts one fault of `kind` at `now`; logs `detail` (a warning) unless this kind was
    /// reported less than the interval ago. Returns whether it logged.
    pub fn record(&mut self, kind: &'static str, now: Instant, detail: impl Display) -> bool {
        let i = match self.entries.iter().position(|e| e.kind == kind) {
            Some(i) => i,
            None => {
                self.entries.push(Entry {
                    kind,
                    total: 0,
                    unreported: 0,
                    last_report: None,
                });
                self.entries.len() - 1
            }
        };
        let e = &mut self.entries[i];
        e.total += 1;
        let due = e
            .last_report
            .is_none_or(|t| now.saturating_duration_since(t) >= self.interval);
        if !due {
            e.unreported += 1;
            return false;
        }
        if e.unreported > 0 {
            tracing::warn!(
                kind,
                total = e.total,
                "{detail} ({} more of this kind since the last report, {} in all)",
                e.unreported,
                e.total
            );
        } else {
            tracing::warn!(kind, total = e.total, "{detail}");
        }
        e.unreported = 0;
        e.last_report = Some(now);
        true
    }

    /// Count of `kind` so far.
    pub fn count(&self, kind: &str) -> u64 {
        self.entries
            .iter()
            .find(|e| e.kind == kind)
            .map_or(0, |e| e.total)
    }

    /// All faults so far.
    pub fn total(&self) -> u64 {
        self.entries.iter().map(|e| e.total).sum()
    }

    /// `kind=count` pairs, in the order the kinds first occurred, for statistics lines.
    pub fn summary(&self) -> String {
        if self.entries.is_empty() {
            return "none".into();
        }
        self.entries
            .iter()
            .map(|e| format!("{}={}", e.kind, e.total))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_fault_logs_then_one_line_per_interval() {
        let mut f = Faults::new(Duration::from_secs(5));
        let t0 = Instant::now();
        assert!(f.record("wrong_length", t0, "x"));
        assert!(!f.record("wrong_length", t0 + Duration::from_secs(1), "x"));
        assert!(!f.record("wrong_length", t0 + Duration::from_secs(4), "x"));
        // another kind has its own budget
        assert!(f.record("bad_block_flag", t0 + Duration::from_secs(4), "y"));
        assert!(f.record("wrong_length", t0 + Duration::from_secs(5), "x"));
        assert_eq!(f.count("wrong_length"), 4);
        assert_eq!(f.total(), 5);
        assert_eq!(f.summary(), "wrong_length=4 bad_block_flag=1");
    }
}
