"""fake_spot: a stand-in Spot for trying and testing mimnav-spot without the robot.

A gRPC server built from the servicers ``bosdyn-api`` generates (``bosdyn.api.*_service_pb2_grpc``),
speaking the same protocol as the robot to the real Spot SDK: robot id, auth, directory, time
sync, lease, E-Stop, robot state, robot command and power, all on one TLS port of 127.0.0.1 under
a certificate authority it makes itself (openssl) for the robot's authority names
(``*.spot.robot``). Its robot clock runs ``--skew`` seconds ahead of the host's, so a client
that skips time sync sends wrong end times. It moves a simulated body by the velocity commands
it accepts, each only until its end time.

It records every request as a JSON line on stdout (``{"t": "velocity", ...}``), with the host's
``CLOCK_MONOTONIC`` time it came (``mono_ns``) and, for commands with an end time, that end time
moved back to the host's monotonic clock (``end_mono_ns``), which it can do exactly because it
knows its own skew. Faults come as lines on stdin:

- ``revoke_lease``: another client (the tablet) takes the body lease; ``release_lease`` gives it
  back (free to acquire).
- ``estop`` / ``release_estop``: the robot's software E-Stop from another endpoint (cuts the
  motors: the robot stays powered off after a release until it is powered on again).
- ``quit`` (or the end of stdin): stop serving and exit.

The bridge's own E-Stop endpoint must check in within its timeout, or the fake E-Stops too.

    python fake_spot.py --port 0 --cert-dir /tmp/fake-spot   # prints {"t": "ready", "port": ...}
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import threading
import time
from concurrent import futures

import grpc
from bosdyn.api import (
    auth_pb2,
    auth_service_pb2_grpc,
    directory_pb2,
    directory_service_pb2_grpc,
    estop_pb2,
    estop_service_pb2_grpc,
    lease_pb2,
    lease_service_pb2_grpc,
    power_pb2,
    power_service_pb2_grpc,
    robot_command_pb2,
    robot_command_service_pb2_grpc,
    robot_id_pb2,
    robot_id_service_pb2_grpc,
    robot_state_pb2,
    robot_state_service_pb2_grpc,
    time_sync_pb2,
    time_sync_service_pb2_grpc,
)
from bosdyn.api import header_pb2

USERNAME, PASSWORD = "user", "fake-spot-password"
TOKEN = "fake-spot-token"

# name, type, authority: what the robot's directory lists (the SDK asks it for every service but
# auth, directory and robot-id, whose authorities it knows)
SERVICES = [
    ("robot-id", "bosdyn.api.RobotIdService", "id.spot.robot"),
    ("auth", "bosdyn.api.AuthService", "auth.spot.robot"),
    ("directory", "bosdyn.api.DirectoryService", "api.spot.robot"),
    ("time-sync", "bosdyn.api.TimeSyncService", "api.spot.robot"),
    ("lease", "bosdyn.api.LeaseService", "api.spot.robot"),
    ("estop", "bosdyn.api.EstopService", "estop.spot.robot"),
    ("robot-state", "bosdyn.api.RobotStateService", "api.spot.robot"),
    ("robot-command", "bosdyn.api.RobotCommandService", "command.spot.robot"),
    ("power", "bosdyn.api.PowerService", "power.spot.robot"),
]


def make_certs(d: str) -> tuple[str, str, str]:
    """A CA and a server certificate for ``*.spot.robot`` in ``d`` (kept if there)."""
    ca, key, crt = (os.path.join(d, n) for n in ("ca.pem", "server.key", "server.pem"))
    if all(os.path.exists(p) for p in (ca, key, crt)):
        return ca, key, crt
    os.makedirs(d, exist_ok=True)
    run = lambda *a: subprocess.run(a, check=True, capture_output=True, cwd=d)  # noqa: E731
    run("openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "2",
        "-keyout", "ca.key", "-out", "ca.pem", "-subj", "/CN=fake-spot-ca")
    run("openssl", "req", "-newkey", "rsa:2048", "-nodes", "-keyout", "server.key",
        "-out", "server.csr", "-subj", "/CN=api.spot.robot")
    with open(os.path.join(d, "san.ext"), "w") as f:
        f.write("subjectAltName=DNS:*.spot.robot,DNS:spot.robot,IP:127.0.0.1\n")
    run("openssl", "x509", "-req", "-in", "server.csr", "-CA", "ca.pem", "-CAkey", "ca.key",
        "-CAcreateserial", "-days", "2", "-out", "server.pem", "-extfile", "san.ext")
    return ca, key, crt


class Robot:
    """The fake robot's state, shared by every servicer (one lock)."""

    def __init__(self, skew_s: float, out):
        self.lock = threading.RLock()
        self.skew_ns = int(skew_s * 1e9)
        self.out = out
        self.epoch = "epoch-1"
        self.lease_seq = 0
        self.lease_owner = None  # client name holding the body lease; "tablet" after a revoke
        self.revoked = False
        self.estop_config = estop_pb2.EstopConfig(unique_id="config-0")
        self.estop_endpoint = None  # (unique_id, timeout_s)
        self.last_checkin = None  # monotonic s
        self.remote_estop = False  # e-stopped by another endpoint (estop command)
        self.timeout_estop = False  # e-stopped because our endpoint stopped checking in
        self.endpoint_level = estop_pb2.ESTOP_LEVEL_CUT
        self.motors_on = False
        self.power_cmd = 0
        self.cmd_id = 0
        # the body in the odom frame and the velocity command it follows
        self.x = self.y = self.yaw = 0.0
        self.vx = self.vrot = 0.0
        self.vel_end_ns = 0  # robot time
        self.t_ns = time.monotonic_ns()
        self.timesync_samples = 0
        self.best_rtt = None
        self.last_challenge = None

    # --- clocks -----------------------------------------------------------------------------
    def robot_ns(self) -> int:
        return time.time_ns() + self.skew_ns

    def robot_to_mono_ns(self, robot_ns: int) -> int:
        return robot_ns - self.skew_ns - time.time_ns() + time.monotonic_ns()

    def record(self, t: str, **kw) -> None:
        kw = {"t": t, "mono_ns": time.monotonic_ns(), **kw}
        with self.lock:
            self.out.write(json.dumps(kw) + "\n")
            self.out.flush()

    # --- state --------------------------------------------------------------------------------
    def estopped(self) -> bool:
        return (
            self.remote_estop
            or self.timeout_estop
            or self.estop_endpoint is None
            or self.endpoint_level != estop_pb2.ESTOP_LEVEL_NONE
        )

    def step(self) -> None:
        """Moves the body by the current velocity command up to now (or its end)."""
        now = time.monotonic_ns()
        with self.lock:
            if self.estop_endpoint and self.last_checkin is not None:
                if time.monotonic() - self.last_checkin > self.estop_endpoint[1]:
                    if not self.timeout_estop:
                        self.record("estop_timeout")
                    self.timeout_estop = True
            if self.estopped():
                self.motors_on = False
            end_mono = self.robot_to_mono_ns(self.vel_end_ns)
            t1 = min(now, end_mono) if self.motors_on else self.t_ns
            if t1 > self.t_ns:
                dt = (t1 - self.t_ns) * 1e-9
                self.x += self.vx * math.cos(self.yaw) * dt
                self.y += self.vx * math.sin(self.yaw) * dt
                self.yaw = math.remainder(self.yaw + self.vrot * dt, math.tau)
            self.t_ns = now
            if now >= end_mono or not self.motors_on:
                self.vx = self.vrot = 0.0

    def lease(self) -> lease_pb2.Lease:
        return lease_pb2.Lease(resource="body", epoch=self.epoch, sequence=[self.lease_seq],
                               client_names=[self.lease_owner or ""])

    def lease_use(self, lease: lease_pb2.Lease) -> lease_pb2.LeaseUseResult:
        """The result of using ``lease``: ok while it is the current epoch and not revoked."""
        r = lease_pb2.LeaseUseResult(attempted_lease=lease)
        r.latest_known_lease.CopyFrom(self.lease())
        if self.lease_owner:
            r.owner.client_name = self.lease_owner
        if lease.epoch != self.epoch or self.lease_owner is None:
            r.status = lease_pb2.LeaseUseResult.STATUS_WRONG_EPOCH
        elif self.revoked:
            r.status = lease_pb2.LeaseUseResult.STATUS_REVOKED
        elif not lease.sequence or lease.sequence[0] < self.lease_seq:
            r.status = lease_pb2.LeaseUseResult.STATUS_OLDER
        else:
            # the SDK's wallet advances the lease's sequence with each command: a newer one is
            # the current lease from then on
            self.lease_seq = lease.sequence[0]
            r.status = lease_pb2.LeaseUseResult.STATUS_OK
        return r


