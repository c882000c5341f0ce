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

Per vehicle k (1..N), in the ``map`` frame (REP-105) and SI units (REP-103):

=============================  ===============================  ==============================
topic                          type                             content
=============================  ===============================  ==============================
``/vehicle_k/odom``            nav_msgs/Odometry                pose (yaw = heading theta),
                                                                twist in ``vehicle_k/base_link``
                                                                = ground velocity, yaw rate
``/vehicle_k/flow``            geometry_msgs/Vector3Stamped     flow the vehicle measures (map)
``/vehicle_k/formation_state`` sensor_msgs/JointState           see :data:`STATE_FIELDS`
``/vehicle_k/cmd``             geometry_msgs/WrenchStamped      force.x = T, force.y = F (N);
                                                                torque.z = angular acceleration
                                                                (second_order) or turn rate
                                                                (first_order)
=============================  ===============================  ==============================

Fleet-wide: ``/formation/scenario`` (std_msgs/String, latched: the plant's scenario as JSON),
``/formation/metrics`` (sensor_msgs/JointState: :data:`METRIC_DOC` names in ``name``, values
in ``position``), ``/diagnostics`` and ``/formation/markers`` (from the ``monitor`` node).

Every stamp is the time of the state it carries; in lockstep it names the step.
"""
import copy
import math
import struct

from formation_control.core.models import (ground_velocity, PARTICLE_MODELS, position,
                                           ROW_OMEGA, ROW_THETA)
from geometry_msgs.msg import Vector3Stamped, WrenchStamped
from nav_msgs.msg import Odometry
import numpy as np
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.qos_overriding_options import QoSOverridingOptions, QoSPolicyKind
from sensor_msgs.msg import JointState
from std_msgs.msg import String

MAP_FRAME = 'map'
DIAGNOSTICS_TOPIC = '/diagnostics'
SCENARIO_TOPIC = '/formation/scenario'
METRICS_TOPIC = '/formation/metrics'
MARKERS_TOPIC = '/formation/markers'
STALL = 3.0
"""Lockstep: after this many wall seconds without progress, a node says what it waits for."""
METRIC_DOC = {
    'order_parameter': '|p|, modulus of the mean phase vector (1.10); 1 = parallel',
    'potential': 'formation potential V (1.11), (1.14), (7.18)',
    'lyapunov': 'composite Lyapunov value V_c = V + sum z_k^2 / 2 (2.10)',
    'max_turn_rate': 'max_k |phase rate| (rad/s)',
    'centre_spread': 'circular: max_k |c_k - mean c| (m), c_k = r_k + i e_k / omega0',
    'radius': 'circular: mean_k |r_k - mean c| (m); target 1/|omega0|',
    'centre_x': 'circular: mean circle centre, x (m, map)',
    'centre_y': 'circular: mean circle centre, y (m, map)',
    'speed_error': 'rigid bodies: mean_k |u_k - u0| (m/s)',
    'crab_angle': 'rigid bodies: mean_k beta_k = atan2(v_k, u_k) (rad), flow-relative',
    'crab_angle_inertial': 'rigid bodies: mean_k beta_hat_k = gamma_k - theta_k (rad) (8.1)',
    'live_links': 'links of the communication graph that are live (both ends heard recently, '
                  'each hearing the other)',
    'algebraic_connectivity': 'lambda_2 of the Laplacian of the live graph (the vehicles heard '
                              'recently and their live links); 0 = disconnected',
}
STATE_FIELDS = ('x', 'y', 'heading', 'yaw_rate', 'phase', 'phase_rate', 'speed')
"""formation_state: JointState.name, and .position holds these values (m, rad, rad/s, m/s);
on a communication graph other than the complete one, ``hears_j`` follows for each graph
neighbour j of the sender: 1 while it hears j, else 0 (:func:`state_names`)."""


def state_names(hears=()):
    """Return the names of a formation_state whose sender's graph neighbours are ``hears``."""
    return STATE_FIELDS + tuple(f'hears_{j}' for j in hears)


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

STREAM_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                        reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.VOLATILE)
"""``/formation/metrics``, ``/formation/markers`` and ``/diagnostics``."""


def yaw_quaternion(orientation, theta):
    """Write the quaternion of a yaw ``theta`` (rad, CCW about z) into ``orientation``."""
    orientation.z = math.sin(0.5 * theta)
    orientation.w = math.cos(0.5 * theta)


def topic(k, name):
    return f'/vehicle_{k}/{name}'


def base_link(k):
    return f'vehicle_{k}/base_link'


def stamp_ns(stamp):
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def set_stamp(header, ns):
    header.stamp.sec, header.stamp.nanosec = divmod(int(ns), 1_000_000_000)


def odom_msg(k, ns, X, flow):
    """Odometry of vehicle k from its state column X (6,): ground velocity in the body frame."""
    msg = Odometry()
    set_stamp(msg.header, ns)
    msg.header.frame_id = MAP_FRAME
    msg.child_frame_id = base_link(k)
    theta = float(X[ROW_THETA])
    r = complex(position(X))
    msg.pose.pose.position.x, msg.pose.pose.position.y = r.real, r.imag
    yaw_quaternion(msg.pose.pose.orientation, theta)
    body = complex(ground_velocity(X, flow)) * complex(math.cos(theta), -math.sin(theta))
    msg.twist.twist.linear.x, msg.twist.twist.linear.y = body.real, body.imag
    msg.twist.twist.angular.z = float(X[ROW_OMEGA])
    return msg


