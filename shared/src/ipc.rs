//! Opening the project's topics with the project's settings.
//!
//! Every topic is a publish-subscribe service paired with an event service of the same name:
//! publishers notify after sending, receivers block in a [`WaitSet`](iceoryx2::prelude::WaitSet)
//! on the [`Listener`] instead of polling. One function per topic opens it, so every process
//! agrees on the quality of service (the first creator fixes it; a later opener that asks for
//! more fails).
//!
//! Quality of service, the same for every topic unless noted:
//! - safe overflow on: a slow subscriber loses its oldest sample, a publisher never blocks;
//! - no history: a late subscriber starts with the next sample;
//! - slice payloads are allocated statically at their worst-case length, fixed at start-up from
//!   the config (see the README's topic table);
//! - the subscriber buffer holds [`SLICE_BUFFER`] samples for large slice topics and
//!   [`SMALL_BUFFER`] for fixed-size ones.

use std::fmt::Debug;

use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::sample::Sample;
use iceoryx2::waitset::{WaitSetRunError, WaitSetRunResult};

use std::path::PathBuf;
use std::sync::atomic::{AtomicU32, Ordering};

use crate::config::Common;
use crate::signals;
use crate::topics::{self, EVENT_END_OF_STREAM, EVENT_NEW_DATA};

/// The service variant every process uses: inter-process.
pub type Svc = ipc::Service;

/// Most publishers of one topic (the producing service plus, say, a replay tool).
pub const MAX_PUBLISHERS: usize = 2;
/// Most subscribers of one topic.
pub const MAX_SUBSCRIBERS: usize = 6;
/// Most nodes that may open one topic.
pub const MAX_NODES: usize = 12;
/// Subscriber buffer of the large slice topics (revolutions, maps).
pub const SLICE_BUFFER: usize = 2;
/// Subscriber buffer of a replay's own subscriber of `lidar/points` in the replay's private domain
/// (`mimnav replay`): the revolutions of a short capture replayed as fast as possible all wait
/// in it when the reader falls behind, instead of being overwritten.
pub const REPLAY_BUFFER: usize = 16;
/// Subscriber buffer of `lidar/slices`: more than a revolution's slices at the shipped slice
/// size (38 in dual-return mode at 600 rpm, 4 packets each), so a mapper busy with a map misses
/// none.
pub const SLICES_BUFFER: usize = 64;
/// Subscriber buffer of fixed-size topics (raw packets, commands).
pub const SMALL_BUFFER: usize = 64;

/// Why a topic could not be opened or used.
#[derive(Debug, thiserror::Error)]
pub enum IpcError {
    /// The iceoryx2 node could not be created (root path not writable, …).
    #[error("cannot create the iceoryx2 node `{name}`: {detail}")]
    Node {
        /// Node name.
        name: String,
        /// What iceoryx2 said.
        detail: String,
    },
    /// A service could not be opened or created, or a port could not be made on it.
    #[error("topic `{topic}`: {detail}")]
    Topic {
        /// Topic name.
        topic: &'static str,
        /// What iceoryx2 said.
        detail: String,
    },
    /// A sample could not be loaned or sent.
    #[error("topic `{topic}`: cannot publish: {detail}")]
    Publish {
        /// Topic name.
        topic: &'static str,
        /// What iceoryx2 said.
        detail: String,
    },
    /// More elements than the topic's static capacity.
    #[error("topic `{topic}`: {len} elements exceed the capacity of {capacity}")]
    Capacity {
        /// Topic name.
        topic: &'static str,
        /// Elements offered.
        len: usize,
        /// Capacity fixed at start-up.
        capacity: usize,
    },
}

fn topic_err(topic: &'static str, e: impl Debug) -> IpcError {
    IpcError::Topic {
        topic,
        detail: format!("{e:?}"),
    }
}

/// Creates this process's iceoryx2 node with the configured root path and prefix; SIGTERM and
/// SIGINT end its waits (see [`Node::wait`] and [`WaitSet`]).
///
/// Two things happen on the way (issue 23, item 10):
/// - the shared memory of **dead nodes** of the domain (processes killed before they could clean
///   up) is removed, always — whatever the config's `node.cleanup-dead-nodes-on-creation` says —
///   and logged (INFO) when there was any: a service restarted after a SIGKILL (systemd's
///   `Restart=on-failure`) frees what its predecessor left;
/// - iceoryx2 makes the domain's **global management segment** (`/dev/shm/PREFIX…_node.…
///   .global_mgmt`) readable and writable by every user (mode 0666, with `fchmod`, so no umask
///   helps): the process that created it takes the access of other users away (0660), so
///   nothing of the stack is world-writable (see [`restrict_global_mgmt`]).
///
/// iceoryx2 installs its signal handler on the first wait, not when the node is created; a
/// SIGTERM before that would kill the process outright. So this function waits once for zero
/// time: from then on SIGTERM and SIGINT only end the loops. iceoryx2 keeps only the last signal
/// and clears it once read, so [`signals::install`] then puts a handler in front of it that
/// remembers a stop request for good ([`signals::requested`]): [`run_waitset`] and [`sleep`]
/// look at that.
pub fn node(config: &Common, name: &str) -> Result<Node<Svc>, IpcError> {
    let node = create_node(config, name)?;
    let _ = node.wait(core::time::Duration::ZERO);
    signals::restore_fatal_signals();
    signals::install();
    Ok(node)
}