def header(robot: Robot, request, code=header_pb2.CommonError.CODE_OK) -> header_pb2.ResponseHeader:
    h = header_pb2.ResponseHeader()
    h.request_header.CopyFrom(request.header)
    h.request_received_timestamp.FromNanoseconds(robot.robot_ns())
    h.response_timestamp.FromNanoseconds(robot.robot_ns())
    h.error.code = code
    return h


def authorized(context) -> bool:
    md = dict(context.invocation_metadata())
    return md.get("authorization") == f"Bearer {TOKEN}"


class RobotIdServicer(robot_id_service_pb2_grpc.RobotIdServiceServicer):
    def __init__(self, robot):
        self.r = robot

    def GetRobotId(self, request, context):
        resp = robot_id_pb2.RobotIdResponse(header=header(self.r, request))
        resp.robot_id.serial_number = "fake-spot-0"
        resp.robot_id.nickname = "fake-spot"
        return resp


class AuthServicer(auth_service_pb2_grpc.AuthServiceServicer):
    def __init__(self, robot):
        self.r = robot

    def GetAuthToken(self, request, context):
        ok = (request.username, request.password) == (USERNAME, PASSWORD) or (
            request.token == TOKEN
        )
        self.r.record("auth", username=request.username, ok=ok)
        resp = auth_pb2.GetAuthTokenResponse(header=header(self.r, request))
        if ok:
            resp.status, resp.token = auth_pb2.GetAuthTokenResponse.STATUS_OK, TOKEN
        else:
            resp.status = auth_pb2.GetAuthTokenResponse.STATUS_INVALID_LOGIN
        return resp


