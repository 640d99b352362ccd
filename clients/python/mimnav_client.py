"""mimnav_client: mimnav's iceoryx2 topics from Python.

A thin layer over PyPI's ``iceoryx2==0.10.0`` binding: ctypes mirrors of every payload and user
header of ``shared/src/topics.rs``, the topic table, and the quality of service of
``shared/src/ipc.rs``, so a Python process joins a running stack as one more subscriber (or
publisher) without either side refusing the other. ``docs/topics.md`` is the contract this file
follows; its layout test in ``shared/src/topics.rs`` keeps the numbers honest on the Rust side and
:func:`check_layouts` on this side.

Example: print the point count of every revolution the driver publishes::

    import mimnav_client as mc

    node = mc.node("my-tool")              # the stack's default root path and prefix
    points = mc.Subscriber(node, mc.LIDAR_POINTS)
    while True:
        heard = points.wait(1.0)           # blocks on the topic's event service
        for msg in points.receive_all():
            print(msg.header.seq, msg.header.point_count, len(msg.items))
        if heard.end_of_stream:
            break

Received samples are copied out of shared memory (``Subscriber.receive``) because a subscriber
of a slice topic may hold only one sample at a time; ``Subscriber.borrow`` gives the zero-copy
view for the duration of a ``with`` block instead.
"""

from __future__ import annotations

import contextlib
import ctypes
from dataclasses import dataclass
from typing import Iterator, Optional

try:
    import iceoryx2 as iox2
except ImportError:  # pragma: no cover - a host that only reads Zenoh (decode_remote) needs ctypes
    iox2 = None

__all__ = [
    "DEFAULT_ROOT_PATH",
    "DEFAULT_PREFIX",
    "EVENT_NEW_DATA",
    "EVENT_END_OF_STREAM",
    "Point",
    "PointsHeader",
    "SliceHeader",
    "ScanReturn",
    "ScanHeader",
    "RawPacket",
    "VelocityCommand",
    "Odometry",
    "TruthHeader",
    "MapHeader",
    "PlanCell",
    "Goal",
    "BaseState",
    "FoliageHeader",
    "FoliageReturn",
    "Topic",
    "TOPICS",
    "LIDAR_POINTS",
    "LIDAR_SLICES",
    "LIDAR_SCAN2D",
    "LIDAR_PACKETS",
    "CMD_VEL",
    "ODOM",
    "GOAL",
    "BASE_STATE",
    "SIM_TRUTH",
    "MAP_LAYERS",
    "MAP_PLAN",
    "FOLIAGE_ALARM",
    "config",
    "node",
    "Heard",
    "Message",
    "Subscriber",
    "Publisher",
    "check_layouts",
    "ZENOH_ENCODING",
    "decode_remote",
    "goal_json",
    "GOAL_STOP",
]

# --- joining the domain (shared/src/config/iceoryx2.rs) ------------------------------------------

#: iceoryx2 root path of a stack run with the shipped config (``[iceoryx2.global] root-path``).
DEFAULT_ROOT_PATH = "/tmp/mimnav/iceoryx2/"
#: iceoryx2 file prefix of a stack run with the shipped config (``[iceoryx2.global] prefix``).
DEFAULT_PREFIX = "mimnav_"

# --- quality of service (shared/src/ipc.rs) ------------------------------------------------------

MAX_PUBLISHERS = 2
MAX_SUBSCRIBERS = 6
MAX_NODES = 12
SLICE_BUFFER = 2
#: ``lidar/slices`` (QoS ``slices``): more than a revolution's slices.
SLICES_BUFFER = 64
SMALL_BUFFER = 64
SLICE_BORROWED = 1
SMALL_BORROWED = 2

#: Event id a publisher notifies with after it sent a sample.
EVENT_NEW_DATA = 0
#: Event id a replaying source notifies with once its capture has ended and every sample was sent.
EVENT_END_OF_STREAM = 1

# --- payloads and headers (shared/src/topics.rs) -------------------------------------------------


class _Named(ctypes.Structure):
    """A payload with the versioned iceoryx2 type name of its Rust twin (``#[type_name]``)."""

    TYPE_NAME = ""
    #: (size, alignment) the Rust type has; checked by check_layouts().
    LAYOUT = (0, 0)

    @classmethod
    def type_name(cls) -> str:
        # the iceoryx2 binding's get_type_name() asks for this
        return cls.TYPE_NAME

    def as_dict(self) -> dict:
        out = {}
        for name, _ in self._fields_:
            v = getattr(self, name)
            out[name] = list(v) if isinstance(v, ctypes.Array) else v
        return out

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.as_dict()})"