/// Runs `waitset` until SIGTERM or SIGINT asks the process to stop, or `f` returns
/// [`CallbackProgression::Stop`]. iceoryx2 reports any signal that cuts a wait short as
/// `Interrupt` — a SIGCONT after a stop, a profiler's SIGPROF — which is not a request to stop:
/// the wait is resumed. A stop request is [`signals::requested`], looked at before every wait;
/// the WaitSet also waits on [`signals::wake_fd`], so the request wakes it at once even when the
/// signal went to another of the process's threads. `f` never sees that attachment.
pub fn run_waitset<F>(waitset: &WaitSet<Svc>, mut f: F) -> Result<WaitSetRunResult, WaitSetRunError>
where
    F: FnMut(WaitSetAttachmentId<Svc>) -> CallbackProgression,
{
    let wake = signals::wake_fd().and_then(crate::service::SocketFd::borrowed);
    let guard = (wake.as_ref()).and_then(|fd| waitset.attach_notification(fd).ok());
    loop {
        if signals::requested() {
            return Ok(WaitSetRunResult::TerminationRequest);
        }
        let result = waitset.wait_and_process_once(|id| match &guard {
            Some(g) if id.has_event_from(g) => CallbackProgression::Stop,
            _ => f(id),
        });
        match result {
            Ok(WaitSetRunResult::Interrupt | WaitSetRunResult::AllEventsHandled) => continue,
            // the wake-up attachment's Stop
            Ok(WaitSetRunResult::StopRequest) if signals::requested() => {
                return Ok(WaitSetRunResult::TerminationRequest);
            }
            other => return other,
        }
    }
}

/// Sleeps up to `d`; false once SIGTERM or SIGINT asked the process to stop (before or during
/// the sleep). As with [`run_waitset`], a sleep cut short by any other signal is not a stop
/// request.
pub fn sleep(node: &Node<Svc>, d: core::time::Duration) -> bool {
    sleep_unless_asked(node, d, 0)
}

/// Sleeps up to `d`; false once more than `asked` stop requests came ([`signals::count`]): for
/// the work that goes on after the first one, until a second.
pub fn sleep_unless_asked(node: &Node<Svc>, d: core::time::Duration, asked: u32) -> bool {
    if signals::count() > asked {
        return false;
    }
    // iceoryx2's own termination report says nothing the count does not
    let _ = node.wait(d);
    signals::count() <= asked
}

fn create_node(config: &Common, name: &str) -> Result<Node<Svc>, IpcError> {
    let node_err = |detail: String| IpcError::Node {
        name: name.to_string(),
        detail,
    };
    let node_name: NodeName = name
        .try_into()
        .map_err(|e| node_err(format!("bad name: {e:?}")))?;
    // the dead-node sweep is done below, where its result can be logged; the node keeps the
    // config's setting for the sweep iceoryx2 does when it is dropped
    let mut iceoryx2 = config.iceoryx2.clone();
    iceoryx2.global.node.cleanup_dead_nodes_on_creation = false;
    let node = NodeBuilder::new()
        .name(&node_name)
        .config(&iceoryx2)
        .signal_handling_mode(SignalHandlingMode::HandleTerminationRequests)
        .create::<Svc>()
        .map_err(|e| {
            node_err(format!(
                "{e:?} (root path {})",
                config.iceoryx2.global.root_path()
            ))
        })?;
    let swept = node.try_cleanup_dead_nodes();
    if swept.cleanups > 0 {
        tracing::info!(
            dead_nodes = swept.cleanups,
            "removed the shared memory and files of {} dead iceoryx2 node(s) of this domain",
            swept.cleanups
        );
    }
    if swept.failed_cleanups > 0 {
        tracing::warn!(
            dead_nodes = swept.failed_cleanups,
            "could not remove what {} dead iceoryx2 node(s) of this domain left (another \
             user's, or being removed by another process)",
            swept.failed_cleanups
        );
    }
    if let Err(e) = restrict_global_mgmt(&config.iceoryx2) {
        tracing::warn!("cannot restrict the access to iceoryx2's global management segment: {e}");
    }
    Ok(node)
}

/// Where Linux keeps POSIX shared memory (`shm_open`), iceoryx2's segments among it.
pub const SHM_DIR: &str = "/dev/shm";

/// Whether `file` (a name in [`SHM_DIR`]) is the global management segment of the domain with
/// file prefix `prefix`: `PREFIX` + 40 hex digits (iceoryx2's type hash) + `_node.` + the
/// iceoryx2 version + the suffix `suffix` (`.global_mgmt`).
pub fn is_global_mgmt(file: &str, prefix: &str, suffix: &str) -> bool {
    let Some(rest) = file.strip_prefix(prefix) else {
        return false;
    };
    let Some((hash, rest)) = rest.split_at_checked(40) else {
        return false;
    };
    hash.bytes().all(|b| b.is_ascii_hexdigit())
        && rest.starts_with("_node.")
        && rest.ends_with(suffix)
}

/// Takes the access of other users (read and write) away from the domain's global management
/// segment where this process's user owns it; returns how many segments it changed. iceoryx2
/// creates the segment with mode 0666 on purpose (any user may join a domain), but every other
/// segment of the stack is its owner's alone (0600), so no one else could use the domain anyway.
/// Group access stays. A segment another user owns is left alone.
///
/// The segment outlives every process (iceoryx2 never removes it), so one that root created —
/// `sudo mimnav goal …` before the installed stack started — would lock the stack's own user out
/// for good once narrowed. So root first hands a segment it owns to the owner of the domain's
/// root-path folder (`/run/mimnav/iceoryx2`, the `mimnav` user's), where that is not root.
pub fn restrict_global_mgmt(config: &iceoryx2::config::Config) -> std::io::Result<usize> {
    use std::os::unix::fs::{MetadataExt, PermissionsExt};
    let prefix = config.global.prefix.to_string();
    let suffix = config.global.node.global_mgmt_suffix.to_string();
    // SAFETY: geteuid(2) has no preconditions and cannot fail
    let me = unsafe { libc::geteuid() };
    // root: the domain's owner, to hand the segment to
    let owner = (me == 0)
        .then(|| std::fs::metadata(config.global.root_path().to_string()).ok())
        .flatten()
        .map(|m| (m.uid(), m.gid()))
        .filter(|&(uid, _)| uid != 0);
    let mut changed = 0;
    for entry in std::fs::read_dir(SHM_DIR)? {
        let entry = entry?;
        let name = entry.file_name();
        if !name
            .to_str()
            .is_some_and(|n| is_global_mgmt(n, &prefix, &suffix))
        {
            continue;
        }
        let path = entry.path();
        let meta = match std::fs::metadata(&path) {
            Ok(m) => m,
            // removed meanwhile
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
            Err(e) => return Err(e),
        };
        let mode = meta.mode() & 0o7777;
        if meta.uid() != me || mode & 0o007 == 0 {
            continue;
        }
        if let Some((uid, gid)) = owner {
            std::os::unix::fs::chown(&path, Some(uid), Some(gid))?;
        }
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(mode & !0o007))?;
        tracing::debug!(
            segment = %path.display(),
            "iceoryx2's global management segment: mode {mode:o} → {:o}",
            mode & !0o007
        );
        changed += 1;
    }
    Ok(changed)
}