class DirectoryServicer(directory_service_pb2_grpc.DirectoryServiceServicer):
    def __init__(self, robot):
        self.r = robot

    @staticmethod
    def entry(name, type_, authority):
        return directory_pb2.ServiceEntry(name=name, type=type_, authority=authority,
                                          user_token_required=True)

    def ListServiceEntries(self, request, context):
        resp = directory_pb2.ListServiceEntriesResponse(header=header(self.r, request))
        resp.service_entries.extend(self.entry(*s) for s in SERVICES)
        return resp

    def GetServiceEntry(self, request, context):
        resp = directory_pb2.GetServiceEntryResponse(header=header(self.r, request))
        for s in SERVICES:
            if s[0] == request.service_name:
                resp.status = directory_pb2.GetServiceEntryResponse.STATUS_OK
                resp.service_entry.CopyFrom(self.entry(*s))
                return resp
        resp.status = directory_pb2.GetServiceEntryResponse.STATUS_NONEXISTENT_SERVICE
        return resp


class TimeSyncServicer(time_sync_service_pb2_grpc.TimeSyncServiceServicer):
    """Estimates the skew from the client's round trips as the robot does (NTP's formula)."""

    def __init__(self, robot):
        self.r = robot

    def TimeSyncUpdate(self, request, context):
        resp = time_sync_pb2.TimeSyncUpdateResponse(header=header(self.r, request))
        resp.clock_identifier = request.clock_identifier or "fake-spot-clock"
        rt = request.previous_round_trip
        with self.r.lock:
            if request.HasField("previous_round_trip"):
                t0, t1 = rt.client_tx.ToNanoseconds(), rt.server_rx.ToNanoseconds()
                t2, t3 = rt.server_tx.ToNanoseconds(), rt.client_rx.ToNanoseconds()
                rtt = (t3 - t0) - (t2 - t1)
                skew = ((t1 - t0) + (t2 - t3)) // 2
                if self.r.best_rtt is None or rtt <= self.r.best_rtt[0]:
                    self.r.best_rtt = (rtt, skew)
                self.r.timesync_samples += 1
            if self.r.timesync_samples >= 3:
                resp.state.status = time_sync_pb2.TimeSyncState.STATUS_OK
                rtt, skew = self.r.best_rtt
                resp.state.best_estimate.round_trip_time.FromNanoseconds(rtt)
                resp.state.best_estimate.clock_skew.FromNanoseconds(skew)
            else:
                resp.state.status = time_sync_pb2.TimeSyncState.STATUS_MORE_SAMPLES_NEEDED
        return resp


