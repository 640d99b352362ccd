"""mimnav_spot: the bridge between mimnav and a Boston Dynamics Spot (issue 24, item 2).

A base service (docs/bases.md) on Boston Dynamics' Spot SDK (``bosdyn-client``) and the Python
client (``mimnav_client``): ``cmd_vel`` becomes Spot's synchro velocity command, ending no later
than the command's ``valid_until_mono_ns``; Spot's robot state becomes ``odom`` (its "odom"
frame) and ``base/state``.

    python -m mimnav_spot --config /etc/mimnav/mimnav.toml [--stand] [--set spot.hostname="..."]

Keys (``[spot]`` of the stack's config, every one optional; ``--set spot.KEY=VALUE`` overrides):

- ``hostname`` (``"192.168.80.3"``, Spot's own access point): the robot's address.
- ``port`` (443): its API port.
- ``ca_cert`` (``""``: the robot CA the SDK ships): a PEM file of the CA that signed the robot's
  certificate (a test server's own, for example).
- ``credentials_file`` (``"/etc/mimnav/spot-credentials"``): two lines, the username and the
  password, readable by the service's user only (no group or other bits). systemd's
  ``LoadCredential=spot:...`` (``$CREDENTIALS_DIRECTORY/spot``) takes precedence.
- ``command_validity_cap_s`` (1.0): no velocity command runs longer than this on the robot even
  when ``cmd_vel``'s validity is longer; the bridge renews it while the command stays valid.
- ``estop_timeout_s`` (9.0): the E-Stop endpoint's timeout; the robot stops itself (settles and
  cuts motor power) when the bridge misses its check-ins that long.
- ``odom_rate_hz`` (25.0): robot-state reads, each giving an ``odom`` and a ``base/state``.

Whatever goes wrong (a refused command, a lost lease, an E-Stop, a robot that does not answer),
the robot stops: a stop command when one can still be sent, never another velocity command; the
cause is logged (rate-limited), counted and shown in ``base/state``; the bridge reconnects with a
backoff and never exits for it.
"""

from __future__ import annotations

import argparse
import logging
import math
import os
import signal
import socket
import stat
import sys
import time
import tomllib
from dataclasses import dataclass, fields
from typing import Optional

import iceoryx2 as iox2

import mimnav_client as mc

LOG = logging.getLogger("mimnav_spot")

# base/state's halted bits (docs/topics.md, BaseState)
COMMAND_EXPIRED, LINK_DOWN, ESTOP, NO_LEASE, MOTORS_OFF = 8, 16, 32, 64, 128
BASE_SPOT = 2

#: A velocity command shorter than this is not sent (it would expire on the way): a stop instead.
MIN_COMMAND_S = 0.02
#: Each RPC's deadline, s.
RPC_TIMEOUT_S = 1.0
#: Reconnection backoff, s: doubles from the first to the last.
BACKOFF_S = (0.5, 5.0)
#: A rate-limited log line repeats at most this often, s.
LOG_EVERY_S = 5.0


@dataclass
class SpotConfig:
    """``[spot]`` of the stack's config, with its defaults."""

    hostname: str = "192.168.80.3"
    port: int = 443
    ca_cert: str = ""
    credentials_file: str = "/etc/mimnav/spot-credentials"
    command_validity_cap_s: float = 0.6
    estop_timeout_s: float = 9.0
    odom_rate_hz: float = 25.0

    def check(self) -> None:
        if not (0.05 <= self.command_validity_cap_s <= 5):
            raise ValueError("spot.command_validity_cap_s must be in [0.05, 5]")
        if not (1 <= self.estop_timeout_s <= 60):
            raise ValueError("spot.estop_timeout_s must be in [1, 60]")
        if not (1 <= self.odom_rate_hz <= 200):
            raise ValueError("spot.odom_rate_hz must be in [1, 200]")
        if not (0 < self.port < 65536):
            raise ValueError("spot.port must be a TCP port")