u8, u16, u32, u64 = ctypes.c_uint8, ctypes.c_uint16, ctypes.c_uint32, ctypes.c_uint64
f32, f64 = ctypes.c_float, ctypes.c_double


class Point(_Named):
    """One lidar return in the sensor frame (REP-103, metres)."""

    TYPE_NAME = "mimnav/Point/v1"
    LAYOUT = (24, 4)
    _fields_ = [
        ("x", f32),
        ("y", f32),
        ("z", f32),
        ("time_offset_ns", u32),
        ("distance_raw", u16),
        ("azimuth_cdeg", u16),
        ("intensity", u8),
        ("laser_id", u8),
        ("ring", u8),
        ("return_type", u8),
    ]


class PointsHeader(_Named):
    """User header of a ``lidar/points`` sample: one revolution."""

    TYPE_NAME = "mimnav/PointsHeader/v1"
    LAYOUT = (56, 8)
    _fields_ = [
        ("seq", u64),
        ("stamp_ns", u64),
        ("rx_mono_ns", u64),
        ("first_packet_seq", u64),
        ("packet_count", u32),
        ("point_count", u32),
        ("strongest_count", u32),
        ("last_count", u32),
        ("both_count", u32),
        ("return_mode", u8),
        ("product", u8),
        ("cut_reason", u8),
        ("reserved", u8),
    ]


class SliceHeader(_Named):
    """User header of a ``lidar/slices`` sample: the next whole packets of a revolution."""

    TYPE_NAME = "mimnav/SliceHeader/v1"
    LAYOUT = (72, 8)
    _fields_ = [
        ("revolution", PointsHeader),
        ("index", u32),
        ("first_point", u32),
        ("last", u8),
        ("reserved", u8 * 7),
    ]


class ScanReturn(_Named):
    """One firing of the chosen laser in a planar scan."""

    TYPE_NAME = "mimnav/ScanReturn/v1"
    LAYOUT = (12, 4)
    _fields_ = [
        ("angle_rad", f32),
        ("range_m", f32),
        ("intensity", u8),
        ("return_type", u8),
        ("reserved", u8 * 2),
    ]


class ScanHeader(_Named):
    """User header of a ``lidar/scan2d`` sample."""

    TYPE_NAME = "mimnav/ScanHeader/v1"
    LAYOUT = (40, 8)
    _fields_ = [
        ("seq", u64),
        ("stamp_ns", u64),
        ("rx_mono_ns", u64),
        ("count", u32),
        ("elevation_rad", f32),
        ("laser_id", u8),
        ("return_select", u8),
        ("reserved", u8 * 6),
    ]


DATA_PACKET_LEN = 1206


class RawPacket(_Named):
    """One raw sensor datagram (``lidar/packets``, off unless ``velodyne.publish_packets``)."""

    TYPE_NAME = "mimnav/RawPacket/v1"
    LAYOUT = (1240, 8)
    _fields_ = [
        ("seq", u64),
        ("host_ns", u64),
        ("rx_mono_ns", u64),
        ("len", u32),
        ("port", u16),
        ("reserved", u8 * 2),
        ("data", u8 * DATA_PACKET_LEN),
    ]


class VelocityCommand(_Named):
    """A velocity command for the base (``cmd_vel``)."""

    TYPE_NAME = "mimnav/VelocityCommand/v2"
    LAYOUT = (56, 8)
    _fields_ = [
        ("seq", u64),
        ("stamp_mono_ns", u64),
        ("source_stamp_ns", u64),
        ("source_seq", u64),
        ("valid_until_mono_ns", u64),
        ("v", f32),
        ("omega", f32),
        ("status", u8),
        ("flags", u8),
        ("reserved", u8 * 6),
    ]


class Odometry(_Named):
    """The robot's 2-D pose and velocity in the odometry frame (``odom``)."""

    TYPE_NAME = "mimnav/Odometry/v1"
    LAYOUT = (56, 8)
    _fields_ = [
        ("seq", u64),
        ("stamp_ns", u64),
        ("rx_mono_ns", u64),
        ("x", f64),
        ("y", f64),
        ("yaw", f64),
        ("v", f32),
        ("omega", f32),
    ]


