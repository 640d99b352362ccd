//! The local side: one iceoryx2 subscriber per published topic, each message copied out as the
//! bytes [`crate::wire`] lays out.

use iceoryx2::port::listener::Listener;
use iceoryx2::prelude::*;

use mimnav_shared::ipc::{self, IpcError, Listening, SliceSubscriber, Svc, ValueSubscriber};
use mimnav_shared::topics;

use crate::bridge::Topic;
use crate::wire::{self, Plain};

/// A subscriber of one topic, whatever its type.
#[derive(Debug)]
pub enum Tap {
    /// `lidar/points`.
    Points(ipc::PointsSubscriber),
    /// `lidar/scan2d`.
    Scan(ipc::ScanSubscriber),
    /// `map/plan`.
    Plan(ipc::PlanSubscriber),
    /// `map/layers`.
    Layers(ipc::LayersSubscriber),
    /// `sim/truth`.
    Truth(ipc::TruthSubscriber),
    /// `foliage/alarm`.
    Foliage(ipc::FoliageSubscriber),
    /// `odom`.
    Odom(ValueSubscriber<topics::Odometry>),
    /// `cmd_vel`.
    CmdVel(ValueSubscriber<topics::VelocityCommand>),
    /// `goal`.
    Goal(ValueSubscriber<topics::Goal>),
    /// `base/state`.
    BaseState(ValueSubscriber<topics::BaseState>),
}

impl Tap {
    /// Subscribes to `topic` with the stack's QoS.
    pub fn open(node: &Node<Svc>, topic: Topic) -> Result<Tap, IpcError> {
        Ok(match topic {
            Topic::Points => Tap::Points(ipc::points_subscriber(node)?),
            Topic::Scan => Tap::Scan(ipc::scan_subscriber(node)?),
            Topic::Plan => Tap::Plan(ipc::plan_subscriber(node)?),
            Topic::Layers => Tap::Layers(ipc::layers_subscriber(node)?),
            Topic::Truth => Tap::Truth(ipc::truth_subscriber(node)?),
            Topic::Foliage => Tap::Foliage(ipc::foliage_subscriber(node)?),
            Topic::Odom => Tap::Odom(ipc::odom_subscriber(node)?),
            Topic::CmdVel => Tap::CmdVel(ipc::cmd_vel_subscriber(node)?),
            Topic::Goal => Tap::Goal(ipc::goal_subscriber(node)?),
            Topic::BaseState => Tap::BaseState(ipc::base_state_subscriber(node)?),
        })
    }

    /// Takes the next message waiting: `None` when there is none; else whether `admit` let it
    /// go, in which case `out` holds its bytes (header, then payload). A refused message is not
    /// copied.
    pub fn next(
        &self,
        out: &mut Vec<u8>,
        admit: impl FnOnce() -> bool,
    ) -> Result<Option<bool>, IpcError> {
        match self {
            Tap::Points(s) => slice(s, out, admit),
            Tap::Scan(s) => slice(s, out, admit),
            Tap::Plan(s) => slice(s, out, admit),
            Tap::Layers(s) => slice(s, out, admit),
            Tap::Truth(s) => slice(s, out, admit),
            Tap::Foliage(s) => slice(s, out, admit),
            Tap::Odom(s) => value(s, out, admit),
            Tap::CmdVel(s) => value(s, out, admit),
            Tap::Goal(s) => value(s, out, admit),
            Tap::BaseState(s) => value(s, out, admit),
        }
    }
}

impl Listening for Tap {
    fn listener(&self) -> &Listener<Svc> {
        match self {
            Tap::Points(s) => s.listener(),
            Tap::Scan(s) => s.listener(),
            Tap::Plan(s) => s.listener(),
            Tap::Layers(s) => s.listener(),
            Tap::Truth(s) => s.listener(),
            Tap::Foliage(s) => s.listener(),
            Tap::Odom(s) => s.listener(),
            Tap::CmdVel(s) => s.listener(),
            Tap::Goal(s) => s.listener(),
            Tap::BaseState(s) => s.listener(),
        }
    }
}

fn slice<T, H>(
    s: &SliceSubscriber<T, H>,
    out: &mut Vec<u8>,
    admit: impl FnOnce() -> bool,
) -> Result<Option<bool>, IpcError>
where
    T: std::fmt::Debug + ZeroCopySend + Copy + Plain + 'static,
    H: std::fmt::Debug + ZeroCopySend + Copy + Default + Plain + 'static,
{
    let Some(sample) = s.receive()? else {
        return Ok(None);
    };
    if !admit() {
        return Ok(Some(false));
    }
    out.clear();
    wire::put(out, sample.user_header(), sample.payload());
    Ok(Some(true))
}

fn value<T>(
    s: &ValueSubscriber<T>,
    out: &mut Vec<u8>,
    admit: impl FnOnce() -> bool,
) -> Result<Option<bool>, IpcError>
where
    T: std::fmt::Debug + ZeroCopySend + Copy + Plain + 'static,
{
    let Some(v) = s.receive()? else {
        return Ok(None);
    };
    if !admit() {
        return Ok(Some(false));
    }
    out.clear();
    out.extend_from_slice(wire::bytes_of(std::slice::from_ref(&v)));
    Ok(Some(true))
}