fn service_name(topic: &'static str) -> Result<ServiceName, IpcError> {
    topic.try_into().map_err(|e| topic_err(topic, e))
}

fn event_service(
    node: &Node<Svc>,
    topic: &'static str,
) -> Result<iceoryx2::service::port_factory::event::PortFactory<Svc>, IpcError> {
    node.service_builder(&service_name(topic)?)
        .event()
        .max_notifiers(MAX_PUBLISHERS)
        .max_listeners(MAX_SUBSCRIBERS)
        .max_nodes(MAX_NODES)
        .open_or_create()
        .map_err(|e| topic_err(topic, e))
}

/// Opens (or creates) the publish-subscribe service of a slice topic with the project's QoS;
/// publishers and subscribers both come through here, so they always agree.
fn slice_service<T, H>(
    node: &Node<Svc>,
    topic: &'static str,
    max_buffer: usize,
) -> Result<iceoryx2::service::port_factory::publish_subscribe::PortFactory<Svc, [T], H>, IpcError>
where
    T: Debug + ZeroCopySend + Copy + 'static,
    H: Debug + ZeroCopySend + Copy + Default + 'static,
{
    node.service_builder(&service_name(topic)?)
        .publish_subscribe::<[T]>()
        .user_header::<H>()
        .enable_safe_overflow(true)
        .history_size(0)
        .subscriber_max_buffer_size(max_buffer)
        .subscriber_max_borrowed_samples(1)
        .max_publishers(MAX_PUBLISHERS)
        .max_subscribers(MAX_SUBSCRIBERS)
        .max_nodes(MAX_NODES)
        .open_or_create()
        .map_err(|e| topic_err(topic, e))
}

/// Publisher side of a slice topic: `[T]` payload with an `H` user header.
#[derive(Debug)]
pub struct SlicePublisher<
    T: Debug + ZeroCopySend + Copy + 'static,
    H: Debug + ZeroCopySend + Copy + Default + 'static,
> {
    topic: &'static str,
    capacity: usize,
    publisher: Publisher<Svc, [T], H>,
    notifier: Notifier<Svc>,
    /// The service, for its count of subscribers.
    service: iceoryx2::service::port_factory::publish_subscribe::PortFactory<Svc, [T], H>,
}

impl<T, H> SlicePublisher<T, H>
where
    T: Debug + ZeroCopySend + Copy + 'static,
    H: Debug + ZeroCopySend + Copy + Default + 'static,
{
    fn open(node: &Node<Svc>, topic: &'static str, capacity: usize) -> Result<Self, IpcError> {
        Self::open_buffered(node, topic, capacity, SLICE_BUFFER)
    }

    fn open_buffered(
        node: &Node<Svc>,
        topic: &'static str,
        capacity: usize,
        buffer: usize,
    ) -> Result<Self, IpcError> {
        let service = slice_service::<T, H>(node, topic, buffer)?;
        let publisher = service
            .publisher_builder()
            .initial_max_slice_len(capacity.max(1))
            .allocation_strategy(AllocationStrategy::Static)
            .max_loaned_samples(1)
            .create()
            .map_err(|e| topic_err(topic, e))?;
        let notifier = event_service(node, topic)?
            .notifier_builder()
            .default_event_id(EventId::new(EVENT_NEW_DATA))
            .create()
            .map_err(|e| topic_err(topic, e))?;
        Ok(SlicePublisher {
            topic,
            capacity,
            publisher,
            notifier,
            service,
        })
    }

    /// The static capacity (elements).
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// True when a subscriber of the topic is open now (one read of the service's shared
    /// counters): a publisher may leave out a sample that takes long to fill and that nobody
    /// would read.
    pub fn has_subscribers(&self) -> bool {
        self.service.dynamic_config().number_of_subscribers() > 0
    }

    /// Copies `items` into a loaned shared-memory sample with `header`, sends it and wakes the
    /// listeners. Returns how many subscribers received it.
    pub fn publish(&self, header: H, items: &[T]) -> Result<usize, IpcError> {
        self.send_loaned(header, items.len(), |sample| sample.write_from_slice(items))
    }

    /// Like [`publish`](Self::publish), but element `i` of the shared-memory sample is written
    /// as `item(i)`, for `i` in `0..len`, with no buffer in between: with the sources indexed
    /// directly (sliced to `len` first) the compiler vectorises the fill, where an iterator is
    /// stepped one element at a time (the 40 000 cells of `map/plan`: 2–6 µs instead of
    /// 25–50 µs).
    pub fn publish_from_fn(
        &self,
        header: H,
        len: usize,
        item: impl FnMut(usize) -> T,
    ) -> Result<usize, IpcError> {
        self.send_loaned(header, len, |sample| sample.write_from_fn(item))
    }

    /// Like [`publish`](Self::publish), the `len` elements written by `fill` straight into the
    /// shared-memory sample (set to `T::default()` first): for a source that fills a slice
    /// faster than it yields elements in order (`map/layers`, a layer at a time).
    pub fn publish_filled(
        &self,
        header: H,
        len: usize,
        fill: impl FnOnce(&mut [T]),
    ) -> Result<usize, IpcError>
    where
        T: Default,
    {
        self.send_loaned(header, len, |sample| {
            let mut sample = sample.write_from_fn(|_| T::default());
            fill(sample.payload_mut());
            sample
        })
    }

    fn send_loaned(
        &self,
        header: H,
        len: usize,
        write: impl FnOnce(
            iceoryx2::sample_mut_uninit::SampleMutUninit<Svc, [core::mem::MaybeUninit<T>], H>,
        ) -> iceoryx2::sample_mut::SampleMut<Svc, [T], H>,
    ) -> Result<usize, IpcError> {
        if len > self.capacity {
            return Err(IpcError::Capacity {
                topic: self.topic,
                len,
                capacity: self.capacity,
            });
        }
        let publish_err = |e: &dyn Debug| IpcError::Publish {
            topic: self.topic,
            detail: format!("{e:?}"),
        };
        let mut sample = self
            .publisher
            .loan_slice_uninit(len)
            .map_err(|e| publish_err(&e))?;
        *sample.user_header_mut() = header;
        let delivered = write(sample).send().map_err(|e| publish_err(&e))?;
        self.notifier.notify().map_err(|e| publish_err(&e))?;
        Ok(delivered)
    }

    /// Tells the listeners that this publisher's stream has ended (a replay reached the end of
    /// its capture).
    pub fn end_of_stream(&self) -> Result<(), IpcError> {
        self.notifier
            .notify_with_custom_event_id(EventId::new(EVENT_END_OF_STREAM))
            .map(|_| ())
            .map_err(|e| IpcError::Publish {
                topic: self.topic,
                detail: format!("{e:?}"),
            })
    }
}

