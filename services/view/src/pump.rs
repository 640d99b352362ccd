//! The receiving side: every topic the view shows, subscribed in the stack's iceoryx2 domain, and
//! drained into the [`Bridge`] a turn at a time.
//!
//! Each subscriber has the stack's QoS (safe overflow, no history, a buffer of two for the slice
//! topics): a view that falls behind loses the oldest samples in its own buffers, never slows a
//! publisher, and counts what it lost from the publishers' sequence numbers ([`Hop`]).

use iceoryx2::prelude::Node;

use mimnav_shared::hop::Hop;
use mimnav_shared::ipc::{self, IpcError, Listening, Svc, ValueSubscriber};
use mimnav_shared::topics::{self, BaseState, Goal, Odometry, VelocityCommand};

use crate::bridge::Bridge;

/// Most samples of one topic handled in a turn, so one busy topic cannot starve the others.
const PER_TURN: usize = 8;

/// Every subscription of the view.
pub struct Inputs {
    /// `lidar/points`.
    pub points: ipc::PointsSubscriber,
    /// `map/layers`.
    pub layers: ipc::LayersSubscriber,
    /// `map/plan`.
    pub plan: ipc::PlanSubscriber,
    /// `odom`.
    pub odom: ValueSubscriber<Odometry>,
    /// `goal`.
    pub goal: ValueSubscriber<Goal>,
    /// `cmd_vel`.
    pub cmd_vel: ValueSubscriber<VelocityCommand>,
    /// `foliage/alarm`.
    pub foliage: ipc::FoliageSubscriber,
    /// `base/state`.
    pub base_state: ValueSubscriber<BaseState>,
}

/// What each subscription has seen of its publisher's sequence numbers (kept apart from
/// [`Inputs`], which the loop's WaitSet borrows).
#[derive(Debug, Default)]
pub struct Seen {
    hops: [Hop; 8],
}

impl std::fmt::Debug for Inputs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Inputs").finish_non_exhaustive()
    }
}

/// Index of each topic's [`Hop`] and its name.
const NAMES: [&str; 8] = [
    topics::LIDAR_POINTS,
    topics::MAP_LAYERS,
    topics::MAP_PLAN,
    topics::ODOM,
    topics::GOAL,
    topics::CMD_VEL,
    topics::FOLIAGE_ALARM,
    topics::BASE_STATE,
];

/// A received sample's fate, for the counters: its sequence number, and a conversion error.
fn seen(bridge: &mut Bridge, hop: &mut Hop, topic: &'static str, seq: u64) {
    let before = hop.dropped();
    hop.see(seq);
    let t = bridge.counters_mut().topic(topic);
    t.received += 1;
    t.missed += hop.dropped() - before;
}

impl Inputs {
    /// Subscribes to every topic on `node`.
    pub fn open(node: &Node<Svc>) -> Result<Inputs, IpcError> {
        Ok(Inputs {
            points: ipc::points_subscriber(node)?,
            layers: ipc::layers_subscriber(node)?,
            plan: ipc::plan_subscriber(node)?,
            odom: ipc::odom_subscriber(node)?,
            goal: ipc::goal_subscriber(node)?,
            cmd_vel: ipc::cmd_vel_subscriber(node)?,
            foliage: ipc::foliage_subscriber(node)?,
            base_state: ipc::base_state_subscriber(node)?,
        })
    }

    /// Every subscription's listener, to wake the loop.
    pub fn listeners(&self) -> [&dyn Listening; 8] {
        [
            &self.points,
            &self.layers,
            &self.plan,
            &self.odom,
            &self.goal,
            &self.cmd_vel,
            &self.foliage,
            &self.base_state,
        ]
    }

    /// Clears every listener's notifications (the samples are taken by [`Inputs::drain`]).
    pub fn clear_notifications(&self) {
        for l in self.listeners() {
            let _ = l.heard();
        }
    }