@dataclass
class Settings:
    spot: SpotConfig
    root_path: str = mc.DEFAULT_ROOT_PATH
    prefix: str = mc.DEFAULT_PREFIX
    log_level: str = "info"


def _value(text: str):
    """A ``--set`` value in TOML syntax (``"text"``, ``1.5``, ``true``), else the text itself."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def load_settings(path: Optional[str], sets: list[str]) -> Settings:
    """The stack's config file (every other section ignored, ``[spot]`` optional) and the
    ``--set KEY=VALUE`` overrides."""
    doc = {}
    if path:
        with open(path, "rb") as f:
            doc = tomllib.load(f)
    for s in sets:
        key, eq, text = s.partition("=")
        if not eq:
            raise ValueError(f"--set {s}: expected KEY=VALUE")
        *parents, leaf = key.strip().split(".")
        t = doc
        for p in parents:
            t = t.setdefault(p, {})
            if not isinstance(t, dict):
                raise ValueError(f"--set {s}: {p} is not a section")
        t[leaf] = _value(text.strip())
    table = doc.get("spot", {})
    known = {f.name: f.type for f in fields(SpotConfig)}
    unknown = sorted(set(table) - set(known))
    if unknown:
        raise ValueError(f"[spot]: unknown key(s) {', '.join(unknown)} (known: {', '.join(known)})")
    spot = SpotConfig()
    for k, v in table.items():
        default = getattr(spot, k)
        if isinstance(default, float) and isinstance(v, int) and not isinstance(v, bool):
            v = float(v)
        if type(v) is not type(default):
            raise ValueError(f"spot.{k}: expected a {type(default).__name__}, got {v!r}")
        setattr(spot, k, v)
    spot.check()
    g = doc.get("iceoryx2", {}).get("global", {})
    level = doc.get("log", {}).get("level", "info")
    return Settings(spot, g.get("root-path", mc.DEFAULT_ROOT_PATH),
                    g.get("prefix", mc.DEFAULT_PREFIX), level if isinstance(level, str) else "info")


class CredentialsError(Exception):
    pass


def credentials_path(cfg: SpotConfig) -> str:
    """systemd's credential ``spot`` when the unit loads one, else ``spot.credentials_file``."""
    d = os.environ.get("CREDENTIALS_DIRECTORY")
    if d and os.path.exists(os.path.join(d, "spot")):
        return os.path.join(d, "spot")
    return cfg.credentials_file


def read_credentials(path: str) -> tuple[str, str]:
    """Username and password: the first two lines of ``path``, a file no group or other may read."""
    try:
        st = os.stat(path)
    except OSError as e:
        raise CredentialsError(f"cannot read the Spot credentials {path}: {e.strerror}") from e
    if st.st_mode & 0o077:
        raise CredentialsError(
            f"refusing the Spot credentials {path}: mode {stat.S_IMODE(st.st_mode):04o} lets "
            f"group or others read or write it; `chmod 600 {path}` (owned by the service's user)"
        )
    try:
        with open(path, encoding="utf-8") as f:
            lines = f.read().splitlines()
    except OSError as e:
        raise CredentialsError(f"cannot read the Spot credentials {path}: {e.strerror}") from e
    if len(lines) < 2 or not lines[0].strip() or not lines[1]:
        raise CredentialsError(
            f"the Spot credentials {path} must hold the username on the first line and the "
            "password on the second"
        )
    return lines[0].strip(), lines[1]


def velocity_end_s(valid_until_mono_ns: int, mono_ns: int, wall_s: float, cap_s: float,
                   margin_s: float) -> Optional[float]:
    """The end of a velocity command in the host's wall clock (what the SDK converts to robot
    time with the time-sync skew): the command's deadline moved from the monotonic to the wall
    clock, less ``margin_s`` (the time-sync estimate's uncertainty), at most ``cap_s`` ahead;
    None when less than MIN_COMMAND_S would be left. ``wall_s`` must be read before ``mono_ns``
    so that the conversion errs early."""
    left = (valid_until_mono_ns - mono_ns) * 1e-9 - margin_s
    horizon = min(left, cap_s)
    if horizon < MIN_COMMAND_S:
        return None
    return wall_s + horizon


