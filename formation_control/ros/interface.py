# Copyright 2026 formation_control developers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
Topics, QoS and message conversions shared by the plant and the vehicle nodes.

Every name is relative, so a fleet lives in the namespace of its nodes (``-r __ns:=/fleet_a``)
and its topics can be remapped. Per vehicle k (1..N), in the world frame (``world_frame``,
default ``map``, REP-105) and SI units (REP-103):

=============================  ===============================  ==============================
topic                          type                             content
=============================  ===============================  ==============================
``vehicle_k/odom``             nav_msgs/Odometry                pose (yaw = heading theta),
                                                                twist in the base frame
                                                                (``vehicle_k/base_link``)
                                                                = ground velocity, yaw rate
``vehicle_k/flow``             geometry_msgs/Vector3Stamped     the local flow at the vehicle
                                                                (world frame; ``flow_source:
                                                                known``: latched once if
                                                                uniform, else with each
                                                                odometry, same stamp)
``vehicle_k/water_velocity``   geometry_msgs/TwistStamped       rigid bodies, ``flow_source:
                                                                estimated``: velocity through
                                                                the flow in the base frame
                                                                (u, v), as a DVL or airspeed
                                                                sensor gives it; with each
                                                                odometry, same stamp
``vehicle_k/formation_state``  formation_control_msgs/          what its neighbours need: pose,
                               FormationState                   phase, rate, speed predicted to
                                                                ``predicted_stamp``, whom it
                                                                hears, its flow estimate (world
                                                                frame)
``vehicle_k/cmd``              formation_control_msgs/          thrust, steering_force (N) or
                               VehicleCommand                   angular_acceleration
                                                                (second_order) or turn_rate
                                                                (first_order), by ``kind``
``vehicle_k/cmd_vel``          geometry_msgs/TwistStamped       aircraft (``plant_backend:
                                                                jsbsim``): the autopilot
                                                                demand, linear.x airspeed,
                                                                angular.z turn rate, base
                                                                frame; the plant flies it
                                                                (``cmd`` is then monitoring)
=============================  ===============================  ==============================

Fleet-wide: ``clock`` (lockstep), ``formation/scenario`` (std_msgs/String, latched: the
plant's scenario as JSON), ``formation/metrics`` (formation_control_msgs/FormationMetrics:
every metric of :data:`~formation_control.protocol.messages.METRIC_DOC` by name, the
convergence latch), ``formation/faults`` (formation_control_msgs/FaultEvent, from ``swarm``),
``formation/markers`` (from the ``monitor`` node), and the absolute ``/diagnostics`` that
diagnostic aggregators read. The names are those of :mod:`formation_control.protocol.names`,
the plain values of the messages and their canonical bytes those of
:mod:`formation_control.protocol.messages`.

Every stamp is the time of the sample a message comes from; in lockstep it names the step.
"""

import copy
import math
import struct

from formation_control.core.models import ROW_U, ROW_V
from formation_control.protocol.messages import (CMD_FIELDS, cmd_values, CMD_VEL_FIELDS,
                                                 command_kind, CommandWire, FormationState,
                                                 METRIC_DOC, ODOM_FIELDS, odom_values,
                                                 set_fields, set_stamp, set_time, stamp_parts)
from formation_control.protocol.names import DEFAULT_FRAMES, WORLD_FRAME
import formation_control_msgs.msg as fcm
from geometry_msgs.msg import TwistStamped, Vector3Stamped
from nav_msgs.msg import Odometry
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.qos_overriding_options import QoSOverridingOptions, QoSPolicyKind
from rclpy.serialization import serialize_message
from std_msgs.msg import String

STALL = 3.0
"""Lockstep: after this many wall seconds without progress, a node says what it waits for."""


STATE_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                       reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL)
"""Odometry, formation states and commands: every sample of a lockstep step must arrive, and a
node that joins late gets the latest ones (transient local)."""


OVERRIDABLE = QoSOverridingOptions([QoSPolicyKind.RELIABILITY, QoSPolicyKind.HISTORY,
                                    QoSPolicyKind.DEPTH, QoSPolicyKind.DURABILITY])
"""Odometry, formation states and commands take ROS 2's ``qos_overrides.<topic>.publisher|
subscription.<policy>`` parameters (lossy radio links: docs/deployment.md)."""


READER_DEPTH = 100
"""History of a state subscription: a burst (a flood of bad samples, a node that paused) of up
to this many samples is taken, not overwritten before the node reads it; late joiners still get
the publishers' :data:`STATE_QOS` depth."""


