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
its formation_state as a record of named values (:class:`FormationState`) and its canonical
CDR bytes (:class:`StateWire`), and stamps (:func:`stamp_ns`, :func:`set_stamp`). The
functions taking a message read and write attributes only, so they serve rclpy messages and
those a bag reader builds alike.
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence
import math
from operator import attrgetter
import struct
from types import MappingProxyType
from typing import Any, Mapping, NamedTuple, Optional, TypeVar

from formation_control.core.geometry import ComplexArray, RealArray
from formation_control.core.models import (ground_velocity, PARTICLE_MODELS, position, ROW_OMEGA,
                                           ROW_THETA)
from formation_control.core.scenario import Scenario
from formation_control.protocol.names import DEFAULT_FRAMES, Frames
import numpy as np

M = TypeVar('M')

ViewRow = tuple[complex, float, float, float]
"""One vehicle's row of the law's particle view: (r, phase, rate, speed) (complex m, rad, rad/s,
m/s)."""


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


_FIRST = len(STATE_FIELDS)
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


def stamp_parts(ns: int) -> tuple[int, int]:
    """Return (sec, nanosec) of a time in ns: the fields of a builtin_interfaces/Time."""
    return divmod(int(ns), 1_000_000_000)


def stamp_ns(stamp: Any) -> int:
    """Return the time in ns of a builtin_interfaces/Time (``sec``, ``nanosec``)."""
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def set_time(time: Any, ns: int) -> None:
    """Write a time in ns into a builtin_interfaces/Time (``sec``, ``nanosec``)."""
    time.sec, time.nanosec = stamp_parts(ns)


def set_stamp(header: Any, ns: int) -> None:
    """Stamp a std_msgs/Header with a time in ns."""
    set_time(header.stamp, ns)


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


class FormationState(NamedTuple):
    """
    One vehicle's formation_state as named values: what it tells its neighbours each step.

    ``hears`` maps each graph neighbour j of the sender to whether it hears j (empty on the
    complete graph); ``flow_hat`` is its flow estimate (m/s, world frame) if it estimates the
    flow. :meth:`names` and :meth:`values` are the JointState ``name`` and ``position`` arrays,
    :meth:`from_joint` reads them back, and :class:`StateWire` is the same as CDR bytes.
    """

    stamp: int
    x: float
    y: float
    heading: float
    yaw_rate: float
    phase: float
    phase_rate: float
    speed: float
    hears: Mapping[int, bool] = MappingProxyType({})
    flow_hat: Optional[complex] = None

    @classmethod
    def of_vehicle(cls, ns: int, X: RealArray, view_row: ViewRow,
                   hears: Optional[Mapping[int, bool]] = None,
                   flow_hat: Optional[complex] = None) -> FormationState:
        """
        Return the state of stamp ``ns`` of a vehicle's state column X (6,).

        ``view_row`` is its (r, phase, rate, speed) of the law's particle view.
        """
        r, phase, rate, speed = view_row
        return cls(int(ns), float(r.real), float(r.imag), float(X[ROW_THETA]),
                   float(X[ROW_OMEGA]), float(phase), float(rate), float(speed),
                   {j: bool(h) for j, h in (hears or {}).items()},
                   None if flow_hat is None else complex(flow_hat))

    @property
    def r(self) -> complex:
        """Position (complex m, world frame)."""
        return complex(self.x, self.y)

    @property
    def row(self) -> ViewRow:
        """(r, phase, phase_rate, speed): the sender's row of the law's particle view."""
        return self.r, self.phase, self.phase_rate, self.speed

    def names(self) -> tuple[str, ...]:
        """Return the JointState ``name`` array (:func:`state_names`)."""
        return state_names(tuple(self.hears), self.flow_hat is not None)

    def values(self) -> tuple[float, ...]:
        """Return the JointState ``position`` array, in :meth:`names` order."""
        extra = () if self.flow_hat is None else (self.flow_hat.real, self.flow_hat.imag)
        return (self.x, self.y, self.heading, self.yaw_rate, self.phase, self.phase_rate,
                self.speed, *(1.0 if h else 0.0 for h in self.hears.values()), *extra)

    @classmethod
    def from_joint(cls, ns: int, names: Iterable[str],
                   values: Iterable[float]) -> FormationState:
        """
        Return the state of the JointState ``name`` and ``position`` arrays of stamp ``ns``.

        A ``hears_j`` flag is true above 0.5. Raises ValueError unless ``names`` are those of
        :func:`state_names` for some neighbours, one value each.
        """
        names, values = tuple(names), tuple(values)
        hears = tuple(_hears_id(name) for name in names[len(STATE_FIELDS):]
                      if name.startswith('hears_'))
        estimates = names[-len(ESTIMATE_FIELDS):] == ESTIMATE_FIELDS
        if len(values) != len(names) or names != state_names(hears, estimates):
            raise ValueError(f'not the names of a formation_state: {list(names)}')
        return cls.of_layout(int(ns), hears, estimates, tuple(map(float, values)))

    @classmethod
    def of_layout(cls, ns: int, hears: Sequence[int], estimates: bool,
                  values: Sequence[float]) -> FormationState:
        """Return the state of float ``values`` laid out by :func:`state_names`."""
        x, y, heading, yaw_rate, phase, phase_rate, speed = values[:_FIRST]
        flags = values[_FIRST:_FIRST + len(hears)]
        return cls(ns, x, y, heading, yaw_rate, phase, phase_rate, speed,
                   dict(zip(hears, [v > 0.5 for v in flags])),
                   complex(values[-2], values[-1]) if estimates else None)

    def finite(self) -> bool:
        """Return whether every value is finite."""
        return all(map(math.isfinite, self.values()))

    def hears_vehicle(self, k: int) -> bool:
        """Return whether the sender hears vehicle k (always, k not a flagged neighbour)."""
        return self.hears.get(k, True)