class LeaseServicer(lease_service_pb2_grpc.LeaseServiceServicer):
    def __init__(self, robot):
        self.r = robot

    def AcquireLease(self, request, context):
        resp = lease_pb2.AcquireLeaseResponse(header=header(self.r, request))
        name = request.header.client_name
        with self.r.lock:
            if request.resource != "body":
                resp.status = lease_pb2.AcquireLeaseResponse.STATUS_INVALID_RESOURCE
            elif self.r.lease_owner not in (None, name):
                resp.status = lease_pb2.AcquireLeaseResponse.STATUS_RESOURCE_ALREADY_CLAIMED
                resp.lease_owner.client_name = self.r.lease_owner
            else:
                self.r.epoch = f"epoch-{time.monotonic_ns()}"
                self.r.lease_seq, self.r.lease_owner, self.r.revoked = 1, name, False
                resp.status = lease_pb2.AcquireLeaseResponse.STATUS_OK
                resp.lease.CopyFrom(self.r.lease())
                resp.lease_owner.client_name = name
        self.r.record("lease_acquire", client=name,
                      ok=resp.status == lease_pb2.AcquireLeaseResponse.STATUS_OK)
        return resp

    def TakeLease(self, request, context):
        resp = lease_pb2.TakeLeaseResponse(header=header(self.r, request))
        resp.status = lease_pb2.TakeLeaseResponse.STATUS_INVALID_RESOURCE
        self.r.record("lease_take", client=request.header.client_name)
        return resp

    def ReturnLease(self, request, context):
        resp = lease_pb2.ReturnLeaseResponse(header=header(self.r, request))
        with self.r.lock:
            use = self.r.lease_use(request.lease)
            if use.status == lease_pb2.LeaseUseResult.STATUS_OK:
                self.r.lease_owner = None
                resp.status = lease_pb2.ReturnLeaseResponse.STATUS_OK
            else:
                resp.status = lease_pb2.ReturnLeaseResponse.STATUS_NOT_ACTIVE_LEASE
        self.r.record("lease_return", ok=resp.status == lease_pb2.ReturnLeaseResponse.STATUS_OK)
        return resp

    def RetainLease(self, request, context):
        resp = lease_pb2.RetainLeaseResponse(header=header(self.r, request))
        with self.r.lock:
            resp.lease_use_result.CopyFrom(self.r.lease_use(request.lease))
        status = lease_pb2.LeaseUseResult.Status.Name(resp.lease_use_result.status)
        self.r.record("lease_retain", status=status)
        return resp

    def ListLeases(self, request, context):
        return lease_pb2.ListLeasesResponse(header=header(self.r, request))


