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
What the fleet's messages carry, as plain values: the pure side of every conversion.

A vehicle's state column X (6,) and input column u (2,) (:mod:`formation_control.core.models`)
to and from the fields of its odometry (:data:`ODOM_FIELDS`) and command (:data:`CMD_FIELDS`),
the values of its formation_state (:func:`state_names`) and their canonical CDR bytes
(:class:`StateWire`), and stamps. The functions taking a message read and write attributes
only, so they serve rclpy messages and those a bag reader builds alike.
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence
import math
from operator import attrgetter
import struct
from typing import Any, TypeVar

from formation_control.core.geometry import ComplexArray, RealArray
from formation_control.core.models import (ground_velocity, PARTICLE_MODELS, position, ROW_OMEGA,
                                           ROW_THETA)
from formation_control.protocol.names import DEFAULT_FRAMES, Frames
import numpy as np

M = TypeVar('M')


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


def state_names(hears: Iterable[int] = (), estimates: bool = False) -> tuple[str, ...]:
    """
    Return the names of a formation_state.

    ``hears``: the sender's graph neighbours; ``estimates``: it estimates the flow.
    """
    return (STATE_FIELDS + tuple(f'hears_{j}' for j in hears)
            + (ESTIMATE_FIELDS if estimates else ()))


def quaternion_zw(theta: float) -> tuple[float, float]:
    """Return (z, w) of the quaternion of a yaw ``theta`` (rad, CCW about z; x = y = 0)."""
    return math.sin(0.5 * theta), math.cos(0.5 * theta)


def yaw_quaternion(orientation: Any, theta: float) -> None:
    """Write the quaternion of a yaw ``theta`` (rad, CCW about z) into ``orientation``."""
    orientation.z, orientation.w = quaternion_zw(theta)


def stamp_ns(stamp: Any) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def set_stamp(header: Any, ns: int) -> None:
    header.stamp.sec, header.stamp.nanosec = divmod(int(ns), 1_000_000_000)


ODOM_FIELDS = ('pose.pose.position.x', 'pose.pose.position.y', 'pose.pose.orientation.z',
               'pose.pose.orientation.w', 'twist.twist.linear.x', 'twist.twist.linear.y',
               'twist.twist.angular.z')
"""The fields of an Odometry the package writes (the others stay zero)."""


CMD_FIELDS = ('wrench.force.x', 'wrench.force.y', 'wrench.torque.z')
"""The fields of a WrenchStamped command (the others stay zero)."""


def get_fields(msg: Any, fields: Iterable[str]) -> tuple[Any, ...]:
    return tuple(attrgetter(name)(msg) for name in fields)


def set_fields(msg: M, fields: Iterable[str], values: Iterable[float]) -> M:
    for name, value in zip(fields, values):
        owner, _, attr = name.rpartition('.')
        setattr(attrgetter(owner)(msg), attr, float(value))
    return msg


def odom_values(X: RealArray, flow: complex | ComplexArray) -> tuple[float, ...]:
    """
    Return the :data:`ODOM_FIELDS` of a vehicle's state column X (6,) in a flow (m/s).

    Position, the quaternion of the heading, the ground velocity in the body frame, yaw rate.
    """
    theta = float(X[ROW_THETA])
    r = complex(position(X))
    body = complex(ground_velocity(X, flow)) * complex(math.cos(theta), -math.sin(theta))
    return (r.real, r.imag, *quaternion_zw(theta), body.real, body.imag, float(X[ROW_OMEGA]))


def state_from_odom_values(values: Sequence[float], flow: complex, model: str) -> RealArray:
    """Return the state column (6,) of a vehicle from its :data:`ODOM_FIELDS` and the flow."""
    x, y, qz, qw, vx, vy, yaw_rate = values
    theta = 2.0 * math.atan2(qz, qw)
    rel = complex(vx, vy) - flow * complex(math.cos(theta), -math.sin(theta))
    if model in PARTICLE_MODELS:
        rel = 1.0 + 0j
    return np.array([x, y, theta, yaw_rate, rel.real, rel.imag])


def ground_velocity_of(values: Sequence[float]) -> complex:
    """Return the ground velocity (complex m/s, world frame) of :data:`ODOM_FIELDS` values."""
    _, _, qz, qw, vx, vy, _ = values
    theta = 2.0 * math.atan2(qz, qw)
    return complex(vx, vy) * complex(math.cos(theta), math.sin(theta))


def cmd_values(u: Sequence[float] | RealArray, model: str) -> tuple[float, float, float]:
    """Return the :data:`CMD_FIELDS` of one vehicle's input column u (2,)."""
    if model in PARTICLE_MODELS:
        return 0.0, 0.0, float(u[1])
    return float(u[0]), float(u[1]), 0.0


def input_from_cmd_values(values: Sequence[float], model: str) -> tuple[float, float]:
    """Return the input column (2,) of the :data:`CMD_FIELDS` of a command."""
    fx, fy, tz = values
    return (0.0, tz) if model in PARTICLE_MODELS else (fx, fy)


def odom_values_of(msg: Any) -> tuple[float, ...]:
    """Return the :data:`ODOM_FIELDS` of an Odometry."""
    return get_fields(msg, ODOM_FIELDS)


def state_from_odom(msg: Any, flow: complex, model: str) -> RealArray:
    """Return the state column (6,) of a vehicle from its Odometry and the flow it measures."""
    return state_from_odom_values(odom_values_of(msg), flow, model)


def input_from_cmd(msg: Any, model: str) -> tuple[float, float]:
    """Return the input column (2,) of a WrenchStamped command."""
    return input_from_cmd_values(get_fields(msg, CMD_FIELDS), model)


def state_values(X: RealArray, view_row: Sequence[Any], hearing: Iterable[float] = (),
                 flow_hat: complex | None = None) -> tuple[float, ...]:
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

    def __init__(self, k: int, hears: Iterable[int] = (), frames: Frames = DEFAULT_FRAMES,
                 estimates: bool = False) -> None:
        self.names = state_names(hears, estimates)
        body = bytearray()

        def put(raw: bytes, align: int = 4) -> None:
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

    def encode(self, ns: int, values: Iterable[float]) -> bytes:
        """Return the bytes of a formation_state stamped ``ns`` (ns) with ``values``."""
        sec, nanosec = divmod(ns, 1_000_000_000)
        return b''.join((self.HEADER, struct.pack('<iI', sec, nanosec), self.middle,
                         self.values.pack(*values), self.tail))

    def decode(self, data: bytes) -> tuple[int, tuple[float, ...]] | None:
        """(stamp in ns, the values) of canonical bytes, else None."""
        if (len(data) < self.values_at + self.values.size or data[:4] != self.HEADER
                or data[12:self.values_at] != self.middle):
            return None
        sec, nanosec = struct.unpack_from('<iI', data, 4)
        return sec * 1_000_000_000 + nanosec, self.values.unpack_from(data, self.values_at)


def _cdr_string(text: str) -> bytes:
    raw = text.encode() + b'\x00'
    return struct.pack('<I', len(raw)) + raw