def _hears_id(name: str) -> int:
    try:
        return int(name[len('hears_'):])
    except ValueError:
        raise ValueError(f'not a hears_j name: {name!r}') from None


class StateWire:
    """
    Vehicle k's formation_state as serialized bytes, without message objects.

    sensor_msgs/JointState in little-endian CDR: every vehicle sends one and hears one from
    each neighbour every step. ``encode`` writes a :class:`FormationState` in the canonical
    layout (zero padding, empty velocity and effort) of the names :func:`state_names` gives for
    the graph neighbours ``hears`` (and the flow estimate, ``estimates``), which ``decode``
    reads in place; it returns None for any other bytes, which the caller then deserializes
    and checks as a message (:mod:`formation_control.protocol.intake`).
    """

    HEADER = b'\x00\x01\x00\x00'                      # CDR, little endian; alignment origin 4

    def __init__(self, k: int, hears: Iterable[int] = (), frames: Frames = DEFAULT_FRAMES,
                 estimates: bool = False) -> None:
        self.k, self.hears, self.frame = k, tuple(hears), frames.base(k)
        self.estimates = estimates
        self.names = state_names(self.hears, estimates)
        body = bytearray()

        def put(raw: bytes, align: int = 4) -> None:
            body.extend(bytes(-(8 + len(body)) % align) + raw)  # body starts at 12 = 8 past origin
        put(_cdr_string(self.frame))
        put(struct.pack('<I', len(self.names)))
        for name in self.names:
            put(_cdr_string(name))
        put(struct.pack('<I', len(self.names)))
        put(b'', align=8)
        self.middle = bytes(body)
        self.values_at = 12 + len(body)
        self.values = struct.Struct(f'<{len(self.names)}d')
        self.tail = bytes(8)                              # velocity and effort: empty

    @classmethod
    def of(cls, sc: Scenario, k: int, frames: Frames = DEFAULT_FRAMES) -> StateWire:
        """Return vehicle k's wire in scenario ``sc`` (its graph neighbours, its estimate)."""
        hears = () if sc.all_to_all else tuple(sc.comm_graph.neighbours(k))
        return cls(k, hears, frames, sc.flow_source == 'estimated')

    def encode(self, state: FormationState) -> bytes:
        """Return the bytes of a :class:`FormationState` in this layout."""
        return b''.join((self.HEADER, struct.pack('<iI', *stamp_parts(state.stamp)),
                         self.middle, self.values.pack(*state.values()), self.tail))

    def decode(self, data: bytes) -> FormationState | None:
        """Return the :class:`FormationState` of canonical bytes, else None."""
        if (len(data) < self.values_at + self.values.size or data[:4] != self.HEADER
                or data[12:self.values_at] != self.middle):
            return None
        sec, nanosec = struct.unpack_from('<iI', data, 4)
        return FormationState.of_layout(sec * 1_000_000_000 + nanosec, self.hears,
                                        self.estimates,
                                        self.values.unpack_from(data, self.values_at))


def _cdr_string(text: str) -> bytes:
    raw = text.encode() + b'\x00'
    return struct.pack('<I', len(raw)) + raw