class TruthHeader(_Named):
    """User header of a ``sim/truth`` sample (payload: one class byte per cell)."""

    TYPE_NAME = "mimnav/TruthHeader/v1"
    LAYOUT = (48, 8)
    _fields_ = [
        ("seq", u64),
        ("stamp_ns", u64),
        ("x", f64),
        ("y", f64),
        ("yaw", f64),
        ("cells", u32),
        ("cell_m", f32),
    ]


class MapHeader(_Named):
    """User header of ``map/layers`` and ``map/plan``."""

    TYPE_NAME = "mimnav/MapHeader/v1"
    LAYOUT = (96, 8)
    _fields_ = [
        ("seq", u64),
        ("source_seq", u64),
        ("stamp_ns", u64),
        ("rx_mono_ns", u64),
        ("odom_seq", u64),
        ("odom_stamp_ns", u64),
        ("x", f64),
        ("y", f64),
        ("yaw", f64),
        ("cells", u32),
        ("cell_m", f32),
        ("layers", u32),
        ("processing_us", u32),
        ("status", u8),
        ("reserved", u8 * 7),
    ]


class PlanCell(_Named):
    """One cell of the planning map (``map/plan``)."""

    TYPE_NAME = "mimnav/PlanCell/v2"
    LAYOUT = (2, 1)
    _fields_ = [("class_", u8), ("cost", u8)]


class Goal(_Named):
    """A goal in the odometry frame (``goal``), or with ``flags`` = ``GOAL_STOP`` a stop request."""

    TYPE_NAME = "mimnav/Goal/v2"
    LAYOUT = (48, 8)
    _fields_ = [
        ("seq", u64),
        ("stamp_mono_ns", u64),
        ("x", f64),
        ("y", f64),
        ("tolerance_m", f64),
        ("flags", u8),
        ("reserved", u8 * 7),
    ]


class BaseState(_Named):
    """The robot base's state (``base/state``): safety sensors, link, why it refuses motion."""

    TYPE_NAME = "mimnav/BaseState/v1"
    LAYOUT = (48, 8)
    _fields_ = [
        ("seq", u64),
        ("rx_mono_ns", u64),
        ("base_stamp_ms", u32),
        ("battery_v", f32),
        ("halted", u16),
        ("base", u8),
        ("link", u8),
        ("bumper", u8),
        ("cliff", u8),
        ("wheel_drop", u8),
        ("buttons", u8),
        ("charger", u8),
        ("over_current", u8),
        ("reserved", u8 * 6),
        ("rejected", u32),
        ("link_losses", u32),
    ]


MAX_FOLIAGE_SECTORS = 72


class FoliageHeader(_Named):
    """User header of a ``foliage/alarm`` sample."""

    TYPE_NAME = "mimnav/FoliageHeader/v1"
    LAYOUT = (56 + 4 * MAX_FOLIAGE_SECTORS, 8)
    _fields_ = [
        ("seq", u64),
        ("source_seq", u64),
        ("stamp_ns", u64),
        ("rx_mono_ns", u64),
        ("count", u32),
        ("sectors", u32),
        ("obstacles", u32),
        ("processing_us", u32),
        ("alarm", u8),
        ("laser_id", u8),
        ("reserved", u8 * 6),
        ("nearest_m", f32 * MAX_FOLIAGE_SECTORS),
    ]


class FoliageReturn(_Named):
    """One return of a classified scan."""

    TYPE_NAME = "mimnav/FoliageReturn/v1"
    LAYOUT = (12, 4)
    _fields_ = [
        ("angle_rad", f32),
        ("range_m", f32),
        ("class_", u8),
        ("reserved", u8 * 3),
    ]


# --- the topic table ------------------------------------------------------------------------------