    /// Hands up to [`PER_TURN`] waiting samples of every topic to `bridge`; returns how many were
    /// handled. A receive error is counted on its topic and returned (to be logged at a limited
    /// rate); the other topics are still drained. A slice sample is released before the next is
    /// taken (a slice subscriber may hold one).
    pub fn drain(
        &self,
        seen_so_far: &mut Seen,
        bridge: &mut Bridge,
        now_ns: impl Fn() -> u64,
    ) -> (usize, Vec<IpcError>) {
        let (mut n, mut errors) = (0, Vec::new());
        let mut fail = |bridge: &mut Bridge, i: usize, e: IpcError| {
            bridge.counters_mut().topic(NAMES[i]).errors += 1;
            errors.push(e);
        };
        let [
            h_points,
            h_layers,
            h_plan,
            h_odom,
            h_goal,
            h_cmd,
            h_foliage,
            h_base,
        ] = &mut seen_so_far.hops;
        for _ in 0..PER_TURN {
            match self.points.receive() {
                Ok(Some(s)) => {
                    let h = s.user_header();
                    seen(bridge, h_points, NAMES[0], h.seq);
                    bridge.on_points(h, s.payload(), now_ns());
                    n += 1;
                }
                Ok(None) => break,
                Err(e) => {
                    fail(bridge, 0, e);
                    break;
                }
            }
        }
        for _ in 0..PER_TURN {
            match self.layers.receive() {
                Ok(Some(s)) => {
                    let h = s.user_header();
                    seen(bridge, h_layers, NAMES[1], h.seq);
                    let _ = bridge.on_layers(h, s.payload(), now_ns());
                    n += 1;
                }
                Ok(None) => break,
                Err(e) => {
                    fail(bridge, 1, e);
                    break;
                }
            }
        }
        for _ in 0..PER_TURN {
            match self.plan.receive() {
                Ok(Some(s)) => {
                    let h = s.user_header();
                    seen(bridge, h_plan, NAMES[2], h.seq);
                    let _ = bridge.on_plan(h, s.payload(), now_ns());
                    n += 1;
                }
                Ok(None) => break,
                Err(e) => {
                    fail(bridge, 2, e);
                    break;
                }
            }
        }
        for _ in 0..PER_TURN {
            match self.foliage.receive() {
                Ok(Some(s)) => {
                    let h = s.user_header();
                    seen(bridge, h_foliage, NAMES[6], h.seq);
                    bridge.on_foliage(h, s.payload(), now_ns());
                    n += 1;
                }
                Ok(None) => break,
                Err(e) => {
                    fail(bridge, 6, e);
                    break;
                }
            }
        }
        // the value topics: small, buffered 64 deep; every one is handled
        loop {
            match self.odom.receive() {
                Ok(Some(o)) => {
                    seen(bridge, h_odom, NAMES[3], o.seq);
                    let _ = bridge.on_odom(&o, now_ns());
                    n += 1;
                }
                Ok(None) => break,
                Err(e) => {
                    fail(bridge, 3, e);
                    break;
                }
            }
        }
        loop {
            match self.goal.receive() {
                Ok(Some(g)) => {
                    seen(bridge, h_goal, NAMES[4], g.seq);
                    let _ = bridge.on_goal(&g, now_ns());
                    n += 1;
                }
                Ok(None) => break,
                Err(e) => {
                    fail(bridge, 4, e);
                    break;
                }
            }
        }
        loop {
            match self.cmd_vel.receive() {
                Ok(Some(c)) => {
                    seen(bridge, h_cmd, NAMES[5], c.seq);
                    bridge.on_cmd_vel(&c, now_ns());
                    n += 1;
                }
                Ok(None) => break,
                Err(e) => {
                    fail(bridge, 5, e);
                    break;
                }
            }
        }
        loop {
            match self.base_state.receive() {
                Ok(Some(b)) => {
                    seen(bridge, h_base, NAMES[7], b.seq);
                    bridge.on_base_state(&b, now_ns());
                    n += 1;
                }
                Ok(None) => break,
                Err(e) => {
                    fail(bridge, 7, e);
                    break;
                }
            }
        }
        (n, errors)
    }
}
