//! `[latency]`: the CPU wake-up latency and real-time priority the services ask for.

use serde::Deserialize;

use super::check::{Checks, Invalid};

/// The services' latency settings (`[latency]`); both default to 0.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LatencyConfig {
    /// The longest CPU wake-up the driver, mapper, foliage classifier and planner allow while
    /// they run, µs: a Linux PM QoS request through `/dev/cpu_dma_latency`, which keeps the CPUs
    /// out of idle states slower to leave (0: the CPUs poll when idle). −1 leaves the CPUs'
    /// power management alone.
    pub cpu_wakeup_us: i32,
    /// The SCHED_FIFO priority the drivers run at (1–99; 0: the normal scheduler); the planner,
    /// mapper, foliage classifier and the rest run 1, 2, 3 and 4 steps lower
    /// ([`crate::realtime::priority_of`]). Off by default: a real-time process that never sleeps starves
    /// the rest of its CPU, and a capture replayed at full speed never sleeps.
    pub realtime_priority: i32,
}

impl LatencyConfig {
    /// Checks every key of `[latency]`: each value refused names its key and what is allowed.
    pub fn validate(&self) -> Result<(), Invalid> {
        let mut r = Checks::default();
        r.check(
            "latency.cpu_wakeup_us",
            f64::from(self.cpu_wakeup_us),
            -1.0,
            1_000_000.0,
        );
        r.check(
            "latency.realtime_priority",
            f64::from(self.realtime_priority),
            0.0,
            99.0,
        );
        r.finish()
    }
}
