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
``vehicle_k/formation_state``  sensor_msgs/JointState           see :data:`STATE_FIELDS`
``vehicle_k/cmd``              geometry_msgs/WrenchStamped      force.x = T, force.y = F (N);
                                                                torque.z = angular acceleration
                                                                (second_order) or turn rate
                                                                (first_order)
=============================  ===============================  ==============================

Fleet-wide: ``clock`` (lockstep), ``formation/scenario`` (std_msgs/String, latched: the
plant's scenario as JSON), ``formation/metrics`` (sensor_msgs/JointState: :data:`METRIC_DOC`
names in ``name``, values in ``position``), ``formation/markers`` (from the ``monitor`` node),
and the absolute ``/diagnostics`` that diagnostic aggregators read.

Every stamp is the time of the sample a message comes from; in lockstep it names the step.
"""
import copy
import math
from operator import attrgetter
import struct

from formation_control.core.models import (ground_velocity, PARTICLE_MODELS, position,
                                           ROW_OMEGA, ROW_THETA, ROW_U, ROW_V)
from formation_control.core.node_parameters import BASE_FRAME, base_frame, WORLD_FRAME
from geometry_msgs.msg import TwistStamped, Vector3Stamped, WrenchStamped
from nav_msgs.msg import Odometry
import numpy as np
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.qos_overriding_options import QoSOverridingOptions, QoSPolicyKind
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import String

DIAGNOSTICS_TOPIC = '/diagnostics'
CLOCK_TOPIC = 'clock'
SCENARIO_TOPIC = 'formation/scenario'
METRICS_TOPIC = 'formation/metrics'
FAULTS_TOPIC = 'formation/faults'
"""swarm: each scripted fault as it is applied (std_msgs/String, JSON; :data:`FAULTS_QOS`)."""
MARKERS_TOPIC = 'formation/markers'
SCENE_TOPIC = 'formation/scene'
"""The Foxglove live view's SceneUpdate channel (not a ROS topic), named as the monitor resolves
it (``/fleet_a/formation/scene``)."""
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
    'min_separation': 'min_{j != k} |r_j - r_k|, the smallest distance between two vehicles (m)',
    **{f'phase_order_{m}': f'symmetric pattern: |p_{m}| = |mean_k e^{{i {m} phase_k}}| / {m}; '
       f'splay: 0; M clusters: 1/M at m = M, 0 below' for m in range(1, 9)},
    'live_links': 'links of the communication graph that are live (both ends heard recently, '
                  'each hearing the other)',
    'algebraic_connectivity': 'lambda_2 of the Laplacian of the live graph (the vehicles heard '
                              'recently and their live links); 0 = disconnected',
}
STATE_FIELDS = ('x', 'y', 'heading', 'yaw_rate', 'phase', 'phase_rate', 'speed')
"""formation_state: JointState.name, and .position holds these values (m, rad, rad/s, m/s) of
the state the sender computes its command for: its odometry of the stamp predicted to the middle
of the command's hold (``hold_prediction``; in real time also over its measured delay). On a
communication graph other than the complete one, ``hears_j`` follows for each graph
neighbour j of the sender: 1 while it hears j, else 0; with ``flow_source: estimated``,
:data:`ESTIMATE_FIELDS` come last (:func:`state_names`)."""
ESTIMATE_FIELDS = ('flow_hat_x', 'flow_hat_y')
"""formation_state of an estimating vehicle: its flow estimate (m/s, world frame)."""


def state_names(hears=(), estimates=False):
    """
    Return the names of a formation_state.

    ``hears``: the sender's graph neighbours; ``estimates``: it estimates the flow.
    """
    return (STATE_FIELDS + tuple(f'hears_{j}' for j in hears)
            + (ESTIMATE_FIELDS if estimates else ()))


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


def quaternion_zw(theta):
    """Return (z, w) of the quaternion of a yaw ``theta`` (rad, CCW about z; x = y = 0)."""
    return math.sin(0.5 * theta), math.cos(0.5 * theta)


def yaw_quaternion(orientation, theta):
    """Write the quaternion of a yaw ``theta`` (rad, CCW about z) into ``orientation``."""
    orientation.z, orientation.w = quaternion_zw(theta)


def topic(k, name):
    """Return the relative name of vehicle k's topic ``name`` (in the node's namespace)."""
    return f'vehicle_{k}/{name}'


def base_link(k, template=BASE_FRAME):
    """Return vehicle k's base frame: the ``base_frame`` template with ``{id}`` = k."""
    return base_frame(template, k)