@dataclass(frozen=True)
class Topic:
    """One topic: its iceoryx2 service name, its payload and its user header."""

    #: iceoryx2 service name (also the name of the paired event service).
    name: str
    #: ctypes type of the payload, or of one element when ``is_slice``.
    payload: type
    #: ctypes type of the user header; None: no user header (iceoryx2's ``()``).
    header: Optional[type]
    #: True: the payload is a slice ``[payload]`` whose length varies per sample.
    is_slice: bool
    #: The QoS row of docs/topics.md: ``slice``, ``value``, or ``slices`` (``lidar/slices``).
    qos: str = ""

    @property
    def kind(self) -> str:
        return self.qos or ("slice" if self.is_slice else "value")

    @property
    def buffer(self) -> int:
        if self.kind == "slices":
            return SLICES_BUFFER
        return SLICE_BUFFER if self.is_slice else SMALL_BUFFER

    @property
    def borrowed(self) -> int:
        return SLICE_BORROWED if self.is_slice else SMALL_BORROWED

    @property
    def iox2_payload(self):
        return iox2.Slice[self.payload] if self.is_slice else self.payload


LIDAR_POINTS = Topic("mimnav/lidar/points", Point, PointsHeader, True)
LIDAR_SLICES = Topic("mimnav/lidar/slices", Point, SliceHeader, True, "slices")
LIDAR_SCAN2D = Topic("mimnav/lidar/scan2d", ScanReturn, ScanHeader, True)
LIDAR_PACKETS = Topic("mimnav/lidar/packets", RawPacket, None, False)
CMD_VEL = Topic("mimnav/cmd_vel", VelocityCommand, None, False)
ODOM = Topic("mimnav/odom", Odometry, None, False)
GOAL = Topic("mimnav/goal", Goal, None, False)
BASE_STATE = Topic("mimnav/base/state", BaseState, None, False)
SIM_TRUTH = Topic("mimnav/sim/truth", ctypes.c_uint8, TruthHeader, True)
MAP_LAYERS = Topic("mimnav/map/layers", ctypes.c_float, MapHeader, True)
MAP_PLAN = Topic("mimnav/map/plan", PlanCell, MapHeader, True)
FOLIAGE_ALARM = Topic("mimnav/foliage/alarm", FoliageReturn, FoliageHeader, True)

#: Every topic by service name.
TOPICS = {
    t.name: t
    for t in (
        LIDAR_POINTS,
        LIDAR_SLICES,
        LIDAR_SCAN2D,
        LIDAR_PACKETS,
        CMD_VEL,
        ODOM,
        GOAL,
        BASE_STATE,
        SIM_TRUTH,
        MAP_LAYERS,
        MAP_PLAN,
        FOLIAGE_ALARM,
    )
}


def check_layouts() -> None:
    """Raises AssertionError if a ctypes mirror's size or alignment differs from the Rust type."""
    for t in (
        Point,
        PointsHeader,
        SliceHeader,
        ScanReturn,
        ScanHeader,
        RawPacket,
        VelocityCommand,
        Odometry,
        TruthHeader,
        MapHeader,
        PlanCell,
        Goal,
        BaseState,
        FoliageHeader,
        FoliageReturn,
    ):
        got = (ctypes.sizeof(t), ctypes.alignment(t))
        assert got == t.LAYOUT, f"{t.__name__}: (size, align) {got}, Rust has {t.LAYOUT}"


# --- joining the domain ---------------------------------------------------------------------------


def config(root_path: str = DEFAULT_ROOT_PATH, prefix: str = DEFAULT_PREFIX):
    """iceoryx2's default config moved to mimnav's domain: every process of a stack must agree on
    the root path (ends with ``/``) and the prefix."""
    if not root_path.endswith("/"):
        root_path += "/"
    cfg = iox2.config.default()
    cfg.global_cfg.root_path = iox2.Path.new(root_path)
    cfg.global_cfg.prefix = iox2.FileName.new(prefix)
    return cfg


def node(name: str, root_path: str = DEFAULT_ROOT_PATH, prefix: str = DEFAULT_PREFIX):
    """A node named ``name`` in the domain; SIGINT/SIGTERM end its waits instead of the process."""
    return (
        iox2.NodeBuilder.new()
        .name(iox2.NodeName.new(name))
        .config(config(root_path, prefix))
        .signal_handling_mode(iox2.SignalHandlingMode.HandleTerminationRequests)
        .create(iox2.ServiceType.Ipc)
    )


