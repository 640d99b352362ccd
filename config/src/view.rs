//! `[view]`: the Foxglove live view (`mimnav-view`). Its keys live here rather than in the
//! `mimnav-view` crate so that the config crate, which every service links, does not pull in the
//! Foxglove SDK and its tokio / WebSocket tree.

use serde::Deserialize;

use mimnav_shared::config::{Checks, Invalid};

/// The keys of `[view]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ViewConfig {
    /// Serve the view; false: the service starts, reports itself ready and idles (so the unit
    /// can stay in `mimnav.target` on a robot that is never watched).
    pub enabled: bool,
    /// The address the WebSocket server listens on. The default keeps the view on the robot
    /// itself (reach it through an SSH tunnel); `0.0.0.0` serves every network, unauthenticated.
    pub bind: String,
    /// The TCP port (Foxglove's default is 8765); 0: any free port (logged at start).
    pub port: u16,
    /// Most revolutions' points sent a second (`/lidar/points`, `/foliage/scan`); 0: every one.
    pub points_hz: f64,
    /// Most maps sent a second (`/map/layers`, `/map/plan`, `/map/glass`); 0: every one.
    pub grids_hz: f64,
    /// Most poses and transforms sent a second (`/tf`, `/odom`); 0: every one.
    pub pose_hz: f64,
    /// Most updates of the driven path, the goal and the counters a second (`/path`, `/goal`,
    /// `/view/stats`).
    pub slow_hz: f64,
    /// The driven path keeps a pose every this many metres driven.
    pub path_step_m: f64,
    /// The driven path keeps at most this many poses (the oldest go first).
    pub path_poses: usize,
    /// Messages queued for one client before its oldest are dropped (the SDK's per-client
    /// backlog): with `points_hz` it bounds the memory a stalled client can hold.
    pub client_backlog: usize,
    /// Threads of the WebSocket server's runtime.
    pub threads: usize,
    /// How often the counters are logged, s.
    pub log_interval_s: f64,
}

impl Default for ViewConfig {
    fn default() -> Self {
        ViewConfig {
            enabled: true,
            bind: "127.0.0.1".into(),
            port: 8765,
            points_hz: 10.0,
            grids_hz: 5.0,
            pose_hz: 25.0,
            slow_hz: 2.0,
            path_step_m: 0.05,
            path_poses: 4000,
            client_backlog: 64,
            threads: 1,
            log_interval_s: 10.0,
        }
    }
}

impl ViewConfig {
    /// Checks every key.
    pub fn validate(&self) -> Result<(), Invalid> {
        let mut r = Checks::default();
        r.require(
            self.bind.trim().parse::<std::net::IpAddr>().is_ok(),
            "view.bind",
            format!(
                "view.bind = {:?} is not an IP address (127.0.0.1, ::1, 0.0.0.0, …)",
                self.bind
            ),
        );
        r.check("view.points_hz", self.points_hz, 0.0, 100.0);
        r.check("view.grids_hz", self.grids_hz, 0.0, 100.0);
        r.check("view.pose_hz", self.pose_hz, 0.0, 1000.0);
        r.check("view.slow_hz", self.slow_hz, 0.1, 100.0);
        r.check("view.path_step_m", self.path_step_m, 0.0, 10.0);
        r.check("view.path_poses", self.path_poses as f64, 2.0, 100_000.0);
        r.check(
            "view.client_backlog",
            self.client_backlog as f64,
            4.0,
            4096.0,
        );
        r.check("view.threads", self.threads as f64, 1.0, 8.0);
        r.check("view.log_interval_s", self.log_interval_s, 1.0, 3600.0);
        r.finish()
    }
}