/// Subscriber side of a slice topic, with the listener to block on.
#[derive(Debug)]
pub struct SliceSubscriber<
    T: Debug + ZeroCopySend + Copy + 'static,
    H: Debug + ZeroCopySend + Copy + Default + 'static,
> {
    topic: &'static str,
    subscriber: Subscriber<Svc, [T], H>,
    listener: Listener<Svc>,
}

/// What a listener heard since it was last asked.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Heard {
    /// New-data notifications.
    pub new_data: u64,
    /// An end-of-stream notification came.
    pub end_of_stream: bool,
}

/// The receiving side of a topic's event service: what subscribers block on.
pub trait Listening {
    /// The listener to attach to a WaitSet.
    fn listener(&self) -> &Listener<Svc>;

    /// Drains the listener's notifications without blocking.
    fn heard(&self) -> Heard {
        let mut h = Heard::default();
        let _ = self.listener().try_wait(|a| h.add(a));
        h
    }

    /// Waits up to `timeout` for notifications and drains them (for loops without a WaitSet).
    fn heard_within(&self, timeout: core::time::Duration) -> Heard {
        let mut h = Heard::default();
        let _ = self.listener().timed_wait(|a| h.add(a), timeout);
        h
    }
}

fn listener(node: &Node<Svc>, topic: &'static str) -> Result<Listener<Svc>, IpcError> {
    event_service(node, topic)?
        .listener_builder()
        .create()
        .map_err(|e| topic_err(topic, e))
}

impl<T, H> Listening for SliceSubscriber<T, H>
where
    T: Debug + ZeroCopySend + Copy + 'static,
    H: Debug + ZeroCopySend + Copy + Default + 'static,
{
    fn listener(&self) -> &Listener<Svc> {
        &self.listener
    }
}

impl<T: Debug + ZeroCopySend + Copy + 'static> Listening for ValueSubscriber<T> {
    fn listener(&self) -> &Listener<Svc> {
        &self.listener
    }
}

impl Heard {
    fn add(&mut self, a: EventActivation) {
        if a.id.as_value() == EVENT_END_OF_STREAM {
            self.end_of_stream = true;
        } else {
            self.new_data += a.count;
        }
    }
}

impl<T, H> SliceSubscriber<T, H>
where
    T: Debug + ZeroCopySend + Copy + 'static,
    H: Debug + ZeroCopySend + Copy + Default + 'static,
{
    fn open(node: &Node<Svc>, topic: &'static str, buffer: usize) -> Result<Self, IpcError> {
        let service = slice_service::<T, H>(node, topic, buffer)?;
        let subscriber = service
            .subscriber_builder()
            .buffer_size(buffer)
            .create()
            .map_err(|e| topic_err(topic, e))?;
        let listener = listener(node, topic)?;
        Ok(SliceSubscriber {
            topic,
            subscriber,
            listener,
        })
    }

    /// The next received sample, if any.
    pub fn receive(&self) -> Result<Option<Sample<Svc, [T], H>>, IpcError> {
        self.subscriber.receive().map_err(|e| IpcError::Topic {
            topic: self.topic,
            detail: format!("cannot receive: {e:?}"),
        })
    }
}

/// Publisher of `lidar/points`.
pub type PointsPublisher = SlicePublisher<topics::Point, topics::PointsHeader>;
/// Subscriber of `lidar/points`.
pub type PointsSubscriber = SliceSubscriber<topics::Point, topics::PointsHeader>;
/// Publisher of `lidar/scan2d`.
pub type ScanPublisher = SlicePublisher<topics::ScanReturn, topics::ScanHeader>;
/// Subscriber of `lidar/scan2d`.
pub type ScanSubscriber = SliceSubscriber<topics::ScanReturn, topics::ScanHeader>;

/// Opens `lidar/points` for publishing revolutions of up to `max_points` points.
pub fn points_publisher(node: &Node<Svc>, max_points: usize) -> Result<PointsPublisher, IpcError> {
    SlicePublisher::open(node, topics::LIDAR_POINTS, max_points)
}

/// Publisher of `lidar/slices`.
pub type SlicesPublisher = SlicePublisher<topics::Point, topics::SliceHeader>;
/// Subscriber of `lidar/slices`.
pub type SlicesSubscriber = SliceSubscriber<topics::Point, topics::SliceHeader>;

/// Opens `lidar/slices` for publishing slices of up to `max_points` points.
pub fn slices_publisher(node: &Node<Svc>, max_points: usize) -> Result<SlicesPublisher, IpcError> {
    SlicePublisher::open_buffered(node, topics::LIDAR_SLICES, max_points, SLICES_BUFFER)
}

/// Opens `lidar/slices` for receiving.
pub fn slices_subscriber(node: &Node<Svc>) -> Result<SlicesSubscriber, IpcError> {
    SliceSubscriber::open(node, topics::LIDAR_SLICES, SLICES_BUFFER)
}

/// Opens `lidar/points` for receiving.
pub fn points_subscriber(node: &Node<Svc>) -> Result<PointsSubscriber, IpcError> {
    SliceSubscriber::open(node, topics::LIDAR_POINTS, SLICE_BUFFER)
}

