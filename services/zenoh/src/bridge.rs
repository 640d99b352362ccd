//! The bridge's decisions, without Zenoh or iceoryx2: which topics go out on which key with
//! which encoding, whether a message may go now (the rate cap per topic), and what a remote
//! message becomes on the local `mimnav/goal` topic.

use mimnav_shared::topics::{self, Goal, goal_flags};

use crate::remote::{self, BadInput, Remote, RemoteKey};

/// A topic the bridge can publish.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Topic {
    /// `lidar/points`: `PointsHeader` then `[Point]`.
    Points,
    /// `lidar/scan2d`: `ScanHeader` then `[ScanReturn]`.
    Scan,
    /// `map/plan`: `MapHeader` then `[PlanCell]`.
    Plan,
    /// `map/layers`: `MapHeader` then `[f32]`.
    Layers,
    /// `odom`: `Odometry`.
    Odom,
    /// `cmd_vel`: `VelocityCommand`.
    CmdVel,
    /// `goal`: `Goal`.
    Goal,
    /// `base/state`: `BaseState`.
    BaseState,
    /// `foliage/alarm`: `FoliageHeader` then `[FoliageReturn]`.
    Foliage,
    /// `sim/truth`: `TruthHeader` then `[u8]`.
    Truth,
}

impl Topic {
    /// Every topic the bridge can publish.
    pub const ALL: [Topic; 10] = [
        Topic::Points,
        Topic::Scan,
        Topic::Plan,
        Topic::Layers,
        Topic::Odom,
        Topic::CmdVel,
        Topic::Goal,
        Topic::BaseState,
        Topic::Foliage,
        Topic::Truth,
    ];

    /// The iceoryx2 service it is read from.
    pub fn service(self) -> &'static str {
        match self {
            Topic::Points => topics::LIDAR_POINTS,
            Topic::Scan => topics::LIDAR_SCAN2D,
            Topic::Plan => topics::MAP_PLAN,
            Topic::Layers => topics::MAP_LAYERS,
            Topic::Odom => topics::ODOM,
            Topic::CmdVel => topics::CMD_VEL,
            Topic::Goal => topics::GOAL,
            Topic::BaseState => topics::BASE_STATE,
            Topic::Foliage => topics::FOLIAGE_ALARM,
            Topic::Truth => topics::SIM_TRUTH,
        }
    }

    /// Its name in the config and in the key expression: the service name without `mimnav/`.
    pub fn name(self) -> &'static str {
        let s = self.service();
        s.strip_prefix("mimnav/").unwrap_or(s)
    }

    /// The topic of a config name (`lidar/points`, …).
    pub fn parse(name: &str) -> Option<Topic> {
        Topic::ALL.into_iter().find(|t| t.name() == name)
    }

    /// The schema part of the Zenoh encoding: the versioned type names of docs/topics.md, the
    /// header and `[item]` joined by `+` for a slice topic.
    pub fn schema(self) -> &'static str {
        match self {
            Topic::Points => "mimnav/PointsHeader/v1+[mimnav/Point/v1]",
            Topic::Scan => "mimnav/ScanHeader/v1+[mimnav/ScanReturn/v1]",
            Topic::Plan => "mimnav/MapHeader/v1+[mimnav/PlanCell/v2]",
            Topic::Layers => "mimnav/MapHeader/v1+[f32]",
            Topic::Odom => "mimnav/Odometry/v1",
            Topic::CmdVel => "mimnav/VelocityCommand/v2",
            Topic::Goal => "mimnav/Goal/v2",
            Topic::BaseState => "mimnav/BaseState/v1",
            Topic::Foliage => "mimnav/FoliageHeader/v1+[mimnav/FoliageReturn/v1]",
            Topic::Truth => "mimnav/TruthHeader/v1+[u8]",
        }
    }

    /// The whole encoding string: `application/octet-stream;` and [`Topic::schema`].
    pub fn encoding(self) -> String {
        format!("{ENCODING_MIME};{}", self.schema())
    }
}

/// The MIME type of every published payload.
pub const ENCODING_MIME: &str = "application/octet-stream";

/// At most one message per interval on average: a message is admitted when its time has come
/// on a grid of `interval` steps, so a source a little faster or late does not lose every
/// other message, and after a pause at most two go out back to back.
#[derive(Debug, Clone)]
pub struct RateLimit {
    interval_ns: u64,
    next_ns: Option<u64>,
}

impl RateLimit {
    /// At most `hz` messages a second (`hz` > 0).
    pub fn new(hz: f64) -> Self {
        RateLimit {
            interval_ns: (1e9 / hz.max(1e-3)) as u64,
            next_ns: None,
        }
    }

