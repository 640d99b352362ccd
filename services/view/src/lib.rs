//! `mimnav-view`: the Foxglove live view of a running stack.
//!
//! A separate process, so that a slow viewer can never slow the control path: it subscribes to
//! the stack's iceoryx2 topics like any other reader (safe overflow, no history: the publishers
//! never wait for it), converts what a connected client asked for into Foxglove's well-known
//! schemas, and serves it with the Foxglove SDK's WebSocket server (`foxglove.websocket.v1`).
//! What it cannot send it drops, and counts.
//!
//! To follow one revolution through the crate:
//! - [`pump::Inputs`] receives it from `lidar/points` (and the map from `map/plan`, …), counting
//!   the samples it missed from the publishers' sequence numbers;
//! - [`bridge::Bridge`] decides whether to send it (a client subscribed? within the channel's
//!   rate limit?) and counts each outcome ([`counters`]);
//! - [`convert`] builds the Foxglove message (`PointCloud`, `Grid`, `FrameTransforms`, …);
//! - the SDK queues it for every subscribed client and drops a slow client's oldest messages
//!   ([`server::Server`] starts it on a runtime of its own).
//!
//! The channels (see [`bridge::CHANNELS`] and docs/view.md):
//!
//! | Foxglove topic | schema | from |
//! |---|---|---|
//! | `/lidar/points` | `foxglove.PointCloud` (frame `lidar`) | `lidar/points` |
//! | `/map/layers` | `foxglove.Grid` (frame `odom`), `layer0…` `float32` | `map/layers` |
//! | `/map/plan` | `foxglove.Grid`, `class` and `cost` `uint8` | `map/plan` |
//! | `/map/glass` | `foxglove.Grid`, `glass` `uint8` (1 glass, 2 suspected) | `map/plan` |
//! | `/tf` | `foxglove.FrameTransforms`: `odom → base_link → lidar` | `odom`, `[robot.mount]` |
//! | `/odom` | `foxglove.PoseInFrame` | `odom` |
//! | `/path` | `foxglove.PosesInFrame`, the driven path | `odom` |
//! | `/goal` | `foxglove.SceneUpdate`, a disc of the goal's tolerance | `goal` |
//! | `/goal/raw`, `/cmd_vel`, `/foliage/alarm`, `/base/state` | JSON | their topics |
//! | `/foliage/scan` | `foxglove.PointCloud`, field `class` | `foliage/alarm` |
//! | `/latency` | JSON: each revolution's time per hop | `map/plan`, `cmd_vel`, `foliage/alarm` |
//! | `/view/stats` | JSON: the view's counters | the view |
//!
//! ```
//! use mimnav_view::bridge::Bridge;
//! use mimnav_shared::topics::{MapHeader, PlanCell};
//!
//! let mut bridge = Bridge::new(&Default::default(), Default::default(), 0.5).unwrap();
//! let h = MapHeader { cells: 2, cell_m: 0.1, ..Default::default() };
//! // nobody is subscribed: nothing is converted, the sample is counted as unwatched
//! bridge.on_plan(&h, &[PlanCell::default(); 4], 0).unwrap();
//! assert_eq!(bridge.counters().channels["/map/plan"].unwatched, 1);
//! ```

#![warn(missing_docs)]

pub mod bridge;
pub mod convert;
pub mod counters;
pub mod pump;
pub mod server;