/// Opens `lidar/points` for receiving with a buffer of `buffer` revolutions. Only the creator of
/// the topic can give it room for more than [`SLICE_BUFFER`] (a later opener that asks for more
/// fails): `mimnav replay` subscribes with [`REPLAY_BUFFER`] before it starts the driver in its
/// private domain.
pub fn points_subscriber_with_buffer(
    node: &Node<Svc>,
    buffer: usize,
) -> Result<PointsSubscriber, IpcError> {
    SliceSubscriber::open(node, topics::LIDAR_POINTS, buffer.max(SLICE_BUFFER))
}

/// Opens `lidar/scan2d` for publishing scans of up to `max_returns` returns.
pub fn scan_publisher(node: &Node<Svc>, max_returns: usize) -> Result<ScanPublisher, IpcError> {
    SlicePublisher::open(node, topics::LIDAR_SCAN2D, max_returns)
}

/// Opens `lidar/scan2d` for receiving.
pub fn scan_subscriber(node: &Node<Svc>) -> Result<ScanSubscriber, IpcError> {
    SliceSubscriber::open(node, topics::LIDAR_SCAN2D, SLICE_BUFFER)
}

/// Opens (or creates) the publish-subscribe service of a fixed-size topic with the project's
/// QoS; both sides come through here.
fn value_service<T: Debug + ZeroCopySend + Copy + 'static>(
    node: &Node<Svc>,
    topic: &'static str,
) -> Result<iceoryx2::service::port_factory::publish_subscribe::PortFactory<Svc, T, ()>, IpcError> {
    node.service_builder(&service_name(topic)?)
        .publish_subscribe::<T>()
        .enable_safe_overflow(true)
        .history_size(0)
        .subscriber_max_buffer_size(SMALL_BUFFER)
        .subscriber_max_borrowed_samples(2)
        .max_publishers(MAX_PUBLISHERS)
        .max_subscribers(MAX_SUBSCRIBERS)
        .max_nodes(MAX_NODES)
        .open_or_create()
        .map_err(|e| topic_err(topic, e))
}

/// Publisher of a fixed-size payload topic.
#[derive(Debug)]
pub struct ValuePublisher<T: Debug + ZeroCopySend + Copy + 'static> {
    topic: &'static str,
    publisher: Publisher<Svc, T, ()>,
    notifier: Notifier<Svc>,
}

impl<T: Debug + ZeroCopySend + Copy + 'static> ValuePublisher<T> {
    fn open(node: &Node<Svc>, topic: &'static str) -> Result<Self, IpcError> {
        let service = value_service::<T>(node, topic)?;
        let publisher = service
            .publisher_builder()
            .create()
            .map_err(|e| topic_err(topic, e))?;
        let notifier = event_service(node, topic)?
            .notifier_builder()
            .default_event_id(EventId::new(EVENT_NEW_DATA))
            .create()
            .map_err(|e| topic_err(topic, e))?;
        Ok(ValuePublisher {
            topic,
            publisher,
            notifier,
        })
    }

    /// Sends a copy of `value` and wakes the listeners.
    pub fn publish(&self, value: T) -> Result<usize, IpcError> {
        let publish_err = |e: &dyn Debug| IpcError::Publish {
            topic: self.topic,
            detail: format!("{e:?}"),
        };
        let n = self
            .publisher
            .send_copy(value)
            .map_err(|e| publish_err(&e))?;
        self.notifier.notify().map_err(|e| publish_err(&e))?;
        Ok(n)
    }
}

/// Subscriber of a fixed-size payload topic, with the listener to block on.
#[derive(Debug)]
pub struct ValueSubscriber<T: Debug + ZeroCopySend + Copy + 'static> {
    topic: &'static str,
    subscriber: Subscriber<Svc, T, ()>,
    listener: Listener<Svc>,
}

impl<T: Debug + ZeroCopySend + Copy + 'static> ValueSubscriber<T> {
    fn open(node: &Node<Svc>, topic: &'static str) -> Result<Self, IpcError> {
        let service = value_service::<T>(node, topic)?;
        let subscriber = service
            .subscriber_builder()
            .buffer_size(SMALL_BUFFER)
            .create()
            .map_err(|e| topic_err(topic, e))?;
        let listener = listener(node, topic)?;
        Ok(ValueSubscriber {
            topic,
            subscriber,
            listener,
        })
    }

    /// The next received value, if any.
    pub fn receive(&self) -> Result<Option<T>, IpcError> {
        self.subscriber
            .receive()
            .map(|s| s.map(|s| *s.payload()))
            .map_err(|e| IpcError::Topic {
                topic: self.topic,
                detail: format!("cannot receive: {e:?}"),
            })
    }

    /// The newest value waiting, dropping older ones, if any.
    pub fn latest(&self) -> Result<Option<T>, IpcError> {
        let mut last = None;
        while let Some(v) = self.receive()? {
            last = Some(v);
        }
        Ok(last)
    }
}

/// Opens `cmd_vel` for publishing.
pub fn cmd_vel_publisher(
    node: &Node<Svc>,
) -> Result<ValuePublisher<topics::VelocityCommand>, IpcError> {
    ValuePublisher::open(node, topics::CMD_VEL)
}

/// Opens `cmd_vel` for receiving.
pub fn cmd_vel_subscriber(
    node: &Node<Svc>,
) -> Result<ValueSubscriber<topics::VelocityCommand>, IpcError> {
    ValueSubscriber::open(node, topics::CMD_VEL)
}

/// Opens `odom` for publishing.
pub fn odom_publisher(node: &Node<Svc>) -> Result<ValuePublisher<topics::Odometry>, IpcError> {
    ValuePublisher::open(node, topics::ODOM)
}

/// Opens `odom` for receiving.
pub fn odom_subscriber(node: &Node<Svc>) -> Result<ValueSubscriber<topics::Odometry>, IpcError> {
    ValueSubscriber::open(node, topics::ODOM)
}

/// Opens `base/state` for publishing.
pub fn base_state_publisher(
    node: &Node<Svc>,
) -> Result<ValuePublisher<topics::BaseState>, IpcError> {
    ValuePublisher::open(node, topics::BASE_STATE)
}