    /// Whether a message at `now_ns` (monotonic) may go; if so, it is counted as gone.
    pub fn admit(&mut self, now_ns: u64) -> bool {
        let next = self.next_ns.unwrap_or(now_ns);
        if now_ns < next {
            return false;
        }
        let floor = now_ns.saturating_sub(self.interval_ns / 2);
        self.next_ns = Some(next.max(floor) + self.interval_ns);
        true
    }
}

/// One published topic: its key, its cap, what went out and what was dropped.
#[derive(Debug, Clone)]
pub struct Outgoing {
    /// The topic.
    pub topic: Topic,
    /// `mimnav/<robot>/<topic>`.
    pub key: String,
    limit: RateLimit,
    /// Messages published.
    pub sent: u64,
    /// Bytes published.
    pub bytes: u64,
    /// Messages dropped by the rate cap.
    pub dropped: u64,
}

/// Why the bridge cannot be set up.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BridgeError {
    /// The robot's name is not a single key chunk.
    #[error("robot name {0:?} is not a single Zenoh key chunk")]
    Robot(String),
    /// A topic the bridge does not know.
    #[error("unknown topic {0:?}")]
    Topic(String),
    /// A rate that is not a positive number.
    #[error("max_rate_hz of {0} must be a positive finite number")]
    Rate(String),
}

/// The bridge's state: outgoing topics with their caps, and the remote-input counters.
#[derive(Debug, Clone)]
pub struct Bridge {
    robot: String,
    out: Vec<Outgoing>,
    accept_goals: bool,
    /// Goals forwarded to `mimnav/goal`.
    pub goals: u64,
    /// Stop requests forwarded.
    pub stops: u64,
}

impl Bridge {
    /// A bridge for `robot` publishing `topics` (name, cap in Hz) and, with `accept_goals`,
    /// forwarding goals and stops.
    pub fn new(
        robot: &str,
        topics: &[(&str, f64)],
        accept_goals: bool,
    ) -> Result<Bridge, BridgeError> {
        if !is_key_chunk(robot) {
            return Err(BridgeError::Robot(robot.into()));
        }
        let mut out = Vec::new();
        for (name, hz) in topics {
            let topic = Topic::parse(name).ok_or_else(|| BridgeError::Topic((*name).into()))?;
            if !(hz.is_finite() && *hz > 0.0) {
                return Err(BridgeError::Rate((*name).into()));
            }
            out.push(Outgoing {
                topic,
                key: format!("mimnav/{robot}/{}", topic.name()),
                limit: RateLimit::new(*hz),
                sent: 0,
                bytes: 0,
                dropped: 0,
            });
        }
        Ok(Bridge {
            robot: robot.into(),
            out,
            accept_goals,
            goals: 0,
            stops: 0,
        })
    }

    /// The outgoing topics, in the order given.
    pub fn outgoing(&self) -> &[Outgoing] {
        &self.out
    }

    /// Whether remote goals are forwarded.
    pub fn accepts_goals(&self) -> bool {
        self.accept_goals
    }

    /// The key remote messages of `key` come on: `mimnav/<robot>/goal` or `…/stop`.
    pub fn remote_key(&self, key: RemoteKey) -> String {
        let what = match key {
            RemoteKey::Goal => "goal",
            RemoteKey::Stop => "stop",
        };
        format!("mimnav/{}/{what}", self.robot)
    }

    /// Whether a message of outgoing topic `i` may go at `now_ns`; a refused one is counted.
    pub fn admit(&mut self, i: usize, now_ns: u64) -> bool {
        let Some(o) = self.out.get_mut(i) else {
            return false;
        };
        let ok = o.limit.admit(now_ns);
        o.dropped += u64::from(!ok);
        ok
    }

    /// Counts a message of `bytes` bytes published on outgoing topic `i`.
    pub fn sent(&mut self, i: usize, bytes: usize) {
        if let Some(o) = self.out.get_mut(i) {
            o.sent += 1;
            o.bytes += bytes as u64;
        }
    }

    /// The local message a remote one on `key` becomes, stamped `now_mono_ns` and numbered
    /// `seq`: a goal, or a goal with [`goal_flags::STOP`]. Refused when goals are not
    /// accepted or the message is bad.
    pub fn remote(
        &mut self,
        key: RemoteKey,
        payload: &[u8],
        seq: u64,
        now_mono_ns: u64,
    ) -> Result<Goal, BadInput> {
        if !self.accept_goals {
            return Err(BadInput::NotAccepted);
        }
        let goal = Goal {
            seq,
            stamp_mono_ns: now_mono_ns,
            ..Goal::default()
        };
        Ok(match remote::parse(key, payload)? {
            Remote::Goal { x, y, tolerance_m } => {
                self.goals += 1;
                Goal {
                    x,
                    y,
                    tolerance_m,
                    ..goal
                }
            }
            Remote::Stop => {
                self.stops += 1;
                Goal {
                    flags: goal_flags::STOP,
                    ..goal
                }
            }
        })
    }
}