def yaw_of(q) -> float:
    """Rotation about z of a quaternion (w, x, y, z), in (-pi, pi]."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


class Faults:
    """Counts each kind of fault and logs it at most every LOG_EVERY_S."""

    def __init__(self):
        self.count: dict[str, int] = {}
        self._last: dict[str, float] = {}

    def __call__(self, kind: str, msg: str, level=logging.WARNING) -> None:
        n = self.count[kind] = self.count.get(kind, 0) + 1
        now = time.monotonic()
        if now - self._last.get(kind, -math.inf) >= LOG_EVERY_S:
            self._last[kind] = now
            LOG.log(level, "%s: %s (%d so far)", kind, msg, n)


def sd_notify(msg: str) -> None:
    """systemd's notification socket (Type=notify units); nothing without one."""
    addr = os.environ.get("NOTIFY_SOCKET")
    if not addr:
        return
    if addr.startswith("@"):
        addr = "\0" + addr[1:]
    try:
        with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as s:
            s.sendto(msg.encode(), addr)
    except OSError:
        pass


class Session:
    """One connection to the robot: authenticated, time-synced, E-Stop endpoint checking in,
    body lease kept. Any of its calls may raise the SDK's errors; the bridge drops the session
    on a communication error and makes a new one."""

    def __init__(self, cfg: SpotConfig, creds: tuple[str, str], faults: Faults):
        import bosdyn.client
        from bosdyn.client.estop import EstopClient, EstopEndpoint, EstopKeepAlive
        from bosdyn.client.lease import LeaseClient
        from bosdyn.client.power import PowerClient
        from bosdyn.client.robot_command import RobotCommandClient
        from bosdyn.client.robot_state import RobotStateClient

        self.cfg, self.faults = cfg, faults
        self.estop_keepalive = self.lease_keepalive = None
        self.lease_failed = False
        sdk = bosdyn.client.create_standard_sdk("mimnav-spot",
                                                cert_resource_glob=cfg.ca_cert or None)
        self.robot = robot = sdk.create_robot(cfg.hostname)
        robot.update_secure_channel_port(cfg.port)
        try:
            robot.authenticate(*creds, timeout=RPC_TIMEOUT_S)
            robot.time_sync.wait_for_sync(timeout_sec=5.0)
            self.state_client = robot.ensure_client(RobotStateClient.default_service_name)
            self.command_client = robot.ensure_client(RobotCommandClient.default_service_name)
            self.lease_client = robot.ensure_client(LeaseClient.default_service_name)
            self.power_client = robot.ensure_client(PowerClient.default_service_name)
            estop_client = robot.ensure_client(EstopClient.default_service_name)
            # a configuration of our endpoint alone, as the SDK's E-Stop examples make: the
            # robot's motors stay cut unless this endpoint checks in
            endpoint = EstopEndpoint(estop_client, "mimnav-spot", cfg.estop_timeout_s)
            endpoint.force_simple_setup()
            self.estop_keepalive = EstopKeepAlive(endpoint, rpc_timeout_seconds=RPC_TIMEOUT_S)
            self.acquire_lease()
        except BaseException:
            self.close()
            raise

    def acquire_lease(self) -> None:
        """Acquires the body lease (never takes it from another client) and keeps it."""
        from bosdyn.client.lease import LeaseKeepAlive

        if self.lease_keepalive is not None:
            self.lease_keepalive.shutdown()
            self.lease_keepalive = None
        self.lease_client.acquire(timeout=RPC_TIMEOUT_S)
        self.lease_failed = False

        def failed(exc):
            self.lease_failed = True
            self.faults("lease_retain", f"retaining the lease failed: {exc}")

        self.lease_keepalive = LeaseKeepAlive(self.lease_client, on_failure_callback=failed,
                                              rpc_interval_seconds=0.5, warnings=False,
                                              return_at_exit=True)

    def has_lease(self) -> bool:
        from bosdyn.client.lease import LeaseState

        if self.lease_keepalive is None:
            return False
        try:
            st = self.lease_client.lease_wallet.get_lease_state()
        except Exception:  # noqa: BLE001 - no lease of that resource in the wallet
            return False
        return st.lease_status == LeaseState.Status.SELF_OWNER

    def time_margin_s(self) -> float:
        """Half the best time-sync round trip: how far off the skew estimate may be."""
        rtt = self.robot.time_sync.endpoint.round_trip_time
        return rtt.ToNanoseconds() * 0.5e-9 if rtt is not None else 0.05

    def power_on_and_stand(self) -> None:
        from bosdyn.client.power import power_on_motors
        from bosdyn.client.robot_command import RobotCommandBuilder

        power_on_motors(self.power_client, timeout_sec=20, timeout=RPC_TIMEOUT_S)
        self.command_client.robot_command(RobotCommandBuilder.synchro_stand_command(),
                                          timeout=RPC_TIMEOUT_S)

    def velocity(self, v: float, omega: float, end_wall_s: float) -> None:
        from bosdyn.client.robot_command import RobotCommandBuilder

        cmd = RobotCommandBuilder.synchro_velocity_command(v_x=v, v_y=0.0, v_rot=omega)
        self.command_client.robot_command(cmd, end_time_secs=end_wall_s, timeout=RPC_TIMEOUT_S)

    def stop(self) -> None:
        from bosdyn.client.robot_command import RobotCommandBuilder

        self.command_client.robot_command(RobotCommandBuilder.stop_command(),
                                          timeout=RPC_TIMEOUT_S)

    def sit_and_power_off(self) -> None:
        from bosdyn.client.robot_command import RobotCommandBuilder

        self.command_client.robot_command(RobotCommandBuilder.safe_power_off_command(),
                                          timeout=RPC_TIMEOUT_S)

    def state(self):
        return self.state_client.get_robot_state(timeout=RPC_TIMEOUT_S)

    def local_ns(self, robot_ts) -> Optional[int]:
        """A robot timestamp in the host's wall clock, ns."""
        try:
            conv = self.robot.time_sync.endpoint.get_robot_time_converter()
            return int(conv.local_seconds_from_robot_timestamp(robot_ts) * 1e9)
        except Exception:  # noqa: BLE001 - time sync lost: the caller uses its own clock
            return None

    def close(self) -> None:
        """Ends the keep-alives (returning the lease) and time sync; never raises."""
        for what in ("lease_keepalive", "estop_keepalive"):
            k = getattr(self, what, None)
            if k is not None:
                try:
                    k.shutdown()
                except Exception as e:  # noqa: BLE001
                    LOG.debug("closing %s: %s", what, e)
                setattr(self, what, None)
        try:
            self.robot.stop_time_sync()
        except Exception:  # noqa: BLE001
            pass


