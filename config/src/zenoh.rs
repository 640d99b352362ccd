//! `[zenoh]`: the Zenoh bridge (`mimnav-zenoh`, issue 25): selected topics published to other
//! hosts on `mimnav/<robot>/<topic>`, goals and a stop request taken from them. Off by default.
//!
//! The section lives here rather than in the bridge's crate so that the config crate, which
//! every service links, never builds the `zenoh` crate; the bridge reads it from [`crate::Config`].
//! Zenoh's own settings (mode, listen and connect endpoints, TLS, access control) stay in Zenoh's
//! JSON5 file named by `config_file`: docs/zenoh.md.

use std::collections::BTreeMap;
use std::path::PathBuf;

use serde::Deserialize;

use mimnav_shared::config::{Checks, Invalid};

/// The topics the bridge can publish, by the name used in `topics` and in the key expression
/// (`mimnav/<robot>/<name>`), with the rate cap each gets when `max_rate_hz` does not name it.
/// `lidar/packets` is not offered: one message per UDP datagram is the sensor's own stream.
pub const BRIDGE_TOPICS: [(&str, f64); 10] = [
    ("lidar/points", 2.0),
    ("lidar/scan2d", 5.0),
    ("map/plan", 2.0),
    ("map/layers", 1.0),
    ("odom", 20.0),
    ("cmd_vel", 20.0),
    ("goal", 20.0),
    ("base/state", 10.0),
    ("foliage/alarm", 10.0),
    ("sim/truth", 1.0),
];

/// The keys of `[zenoh]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ZenohConfig {
    /// Whether `mimnav-zenoh` runs at all (it exits at once, successfully, when false).
    pub enabled: bool,
    /// The robot's name: one chunk of the key expressions `mimnav/<robot>/<topic>`.
    pub robot: String,
    /// The topics published (names of [`BRIDGE_TOPICS`]).
    pub topics: Vec<String>,
    /// Per topic, at most this many messages a second go out (the rest are dropped and counted);
    /// a topic not named here gets its default of [`BRIDGE_TOPICS`].
    pub max_rate_hz: BTreeMap<String, f64>,
    /// Whether goals and stop requests from the network (`mimnav/<robot>/goal`, `…/stop`) are
    /// forwarded to the planner.
    pub accept_goals: bool,
    /// Zenoh's own JSON5 config file (mode, listen/connect endpoints, TLS, access control);
    /// empty: Zenoh's defaults (peer mode, multicast scouting).
    pub config_file: PathBuf,
}

impl Default for ZenohConfig {
    fn default() -> Self {
        ZenohConfig {
            enabled: false,
            robot: "robot".into(),
            topics: [
                "lidar/points",
                "map/plan",
                "odom",
                "cmd_vel",
                "base/state",
                "foliage/alarm",
            ]
            .map(String::from)
            .to_vec(),
            max_rate_hz: BTreeMap::new(),
            accept_goals: false,
            config_file: PathBuf::new(),
        }
    }
}

/// Characters a key expression chunk may not hold (Zenoh's separators and wildcards, and the
/// verbatim marker), besides whitespace.
const KEY_SPECIALS: [char; 5] = ['/', '*', '$', '?', '#'];

/// Whether `s` is a plain Zenoh key chunk: non-empty, no `/`, no wildcard or special character,
/// no whitespace or control character.
pub fn is_key_chunk(s: &str) -> bool {
    !s.is_empty()
        && s.len() <= 64
        && !s
            .chars()
            .any(|c| KEY_SPECIALS.contains(&c) || c.is_whitespace() || c.is_control())
}

impl ZenohConfig {
    /// The rate cap of `topic`, Hz: `max_rate_hz`'s or the topic's default.
    pub fn rate_hz(&self, topic: &str) -> f64 {
        match self.max_rate_hz.get(topic) {
            Some(hz) => *hz,
            None => (BRIDGE_TOPICS.iter())
                .find(|(t, _)| *t == topic)
                .map_or(1.0, |(_, hz)| *hz),
        }
    }

    /// Checks every key.
    pub fn validate(&self) -> Result<(), Invalid> {
        let mut r = Checks::default();
        r.require(
            is_key_chunk(&self.robot),
            "zenoh.robot",
            format!(
                "zenoh.robot = {:?}: must be one Zenoh key chunk (1–64 characters, none of \
                 / * $ ? # or whitespace)",
                self.robot
            ),
        );
        let known = || BRIDGE_TOPICS.iter().map(|(t, _)| *t);
        let names = known().collect::<Vec<_>>().join(", ");
        for t in &self.topics {
            r.require(
                known().any(|k| k == t),
                "zenoh.topics",
                format!("zenoh.topics: {t:?} is not a topic the bridge publishes ({names})"),
            );
        }
        for (t, hz) in &self.max_rate_hz {
            r.require(
                known().any(|k| k == t),
                "zenoh.max_rate_hz",
                format!("zenoh.max_rate_hz: {t:?} is not a topic the bridge publishes ({names})"),
            );
            r.check(format!("zenoh.max_rate_hz.\"{t}\""), *hz, 0.01, 1000.0);
        }
        r.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_chunks_refuse_separators_wildcards_and_blanks() {
        for ok in ["spot1", "turtle-2", "robot_a.b", "ü"] {
            assert!(is_key_chunk(ok), "{ok}");
        }
        for bad in [
            "",
            "a/b",
            "*",
            "a**",
            "$*",
            "a?",
            "a#",
            "a b",
            "a\n",
            &"x".repeat(65),
        ] {
            assert!(!is_key_chunk(bad), "{bad:?}");
        }
    }

    #[test]
    fn defaults_validate_and_rates_fall_back_per_topic() {
        let mut c = ZenohConfig::default();
        assert!(c.validate().is_ok());
        assert_eq!(c.rate_hz("lidar/points"), 2.0);
        c.max_rate_hz.insert("lidar/points".into(), 5.0);
        assert_eq!(c.rate_hz("lidar/points"), 5.0);
        assert_eq!(c.rate_hz("odom"), 20.0);
    }

    #[test]
    fn unknown_topics_bad_rates_and_bad_robot_names_are_refused() {
        let c = ZenohConfig {
            robot: "a/b".into(),
            topics: vec!["lidar/packets".into()],
            max_rate_hz: [("odom".to_string(), 0.0)].into(),
            ..ZenohConfig::default()
        };
        let e = c.validate().expect_err("three mistakes").to_string();
        for says in ["zenoh.robot", "lidar/packets", "zenoh.max_rate_hz.\"odom\""] {
            assert!(e.contains(says), "{e}");
        }
    }
}
