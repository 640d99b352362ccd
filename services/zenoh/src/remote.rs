//! Goals and stop requests from the network, checked before anything reaches the planner.
//!
//! Two keys are heard (docs/zenoh.md):
//! - `mimnav/<robot>/goal`: a JSON object `{"x": 2.0, "y": -1.0, "tolerance_m": 0.3}`
//!   (`tolerance_m` optional, [`DEFAULT_TOLERANCE_M`]; no other key), or the 48 bytes of a
//!   `mimnav/Goal/v2` as docs/topics.md lays it out (little-endian; `seq` and `stamp_mono_ns`
//!   are ignored, the bridge stamps its own; `flags` 1 makes it a stop request);
//! - `mimnav/<robot>/stop`: any payload of at most [`MAX_PAYLOAD`] bytes (empty is fine).
//!
//! Everything else is a [`BadInput`]: the caller counts it and logs it at a limited rate.

use serde::Deserialize;

use mimnav_shared::topics::goal_flags;

/// The largest payload read from the network, bytes.
pub const MAX_PAYLOAD: usize = 1024;
/// `tolerance_m` when a JSON goal does not give one, m (as `mimnav goal`).
pub const DEFAULT_TOLERANCE_M: f64 = 0.3;
/// The tolerances accepted, m.
pub const TOLERANCE_RANGE_M: (f64, f64) = (0.05, 10.0);
/// A goal's coordinates are accepted within this distance of the odometry frame's origin, m.
pub const MAX_COORDINATE_M: f64 = 10_000.0;
/// The size of a binary goal: `mimnav/Goal/v2`.
pub const GOAL_V2_SIZE: usize = 48;

/// What the network asked for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Remote {
    /// Go to (x, y) in the odometry frame, reached within `tolerance_m`.
    Goal {
        /// m, odometry frame.
        x: f64,
        /// m, odometry frame.
        y: f64,
        /// m.
        tolerance_m: f64,
    },
    /// Drop the goal and hold zero velocity until a new goal.
    Stop,
}

/// Which key a remote message came on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RemoteKey {
    /// `mimnav/<robot>/goal`.
    Goal,
    /// `mimnav/<robot>/stop`.
    Stop,
}

/// Why a remote message was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BadInput {
    /// The payload is larger than [`MAX_PAYLOAD`].
    #[error("{0} bytes: more than {MAX_PAYLOAD}")]
    TooLarge(usize),
    /// Neither a JSON object nor the 48 bytes of a `mimnav/Goal/v2`.
    #[error("neither a JSON goal nor the {GOAL_V2_SIZE} bytes of mimnav/Goal/v2 ({0} bytes)")]
    NotAGoal(usize),
    /// JSON that is not `{"x": …, "y": …, "tolerance_m": …}`.
    #[error("bad JSON goal: {0}")]
    Json(String),
    /// x or y is not a finite number within [`MAX_COORDINATE_M`].
    #[error("goal ({0}, {1}): x and y must be finite numbers within {MAX_COORDINATE_M} m")]
    Position(f64, f64),
    /// The tolerance is outside [`TOLERANCE_RANGE_M`] (or not finite).
    #[error("tolerance_m = {0}: must be within [{lo}, {hi}] m", lo = TOLERANCE_RANGE_M.0, hi = TOLERANCE_RANGE_M.1)]
    Tolerance(f64),
    /// A binary goal with flag bits other than [`goal_flags::STOP`], or non-zero reserved bytes.
    #[error("binary goal: unknown flags {0:#04x} or non-zero reserved bytes")]
    Flags(u8),
    /// Goals from the network are not accepted (`zenoh.accept_goals = false`).
    #[error("goals from the network are not accepted (zenoh.accept_goals = false)")]
    NotAccepted,
}

