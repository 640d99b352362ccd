//! The bridge: the stack's samples in, Foxglove channels out.
//!
//! [`Bridge`] owns a Foxglove [`Context`] with one channel per Foxglove topic ([`CHANNELS`]) and
//! decides, sample by sample, whether to send: a channel no client subscribed to costs nothing
//! (no conversion), a channel over its rate limit is thinned, a sample the conversion refuses is
//! counted as bad; each outcome has its counter ([`crate::counters`]). Sending never waits:
//! the SDK hands each message to every subscribed client's own queue, dropping that client's
//! oldest when it is full, so one slow client neither slows the bridge nor the other clients.
//!
//! The bridge sees no iceoryx2 and no socket ([`crate::pump`] receives, [`crate::server`]
//! serves), so the bench and the unit tests drive it directly.

use std::collections::VecDeque;
use std::sync::Arc;

use foxglove::messages::{
    FrameTransforms, Grid, PointCloud, PoseInFrame, PosesInFrame, SceneUpdate,
};
use foxglove::{Channel, ChannelBuilder, Context, Encode, RawChannel, Schema};
use serde_json::json;

use mimnav_config::ViewConfig;
use mimnav_shared::pose::LidarMount;
use mimnav_shared::topics::{
    self, BaseState, FoliageHeader, FoliageReturn, Goal, MapHeader, Odometry, PlanCell, Point,
    PointsHeader, VelocityCommand,
};

use crate::convert::{self, BadSample};
use crate::counters::{Counters, RateLimit};

/// Foxglove topic of the revolution's points (`PointCloud`, frame `lidar`).
pub const POINTS: &str = "/lidar/points";
/// The intensity map's layers (`Grid`, one `float32` field a layer).
pub const LAYERS: &str = "/map/layers";
/// The plan map: classes and cost (`Grid`, `class` and `cost`, `uint8`).
pub const PLAN: &str = "/map/plan";
/// The glass memory (`Grid`, `glass`: 1 glass, 2 suspected).
pub const GLASS: &str = "/map/glass";
/// Transforms `odom → base_link → lidar` (`FrameTransforms`).
pub const TF: &str = "/tf";
/// The robot's pose (`PoseInFrame`, frame `odom`).
pub const ODOM: &str = "/odom";
/// The driven path (`PosesInFrame`, frame `odom`).
pub const PATH: &str = "/path";
/// The goal as a disc of its tolerance (`SceneUpdate`).
pub const GOAL: &str = "/goal";
/// The goal's fields (JSON `mimnav.Goal`).
pub const GOAL_RAW: &str = "/goal/raw";
/// Velocity commands and their status (JSON `mimnav.VelocityCommand`).
pub const CMD_VEL: &str = "/cmd_vel";
/// The foliage classifier's verdict (JSON `mimnav.FoliageAlarm`).
pub const FOLIAGE_ALARM: &str = "/foliage/alarm";
/// The classified scan (`PointCloud`, frame `lidar`, field `class`).
pub const FOLIAGE_SCAN: &str = "/foliage/scan";
/// The robot base's state (JSON `mimnav.BaseState`).
pub const BASE_STATE: &str = "/base/state";
/// Per-hop latency of each revolution (JSON `mimnav.Latency`).
pub const LATENCY: &str = "/latency";
/// The view's own counters (JSON `mimnav.ViewStats`).
pub const STATS: &str = "/view/stats";

/// Every channel the view advertises.
pub const CHANNELS: [&str; 15] = [
    POINTS,
    LAYERS,
    PLAN,
    GLASS,
    TF,
    ODOM,
    PATH,
    GOAL,
    GOAL_RAW,
    CMD_VEL,
    FOLIAGE_ALARM,
    FOLIAGE_SCAN,
    BASE_STATE,
    LATENCY,
    STATS,
];

/// A map the view received: its revolution and when each hop saw it.
#[derive(Debug, Clone, Copy)]
struct MapSeen {
    source_seq: u64,
    /// monotonic time the revolution's last packet was received by the driver
    rx_mono_ns: u64,
    /// the mapper's time for it
    mapper_us: u32,
    /// monotonic time the view received the map
    view_ns: u64,
}

/// Maps remembered for the latency of their commands.
const MAPS_REMEMBERED: usize = 32;

