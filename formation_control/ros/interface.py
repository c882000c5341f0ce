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
``vehicle_k/formation_state``  sensor_msgs/JointState           see ``STATE_FIELDS``
``vehicle_k/cmd``              geometry_msgs/WrenchStamped      force.x = T, force.y = F (N);
                                                                torque.z = angular acceleration
                                                                (second_order) or turn rate
                                                                (first_order)
=============================  ===============================  ==============================

Fleet-wide: ``clock`` (lockstep), ``formation/scenario`` (std_msgs/String, latched: the
plant's scenario as JSON), ``formation/metrics`` (sensor_msgs/JointState: the names of
:data:`~formation_control.protocol.messages.METRIC_DOC` in ``name``, values in ``position``),
``formation/markers`` (from the ``monitor`` node), and the absolute ``/diagnostics`` that
diagnostic aggregators read. The names are those of :mod:`formation_control.protocol.names`,
the plain values of the messages those of :mod:`formation_control.protocol.messages`
(``STATE_FIELDS`` is there).

Every stamp is the time of the sample a message comes from; in lockstep it names the step.
"""

import copy
import struct

from formation_control.core.models import ROW_U, ROW_V
from formation_control.protocol.messages import (CMD_FIELDS, cmd_values, FormationState,
                                                 ODOM_FIELDS, odom_values, set_fields, set_stamp,
                                                 stamp_parts)
from formation_control.protocol.names import DEFAULT_FRAMES, WORLD_FRAME
from geometry_msgs.msg import TwistStamped, Vector3Stamped, WrenchStamped
from nav_msgs.msg import Odometry
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.qos_overriding_options import QoSOverridingOptions, QoSPolicyKind
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState
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


def state_qos_kwargs():
    """
    Keyword arguments of a state publisher or subscription.

    A fresh :data:`STATE_QOS` (rclpy writes the overrides into the profile it is given) that
    the ``qos_overrides`` parameters may change.
    """
    return {'qos_profile': copy.copy(STATE_QOS), 'qos_overriding_options': OVERRIDABLE}


LATCHED_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
"""The flow: published when it changes, kept for late joiners."""


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
    """Build the WrenchStamped of one vehicle's input column u (2,)."""
    msg = WrenchStamped()
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


def cmd_wire(k, frames=DEFAULT_FRAMES):
    """Return the :class:`MessageWire` of vehicle k's command (:data:`CMD_FIELDS`)."""
    msg = WrenchStamped()
    msg.header.frame_id = frames.base(k)
    return MessageWire(msg, CMD_FIELDS)


class MessageWire:
    """
    A stamped message of fixed layout as CDR bytes, its stamp and float64 ``fields`` in place.

    The plant sends N odometries and hears N commands each step, the vehicles the reverse:
    writing and reading them as bytes skips building message objects. The byte offsets of the
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


def state_msg(k, ns, X, view_row, hears=(), hearing=(), frames=DEFAULT_FRAMES):
    """
    formation_state of vehicle k: its pose, heading, yaw rate and the law's phase values.

    ``hears`` are its graph neighbours' ids and ``hearing`` whether it hears each (bool).
    """
    return formation_state_msg(k, FormationState.of_vehicle(ns, X, view_row,
                                                            dict(zip(hears, hearing))), frames)


def formation_state_msg(k, state, frames=DEFAULT_FRAMES):
    """Return the JointState of vehicle k's :class:`FormationState` ``state``."""
    msg = JointState()
    set_stamp(msg.header, state.stamp)
    msg.header.frame_id = frames.base(k)
    msg.name = list(state.names())
    msg.position = list(state.values())
    return msg


def scenario_msg(sc):
    return String(data=sc.to_json())


def metrics_msg(ns, values, world=WORLD_FRAME):
    """``formation/metrics``: JointState with the metric names and their values (position)."""
    msg = JointState()
    set_stamp(msg.header, ns)
    msg.header.frame_id = world
    msg.name = list(values)
    msg.position = [float(v) for v in values.values()]
    return msg