class EstopServicer(estop_service_pb2_grpc.EstopServiceServicer):
    def __init__(self, robot):
        self.r = robot

    def GetEstopConfig(self, request, context):
        resp = estop_pb2.GetEstopConfigResponse(header=header(self.r, request))
        with self.r.lock:
            resp.active_config.CopyFrom(self.r.estop_config)
        return resp

    def SetEstopConfig(self, request, context):
        resp = estop_pb2.SetEstopConfigResponse(header=header(self.r, request))
        with self.r.lock:
            if request.target_config_id != self.r.estop_config.unique_id:
                resp.status = estop_pb2.SetEstopConfigResponse.STATUS_INVALID_ID
                return resp
            cfg = estop_pb2.EstopConfig()
            cfg.CopyFrom(request.config)
            cfg.unique_id = f"config-{time.monotonic_ns()}"
            for i, e in enumerate(cfg.endpoints):
                e.unique_id = f"endpoint-{i}"
            self.r.estop_config = cfg
            self.r.estop_endpoint = None
            resp.active_config.CopyFrom(cfg)
            resp.status = estop_pb2.SetEstopConfigResponse.STATUS_SUCCESS
        return resp

    def RegisterEstopEndpoint(self, request, context):
        resp = estop_pb2.RegisterEstopEndpointResponse(header=header(self.r, request))
        with self.r.lock:
            if request.target_config_id != self.r.estop_config.unique_id:
                resp.status = estop_pb2.RegisterEstopEndpointResponse.STATUS_CONFIG_MISMATCH
                return resp
            ep = estop_pb2.EstopEndpoint()
            ep.CopyFrom(request.new_endpoint)
            ep.unique_id = f"registered-{time.monotonic_ns()}"
            self.r.estop_endpoint = (ep.unique_id, ep.timeout.ToNanoseconds() * 1e-9)
            self.r.last_checkin, self.r.timeout_estop = time.monotonic(), False
            self.r.endpoint_level = estop_pb2.ESTOP_LEVEL_CUT
            resp.new_endpoint.CopyFrom(ep)
            resp.status = estop_pb2.RegisterEstopEndpointResponse.STATUS_SUCCESS
        self.r.record("estop_register", name=ep.name, timeout_s=self.r.estop_endpoint[1])
        return resp

    def DeregisterEstopEndpoint(self, request, context):
        resp = estop_pb2.DeregisterEstopEndpointResponse(header=header(self.r, request))
        with self.r.lock:
            self.r.estop_endpoint = None
        resp.status = estop_pb2.DeregisterEstopEndpointResponse.STATUS_SUCCESS
        self.r.record("estop_deregister")
        return resp

    def EstopCheckIn(self, request, context):
        resp = estop_pb2.EstopCheckInResponse(header=header(self.r, request))
        resp.request.CopyFrom(request)
        with self.r.lock:
            known = self.r.estop_endpoint is not None and (
                request.endpoint.unique_id == self.r.estop_endpoint[0]
            )
            # the response to a challenge is its bitwise complement (bosdyn.client.estop)
            right = request.response == (~request.challenge & 0xFFFFFFFFFFFFFFFF)
            if not known:
                resp.status = estop_pb2.EstopCheckInResponse.STATUS_ENDPOINT_UNKNOWN
            elif self.r.last_challenge is not None and not right:
                resp.status = estop_pb2.EstopCheckInResponse.STATUS_INCORRECT_CHALLENGE_RESPONSE
            else:
                resp.status = estop_pb2.EstopCheckInResponse.STATUS_OK
                self.r.last_checkin = time.monotonic()
                self.r.endpoint_level = request.stop_level
                self.r.timeout_estop = False
            self.r.last_challenge = int.from_bytes(os.urandom(6), "little")
            resp.challenge = self.r.last_challenge
        self.r.record("estop_checkin", level=estop_pb2.EstopStopLevel.Name(request.stop_level),
                      status=estop_pb2.EstopCheckInResponse.Status.Name(resp.status))
        return resp

    def GetEstopSystemStatus(self, request, context):
        return estop_pb2.GetEstopSystemStatusResponse(header=header(self.r, request))


class RobotStateServicer(robot_state_service_pb2_grpc.RobotStateServiceServicer):
    def __init__(self, robot):
        self.r = robot

    def GetRobotState(self, request, context):
        self.r.step()
        resp = robot_state_pb2.RobotStateResponse(header=header(self.r, request))
        s = resp.robot_state
        r = self.r
        with r.lock:
            now = r.robot_ns()
            s.power_state.timestamp.FromNanoseconds(now)
            s.power_state.motor_power_state = (
                robot_state_pb2.PowerState.MOTOR_POWER_STATE_ON
                if r.motors_on
                else robot_state_pb2.PowerState.MOTOR_POWER_STATE_OFF
            )
            b = s.battery_states.add()
            b.identifier = "battery-0"
            b.voltage.value = 54.5
            b.charge_percentage.value = 87.0
            for name, stopped in (("software_estop", r.remote_estop),
                                  ("mimnav-spot", r.timeout_estop or r.estop_endpoint is None
                                   or r.endpoint_level != estop_pb2.ESTOP_LEVEL_NONE)):
                e = s.estop_states.add(name=name, type=robot_state_pb2.EStopState.TYPE_SOFTWARE)
                e.timestamp.FromNanoseconds(now)
                e.state = (robot_state_pb2.EStopState.STATE_ESTOPPED if stopped
                           else robot_state_pb2.EStopState.STATE_NOT_ESTOPPED)
            k = s.kinematic_state
            k.acquisition_timestamp.FromNanoseconds(now)
            # the robot's frame tree is rooted at the body: odom's parent is the body, the edge
            # holds body_tform_odom (the inverse of the body's pose in odom)
            snap = k.transforms_snapshot
            snap.child_to_parent_edge_map["body"].parent_frame_name = ""
            edge = snap.child_to_parent_edge_map["odom"]
            edge.parent_frame_name = "body"
            c, si = math.cos(r.yaw), math.sin(r.yaw)
            p = edge.parent_tform_child
            p.position.x = -(c * r.x + si * r.y)
            p.position.y = -(-si * r.x + c * r.y)
            p.rotation.w, p.rotation.z = math.cos(-r.yaw / 2), math.sin(-r.yaw / 2)
            vo = k.velocity_of_body_in_odom
            vo.linear.x, vo.linear.y = r.vx * c, r.vx * si
            vo.angular.z = r.vrot
        return resp