def _pubsub_service(node, topic: Topic):
    # the same QoS as shared/src/ipc.rs, so whichever side comes first creates what the other
    # expects (iceoryx2 refuses an opener that asks for more than the creator granted)
    b = node.service_builder(iox2.ServiceName.new(topic.name)).publish_subscribe(
        topic.iox2_payload
    )
    if topic.header is not None:
        b = b.user_header(topic.header)
    return (
        b.enable_safe_overflow(True)
        .history_size(0)
        .subscriber_max_buffer_size(topic.buffer)
        .subscriber_max_borrowed_samples(topic.borrowed)
        .max_publishers(MAX_PUBLISHERS)
        .max_subscribers(MAX_SUBSCRIBERS)
        .max_nodes(MAX_NODES)
        .open_or_create()
    )


def _event_service(node, topic: Topic):
    return (
        node.service_builder(iox2.ServiceName.new(topic.name))
        .event()
        .max_notifiers(MAX_PUBLISHERS)
        .max_listeners(MAX_SUBSCRIBERS)
        .max_nodes(MAX_NODES)
        .open_or_create()
    )


# --- receiving ------------------------------------------------------------------------------------


@dataclass
class Heard:
    """What a listener heard: new-data notifications, and whether the stream ended."""

    new_data: int = 0
    end_of_stream: bool = False

    def _add(self, activations) -> "Heard":
        for a in activations:
            if a.id.as_value == EVENT_END_OF_STREAM:
                self.end_of_stream = True
            else:
                self.new_data += a.count
        return self


@dataclass
class Message:
    """A received sample, copied out of shared memory."""

    #: The user header (a ctypes Structure), or None on topics without one.
    header: object
    #: Slice topics: a ctypes array of ``len(items)`` elements; value topics: the payload itself.
    items: object


def _element_count(sample, topic: Topic) -> int:
    # The binding's Slice length (payload().len()) is the payload's size in BYTES for slices a
    # Rust publisher sent, not its element count; the sample header's number_of_elements is the
    # element count the publisher loaned. Both are checked against each other; a binding with
    # the upstream fix (eclipse-iceoryx/iceoryx2#1533) reports elements, which is accepted too.
    n = sample.header.number_of_elements
    nbytes = sample.payload().len()
    size = ctypes.sizeof(topic.payload)
    if nbytes not in (n, n * size):
        raise ValueError(
            f"{topic.name}: payload length {nbytes} is neither {n} elements nor {n * size} bytes"
        )
    return n


class Subscriber:
    """Subscriber of one topic, with the listener of its event service to block on."""

    def __init__(self, node, topic: Topic, buffer_size: Optional[int] = None):
        self.topic = topic
        self._node = node
        service = _pubsub_service(node, topic)
        self._sub = service.subscriber_builder().buffer_size(buffer_size or topic.buffer).create()
        self.listener = _event_service(node, topic).listener_builder().create()

    def wait(self, timeout_s: float) -> Heard:
        """Blocks up to ``timeout_s`` for notifications and drains them."""
        got = self.listener.timed_wait(iox2.Duration.from_secs_f64(timeout_s))
        return Heard()._add(got)

    def heard(self) -> Heard:
        """Drains the notifications that came, without blocking."""
        return Heard()._add(self.listener.try_wait())

    @contextlib.contextmanager
    def borrow(self) -> Iterator[Optional[Message]]:
        """The next sample in place, zero-copy, valid inside the ``with`` block only; None when
        there is none."""
        sample = self._sub.receive()
        if sample is None:
            yield None
            return
        try:
            yield self._view(sample)
        finally:
            sample.delete()

    def receive(self) -> Optional[Message]:
        """The next sample, copied; None when there is none."""
        sample = self._sub.receive()
        if sample is None:
            return None
        try:
            view = self._view(sample)
            header = None
            if view.header is not None:
                header = type(view.header).from_buffer_copy(view.header)
            items = type(view.items).from_buffer_copy(view.items)
            return Message(header, items)
        finally:
            sample.delete()

    def receive_all(self) -> list:
        """Every sample waiting, copied, oldest first."""
        out = []
        while (m := self.receive()) is not None:
            out.append(m)
        return out

    def _view(self, sample) -> Message:
        t = self.topic
        header = sample.user_header().contents if t.header is not None else None
        if t.is_slice:
            n = _element_count(sample, t)
            items = (t.payload * n).from_address(sample.payload_ptr)
        else:
            items = t.payload.from_address(sample.payload_ptr)
        return Message(header, items)

    def close(self) -> None:
        self._sub.delete()
        self.listener.delete()