/// Why the bridge could not be made.
#[derive(Debug, thiserror::Error)]
#[error("cannot create the Foxglove channel {topic}: {detail}")]
pub struct ChannelError {
    topic: &'static str,
    detail: String,
}

/// A channel of the SDK's well-known schemas, with its rate limit.
struct Typed<T: Encode> {
    name: &'static str,
    ch: Channel<T>,
    limit: RateLimit,
}

/// A JSON channel, with its rate limit.
struct Json {
    name: &'static str,
    ch: Arc<RawChannel>,
    limit: RateLimit,
}

/// What to do with a sample of a channel.
enum Gate {
    /// Convert it and send it.
    Send,
    /// Counted already: skip it.
    Skip,
}

fn gate(
    counters: &mut Counters,
    name: &'static str,
    watched: bool,
    limit: &mut RateLimit,
    now_ns: u64,
) -> Gate {
    let c = counters.channel(name);
    if !watched {
        c.unwatched += 1;
        Gate::Skip
    } else if !limit.allow(now_ns) {
        c.thinned += 1;
        Gate::Skip
    } else {
        Gate::Send
    }
}

impl<T: Encode> Typed<T> {
    fn new(ctx: &Arc<Context>, name: &'static str, hz: f64) -> Typed<T> {
        Typed {
            name,
            ch: ChannelBuilder::new(name).context(ctx).build::<T>(),
            limit: RateLimit::new(hz),
        }
    }

    /// Converts with `make` and sends, if watched and within the rate limit.
    fn offer(
        &mut self,
        counters: &mut Counters,
        now_ns: u64,
        make: impl FnOnce() -> Result<T, BadSample>,
    ) -> Result<bool, BadSample> {
        if let Gate::Skip = gate(
            counters,
            self.name,
            self.ch.has_sinks(),
            &mut self.limit,
            now_ns,
        ) {
            return Ok(false);
        }
        match make() {
            Ok(m) => {
                self.ch.log(&m);
                let c = counters.channel(self.name);
                c.sent += 1;
                c.bytes += m.encoded_len().unwrap_or(0) as u64;
                Ok(true)
            }
            Err(e) => {
                counters.channel(self.name).bad += 1;
                Err(e)
            }
        }
    }
}

impl Json {
    fn new(
        ctx: &Arc<Context>,
        name: &'static str,
        schema: serde_json::Value,
        hz: f64,
    ) -> Result<Json, ChannelError> {
        let title = schema["title"]
            .as_str()
            .unwrap_or("mimnav.Json")
            .to_string();
        let data = serde_json::to_vec(&schema).unwrap_or_default();
        let ch = ChannelBuilder::new(name)
            .context(ctx)
            .message_encoding("json")
            .schema(Schema::new(title, "jsonschema", data))
            .build_raw()
            .map_err(|e| ChannelError {
                topic: name,
                detail: e.to_string(),
            })?;
        Ok(Json {
            name,
            ch,
            limit: RateLimit::new(hz),
        })
    }

    fn offer(&mut self, counters: &mut Counters, now_ns: u64, make: impl FnOnce() -> Vec<u8>) {
        if let Gate::Skip = gate(
            counters,
            self.name,
            self.ch.has_sinks(),
            &mut self.limit,
            now_ns,
        ) {
            return;
        }
        let m = make();
        self.ch.log(&m);
        let c = counters.channel(self.name);
        c.sent += 1;
        c.bytes += m.len() as u64;
    }
}

/// The stack's samples in, Foxglove channels out; see the module doc.
pub struct Bridge {
    ctx: Arc<Context>,
    points: Typed<PointCloud>,
    layers: Typed<Grid>,
    plan: Typed<Grid>,
    glass: Typed<Grid>,
    tf: Typed<FrameTransforms>,
    odom: Typed<PoseInFrame>,
    path_ch: Typed<PosesInFrame>,
    goal: Typed<SceneUpdate>,
    goal_raw: Json,
    cmd_vel: Json,
    foliage_alarm: Json,
    foliage_scan: Typed<PointCloud>,
    base_state: Json,
    latency: Json,
    stats: Json,
    counters: Counters,
    path: convert::Path,
    mount: LidarMount,
    sensor_height_m: f64,
    last_goal: Option<Goal>,
    slow_hz: f64,
    /// the latest maps, for the latency of the commands planned from them
    maps: VecDeque<MapSeen>,
    foliage_us: Option<u32>,
}