/// Opens `base/state` for receiving.
pub fn base_state_subscriber(
    node: &Node<Svc>,
) -> Result<ValueSubscriber<topics::BaseState>, IpcError> {
    ValueSubscriber::open(node, topics::BASE_STATE)
}

/// Opens `goal` for publishing.
pub fn goal_publisher(node: &Node<Svc>) -> Result<ValuePublisher<topics::Goal>, IpcError> {
    ValuePublisher::open(node, topics::GOAL)
}

/// Opens `goal` for receiving.
pub fn goal_subscriber(node: &Node<Svc>) -> Result<ValueSubscriber<topics::Goal>, IpcError> {
    ValueSubscriber::open(node, topics::GOAL)
}

/// Publisher of `sim/truth`.
pub type TruthPublisher = SlicePublisher<u8, topics::TruthHeader>;
/// Subscriber of `sim/truth`.
pub type TruthSubscriber = SliceSubscriber<u8, topics::TruthHeader>;

/// Opens `sim/truth` for publishing grids of up to `cells` cells.
pub fn truth_publisher(node: &Node<Svc>, cells: usize) -> Result<TruthPublisher, IpcError> {
    SlicePublisher::open(node, topics::SIM_TRUTH, cells)
}

/// Opens `sim/truth` for receiving.
pub fn truth_subscriber(node: &Node<Svc>) -> Result<TruthSubscriber, IpcError> {
    SliceSubscriber::open(node, topics::SIM_TRUTH, SLICE_BUFFER)
}

/// Publisher of `map/layers`.
pub type LayersPublisher = SlicePublisher<f32, topics::MapHeader>;
/// Subscriber of `map/layers`.
pub type LayersSubscriber = SliceSubscriber<f32, topics::MapHeader>;
/// Publisher of `map/plan`.
pub type PlanPublisher = SlicePublisher<topics::PlanCell, topics::MapHeader>;
/// Subscriber of `map/plan`.
pub type PlanSubscriber = SliceSubscriber<topics::PlanCell, topics::MapHeader>;

/// Opens `map/layers` for publishing up to `values` values (layers × cells).
pub fn layers_publisher(node: &Node<Svc>, values: usize) -> Result<LayersPublisher, IpcError> {
    SlicePublisher::open(node, topics::MAP_LAYERS, values)
}

/// Opens `map/layers` for receiving.
pub fn layers_subscriber(node: &Node<Svc>) -> Result<LayersSubscriber, IpcError> {
    SliceSubscriber::open(node, topics::MAP_LAYERS, SLICE_BUFFER)
}

/// Opens `map/plan` for publishing grids of up to `cells` cells.
pub fn plan_publisher(node: &Node<Svc>, cells: usize) -> Result<PlanPublisher, IpcError> {
    SlicePublisher::open(node, topics::MAP_PLAN, cells)
}

/// Opens `map/plan` for receiving.
pub fn plan_subscriber(node: &Node<Svc>) -> Result<PlanSubscriber, IpcError> {
    SliceSubscriber::open(node, topics::MAP_PLAN, SLICE_BUFFER)
}

/// Publisher of `foliage/alarm`.
pub type FoliagePublisher = SlicePublisher<topics::FoliageReturn, topics::FoliageHeader>;
/// Subscriber of `foliage/alarm`.
pub type FoliageSubscriber = SliceSubscriber<topics::FoliageReturn, topics::FoliageHeader>;

/// Opens `foliage/alarm` for publishing verdicts of scans of up to `max_returns` returns.
pub fn foliage_publisher(
    node: &Node<Svc>,
    max_returns: usize,
) -> Result<FoliagePublisher, IpcError> {
    SlicePublisher::open(node, topics::FOLIAGE_ALARM, max_returns)
}

/// Opens `foliage/alarm` for receiving.
pub fn foliage_subscriber(node: &Node<Svc>) -> Result<FoliageSubscriber, IpcError> {
    SliceSubscriber::open(node, topics::FOLIAGE_ALARM, SLICE_BUFFER)
}

/// Opens `lidar/packets` for publishing raw datagrams.
pub fn packets_publisher(node: &Node<Svc>) -> Result<ValuePublisher<topics::RawPacket>, IpcError> {
    ValuePublisher::open(node, topics::LIDAR_PACKETS)
}

/// `CLOCK_MONOTONIC` now, ns: the clock every message's `rx_mono_ns` uses, comparable across the
/// processes of one machine.
pub fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec through the valid pointer it is given.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// Wall-clock time now, ns since the Unix epoch.
pub fn realtime_ns() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64)
}

static COUNTER: AtomicU32 = AtomicU32::new(0);

/// A private iceoryx2 domain (root path and prefix) for one test or one tool run: a root path
/// under the temp folder and a prefix, both unique to this process and call, so parallel tests,
/// a running stack and leftovers of crashed runs never meet. iceoryx2 removes a service's files itself when the last node
/// using it goes; when this value is dropped it also removes the location's global management
/// segment (through iceoryx2's own API) and the root folder. Keep it alive longer than every
/// node and process that uses it.
#[derive(Debug)]
pub struct PrivateDomain {
    /// The root path (ends with `/`).
    pub root: PathBuf,
    /// The prefix.
    pub prefix: String,
}

impl PrivateDomain {
    /// A new location tagged `tag` (letters and digits).
    pub fn new(tag: &str) -> Self {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let pid = std::process::id();
        let root = std::env::temp_dir().join(format!("mimnav-{tag}-{pid}-{n}"));
        PrivateDomain {
            root,
            prefix: format!("mt{pid}x{n}_"),
        }
    }

    /// The root path as iceoryx2 wants it (with a trailing slash).
    pub fn root_str(&self) -> String {
        format!("{}/", self.root.display())
    }

    /// `config` (the shared sections, or a whole config holding them) relocated to this
    /// location.
    pub fn apply<C: AsMut<Common>>(&self, mut config: C) -> C {
        // the location is made of valid characters by construction
        config
            .as_mut()
            .set_iceoryx2_location(&self.root_str(), &self.prefix)
            .unwrap_or_else(|e| panic!("isolated iceoryx2 location: {e}"));
        config
    }