class RobotCommandServicer(robot_command_service_pb2_grpc.RobotCommandServiceServicer):
    def __init__(self, robot):
        self.r = robot

    def RobotCommand(self, request, context):
        r = self.r
        r.step()
        resp = robot_command_pb2.RobotCommandResponse(header=header(r, request))
        cmd = request.command
        mob = cmd.synchronized_command.mobility_command
        if cmd.full_body_command.HasField("stop_request"):
            kind, rec = "stop", {}
        elif mob.HasField("se2_velocity_request"):
            vr = mob.se2_velocity_request
            end = vr.end_time.ToNanoseconds()
            kind = "velocity"
            rec = dict(v_x=vr.velocity.linear.x, v_y=vr.velocity.linear.y,
                       v_rot=vr.velocity.angular, end_robot_ns=end,
                       end_mono_ns=r.robot_to_mono_ns(end), frame=vr.se2_frame_name)
        elif mob.HasField("stand_request"):
            kind, rec = "stand", {}
        elif cmd.full_body_command.HasField("safe_power_off_request"):
            kind, rec = "safe_power_off", {}
        else:
            kind, rec = "other", {}
        with r.lock:
            resp.lease_use_result.CopyFrom(r.lease_use(request.lease))
            if resp.lease_use_result.status != lease_pb2.LeaseUseResult.STATUS_OK:
                resp.status = robot_command_pb2.RobotCommandResponse.STATUS_UNKNOWN
            elif not r.motors_on:
                resp.status = robot_command_pb2.RobotCommandResponse.STATUS_NOT_POWERED_ON
            elif kind == "velocity" and rec["end_robot_ns"] <= r.robot_ns():
                resp.status = robot_command_pb2.RobotCommandResponse.STATUS_EXPIRED
            else:
                resp.status = robot_command_pb2.RobotCommandResponse.STATUS_OK
                r.cmd_id += 1
                resp.robot_command_id = r.cmd_id
                if kind == "velocity":
                    r.vx, r.vrot, r.vel_end_ns = rec["v_x"], rec["v_rot"], rec["end_robot_ns"]
                elif kind in ("stop", "safe_power_off"):
                    r.vx = r.vrot = 0.0
                    r.motors_on = kind == "stop"  # it sits, then cuts motor power
        rec["status"] = robot_command_pb2.RobotCommandResponse.Status.Name(resp.status)
        rec["lease"] = lease_pb2.LeaseUseResult.Status.Name(resp.lease_use_result.status)
        r.record(kind, **rec)
        return resp

    def RobotCommandFeedback(self, request, context):
        resp = robot_command_pb2.RobotCommandFeedbackResponse(header=header(self.r, request))
        resp.status = robot_command_pb2.RobotCommandFeedbackResponse.STATUS_PROCESSING
        return resp