impl std::fmt::Debug for Bridge {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Bridge")
            .field("counters", &self.counters)
            .finish_non_exhaustive()
    }
}

impl Bridge {
    /// The bridge's channels on a context of its own, with `view`'s rate limits; the robot's
    /// lidar mount and sensor height place the `lidar` frame on `base_link`.
    pub fn new(
        view: &ViewConfig,
        mount: LidarMount,
        sensor_height_m: f64,
    ) -> Result<Bridge, ChannelError> {
        let ctx = Context::new();
        let (p, g, q, s) = (view.points_hz, view.grids_hz, view.pose_hz, view.slow_hz);
        Ok(Bridge {
            points: Typed::new(&ctx, POINTS, p),
            layers: Typed::new(&ctx, LAYERS, g),
            plan: Typed::new(&ctx, PLAN, g),
            glass: Typed::new(&ctx, GLASS, g),
            tf: Typed::new(&ctx, TF, q),
            odom: Typed::new(&ctx, ODOM, q),
            path_ch: Typed::new(&ctx, PATH, s),
            goal: Typed::new(&ctx, GOAL, s),
            goal_raw: Json::new(&ctx, GOAL_RAW, convert::schemas::goal(), s)?,
            cmd_vel: Json::new(&ctx, CMD_VEL, convert::schemas::cmd_vel(), 0.0)?,
            foliage_alarm: Json::new(&ctx, FOLIAGE_ALARM, convert::schemas::foliage_alarm(), 0.0)?,
            foliage_scan: Typed::new(&ctx, FOLIAGE_SCAN, p),
            base_state: Json::new(&ctx, BASE_STATE, convert::schemas::base_state(), q)?,
            latency: Json::new(&ctx, LATENCY, convert::schemas::latency(), 0.0)?,
            stats: Json::new(&ctx, STATS, convert::schemas::stats(), s)?,
            ctx,
            counters: Counters::default(),
            path: convert::Path::new(view.path_step_m, view.path_poses),
            mount,
            sensor_height_m,
            last_goal: None,
            slow_hz: view.slow_hz,
            maps: VecDeque::new(),
            foliage_us: None,
        })
    }

    /// The Foxglove context the WebSocket server serves.
    pub fn context(&self) -> &Arc<Context> {
        &self.ctx
    }

    /// The counters so far.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// The counters, for the receiving side to count what it received and missed.
    pub fn counters_mut(&mut self) -> &mut Counters {
        &mut self.counters
    }

    fn bad(&mut self, topic: &'static str, r: Result<bool, BadSample>) -> Result<(), BadSample> {
        r.map(|_| ())
            .inspect_err(|_| self.counters.topic(topic).bad += 1)
    }

    /// A revolution from `lidar/points`.
    pub fn on_points(&mut self, h: &PointsHeader, pts: &[Point], now_ns: u64) {
        let _ = self
            .points
            .offer(&mut self.counters, now_ns, || Ok(convert::points(h, pts)));
    }

    /// A map from `map/plan`: the plan grid, the glass memory and the revolution's latency.
    pub fn on_plan(
        &mut self,
        h: &MapHeader,
        cells: &[PlanCell],
        now_ns: u64,
    ) -> Result<(), BadSample> {
        if let Err(e) = convert::check_map(h, cells.len(), 1) {
            self.counters.topic(topics::MAP_PLAN).bad += 1;
            return Err(e);
        }
        self.maps.push_back(MapSeen {
            source_seq: h.source_seq,
            rx_mono_ns: h.rx_mono_ns,
            mapper_us: h.processing_us,
            view_ns: now_ns,
        });
        if self.maps.len() > MAPS_REMEMBERED {
            self.maps.pop_front();
        }
        let r = self
            .plan
            .offer(&mut self.counters, now_ns, || convert::plan(h, cells));
        self.bad(topics::MAP_PLAN, r)?;
        // the same cells, checked above
        let _ = self.glass.offer(&mut self.counters, now_ns, || {
            convert::glass(h, cells).map(|(g, _, _)| g)
        });
        Ok(())
    }