    /// The default shared sections relocated to this location.
    pub fn config(&self) -> Common {
        self.apply(Common::default())
    }

    /// `--set` arguments that put a service started as a process at this location.
    pub fn set_args(&self) -> Vec<String> {
        vec![
            "--set".into(),
            format!("iceoryx2.global.root-path=\"{}\"", self.root_str()),
            "--set".into(),
            format!("iceoryx2.global.prefix=\"{}\"", self.prefix),
        ]
    }
}

impl Drop for PrivateDomain {
    fn drop(&mut self) {
        let config = self.config();
        // processes of the domain that died without cleaning up (killed) leave their shared
        // memory behind: iceoryx2 removes it for dead nodes it still knows of
        let _ = Node::<Svc>::list(&config.iceoryx2, |state| {
            if let NodeState::<Svc>::Dead(view) = state {
                let _ = view.try_remove_stale_resources();
            }
            CallbackProgression::Continue
        });
        // SAFETY: the domain is private to its owner, whose nodes and processes are gone by now
        // (the owner keeps this value alive longest).
        let _ = unsafe {
            iceoryx2::testing::remove_global_mgmt_segment::<iceoryx2::prelude::ipc::Service>(
                &config.iceoryx2,
            )
        };
        let _ = std::fs::remove_dir_all(&self.root);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::topics::{MapHeader, Point, PointsHeader};

    #[test]
    fn points_round_trip_with_end_of_stream() {
        let loc = PrivateDomain::new("ipc");
        let config = loc.config();
        let node = node(&config, "ipc-test").expect("node");
        let sub = points_subscriber(&node).expect("subscriber");
        let publ = points_publisher(&node, 100).expect("publisher");
        let pts: Vec<Point> = (0..10)
            .map(|i| Point {
                x: i as f32,
                ..Point::default()
            })
            .collect();
        let header = PointsHeader {
            seq: 7,
            point_count: 10,
            ..PointsHeader::default()
        };
        assert_eq!(publ.publish(header, &pts).expect("publish"), 1);
        assert!(matches!(
            publ.publish(header, &vec![Point::default(); 101]),
            Err(IpcError::Capacity {
                len: 101,
                capacity: 100,
                ..
            })
        ));
        publ.end_of_stream().expect("eos");
        let heard = sub.heard();
        assert_eq!(
            heard,
            Heard {
                new_data: 1,
                end_of_stream: true
            }
        );
        let sample = sub.receive().expect("receive").expect("a sample");
        assert_eq!(sample.user_header().seq, 7);
        assert_eq!(sample.payload().len(), 10);
        assert_eq!(sample.payload()[9].x, 9.0);
        drop(sample);
        assert!(sub.receive().expect("receive").is_none());
    }

    #[test]
    fn a_publisher_knows_whether_anyone_subscribes() {
        let loc = PrivateDomain::new("ipcsubs");
        let node = node(&loc.config(), "ipc-subs").expect("node");
        let publ = layers_publisher(&node, 8).expect("publisher");
        assert!(!publ.has_subscribers());
        let sub = layers_subscriber(&node).expect("subscriber");
        assert!(publ.has_subscribers());
        drop(sub);
        assert!(!publ.has_subscribers());
    }

    #[test]
    fn a_sample_written_in_place_arrives_in_order_and_padded() {
        let loc = PrivateDomain::new("ipcfn");
        let node = node(&loc.config(), "ipc-fn").expect("node");
        let sub = layers_subscriber(&node).expect("subscriber");
        let publ = layers_publisher(&node, 8).expect("publisher");
        let header = MapHeader {
            seq: 3,
            ..MapHeader::default()
        };
        // filled as a slice, partly: the rest is the default
        let n = publ
            .publish_filled(header, 6, |out| {
                out[..4].copy_from_slice(&[0.0, 1.5, 3.0, 4.5])
            })
            .expect("publish");
        assert_eq!(n, 1);
        assert!(matches!(
            publ.publish_filled(header, 9, |out| out.fill(1.0)),
            Err(IpcError::Capacity {
                len: 9,
                capacity: 8,
                ..
            })
        ));
        let sample = sub.receive().expect("receive").expect("a sample");
        assert_eq!(sample.user_header().seq, 3);
        assert_eq!(sample.payload(), &[0.0, 1.5, 3.0, 4.5, 0.0, 0.0]);
        drop(sample);
        // element by element from its index
        publ.publish_from_fn(header, 5, |i| i as f32 * 2.0)
            .expect("publish");
        let sample = sub.receive().expect("receive").expect("a sample");
        assert_eq!(sample.payload(), &[0.0, 2.0, 4.0, 6.0, 8.0]);
    }

    /// Every file of the domain — its segments in /dev/shm and the files under its root path —
    /// with its mode, after a node and a topic were opened.
    fn domain_files(loc: &PrivateDomain) -> Vec<(PathBuf, u32)> {
        use std::os::unix::fs::MetadataExt;
        let mut files = Vec::new();
        for e in std::fs::read_dir(SHM_DIR).expect("/dev/shm").flatten() {
            if e.file_name().to_string_lossy().starts_with(&loc.prefix) {
                let mode = e.metadata().expect("stat").mode() & 0o7777;
                files.push((e.path(), mode));
            }
        }
        let mut dirs = vec![loc.root.clone()];
        while let Some(d) = dirs.pop() {
            let mode = std::fs::metadata(&d).expect("stat").mode() & 0o7777;
            files.push((d.clone(), mode));
            for e in std::fs::read_dir(&d).expect("read_dir").flatten() {
                let meta = e.metadata().expect("stat");
                if meta.is_dir() {
                    dirs.push(e.path());
                } else {
                    files.push((e.path(), meta.mode() & 0o7777));
                }
            }
        }
        files
    }

    /// Issue 23, item 10: iceoryx2 creates the global management segment with mode 0666.
    #[test]
    fn shared_memory_world_writable_global_mgmt() {
        let loc = PrivateDomain::new("ipcmode");
        let node = node(&loc.config(), "mode-test").expect("node");
        let _sub = cmd_vel_subscriber(&node).expect("subscriber");
        let _publ = points_publisher(&node, 16).expect("publisher");
        let files = domain_files(&loc);
        let suffix = loc
            .config()
            .iceoryx2
            .global
            .node
            .global_mgmt_suffix
            .to_string();
        assert!(
            files.iter().any(|(p, _)| p
                .file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| is_global_mgmt(n, &loc.prefix, &suffix))),
            "the global management segment is among {files:?}"
        );
        assert!(files.len() > 5, "{files:?}");
        let open: Vec<String> = (files.iter())
            .filter(|(_, m)| m & 0o002 != 0)
            .map(|(p, m)| format!("{} {m:o}", p.display()))
            .collect();
        assert!(open.is_empty(), "world-writable: {open:?}");
    }