def state_qos_kwargs(reader=False):
    """
    Keyword arguments of a state publisher or (``reader``) subscription.

    A fresh :data:`STATE_QOS` (rclpy writes the overrides into the profile it is given), of
    depth :data:`READER_DEPTH` for a reader, that the ``qos_overrides`` parameters may change.
    """
    profile = copy.copy(STATE_QOS)
    if reader:
        profile.depth = READER_DEPTH
    return {'qos_profile': profile, 'qos_overriding_options': OVERRIDABLE}


def relaxed(profile, kind):
    """
    Return a copy of ``profile`` that a publisher offering less of policy ``kind`` matches.

    A volatile publisher (the ROS default) matches a volatile reader only, a best-effort one
    (sensor data) a best-effort reader only; None for another policy (no sample is kept
    then: the reader stays as it is and says why).
    """
    out = copy.copy(profile)
    if kind == QoSPolicyKind.DURABILITY:
        out.durability = DurabilityPolicy.VOLATILE
    elif kind == QoSPolicyKind.RELIABILITY:
        out.reliability = ReliabilityPolicy.BEST_EFFORT
    else:
        return None
    return out


LATCHED_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
"""The flow: published when it changes, kept for late joiners."""
LATCHED_READER_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=READER_DEPTH,
                                reliability=ReliabilityPolicy.RELIABLE,
                                durability=DurabilityPolicy.TRANSIENT_LOCAL)
"""A subscription to a latched topic (the flow, the scenario, the start): a burst of other
samples after the one that counts does not overwrite it before the node reads it."""


FAULTS_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                        reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL)
"""The faults of a run: every one kept for late joiners."""


STREAM_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                        reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.VOLATILE)
"""``formation/metrics``, ``formation/markers`` and ``/diagnostics``."""


def water_velocity_msg(k, ns, X, frames=DEFAULT_FRAMES):
    """Return the TwistStamped of vehicle k's through-flow velocity (u, v; its base frame)."""
    msg = TwistStamped()
    set_stamp(msg.header, ns)
    msg.header.frame_id = frames.base(k)
    msg.twist.linear.x, msg.twist.linear.y = float(X[ROW_U]), float(X[ROW_V])
    return msg


def odom_msg(k, ns, X, flow, frames=DEFAULT_FRAMES):
    """Odometry of vehicle k from its state column X (6,): ground velocity in the body frame."""
    msg = Odometry()
    set_stamp(msg.header, ns)
    msg.header.frame_id = frames.world
    msg.child_frame_id = frames.base(k)
    return set_fields(msg, ODOM_FIELDS, odom_values(X, flow))


def flow_msg(k, ns, flow, frames=DEFAULT_FRAMES):
    """Return the Vector3Stamped of the flow (complex m/s) at vehicle k, world frame."""
    msg = Vector3Stamped()
    set_stamp(msg.header, ns)
    msg.header.frame_id = frames.world
    msg.vector.x, msg.vector.y = flow.real, flow.imag
    return msg


def cmd_msg(k, ns, u, model, frames=DEFAULT_FRAMES):
    """Build the VehicleCommand of vehicle k's input column u (2,)."""
    msg = fcm.VehicleCommand(vehicle_id=k, kind=command_kind(model))
    set_stamp(msg.header, ns)
    msg.header.frame_id = frames.base(k)
    return set_fields(msg, CMD_FIELDS, cmd_values(u, model))


def odom_wire(k, frames=DEFAULT_FRAMES, covariance=None):
    """
    Return the :class:`MessageWire` of vehicle k's odometry (:data:`ODOM_FIELDS`).

    ``covariance``: the (pose, twist) covariances it carries (:func:`sensors.covariances`).
    """
    msg = Odometry()
    msg.header.frame_id, msg.child_frame_id = frames.world, frames.base(k)
    if covariance is not None:
        msg.pose.covariance, msg.twist.covariance = covariance
    return MessageWire(msg, ODOM_FIELDS)


def cmd_vel_wire(k, frames=DEFAULT_FRAMES):
    """Return the :class:`MessageWire` of aircraft k's ``cmd_vel`` (:data:`CMD_VEL_FIELDS`)."""
    msg = TwistStamped()
    msg.header.frame_id = frames.base(k)
    return MessageWire(msg, CMD_VEL_FIELDS)


def cmd_wire(k, model, frames=DEFAULT_FRAMES):
    """Return the :class:`~formation_control.protocol.messages.CommandWire` of vehicle k."""
    return CommandWire(k, model, frames)