    /// A map from `map/layers`.
    pub fn on_layers(
        &mut self,
        h: &MapHeader,
        values: &[f32],
        now_ns: u64,
    ) -> Result<(), BadSample> {
        if let Err(e) = convert::check_map(h, values.len(), h.layers) {
            self.counters.topic(topics::MAP_LAYERS).bad += 1;
            return Err(e);
        }
        let r = self
            .layers
            .offer(&mut self.counters, now_ns, || convert::layers(h, values));
        self.bad(topics::MAP_LAYERS, r)
    }

    /// An odometry message: `/tf`, `/odom`, and the driven path.
    pub fn on_odom(&mut self, o: &Odometry, now_ns: u64) -> Result<(), BadSample> {
        if let Err(e) = self.path.add(o) {
            self.counters.topic(topics::ODOM).bad += 1;
            return Err(e);
        }
        // finite, checked by the path
        let (mount, height) = (self.mount, self.sensor_height_m);
        let _ = (self.tf).offer(&mut self.counters, now_ns, || {
            convert::transforms(o, &mount, height)
        });
        let _ = (self.odom).offer(&mut self.counters, now_ns, || convert::odom_pose(o));
        Ok(())
    }

    /// A goal: remembered, and sent at once (and again with every [`Bridge::tick`]).
    pub fn on_goal(&mut self, g: &Goal, now_ns: u64) -> Result<(), BadSample> {
        self.last_goal = Some(*g);
        // a new goal goes at once, whatever was sent just before
        self.goal.limit = RateLimit::new(self.slow_hz);
        self.goal_raw.limit = RateLimit::new(self.slow_hz);
        let r = self.send_goal(now_ns);
        self.bad(topics::GOAL, r)
    }

    fn send_goal(&mut self, now_ns: u64) -> Result<bool, BadSample> {
        let Some(g) = self.last_goal else {
            return Ok(false);
        };
        let stamp = self.path_stamp();
        self.goal_raw
            .offer(&mut self.counters, now_ns, || convert::goal(&g));
        self.goal.offer(&mut self.counters, now_ns, || {
            convert::goal_scene(&g, stamp)
        })
    }

    fn path_stamp(&self) -> u64 {
        self.path.message().timestamp.map_or(0, |t| {
            u64::from(t.sec()) * 1_000_000_000 + u64::from(t.nsec())
        })
    }

    /// A velocity command, and the latency of its revolution hop by hop when the view saw
    /// that revolution's map.
    pub fn on_cmd_vel(&mut self, c: &VelocityCommand, now_ns: u64) {
        let map = (self.maps.iter().rev())
            .find(|m| m.source_seq == c.source_seq)
            .copied();
        let us = |ns: u64| ns as f64 / 1e3;
        let rev_to_cmd = map.map(|m| us(c.stamp_mono_ns.saturating_sub(m.rx_mono_ns)));
        self.cmd_vel.offer(&mut self.counters, now_ns, || {
            convert::cmd_vel(c, rev_to_cmd)
        });
        let foliage_us = self.foliage_us;
        if let Some(m) = map {
            self.latency.offer(&mut self.counters, now_ns, || {
                serde_json::to_vec(&json!({
                    "source_seq": c.source_seq,
                    "mapper_us": m.mapper_us,
                    "rev_to_map_view_us": us(m.view_ns.saturating_sub(m.rx_mono_ns)),
                    "rev_to_cmd_us": us(c.stamp_mono_ns.saturating_sub(m.rx_mono_ns)),
                    "cmd_to_view_us": us(now_ns.saturating_sub(c.stamp_mono_ns)),
                    "foliage_us": foliage_us,
                }))
                .unwrap_or_default()
            });
        }
    }

    /// A verdict of the foliage classifier: `/foliage/alarm` and `/foliage/scan`.
    pub fn on_foliage(&mut self, h: &FoliageHeader, returns: &[FoliageReturn], now_ns: u64) {
        self.foliage_us = Some(h.processing_us);
        self.foliage_alarm
            .offer(&mut self.counters, now_ns, || convert::foliage_alarm(h));
        let _ = self.foliage_scan.offer(&mut self.counters, now_ns, || {
            Ok(convert::foliage_scan(h, returns))
        });
    }