    /// Root's segment in a domain another user owns goes to that user: the stack's user is not
    /// locked out by a segment root created first (as root only; others print SKIP).
    #[test]
    fn shared_memory_world_writable_global_mgmt_of_root_goes_to_the_domain_owner() {
        use std::os::unix::fs::MetadataExt;
        // SAFETY: geteuid(2) has no preconditions and cannot fail
        if unsafe { libc::geteuid() } != 0 {
            println!("SKIP: needs root");
            return;
        }
        let loc = PrivateDomain::new("ipcown");
        std::fs::create_dir_all(&loc.root).expect("root path");
        // nobody:nogroup owns the domain's folder
        std::os::unix::fs::chown(&loc.root, Some(65534), Some(65534)).expect("chown");
        let config = loc.config();
        let _node = node(&config, "own-test").expect("node");
        let suffix = config.iceoryx2.global.node.global_mgmt_suffix.to_string();
        let mgmt: Vec<_> = std::fs::read_dir(SHM_DIR)
            .expect("/dev/shm")
            .flatten()
            .filter(|e| {
                e.file_name()
                    .to_str()
                    .is_some_and(|n| is_global_mgmt(n, &loc.prefix, &suffix))
            })
            .map(|e| e.metadata().expect("stat"))
            .collect();
        assert_eq!(mgmt.len(), 1);
        assert_eq!((mgmt[0].uid(), mgmt[0].gid()), (65534, 65534));
        assert_eq!(mgmt[0].mode() & 0o777, 0o660);
    }

    #[test]
    fn the_global_mgmt_segment_is_told_from_others() {
        let h = "9204dd183d1c4d8e1ff592a30766ffa6765aa8b5";
        assert!(is_global_mgmt(
            &format!("mimnav_{h}_node.0_10_0.global_mgmt"),
            "mimnav_",
            ".global_mgmt"
        ));
        // another domain whose prefix starts with ours
        assert!(!is_global_mgmt(
            &format!("mimnav_x_{h}_node.0_10_0.global_mgmt"),
            "mimnav_",
            ".global_mgmt"
        ));
        assert!(!is_global_mgmt(
            &format!("mimnav_{h}_1234.data"),
            "mimnav_",
            ".global_mgmt"
        ));
        assert!(!is_global_mgmt("mimnav_node", "mimnav_", ".global_mgmt"));
    }

    #[test]
    fn two_locations_do_not_meet() {
        let a = PrivateDomain::new("ipca");
        let b = PrivateDomain::new("ipcb");
        let na = node(&a.config(), "a").expect("node a");
        let nb = node(&b.config(), "b").expect("node b");
        let sub = points_subscriber(&nb).expect("subscriber");
        let publ = points_publisher(&na, 4).expect("publisher");
        assert_eq!(
            publ.publish(PointsHeader::default(), &[Point::default()])
                .expect("publish"),
            0
        );
        assert!(sub.receive().expect("receive").is_none());
    }

    /// Issue 23's stop path: a SIGTERM is not lost when another signal iceoryx2 catches lands
    /// after it (iceoryx2 keeps only the last one), nor when it goes to another thread than the
    /// one waiting (the live view's WebSocket threads): the wait ends at once.
    #[test]
    fn a_stop_request_survives_a_later_signal_and_wakes_a_wait_on_another_thread() {
        let loc = PrivateDomain::new("ipcsig");
        let node = node(&loc.config(), "sig").expect("node");
        let waitset = WaitSetBuilder::new()
            .signal_handling_mode(SignalHandlingMode::HandleTerminationRequests)
            .create::<Svc>()
            .expect("waitset");
        let _tick = waitset
            .attach_interval(core::time::Duration::from_secs(3))
            .expect("interval");
        let began = std::time::Instant::now();
        let other = std::thread::spawn(|| {
            std::thread::sleep(core::time::Duration::from_millis(100));
            // SAFETY: raise(3) sends to this thread only; iceoryx2 catches SIGUSR1 and only
            // records it, over the SIGTERM it recorded just before
            unsafe {
                libc::raise(libc::SIGTERM);
                libc::raise(libc::SIGUSR1);
            }
        });
        let mut turns = 0;
        // a lost request would leave the loop waiting for the interval: one turn ends it
        let result = run_waitset(&waitset, |_| {
            turns += 1;
            CallbackProgression::Stop
        });
        let took = began.elapsed();
        other.join().expect("signalling thread");
        assert!(
            matches!(result, Ok(WaitSetRunResult::TerminationRequest)),
            "{result:?}"
        );
        assert_eq!(turns, 0, "the wake-up is not a turn of the loop");
        assert!(took < core::time::Duration::from_secs(3), "{took:?}");
        // and every later wait of the process ends too
        assert!(!sleep(&node, core::time::Duration::from_secs(3)));
        // the work after the first request (halting the robot) sleeps until a second one
        let asked = signals::count();
        assert_eq!(asked, 1);
        let t = std::time::Instant::now();
        assert!(sleep_unless_asked(
            &node,
            core::time::Duration::from_millis(30),
            asked
        ));
        assert!(t.elapsed() >= core::time::Duration::from_millis(25));
        // SAFETY: as above, on this thread
        unsafe { libc::raise(libc::SIGINT) };
        assert!(!sleep_unless_asked(
            &node,
            core::time::Duration::from_secs(3),
            asked
        ));
    }
}
