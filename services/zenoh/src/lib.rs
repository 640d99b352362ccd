//! mimnav's topics on other hosts over Zenoh (issue 25): the `mimnav-zenoh` service's logic.
//!
//! Selected topics go out on the key expressions `mimnav/<robot>/<topic>` (`mimnav/spot1/
//! lidar/points`), each message the topic's bytes exactly as docs/topics.md lays them out — the
//! user header, then the payload's elements — with the Zenoh encoding
//! `application/octet-stream;<schema>` naming the types and their versions
//! (`mimnav/PointsHeader/v1+[mimnav/Point/v1]`). Each topic has a rate cap; what it refuses is
//! dropped and counted. Goals and stop requests heard on `mimnav/<robot>/goal` and `…/stop`
//! are checked and, when `zenoh.accept_goals` is on, forwarded to the local `mimnav/goal`
//! topic (a stop is a `Goal` with the stop flag: the planner then holds zero velocity until a
//! new goal). docs/zenoh.md is the user's guide.
//!
//! To follow one message, read:
//! - [`bridge`]: the topics, their keys and encodings, the rate cap, what a remote message
//!   becomes ([`bridge::Bridge`], no I/O: unit-tested);
//! - [`remote`]: the checks on remote input ([`remote::parse`]);
//! - [`wire`]: a topic's bytes;
//! - [`tap`]: the iceoryx2 subscribers, one per topic;
//! - [`link`]: the Zenoh session, its publishers and subscribers.
//!
//! ```
//! use mimnav_zenoh::bridge::Bridge;
//! use mimnav_zenoh::remote::RemoteKey;
//!
//! let mut b = Bridge::new("spot1", &[("lidar/points", 2.0)], true).unwrap();
//! assert_eq!(b.outgoing()[0].key, "mimnav/spot1/lidar/points");
//! assert!(b.admit(0, 0) && !b.admit(0, 100_000_000)); // 2 Hz: not again 100 ms later
//! let g = b.remote(RemoteKey::Goal, br#"{"x": 2, "y": 1}"#, 1, 0).unwrap();
//! assert_eq!((g.x, g.y, g.tolerance_m), (2.0, 1.0, 0.3));
//! ```

#![deny(missing_docs)]

pub mod bridge;
pub mod link;
pub mod remote;
pub mod tap;
pub mod wire;