impl BadInput {
    /// The fault counter's name for this kind.
    pub fn kind(&self) -> &'static str {
        match self {
            BadInput::TooLarge(_) => "remote_too_large",
            BadInput::NotAGoal(_) | BadInput::Json(_) => "remote_malformed",
            BadInput::Position(..) | BadInput::Tolerance(_) | BadInput::Flags(_) => {
                "remote_out_of_range"
            }
            BadInput::NotAccepted => "remote_not_accepted",
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct JsonGoal {
    x: f64,
    y: f64,
    #[serde(default = "default_tolerance")]
    tolerance_m: f64,
}

fn default_tolerance() -> f64 {
    DEFAULT_TOLERANCE_M
}

/// Reads and checks one message that came on `key`.
pub fn parse(key: RemoteKey, payload: &[u8]) -> Result<Remote, BadInput> {
    if payload.len() > MAX_PAYLOAD {
        return Err(BadInput::TooLarge(payload.len()));
    }
    if key == RemoteKey::Stop {
        return Ok(Remote::Stop);
    }
    let first = payload.iter().find(|b| !b.is_ascii_whitespace());
    let goal = if first == Some(&b'{') {
        let g: JsonGoal =
            serde_json::from_slice(payload).map_err(|e| BadInput::Json(e.to_string()))?;
        Remote::Goal {
            x: g.x,
            y: g.y,
            tolerance_m: g.tolerance_m,
        }
    } else if payload.len() == GOAL_V2_SIZE {
        let f64_at = |at: usize| {
            let mut b = [0u8; 8];
            b.copy_from_slice(&payload[at..at + 8]);
            f64::from_le_bytes(b)
        };
        let (flags, reserved) = (payload[40], &payload[41..48]);
        if flags & !goal_flags::STOP != 0 || reserved.iter().any(|&b| b != 0) {
            return Err(BadInput::Flags(flags));
        }
        if flags & goal_flags::STOP != 0 {
            return Ok(Remote::Stop);
        }
        Remote::Goal {
            x: f64_at(16),
            y: f64_at(24),
            tolerance_m: f64_at(32),
        }
    } else {
        return Err(BadInput::NotAGoal(payload.len()));
    };
    check(goal)
}

/// Checks a goal's numbers.
pub fn check(r: Remote) -> Result<Remote, BadInput> {
    if let Remote::Goal { x, y, tolerance_m } = r {
        let near = |v: f64| v.is_finite() && v.abs() <= MAX_COORDINATE_M;
        if !(near(x) && near(y)) {
            return Err(BadInput::Position(x, y));
        }
        let (lo, hi) = TOLERANCE_RANGE_M;
        if !(tolerance_m.is_finite() && (lo..=hi).contains(&tolerance_m)) {
            return Err(BadInput::Tolerance(tolerance_m));
        }
    }
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::bytes_of;
    use mimnav_shared::topics::Goal;

    fn goal(x: f64, y: f64, tolerance_m: f64) -> Remote {
        Remote::Goal { x, y, tolerance_m }
    }

    #[test]
    fn json_goals_are_read_with_a_default_tolerance() {
        let p = |s: &str| parse(RemoteKey::Goal, s.as_bytes());
        assert_eq!(
            p(r#"{"x": 2, "y": -1.5, "tolerance_m": 0.5}"#),
            Ok(goal(2.0, -1.5, 0.5))
        );
        assert_eq!(p(r#" {"y": 1, "x": 3}"#), Ok(goal(3.0, 1.0, 0.3)));
    }

    #[test]
    fn binary_goals_follow_the_documented_layout() {
        let g = Goal {
            seq: 99,
            stamp_mono_ns: 1,
            x: 4.0,
            y: 0.5,
            tolerance_m: 0.2,
            ..Goal::default()
        };
        let b = bytes_of(std::slice::from_ref(&g)).to_vec();
        assert_eq!(parse(RemoteKey::Goal, &b), Ok(goal(4.0, 0.5, 0.2)));
        let mut stop = b.clone();
        stop[40] = goal_flags::STOP;
        assert_eq!(parse(RemoteKey::Goal, &stop), Ok(Remote::Stop));
        let mut odd = b.clone();
        odd[40] = 0x80;
        assert_eq!(parse(RemoteKey::Goal, &odd), Err(BadInput::Flags(0x80)));
        let mut dirty = b;
        dirty[47] = 1;
        assert_eq!(parse(RemoteKey::Goal, &dirty), Err(BadInput::Flags(0)));
    }

    #[test]
    fn a_stop_is_any_small_payload() {
        assert_eq!(parse(RemoteKey::Stop, b""), Ok(Remote::Stop));
        assert_eq!(parse(RemoteKey::Stop, b"{}"), Ok(Remote::Stop));
        let big = vec![0u8; MAX_PAYLOAD + 1];
        assert_eq!(
            parse(RemoteKey::Stop, &big),
            Err(BadInput::TooLarge(MAX_PAYLOAD + 1))
        );
    }

    proptest::proptest! {
        /// Any bytes on either key: no panic, and whatever is accepted is a goal whose numbers
        /// pass the checks, or a stop.
        #[test]
        fn any_bytes_are_refused_or_give_a_checked_goal(
            bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..1100),
            json in "\\{\"x\": ?-?[0-9e.]{1,6}, \"y\": ?-?[0-9e.]{1,6}(, \"tolerance_m\": ?-?[0-9e.]{1,5})?\\}",
        ) {
            for key in [RemoteKey::Goal, RemoteKey::Stop] {
                for payload in [&bytes[..], json.as_bytes()] {
                    match parse(key, payload) {
                        Ok(Remote::Goal { x, y, tolerance_m }) => {
                            proptest::prop_assert!(x.is_finite() && y.is_finite());
                            proptest::prop_assert!(x.abs() <= MAX_COORDINATE_M && y.abs() <= MAX_COORDINATE_M);
                            proptest::prop_assert!((TOLERANCE_RANGE_M.0..=TOLERANCE_RANGE_M.1).contains(&tolerance_m));
                        }
                        Ok(Remote::Stop) => proptest::prop_assert!(payload.len() <= MAX_PAYLOAD),
                        Err(e) => proptest::prop_assert!(!e.kind().is_empty()),
                    }
                }
            }
        }
    }

    /// Every malformed or out-of-range message is refused with its kind, never a panic.
    #[test]
    fn bad_remote_input_is_refused_by_kind() {
        let cases: [(&[u8], &str); 12] = [
            (br#"{"x": 1}"#, "remote_malformed"),
            (br#"{"x": 1, "y": 2, "z": 3}"#, "remote_malformed"),
            (br#"{"x": "1", "y": 2}"#, "remote_malformed"),
            (br#"{"x": 1e999, "y": 2}"#, "remote_malformed"),
            (br#"{"x": 1, "y": 2"#, "remote_malformed"),
            (b"\xff\xfe", "remote_malformed"),
            (b"", "remote_malformed"),
            (br#"{"x": 20000, "y": 0}"#, "remote_out_of_range"),
            (
                br#"{"x": 1, "y": 2, "tolerance_m": 0}"#,
                "remote_out_of_range",
            ),
            (
                br#"{"x": 1, "y": 2, "tolerance_m": -1}"#,
                "remote_out_of_range",
            ),
            (
                br#"{"x": 1, "y": 2, "tolerance_m": 11}"#,
                "remote_out_of_range",
            ),
            (&[b' '; MAX_PAYLOAD + 1], "remote_too_large"),
        ];
        for (payload, kind) in cases {
            let e = parse(RemoteKey::Goal, payload).expect_err(kind);
            assert_eq!(
                e.kind(),
                kind,
                "{:?}: {e}",
                String::from_utf8_lossy(payload)
            );
        }
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let g = Goal {
                x: bad,
                tolerance_m: 0.3,
                ..Goal::default()
            };
            let b = bytes_of(std::slice::from_ref(&g));
            assert!(matches!(
                parse(RemoteKey::Goal, b),
                Err(BadInput::Position(..))
            ));
            let g = Goal {
                tolerance_m: bad,
                ..Goal::default()
            };
            let b = bytes_of(std::slice::from_ref(&g));
            assert!(matches!(
                parse(RemoteKey::Goal, b),
                Err(BadInput::Tolerance(_))
            ));
        }
    }
}