def state_from_odom(msg, flow, model):
    """Return the state column (6,) of a vehicle from its Odometry and the flow it measures."""
    q = msg.pose.pose.orientation
    theta = 2.0 * math.atan2(q.z, q.w)
    tw = msg.twist.twist
    rel = complex(tw.linear.x, tw.linear.y) - flow * complex(math.cos(theta), -math.sin(theta))
    if model in PARTICLE_MODELS:
        rel = 1.0 + 0j
    p = msg.pose.pose.position
    return np.array([p.x, p.y, theta, tw.angular.z, rel.real, rel.imag])


def flow_msg(k, ns, flow):
    msg = Vector3Stamped()
    set_stamp(msg.header, ns)
    msg.header.frame_id = MAP_FRAME
    msg.vector.x, msg.vector.y = flow.real, flow.imag
    return msg


def cmd_msg(k, ns, u, model):
    """Build the WrenchStamped of one vehicle's input column u (2,)."""
    msg = WrenchStamped()
    set_stamp(msg.header, ns)
    msg.header.frame_id = base_link(k)
    if model in PARTICLE_MODELS:
        msg.wrench.torque.z = float(u[1])
    else:
        msg.wrench.force.x, msg.wrench.force.y = float(u[0]), float(u[1])
    return msg


def input_from_cmd(msg, model):
    w = msg.wrench
    if model in PARTICLE_MODELS:
        return 0.0, w.torque.z
    return w.force.x, w.force.y


def state_msg(k, ns, X, view_row, hears=(), hearing=()):
    """
    formation_state of vehicle k: its pose, heading, yaw rate and the law's phase values.

    ``hears`` are its graph neighbours' ids and ``hearing`` whether it hears each (bool).
    """
    msg = JointState()
    set_stamp(msg.header, ns)
    msg.header.frame_id = base_link(k)
    msg.name = list(state_names(hears))
    msg.position = list(state_values(X, view_row, hearing))
    return msg


def state_values(X, view_row, hearing=()):
    """Return the values of one vehicle's formation_state (:func:`state_names` order)."""
    r, phase, rate, speed = view_row
    return (r.real, r.imag, float(X[ROW_THETA]), float(X[ROW_OMEGA]), phase, rate, speed,
            *(float(h) for h in hearing))


class StateWire:
    """
    Vehicle k's formation_state as serialized bytes, without message objects.

    sensor_msgs/JointState in little-endian CDR: every vehicle sends one and hears one from
    each neighbour every step. ``encode`` writes the canonical layout (zero padding, empty
    velocity and effort) of the names :func:`state_names` gives for the graph neighbours
    ``hears``, which ``decode`` reads in place; it returns None for any other bytes, which the
    caller then deserializes and checks as a message.
    """

    HEADER = b'\x00\x01\x00\x00'                      # CDR, little endian; alignment origin 4

    def __init__(self, k, hears=()):
        self.names = state_names(hears)
        body = bytearray()

        def put(raw, align=4):
            body.extend(bytes(-(8 + len(body)) % align) + raw)  # body starts at 12 = 8 past origin
        put(_cdr_string(base_link(k)))
        put(struct.pack('<I', len(self.names)))
        for name in self.names:
            put(_cdr_string(name))
        put(struct.pack('<I', len(self.names)))
        put(b'', align=8)
        self.middle = bytes(body)
        self.values_at = 12 + len(body)
        self.values = struct.Struct(f'<{len(self.names)}d')
        self.tail = bytes(8)                              # velocity and effort: empty

    def encode(self, ns, values):
        """Return the bytes of a formation_state stamped ``ns`` (ns) with ``values``."""
        sec, nanosec = divmod(ns, 1_000_000_000)
        return b''.join((self.HEADER, struct.pack('<iI', sec, nanosec), self.middle,
                         self.values.pack(*values), self.tail))

    def decode(self, data):
        """(stamp in ns, the values) of canonical bytes, else None."""
        if (len(data) < self.values_at + self.values.size or data[:4] != self.HEADER
                or data[12:self.values_at] != self.middle):
            return None
        sec, nanosec = struct.unpack_from('<iI', data, 4)
        return sec * 1_000_000_000 + nanosec, self.values.unpack_from(data, self.values_at)


def _cdr_string(text):
    raw = text.encode() + b'\x00'
    return struct.pack('<I', len(raw)) + raw


def scenario_msg(sc):
    return String(data=sc.to_json())


def metrics_msg(ns, values):
    """``/formation/metrics``: JointState with the metric names and their values (position)."""
    msg = JointState()
    set_stamp(msg.header, ns)
    msg.header.frame_id = MAP_FRAME
    msg.name = list(values)
    msg.position = [float(v) for v in values.values()]
    return msg