class Publisher:
    """Publisher of one topic; it notifies the topic's listeners after each sample, as the
    stack's own publishers do."""

    def __init__(self, node, topic: Topic, max_elements: int = 1):
        self.topic = topic
        self._node = node
        service = _pubsub_service(node, topic)
        b = service.publisher_builder()
        if topic.is_slice:
            b = b.initial_max_slice_len(max(1, max_elements)).allocation_strategy(
                iox2.AllocationStrategy.Static
            )
        self._pub = b.create()
        self.notifier = (
            _event_service(node, topic)
            .notifier_builder()
            .default_event_id(iox2.EventId.new(EVENT_NEW_DATA))
            .create()
        )

    def publish(self, value=None, header=None, items=None) -> None:
        """Sends ``value`` (value topics) or ``header`` with ``items`` (slice topics)."""
        t = self.topic
        if t.is_slice:
            items = list(items or [])
            sample = self._pub.loan_slice_uninit(len(items))
            arr = (t.payload * len(items)).from_address(sample.payload_ptr)
            for i, it in enumerate(items):
                arr[i] = it
        else:
            sample = self._pub.loan_uninit()
            ctypes.memmove(sample.payload_ptr, ctypes.byref(value), ctypes.sizeof(t.payload))
        if t.header is not None:
            h = header if header is not None else t.header()
            ctypes.memmove(sample.user_header_ptr, ctypes.byref(h), ctypes.sizeof(t.header))
        sample.assume_init().send()
        self.notifier.notify()

    def end_of_stream(self) -> None:
        """Tells the listeners this publisher's stream has ended."""
        self.notifier.notify_with_custom_event_id(iox2.EventId.new(EVENT_END_OF_STREAM))

    def close(self) -> None:
        self._pub.delete()
        self.notifier.delete()


# --- the same bytes from another host (mimnav-zenoh, docs/zenoh.md) -------------------------------

#: ``Goal.flags`` bit of a stop request: the planner holds zero velocity until a new goal.
GOAL_STOP = 1

#: The MIME type of every payload mimnav-zenoh publishes; the encoding's schema names the types.
ZENOH_ENCODING = "application/octet-stream"


def decode_remote(topic: str, data: bytes) -> Message:
    """Decodes a payload mimnav-zenoh published on ``mimnav/<robot>/<topic>`` (``topic`` as
    ``"lidar/points"`` or ``"mimnav/lidar/points"``): the header, then the elements, laid out as
    in docs/topics.md. Needs only ctypes (no iceoryx2). Raises ValueError when the length does
    not fit the topic's layout, or a slice's header count differs from its elements."""
    name = topic if topic.startswith("mimnav/") else "mimnav/" + topic
    t = TOPICS.get(name)
    if t is None:
        raise ValueError(f"unknown topic {topic!r}")
    data = bytes(data)
    if not t.is_slice:
        if len(data) != ctypes.sizeof(t.payload):
            raise ValueError(f"{name}: {len(data)} bytes, {t.payload.__name__} has {ctypes.sizeof(t.payload)}")
        return Message(header=None, items=t.payload.from_buffer_copy(data))
    hsize, isize = ctypes.sizeof(t.header), ctypes.sizeof(t.payload)
    rest = len(data) - hsize
    if rest < 0 or rest % isize:
        raise ValueError(f"{name}: {len(data)} bytes is not a {t.header.__name__} and whole elements")
    header = t.header.from_buffer_copy(data[:hsize])
    items = (t.payload * (rest // isize)).from_buffer_copy(data[hsize:])
    counted = {
        "mimnav/lidar/points": lambda h: h.point_count,
        "mimnav/lidar/scan2d": lambda h: h.count,
        "mimnav/foliage/alarm": lambda h: h.count,
        "mimnav/map/plan": lambda h: h.cells * h.cells,
        "mimnav/sim/truth": lambda h: h.cells * h.cells,
        "mimnav/map/layers": lambda h: h.cells * h.cells * h.layers,
    }[name](header)
    if counted != len(items):
        raise ValueError(f"{name}: the header says {counted} elements, the payload holds {len(items)}")
    return Message(header=header, items=items)


def goal_json(x: float, y: float, tolerance_m: float = 0.3) -> bytes:
    """A goal for ``mimnav/<robot>/goal`` as mimnav-zenoh reads it (JSON)."""
    import json

    return json.dumps({"x": float(x), "y": float(y), "tolerance_m": float(tolerance_m)}).encode()