/// Whether `s` is one plain Zenoh key chunk (the config's rule, `mimnav_config::is_key_chunk`,
/// repeated here so the library stands alone): 1–64 characters, none of `/ * $ ? #`, no
/// whitespace or control character.
pub fn is_key_chunk(s: &str) -> bool {
    !s.is_empty()
        && s.len() <= 64
        && !s.chars().any(|c| {
            matches!(c, '/' | '*' | '$' | '?' | '#') || c.is_whitespace() || c.is_control()
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u64 = 1_000_000;

    #[test]
    fn keys_and_encodings_name_the_robot_topic_and_types() {
        let b = Bridge::new("spot1", &[("lidar/points", 2.0), ("map/plan", 2.0)], true)
            .expect("bridge");
        let keys: Vec<_> = b.outgoing().iter().map(|o| o.key.as_str()).collect();
        assert_eq!(keys, ["mimnav/spot1/lidar/points", "mimnav/spot1/map/plan"]);
        assert_eq!(
            Topic::Points.encoding(),
            "application/octet-stream;mimnav/PointsHeader/v1+[mimnav/Point/v1]"
        );
        assert_eq!(b.remote_key(RemoteKey::Stop), "mimnav/spot1/stop");
        for t in Topic::ALL {
            assert_eq!(Topic::parse(t.name()), Some(t));
        }
        assert_eq!(
            Bridge::new("a/b", &[], true).err(),
            Some(BridgeError::Robot("a/b".into()))
        );
        assert!(Bridge::new("r", &[("lidar/packets", 1.0)], true).is_err());
        assert!(Bridge::new("r", &[("odom", 0.0)], true).is_err());
    }

    /// Every schema names types at the versions docs/topics.md documents.
    #[test]
    fn schemas_name_the_documented_type_versions() {
        let doc =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/topics.md"))
                .expect("docs/topics.md");
        for t in Topic::ALL {
            for part in t.schema().split('+') {
                let name = part.trim_start_matches('[').trim_end_matches(']');
                if name.starts_with("mimnav/") {
                    assert!(doc.contains(&format!("`{name}`: size")), "{name} of {t:?}");
                }
            }
        }
    }

    /// A 10 Hz source capped at 2 Hz: 2 a second go out, 8 are dropped and counted, also with
    /// the source's jitter.
    #[test]
    fn the_rate_cap_passes_its_rate_and_counts_the_rest() {
        let mut b = Bridge::new("r", &[("lidar/points", 2.0)], false).expect("bridge");
        let mut sent = 0;
        for k in 0..100u64 {
            let jitter = if k % 2 == 0 { 3 * MS } else { 0 };
            if b.admit(0, k * 100 * MS + jitter) {
                sent += 1;
            }
        }
        assert_eq!(sent, 20);
        assert_eq!(b.outgoing()[0].dropped, 80);
        // after a pause: at most two back to back, then the cap again
        let t = 100_000 * MS;
        let burst = (0..10).filter(|k| b.admit(0, t + k * MS)).count();
        assert!(burst <= 2, "{burst}");
    }

    #[test]
    fn remote_goals_and_stops_become_goal_messages() {
        let mut b = Bridge::new("r", &[], true).expect("bridge");
        let g = b
            .remote(RemoteKey::Goal, br#"{"x": 1.5, "y": 2}"#, 7, 99)
            .expect("goal");
        assert_eq!((g.x, g.y, g.tolerance_m, g.flags), (1.5, 2.0, 0.3, 0));
        assert_eq!((g.seq, g.stamp_mono_ns), (7, 99));
        let s = b.remote(RemoteKey::Stop, b"", 8, 100).expect("stop");
        assert_eq!(s.flags, goal_flags::STOP);
        assert_eq!((b.goals, b.stops), (1, 1));
        assert!(b.remote(RemoteKey::Goal, b"{}", 9, 101).is_err());
        assert_eq!((b.goals, b.stops), (1, 1));
    }

    /// `zenoh.accept_goals = false`: nothing from the network becomes a goal, stops included.
    #[test]
    fn goals_are_refused_unless_accepted() {
        let mut b = Bridge::new("r", &[], false).expect("bridge");
        for (key, payload) in [
            (RemoteKey::Goal, &br#"{"x": 1, "y": 2}"#[..]),
            (RemoteKey::Stop, b""),
        ] {
            assert_eq!(b.remote(key, payload, 1, 1), Err(BadInput::NotAccepted));
        }
        assert_eq!((b.goals, b.stops), (0, 0));
    }
}