    /// The base's state.
    pub fn on_base_state(&mut self, b: &BaseState, now_ns: u64) {
        self.base_state
            .offer(&mut self.counters, now_ns, || convert::base_state(b));
    }

    /// The slow channels, at their rate: the driven path, the goal again (a client that
    /// subscribed late sees it) and the counters, with `clients` connected.
    pub fn tick(&mut self, now_ns: u64, uptime_s: f64, clients: usize) {
        let path = &self.path;
        if !path.is_empty() {
            let _ = self
                .path_ch
                .offer(&mut self.counters, now_ns, || Ok(path.message()));
        }
        let _ = self.send_goal(now_ns);
        let stats = self.counters.json(uptime_s, clients);
        self.stats.offer(&mut self.counters, now_ns, || {
            serde_json::to_vec(&stats).unwrap_or_default()
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The topic a Foxglove path names: `/cmd_vel.v` → `/cmd_vel`.
    fn topic_of(path: &str) -> &str {
        path.split(['.', '[']).next().unwrap_or(path)
    }

    fn strings<'a>(v: &'a serde_json::Value, out: &mut Vec<&'a str>) {
        match v {
            serde_json::Value::String(s) => out.push(s),
            serde_json::Value::Array(a) => a.iter().for_each(|x| strings(x, out)),
            serde_json::Value::Object(o) => {
                for (k, x) in o {
                    out.push(k);
                    strings(x, out);
                }
            }
            _ => {}
        }
    }

    #[test]
    fn the_layout_shows_every_channel_and_names_no_other() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../docs/foxglove/mimnav-layout.json"
        );
        let text = std::fs::read_to_string(path).expect("docs/foxglove/mimnav-layout.json");
        let layout: serde_json::Value = serde_json::from_str(&text).expect("JSON");
        let mut all = Vec::new();
        strings(&layout["configById"], &mut all);
        let named: std::collections::BTreeSet<&str> = (all.into_iter())
            .filter(|s| s.starts_with('/'))
            .map(topic_of)
            .collect();
        for t in &named {
            assert!(
                CHANNELS.contains(t),
                "the layout names {t}, which the view does not serve"
            );
        }
        // /tf is used by the 3D panel without being named
        for t in CHANNELS.iter().filter(|t| **t != TF) {
            assert!(named.contains(t), "the layout does not show {t}");
        }
    }

    #[test]
    fn nothing_is_converted_for_nobody_and_every_sample_is_counted() {
        let mut b = Bridge::new(&ViewConfig::default(), LidarMount::default(), 0.5).unwrap();
        let h = MapHeader {
            cells: 2,
            cell_m: 0.1,
            layers: 1,
            ..Default::default()
        };
        b.on_plan(&h, &[PlanCell::default(); 4], 0).unwrap();
        // a malformed map is refused before anyone could see it
        let bad = MapHeader { cells: 3, ..h };
        assert!(b.on_layers(&bad, &[0.0; 4], 0).is_err());
        b.on_points(&PointsHeader::default(), &[Point::default(); 3], 0);
        let o = Odometry {
            x: f64::NAN,
            ..Default::default()
        };
        assert!(b.on_odom(&o, 0).is_err());
        let c = b.counters();
        assert_eq!(c.channels[PLAN].unwatched, 1);
        assert_eq!(c.channels[GLASS].unwatched, 1);
        assert_eq!(c.channels[POINTS].unwatched, 1);
        assert_eq!(c.channels[PLAN].sent + c.channels[POINTS].sent, 0);
        assert_eq!(c.topics[topics::ODOM].bad, 1);
        assert_eq!(c.topics[topics::MAP_LAYERS].bad, 1);
        assert!(
            !c.channels.contains_key(LAYERS),
            "the bad map never reached a channel"
        );
    }

    /// A sink subscribed to every channel that keeps what it was given.
    struct Recorder {
        id: foxglove::SinkId,
        got: std::sync::Mutex<Vec<(String, Vec<u8>)>>,
    }

    impl foxglove::Sink for Recorder {
        fn id(&self) -> foxglove::SinkId {
            self.id
        }