class PowerServicer(power_service_pb2_grpc.PowerServiceServicer):
    def __init__(self, robot):
        self.r = robot

    def PowerCommand(self, request, context):
        r = self.r
        r.step()
        resp = power_pb2.PowerCommandResponse(header=header(r, request))
        with r.lock:
            resp.lease_use_result.CopyFrom(r.lease_use(request.lease))
            if resp.lease_use_result.status != lease_pb2.LeaseUseResult.STATUS_OK:
                resp.status = power_pb2.STATUS_UNKNOWN
            elif r.estopped():
                resp.status = power_pb2.STATUS_ESTOPPED
            else:
                r.motors_on = request.request == power_pb2.PowerCommandRequest.REQUEST_ON_MOTORS
                r.power_cmd += 1
                resp.power_command_id = r.power_cmd
                resp.status = power_pb2.STATUS_SUCCESS
        r.record("power", request=power_pb2.PowerCommandRequest.Request.Name(request.request),
                 status=power_pb2.PowerCommandStatus.Name(resp.status))
        return resp

    def PowerCommandFeedback(self, request, context):
        resp = power_pb2.PowerCommandFeedbackResponse(header=header(self.r, request))
        resp.status = power_pb2.STATUS_SUCCESS
        return resp


class TokenCheck(grpc.ServerInterceptor):
    """Refuses every call but auth and robot-id without the token auth gave."""

    def intercept_service(self, continuation, details):
        if details.method.startswith(("/bosdyn.api.AuthService/", "/bosdyn.api.RobotIdService/")):
            return continuation(details)
        md = dict(details.invocation_metadata)
        if md.get("authorization") == f"Bearer {TOKEN}":
            return continuation(details)

        def deny(request, context):
            context.abort(grpc.StatusCode.UNAUTHENTICATED, "no valid user token")

        return grpc.unary_unary_rpc_method_handler(deny)


def serve(args) -> int:
    ca, key, crt = make_certs(args.cert_dir)
    robot = Robot(args.skew, sys.stdout)
    server = grpc.server(futures.ThreadPoolExecutor(max_workers=8), interceptors=[TokenCheck()])
    for add, servicer in (
        (robot_id_service_pb2_grpc.add_RobotIdServiceServicer_to_server, RobotIdServicer),
        (auth_service_pb2_grpc.add_AuthServiceServicer_to_server, AuthServicer),
        (directory_service_pb2_grpc.add_DirectoryServiceServicer_to_server, DirectoryServicer),
        (time_sync_service_pb2_grpc.add_TimeSyncServiceServicer_to_server, TimeSyncServicer),
        (lease_service_pb2_grpc.add_LeaseServiceServicer_to_server, LeaseServicer),
        (estop_service_pb2_grpc.add_EstopServiceServicer_to_server, EstopServicer),
        (robot_state_service_pb2_grpc.add_RobotStateServiceServicer_to_server,
         RobotStateServicer),
        (robot_command_service_pb2_grpc.add_RobotCommandServiceServicer_to_server,
         RobotCommandServicer),
        (power_service_pb2_grpc.add_PowerServiceServicer_to_server, PowerServicer),
    ):
        add(servicer(robot), server)
    with open(key, "rb") as k, open(crt, "rb") as c:
        creds = grpc.ssl_server_credentials([(k.read(), c.read())])
    port = server.add_secure_port(f"127.0.0.1:{args.port}", creds)
    server.start()
    robot.record("ready", port=port, ca=ca, username=USERNAME, password=PASSWORD,
                 skew_ns=robot.skew_ns)
    for line in sys.stdin:
        cmd = line.strip()
        with robot.lock:
            if cmd == "revoke_lease":
                robot.revoked, robot.lease_owner = True, "tablet"
            elif cmd == "release_lease":
                robot.revoked, robot.lease_owner = False, None
            elif cmd == "estop":
                robot.remote_estop = True
            elif cmd == "release_estop":
                robot.remote_estop = False
            elif cmd == "quit":
                break
        robot.step()
        robot.record("fault", what=cmd)
    server.stop(0)
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--port", type=int, default=0, help="TCP port on 127.0.0.1; 0: any free one")
    ap.add_argument("--cert-dir", required=True, help="where the CA and the server cert go")
    ap.add_argument("--skew", type=float, default=37.5, help="robot clock minus host clock, s")
    return serve(ap.parse_args())


if __name__ == "__main__":
    sys.exit(main())