class MessageWire:
    """
    A stamped message of fixed layout as CDR bytes, its stamp and float64 ``fields`` in place.

    The plant sends N odometries each step, each vehicle hears its own: writing and reading
    them as bytes skips building message objects (the formation states and commands have
    their wires in :mod:`formation_control.protocol.messages`). The byte offsets of the
    fields are found by serializing ``msg`` with a distinct value in each. ``decode`` returns
    None for bytes whose other content (frame ids, the zero fields) differs from ``msg``'s,
    which the caller then deserializes and checks as a message.
    """

    def __init__(self, msg, fields):
        marked = copy.deepcopy(msg)
        marks = [(i + 1) * 1.2345678901234567e-250 for i in range(len(fields))]
        data = serialize_message(set_fields(marked, fields, marks))
        self.offsets = [data.find(struct.pack('<d', v)) for v in marks]
        if min(self.offsets) < 12 or any(data.count(struct.pack('<d', v)) != 1 for v in marks):
            raise ValueError(f'cannot locate the fields {fields} in {type(msg).__name__}')
        zeros = [0.0] * len(fields)
        self.template = serialize_message(set_fields(copy.deepcopy(msg), fields, zeros))
        cuts = sorted([(4, 12)] + [(o, o + 8) for o in self.offsets])
        ends = [0] + [b for _, b in cuts]
        self.constant = [(a, c) for a, (c, _) in zip(ends, cuts + [(len(self.template), 0)])
                         if c > a]

    def encode(self, ns, values):
        """Return the bytes of the message stamped ``ns`` (ns) with the field ``values``."""
        buf = bytearray(self.template)
        struct.pack_into('<iI', buf, 4, *stamp_parts(ns))
        for offset, value in zip(self.offsets, values):
            struct.pack_into('<d', buf, offset, value)
        return bytes(buf)

    def decode(self, data):
        """Return (stamp in ns, field values) of bytes in this layout, else None."""
        if len(data) != len(self.template) or any(
                data[a:b] != self.template[a:b] for a, b in self.constant):
            return None
        sec, nanosec = struct.unpack_from('<iI', data, 4)
        return (sec * 1_000_000_000 + nanosec,
                tuple(struct.unpack_from('<d', data, o)[0] for o in self.offsets))


def state_msg(k, ns, X, view_row, hears=(), hearing=(), frames=DEFAULT_FRAMES, ahead=0):
    """
    formation_state of vehicle k: its pose, heading, yaw rate and the law's phase values.

    ``hears`` are its graph neighbours' ids and ``hearing`` whether it hears each (bool).
    """
    return formation_state_msg(k, FormationState.of_vehicle(
        ns, X, view_row, dict(zip(hears, hearing)), ahead=ahead), frames)


def formation_state_msg(k, state, frames=DEFAULT_FRAMES):
    """Return the FormationState message of vehicle k's :class:`FormationState` ``state``."""
    msg = fcm.FormationState(vehicle_id=k, **state.fields())
    set_stamp(msg.header, state.stamp)
    set_time(msg.predicted_stamp, state.predicted_stamp)
    msg.header.frame_id = frames.world
    return msg


def scenario_msg(sc):
    return String(data=sc.to_json())


def metrics_msg(ns, values, world=WORLD_FRAME, t=math.nan, since=None):
    """
    ``formation/metrics``: the FormationMetrics of ``values`` ({metric: value}) stamped ns.

    A metric of :data:`~formation_control.protocol.messages.METRIC_DOC` without a value (it
    does not apply to the scenario) is NaN. ``t`` is the fleet time (s) of the sample,
    ``since`` when the convergence latch last latched (s, None: not converged).
    """
    msg = fcm.FormationMetrics(time=float(t), converged=since is not None,
                               convergence_time=math.nan if since is None else float(since))
    set_stamp(msg.header, ns)
    msg.header.frame_id = world
    for name in METRIC_DOC:
        value = values.get(name, math.nan)
        setattr(msg, name, int(value) if name == 'live_links' else float(value))
    return msg


def fault_msg(fault, record, ns):
    """
    ``formation/faults``: the FaultEvent of an applied fault.

    ``fault`` is a :class:`~formation_control.protocol.faults.Fault`, ``record`` the swarm's
    (``fault``, ``action``, ``scheduled``, ``applied``: fleet time or None); ``ns`` the wall
    time of publication.
    """
    applied = record['applied']
    msg = fcm.FaultEvent(kind=getattr(fcm.FaultEvent, fault.kind.upper()),
                         vehicle_ids=list(fault.vehicles), fault=record['fault'],
                         action=record['action'], scheduled_time=float(record['scheduled']),
                         applied=applied is not None,
                         applied_time=math.nan if applied is None else float(applied))
    set_stamp(msg.header, ns)
    return msg