        fn log(
            &self,
            channel: &RawChannel,
            msg: &[u8],
            _: &foxglove::Metadata,
        ) -> Result<(), foxglove::FoxgloveError> {
            if let Ok(mut g) = self.got.lock() {
                g.push((channel.topic().to_string(), msg.to_vec()));
            }
            Ok(())
        }
    }

    fn watched(view: &ViewConfig) -> (Bridge, Arc<Recorder>) {
        let b = Bridge::new(view, LidarMount::default(), 0.5).unwrap();
        let r = Arc::new(Recorder {
            id: foxglove::SinkId::next(),
            got: Default::default(),
        });
        b.context().add_sink(r.clone());
        (b, r)
    }

    fn messages(r: &Recorder, topic: &str) -> Vec<Vec<u8>> {
        let g = r.got.lock().unwrap();
        (g.iter().filter(|(t, _)| t == topic))
            .map(|(_, m)| m.clone())
            .collect()
    }

    #[test]
    fn a_watched_channel_is_thinned_to_its_rate_and_counted() {
        let view = ViewConfig {
            points_hz: 10.0,
            ..Default::default()
        };
        let (mut b, r) = watched(&view);
        let pts = [Point::default(); 5];
        // 50 Hz for 180 ms: at 0 and 100 ms through a 10 Hz limit
        for i in 0..10u64 {
            b.on_points(&PointsHeader::default(), &pts, i * 20_000_000);
        }
        let c = b.counters().channels[POINTS];
        assert_eq!((c.sent, c.thinned, c.unwatched), (2, 8, 0));
        assert_eq!(messages(&r, POINTS).len(), 2);
        assert!(c.bytes >= 2 * 5 * 16, "{c:?}");
    }

    #[test]
    fn a_goal_goes_at_once_and_again_for_late_clients() {
        let (mut b, r) = watched(&ViewConfig::default());
        let g = Goal {
            seq: 3,
            x: 1.0,
            y: 2.0,
            tolerance_m: 0.3,
            ..Default::default()
        };
        b.on_goal(&g, 1).unwrap();
        assert_eq!(messages(&r, GOAL).len(), 1);
        let raw: serde_json::Value = serde_json::from_slice(&messages(&r, GOAL_RAW)[0]).unwrap();
        assert_eq!(raw["x"], 1.0);
        // the slow rate (2 Hz): not again within 0.5 s, again after it
        b.tick(100_000_000, 0.1, 1);
        assert_eq!(messages(&r, GOAL).len(), 1);
        b.tick(600_000_000, 0.6, 1);
        assert_eq!(messages(&r, GOAL).len(), 2);
        let stats: serde_json::Value = serde_json::from_slice(&messages(&r, STATS)[0]).unwrap();
        assert_eq!(stats["clients"], 1);
    }

    #[test]
    fn a_command_carries_its_revolutions_latency_hop_by_hop() {
        let (mut b, r) = watched(&ViewConfig::default());
        let h = MapHeader {
            cells: 1,
            cell_m: 0.1,
            source_seq: 7,
            rx_mono_ns: 1_000_000,
            processing_us: 400,
            ..Default::default()
        };
        b.on_plan(&h, &[PlanCell::default()], 1_500_000).unwrap();
        let c = VelocityCommand {
            source_seq: 7,
            stamp_mono_ns: 2_200_000,
            ..Default::default()
        };
        b.on_cmd_vel(&c, 2_300_000);
        let l: serde_json::Value = serde_json::from_slice(&messages(&r, LATENCY)[0]).unwrap();
        assert_eq!(l["rev_to_cmd_us"], 1200.0);
        assert_eq!(l["rev_to_map_view_us"], 500.0);
        assert_eq!(l["cmd_to_view_us"], 100.0);
        assert_eq!(l["mapper_us"], 400);
        let cmd: serde_json::Value = serde_json::from_slice(&messages(&r, CMD_VEL)[0]).unwrap();
        assert_eq!(cmd["rev_to_cmd_us"], 1200.0);
        // a command whose map the view never saw: no latency, the command still goes
        let other = VelocityCommand {
            source_seq: 99,
            ..c
        };
        b.on_cmd_vel(&other, 2_400_000);
        assert_eq!(messages(&r, LATENCY).len(), 1);
        assert_eq!(messages(&r, CMD_VEL).len(), 2);
    }
}