class Frames:
    """
    The frames of a fleet (REP-105): ``world`` and the ``base`` template of each vehicle.

    Odometry poses and flows are in ``world``; odometry twists, commands and formation states
    in :meth:`base` of their vehicle.
    """

    def __init__(self, world=WORLD_FRAME, base=BASE_FRAME):
        self.world, self.template = world, base

    def base(self, k):
        return base_link(k, self.template)

    def vehicle_of(self, frame):
        """Return the id k whose base frame is ``frame``, else None."""
        head, _, tail = self.template.partition('{id}')
        middle = frame[len(head):len(frame) - len(tail)]
        if frame.startswith(head) and frame.endswith(tail) and middle.isdigit():
            return int(middle)
        return None


DEFAULT_FRAMES = Frames()


def stamp_ns(stamp):
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def set_stamp(header, ns):
    header.stamp.sec, header.stamp.nanosec = divmod(int(ns), 1_000_000_000)


ODOM_FIELDS = ('pose.pose.position.x', 'pose.pose.position.y', 'pose.pose.orientation.z',
               'pose.pose.orientation.w', 'twist.twist.linear.x', 'twist.twist.linear.y',
               'twist.twist.angular.z')
"""The fields of an Odometry the package writes (the others stay zero)."""
CMD_FIELDS = ('wrench.force.x', 'wrench.force.y', 'wrench.torque.z')
"""The fields of a WrenchStamped command (the others stay zero)."""


def _get(msg, fields):
    return tuple(attrgetter(name)(msg) for name in fields)


def _set(msg, fields, values):
    for name, value in zip(fields, values):
        owner, _, attr = name.rpartition('.')
        setattr(attrgetter(owner)(msg), attr, float(value))
    return msg


def odom_values(X, flow):
    """
    Return the :data:`ODOM_FIELDS` of a vehicle's state column X (6,) in a flow (m/s).

    Position, the quaternion of the heading, the ground velocity in the body frame, yaw rate.
    """
    theta = float(X[ROW_THETA])
    r = complex(position(X))
    body = complex(ground_velocity(X, flow)) * complex(math.cos(theta), -math.sin(theta))
    return (r.real, r.imag, *quaternion_zw(theta), body.real, body.imag, float(X[ROW_OMEGA]))


def state_from_odom_values(values, flow, model):
    """Return the state column (6,) of a vehicle from its :data:`ODOM_FIELDS` and the flow."""
    x, y, qz, qw, vx, vy, yaw_rate = values
    theta = 2.0 * math.atan2(qz, qw)
    rel = complex(vx, vy) - flow * complex(math.cos(theta), -math.sin(theta))
    if model in PARTICLE_MODELS:
        rel = 1.0 + 0j
    return np.array([x, y, theta, yaw_rate, rel.real, rel.imag])


def ground_velocity_of(values):
    """Return the ground velocity (complex m/s, world frame) of :data:`ODOM_FIELDS` values."""
    _, _, qz, qw, vx, vy, _ = values
    theta = 2.0 * math.atan2(qz, qw)
    return complex(vx, vy) * complex(math.cos(theta), math.sin(theta))


def water_velocity_msg(k, ns, X, frames=DEFAULT_FRAMES):
    """Return the TwistStamped of vehicle k's through-flow velocity (u, v; its base frame)."""
    msg = TwistStamped()
    set_stamp(msg.header, ns)
    msg.header.frame_id = frames.base(k)
    msg.twist.linear.x, msg.twist.linear.y = float(X[ROW_U]), float(X[ROW_V])
    return msg


def cmd_values(u, model):
    """Return the :data:`CMD_FIELDS` of one vehicle's input column u (2,)."""
    if model in PARTICLE_MODELS:
        return 0.0, 0.0, float(u[1])
    return float(u[0]), float(u[1]), 0.0


def input_from_cmd_values(values, model):
    """Return the input column (2,) of the :data:`CMD_FIELDS` of a command."""
    fx, fy, tz = values
    return (0.0, tz) if model in PARTICLE_MODELS else (fx, fy)


