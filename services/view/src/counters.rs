//! What happened to every input topic and every Foxglove channel: the view drops rather than
//! waits, so every drop has a counter.
//!
//! - Per **input topic** (an iceoryx2 subscription): samples received, samples **missed** (the
//!   publisher's sequence numbers skipped: the view fell behind and iceoryx2's safe overflow
//!   replaced them in its buffer of two), samples refused as **bad** and receive errors.
//! - Per **channel** (a Foxglove topic): messages **sent** (handed to the WebSocket server for
//!   every subscribed client), **unwatched** (no client subscribed: not even converted),
//!   **thinned** (over the channel's rate limit, `[view]`'s `*_hz`), **bad** (refused by the
//!   conversion) and the bytes sent.
//!
//! A client too slow for what is sent loses its own oldest messages in the SDK's per-client queue
//! (`view.client_backlog` messages); the other clients and the view do not wait for it. The SDK
//! keeps that count to itself (it logs `outbox for client … full` at most every 30 s), so it is
//! not among these counters.

use std::collections::BTreeMap;

use serde_json::{Value, json};

/// An input topic's counters.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TopicCount {
    /// Samples received.
    pub received: u64,
    /// Samples the publisher sent that the view never saw (sequence numbers skipped).
    pub missed: u64,
    /// Samples refused by the conversion.
    pub bad: u64,
    /// Receive errors.
    pub errors: u64,
}

/// A channel's counters.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ChannelCount {
    /// Messages logged to the server while at least one client was subscribed.
    pub sent: u64,
    /// Samples not converted because no client was subscribed.
    pub unwatched: u64,
    /// Samples skipped by the channel's rate limit.
    pub thinned: u64,
    /// Samples the conversion refused.
    pub bad: u64,
    /// Encoded bytes sent.
    pub bytes: u64,
}

/// Every counter of the view, keyed by topic and channel name.
#[derive(Debug, Clone, Default)]
pub struct Counters {
    /// By iceoryx2 service name (`mimnav/lidar/points`, …).
    pub topics: BTreeMap<&'static str, TopicCount>,
    /// By Foxglove topic (`/lidar/points`, …).
    pub channels: BTreeMap<&'static str, ChannelCount>,
}

impl Counters {
    /// The counters of input topic `name` (created at zero).
    pub fn topic(&mut self, name: &'static str) -> &mut TopicCount {
        self.topics.entry(name).or_default()
    }

    /// The counters of channel `name` (created at zero).
    pub fn channel(&mut self, name: &'static str) -> &mut ChannelCount {
        self.channels.entry(name).or_default()
    }

    /// Samples missed over every topic.
    pub fn missed(&self) -> u64 {
        self.topics.values().map(|t| t.missed).sum()
    }

    /// Bad samples over every topic.
    pub fn bad(&self) -> u64 {
        self.topics.values().map(|t| t.bad).sum()
    }

    /// Messages sent over every channel.
    pub fn sent(&self) -> u64 {
        self.channels.values().map(|c| c.sent).sum()
    }

    /// Samples thinned over every channel.
    pub fn thinned(&self) -> u64 {
        self.channels.values().map(|c| c.thinned).sum()
    }

    /// The counters as the JSON of `/view/stats`.
    pub fn json(&self, uptime_s: f64, clients: usize) -> Value {
        let topics: serde_json::Map<String, Value> = (self.topics.iter())
            .map(|(k, t)| {
                let v = json!({"received": t.received, "missed": t.missed, "bad": t.bad,
                               "errors": t.errors});
                ((*k).to_string(), v)
            })
            .collect();
        let channels: serde_json::Map<String, Value> = (self.channels.iter())
            .map(|(k, c)| {
                let v = json!({"sent": c.sent, "unwatched": c.unwatched, "thinned": c.thinned,
                               "bad": c.bad, "bytes": c.bytes});
                ((*k).to_string(), v)
            })
            .collect();
        // the totals at the top, for plots (Foxglove's message paths reach them simply)
        json!({"uptime_s": uptime_s, "clients": clients, "missed": self.missed(),
               "thinned": self.thinned(), "sent": self.sent(), "bad": self.bad(),
               "topics": topics, "channels": channels})
    }

    /// One line for the log: totals and the topics that missed samples.
    pub fn summary(&self) -> String {
        let missed: Vec<String> = (self.topics.iter())
            .filter(|(_, t)| t.missed > 0)
            .map(|(k, t)| format!("{k} {}", t.missed))
            .collect();
        format!(
            "{} sent, {} thinned, {} missed ({}), {} bad",
            self.sent(),
            self.thinned(),
            self.missed(),
            if missed.is_empty() {
                "none".to_string()
            } else {
                missed.join(", ")
            },
            self.bad()
        )
    }
}

/// At most one message every `1/hz` seconds (0: every one).
#[derive(Debug, Clone, Copy)]
pub struct RateLimit {
    interval_ns: u64,
    last_ns: Option<u64>,
}

impl RateLimit {
    /// A limit of `hz` messages a second; 0 (or not finite) lets every message through.
    pub fn new(hz: f64) -> RateLimit {
        let interval_ns = if hz > 0.0 && hz.is_finite() {
            (1e9 / hz) as u64
        } else {
            0
        };
        RateLimit {
            interval_ns,
            last_ns: None,
        }
    }

    /// Whether a message may go at monotonic time `now_ns`; if so, it counts as sent then.
    /// A little early (a tenth of the interval) still passes, so a 10 Hz source under a 10 Hz
    /// limit is not halved by jitter.
    pub fn allow(&mut self, now_ns: u64) -> bool {
        let ok = match self.last_ns {
            None => true,
            Some(last) => now_ns.saturating_sub(last) >= self.interval_ns - self.interval_ns / 10,
        };
        if ok {
            self.last_ns = Some(now_ns);
        }
        ok
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rate_limit_passes_one_message_an_interval_with_jitter_allowed() {
        let mut r = RateLimit::new(10.0);
        let ms = 1_000_000;
        assert!(r.allow(0));
        assert!(!r.allow(50 * ms));
        // 95 ms: within the tenth allowed early
        assert!(r.allow(95 * ms));
        assert!(!r.allow(150 * ms));
        let mut every = RateLimit::new(0.0);
        assert!((0..5).all(|_| every.allow(7)));
    }

    #[test]
    fn counters_sum_and_render_as_json() {
        let mut c = Counters::default();
        c.topic("mimnav/lidar/points").missed += 2;
        c.topic("mimnav/map/plan").bad += 1;
        c.channel("/lidar/points").sent += 3;
        c.channel("/map/plan").thinned += 4;
        assert_eq!((c.missed(), c.bad(), c.sent(), c.thinned()), (2, 1, 3, 4));
        let j = c.json(1.5, 2);
        assert_eq!(
            (j["clients"].clone(), j["missed"].clone()),
            (json!(2), json!(2))
        );
        assert_eq!(j["topics"]["mimnav/lidar/points"]["missed"], 2);
        assert_eq!(j["channels"]["/map/plan"]["thinned"], 4);
        assert!(
            c.summary().contains("mimnav/lidar/points 2"),
            "{}",
            c.summary()
        );
    }
}