class Bridge:
    """The loop: cmd_vel in, velocity commands out, robot state to odom and base/state."""

    def __init__(self, settings: Settings, creds: tuple[str, str], stand: bool):
        self.cfg, self.creds, self.stand = settings.spot, creds, stand
        self.faults = Faults()
        self.node = mc.node("mimnav-spot", settings.root_path, settings.prefix)
        self.cmd_sub = mc.Subscriber(self.node, mc.CMD_VEL)
        self.odom_pub = mc.Publisher(self.node, mc.ODOM)
        self.state_pub = mc.Publisher(self.node, mc.BASE_STATE)
        self.session: Optional[Session] = None
        self.next_connect = 0.0
        self.backoff = BACKOFF_S[0]
        self.next_lease_try = 0.0
        self.cmd = None  # the newest VelocityCommand
        self.new_cmd = False
        self.driving = False  # a velocity command was accepted and a stop has not followed
        self.sent_until_mono_ns = 0  # where the last accepted velocity command ends
        self.capped = False  # it ends at now + command_validity_cap_s, before its valid_until
        self.robot_halted = 0  # ESTOP | MOTORS_OFF from the last robot state
        self.battery_v = math.nan
        self.odom_seq = self.state_seq = 0
        self.rejected = self.link_losses = 0
        self.last_state_pub = 0.0

    # --- the link ---------------------------------------------------------------------------
    def connect(self) -> None:
        from bosdyn.client.exceptions import Error as SdkError

        try:
            LOG.info("connecting to Spot at %s:%d", self.cfg.hostname, self.cfg.port)
            self.session = Session(self.cfg, self.creds, self.faults)
        except (SdkError, OSError) as e:
            self.faults("connect", f"Spot at {self.cfg.hostname}:{self.cfg.port} refused or "
                        f"did not answer: {type(e).__name__}: {e}; retrying in {self.backoff:.1f} s")
            sd_notify(f"STATUS=waiting for Spot at {self.cfg.hostname} ({type(e).__name__})")
            self.next_connect = time.monotonic() + self.backoff
            self.backoff = min(self.backoff * 2, BACKOFF_S[1])
            return
        self.backoff = BACKOFF_S[0]
        LOG.info("connected to Spot at %s:%d: authenticated, time-synced (round trip %.1f ms), "
                 "E-Stop endpoint checking in, body lease acquired", self.cfg.hostname,
                 self.cfg.port, 2e3 * self.session.time_margin_s())
        sd_notify(f"STATUS=driving Spot at {self.cfg.hostname}")
        if self.stand:
            try:
                self.session.power_on_and_stand()
                LOG.info("motors on, standing")
            except SdkError as e:
                self.faults("stand", f"power on and stand failed: {type(e).__name__}: {e}")
        self.publish_state()

    def link_lost(self, e: Exception) -> None:
        self.faults("link_down", f"lost Spot: {type(e).__name__}: {e}; the robot stops on its "
                    "own (command end times, E-Stop and lease timeouts)", logging.ERROR)
        self.link_losses += 1
        if self.session is not None:
            self.session.close()
        self.session = None
        self.driving = False
        self.robot_halted = 0
        self.next_connect = time.monotonic() + self.backoff
        sd_notify("STATUS=lost Spot, reconnecting")
        self.publish_state()

    # --- commands ----------------------------------------------------------------------------
    def stop_reason(self, mono_ns: int) -> Optional[str]:
        """Why the robot must not move now, or None."""
        c = self.cmd
        if self.session is None:
            return "link down"
        if not self.session.has_lease():
            return "no lease"
        if self.robot_halted & ESTOP:
            return "e-stop"
        if self.robot_halted & MOTORS_OFF:
            return "motors off"
        if c is None:
            return "no command"
        if c.status != 0:
            return f"status {c.status}"
        if not (math.isfinite(c.v) and math.isfinite(c.omega)):
            return "non-finite command"
        if mono_ns >= c.valid_until_mono_ns:
            return "command expired"
        return None

    def drive(self) -> None:
        """Sends a velocity command for a new or renewable valid command, or a stop."""
        from bosdyn.client.exceptions import ResponseError

        s = self.session
        wall_s = time.time()  # before the monotonic clock: the conversion errs early
        mono_ns = time.monotonic_ns()
        reason = self.stop_reason(mono_ns)
        new, self.new_cmd = self.new_cmd, False
        if reason is not None:
            if self.driving and s is not None and s.has_lease():
                self.driving = False
                try:
                    s.stop()
                    LOG.info("stop: %s", reason)
                except ResponseError as e:
                    self.rejected += 1
                    self.faults("stop_refused", f"stop ({reason}) refused: {e}")
            elif reason not in ("no command", "command expired"):
                if new:
                    self.faults("refused_motion", f"not moving: {reason}", logging.INFO)
            self.driving = self.driving and s is not None and s.has_lease()
            return
        # the same command again only when the cap cut its last one short, half a cap before
        # that one ends
        renew = self.capped and mono_ns >= self.sent_until_mono_ns - int(
            self.cfg.command_validity_cap_s * 0.5e9)
        if not (new or renew):
            return
        end = velocity_end_s(self.cmd.valid_until_mono_ns, mono_ns, wall_s,
                             self.cfg.command_validity_cap_s, s.time_margin_s())
        if end is None:
            return  # the current command ends (on the robot) before another could start
        try:
            s.velocity(self.cmd.v, self.cmd.omega, end)
        except ResponseError as e:
            self.rejected += 1
            self.faults("command_refused", f"velocity command refused: {type(e).__name__}: {e}")
            return
        self.driving = True
        self.sent_until_mono_ns = mono_ns + int((end - wall_s) * 1e9)
        self.capped = end - wall_s >= self.cfg.command_validity_cap_s

    # --- robot state -----------------------------------------------------------------------------
    def measure(self) -> None:
        from bosdyn.api.robot_state_pb2 import EStopState, PowerState
        from bosdyn.client.frame_helpers import get_odom_tform_body

        st = self.session.state()
        rx = time.monotonic_ns()
        halted = 0
        if any(e.state == EStopState.STATE_ESTOPPED for e in st.estop_states):
            halted |= ESTOP
        if st.power_state.motor_power_state != PowerState.MOTOR_POWER_STATE_ON:
            halted |= MOTORS_OFF
        if halted & ~self.robot_halted:
            names = [e.name for e in st.estop_states if e.state == EStopState.STATE_ESTOPPED]
            self.faults("robot_halted", f"Spot refuses motion: e-stopped by {names or 'none'}, "
                        f"motor power {PowerState.MotorPowerState.Name(st.power_state.motor_power_state)}")
        self.robot_halted = halted
        volts = [b.voltage.value for b in st.battery_states if b.HasField("voltage")]
        self.battery_v = volts[0] if volts else math.nan
        ks = st.kinematic_state
        pose = get_odom_tform_body(ks.transforms_snapshot)
        if pose is None:
            self.rejected += 1
            self.faults("no_odom", "robot state without the odom -> body transform")
        else:
            yaw = yaw_of(pose.rotation)
            lin = ks.velocity_of_body_in_odom.linear
            v = math.cos(yaw) * lin.x + math.sin(yaw) * lin.y  # into the body frame
            stamp = self.session.local_ns(ks.acquisition_timestamp) or time.time_ns()
            self.odom_seq += 1
            self.odom_pub.publish(mc.Odometry(
                seq=self.odom_seq, stamp_ns=stamp, rx_mono_ns=rx, x=pose.x, y=pose.y, yaw=yaw,
                v=v, omega=ks.velocity_of_body_in_odom.angular.z))
        self.base_stamp_ms = (ks.acquisition_timestamp.ToNanoseconds() // 1_000_000) & 0xFFFFFFFF
        self.publish_state(rx)

    def halted(self) -> int:
        h = self.robot_halted
        if self.session is None:
            h |= LINK_DOWN
        elif not self.session.has_lease():
            h |= NO_LEASE
        if self.stop_reason(time.monotonic_ns()) in ("no command", "command expired") or (
            self.cmd is not None and self.cmd.status != 0
        ):
            h |= COMMAND_EXPIRED
        return h

    def publish_state(self, rx: Optional[int] = None) -> None:
        self.state_seq += 1
        self.last_state_pub = time.monotonic()
        up = self.session is not None
        self.state_pub.publish(mc.BaseState(
            seq=self.state_seq, rx_mono_ns=rx or time.monotonic_ns(),
            base_stamp_ms=getattr(self, "base_stamp_ms", 0) if up else 0,
            battery_v=self.battery_v if up else math.nan, halted=self.halted(), base=BASE_SPOT,
            link=0 if up else 1, rejected=self.rejected & 0xFFFFFFFF,
            link_losses=self.link_losses & 0xFFFFFFFF))

    def keep_lease(self) -> None:
        """After the lease was lost (revoked, taken), acquires it again when it is free."""
        from bosdyn.client.exceptions import ResponseError

        s = self.session
        if s.has_lease() or time.monotonic() < self.next_lease_try:
            return
        if s.lease_keepalive is not None:
            self.faults("lease_lost", "lost the body lease (revoked or taken by another client); "
                        "the robot stops; acquiring it again when it is free", logging.ERROR)
            s.lease_keepalive.shutdown()
            s.lease_keepalive = None
            self.driving = False
        self.next_lease_try = time.monotonic() + 1.0
        try:
            s.acquire_lease()
            LOG.info("body lease acquired again")
        except ResponseError as e:
            self.faults("lease_busy", f"cannot acquire the lease: {type(e).__name__}: {e}")

    # --- the loop ------------------------------------------------------------------------------------
    def run(self) -> int:
        from bosdyn.client.exceptions import RpcError

        # SIGTERM (systemd) and SIGINT end the loop: the robot is stopped, the lease returned
        stopping = []
        for sig in (signal.SIGTERM, signal.SIGINT):
            signal.signal(sig, lambda n, _f: stopping.append(n))
        sd_notify("READY=1")
        period = 1.0 / self.cfg.odom_rate_hz
        next_measure = time.monotonic()
        while not stopping:
            now = time.monotonic()
            wait = max(0.0, min(next_measure, self.next_connect if self.session is None
                                else next_measure) - now)
            try:
                # a zero timeout would block for good in the binding: at least a millisecond
                self.cmd_sub.wait(min(max(wait, 0.001), period))
            except iox2.ListenerWaitError:
                break  # SIGINT or SIGTERM
            for m in self.cmd_sub.receive_all():
                self.cmd, self.new_cmd = m.items, True
            sd_notify("WATCHDOG=1")
            if self.session is None:
                if time.monotonic() >= self.next_connect:
                    self.connect()
                if self.session is None and time.monotonic() - self.last_state_pub >= 0.5:
                    self.publish_state()
                continue
            try:
                self.keep_lease()
                self.drive()
                if time.monotonic() >= next_measure:
                    next_measure = max(next_measure + period, time.monotonic())
                    self.measure()
                    self.drive()  # an E-Stop seen in the state stops at once
            except RpcError as e:
                self.link_lost(e)
        self.shutdown()
        return 0

    def shutdown(self) -> None:
        s = self.session
        if s is not None:
            try:
                if s.has_lease():
                    s.stop()
                    if self.stand:
                        s.sit_and_power_off()
            except Exception as e:  # noqa: BLE001 - leaving anyway
                LOG.warning("stopping on exit: %s", e)
            s.close()
        LOG.info("mimnav-spot ends: faults %s, link losses %d, rejected %d",
                 self.faults.count, self.link_losses, self.rejected)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="mimnav_spot", description=__doc__.splitlines()[0])
    ap.add_argument("--config", help="the stack's config (its [spot] and [iceoryx2.global])")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="override a config key, e.g. spot.hostname=\"10.0.0.3\"")
    ap.add_argument("--stand", action="store_true",
                    help="power the motors on and stand on connecting (sit and power off at exit)")
    args = ap.parse_args(argv)
    try:
        settings = load_settings(args.config, args.set)
    except (OSError, ValueError, tomllib.TOMLDecodeError) as e:
        print(f"mimnav-spot: config: {e}", file=sys.stderr)
        return 2
    level = os.environ.get("MIMNAV_LOG", settings.log_level).split(",")[0].upper()
    logging.basicConfig(level=getattr(logging, level.replace("WARN", "WARNING").replace(
        "WARNINGING", "WARNING"), logging.INFO),
        format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    if LOG.getEffectiveLevel() > logging.DEBUG:
        logging.getLogger("bosdyn").setLevel(logging.WARNING)
    try:
        creds = read_credentials(credentials_path(settings.spot))
    except CredentialsError as e:
        print(f"mimnav-spot: {e}", file=sys.stderr)
        return 2
    mc.check_layouts()
    return Bridge(settings, creds, args.stand).run()


if __name__ == "__main__":
    sys.exit(main())