def odom_msg(k, ns, X, flow, frames=DEFAULT_FRAMES):
    """Odometry of vehicle k from its state column X (6,): ground velocity in the body frame."""
    msg = Odometry()
    set_stamp(msg.header, ns)
    msg.header.frame_id = frames.world
    msg.child_frame_id = frames.base(k)
    return _set(msg, ODOM_FIELDS, odom_values(X, flow))


def odom_values_of(msg):
    """Return the :data:`ODOM_FIELDS` of an Odometry."""
    return _get(msg, ODOM_FIELDS)


def state_from_odom(msg, flow, model):
    """Return the state column (6,) of a vehicle from its Odometry and the flow it measures."""
    return state_from_odom_values(odom_values_of(msg), flow, model)


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
    return _set(msg, CMD_FIELDS, cmd_values(u, model))


def input_from_cmd(msg, model):
    """Return the input column (2,) of a WrenchStamped command."""
    return input_from_cmd_values(_get(msg, CMD_FIELDS), model)


def odom_wire(k, frames=DEFAULT_FRAMES):
    """Return the :class:`MessageWire` of vehicle k's odometry (:data:`ODOM_FIELDS`)."""
    msg = Odometry()
    msg.header.frame_id, msg.child_frame_id = frames.world, frames.base(k)
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
        data = serialize_message(_set(marked, fields, marks))
        self.offsets = [data.find(struct.pack('<d', v)) for v in marks]
        if min(self.offsets) < 12 or any(data.count(struct.pack('<d', v)) != 1 for v in marks):
            raise ValueError(f'cannot locate the fields {fields} in {type(msg).__name__}')
        self.template = serialize_message(_set(copy.deepcopy(msg), fields, [0.0] * len(fields)))
        cuts = sorted([(4, 12)] + [(o, o + 8) for o in self.offsets])
        ends = [0] + [b for _, b in cuts]
        self.constant = [(a, c) for a, (c, _) in zip(ends, cuts + [(len(self.template), 0)])
                         if c > a]

    def encode(self, ns, values):
        """Return the bytes of the message stamped ``ns`` (ns) with the field ``values``."""
        buf = bytearray(self.template)
        struct.pack_into('<iI', buf, 4, *divmod(ns, 1_000_000_000))
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
    msg = JointState()
    set_stamp(msg.header, ns)
    msg.header.frame_id = frames.base(k)
    msg.name = list(state_names(hears))
    msg.position = list(state_values(X, view_row, hearing))
    return msg


def state_values(X, view_row, hearing=(), flow_hat=None):
    """
    Return the values of one vehicle's formation_state (:func:`state_names` order).

    ``flow_hat``: its flow estimate (complex m/s), for an estimating vehicle.
    """
    r, phase, rate, speed = view_row
    extra = () if flow_hat is None else (flow_hat.real, flow_hat.imag)
    return (r.real, r.imag, float(X[ROW_THETA]), float(X[ROW_OMEGA]), phase, rate, speed,
            *(float(h) for h in hearing), *extra)


class StateWire:
    """
    Vehicle k's formation_state as serialized bytes, without message objects.

    sensor_msgs/JointState in little-endian CDR: every vehicle sends one and hears one from
    each neighbour every step. ``encode`` writes the canonical layout (zero padding, empty
    velocity and effort) of the names :func:`state_names` gives for the graph neighbours
    ``hears`` (and the flow estimate, ``estimates``), which ``decode`` reads in place; it
    returns None for any other bytes, which the caller then deserializes and checks as a
    message.
    """

    HEADER = b'\x00\x01\x00\x00'                      # CDR, little endian; alignment origin 4

    def __init__(self, k, hears=(), frames=DEFAULT_FRAMES, estimates=False):
        self.names = state_names(hears, estimates)
        body = bytearray()

        def put(raw, align=4):
            body.extend(bytes(-(8 + len(body)) % align) + raw)  # body starts at 12 = 8 past origin
        put(_cdr_string(frames.base(k)))
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


def metrics_msg(ns, values, world=WORLD_FRAME):
    """``formation/metrics``: JointState with the metric names and their values (position)."""
    msg = JointState()
    set_stamp(msg.header, ns)
    msg.header.frame_id = world
    msg.name = list(values)
    msg.position = [float(v) for v in values.values()]
    return msg
