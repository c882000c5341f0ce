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
to and from the fields of its odometry (:data:`ODOM_FIELDS`) and command (:data:`CMD_FIELDS`
of a formation_control_msgs/VehicleCommand), its formation_state as a record of named values
(:class:`FormationState`), the canonical CDR bytes of both (:class:`StateWire`,
:class:`CommandWire`, laid out by :mod:`formation_control.protocol.cdr` from the field lists
:data:`FORMATION_STATE` and :data:`VEHICLE_COMMAND` of the ``.msg`` files), and stamps
(:func:`stamp_ns`, :func:`set_stamp`). The functions taking a message read and write
attributes only, so they serve rclpy messages and those a bag reader builds alike.
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence
from functools import lru_cache
import math
from operator import attrgetter
from types import MappingProxyType
from typing import Any, Mapping, NamedTuple, Optional, TypeVar

from formation_control.core.geometry import ComplexArray, RealArray
from formation_control.core.models import ground_velocity, position, ROW_OMEGA, ROW_THETA
from formation_control.core.parameters import Scenario
from formation_control.core.vehicles import vehicle_model
from formation_control.protocol.cdr import Codec, Definition, HEADER, Layout, TIME
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


INTERFACE_VERSION = 1
"""The INTERFACE_VERSION of formation_control_msgs these layouts are of; a message of another
``interface_version`` is refused (:mod:`formation_control.protocol.intake`)."""


STATE_FIELDS = ('x', 'y', 'heading', 'yaw_rate', 'phase', 'phase_rate', 'speed')
"""The float64 fields of a formation_control_msgs/FormationState (m, rad, rad/s, m/s) of the
state the sender computes its command for: its odometry of the stamp predicted to
``predicted_stamp`` (``hold_prediction``; in real time also over its measured delay)."""


FORMATION_STATE: Definition = (
    ('interface_version', 'uint8'), ('header', HEADER), ('vehicle_id', 'uint32'),
    ('predicted_stamp', TIME), *((name, 'float64') for name in STATE_FIELDS),
    ('neighbour_ids', 'uint32[]'), ('hears', 'bool[]'), ('estimates_flow', 'bool'),
    ('flow_hat_x', 'float64'), ('flow_hat_y', 'float64'))
"""formation_control_msgs/FormationState, its fields in the order of FormationState.msg."""


CMD_FIELDS = ('thrust', 'steering_force', 'angular_acceleration', 'turn_rate')
"""The float64 fields of a formation_control_msgs/VehicleCommand (N, N, rad/s^2, rad/s)."""


VEHICLE_COMMAND: Definition = (
    ('interface_version', 'uint8'), ('header', HEADER), ('vehicle_id', 'uint32'),
    ('kind', 'uint8'), *((name, 'float64') for name in CMD_FIELDS))
"""formation_control_msgs/VehicleCommand, its fields in the order of VehicleCommand.msg."""


COMMAND_KINDS = {'angular_acceleration': 2, 'turn_rate': 3}
"""VehicleCommand.kind of a particle model by the field its input travels in (SECOND_ORDER,
FIRST_ORDER); a model with a thrust is RIGID_BODY (:func:`command_kind`)."""
RIGID_BODY = 1


def command_kind(model: str) -> int:
    """Return the VehicleCommand ``kind`` of ``model`` (from its ``command_fields``)."""
    return COMMAND_KINDS.get(vehicle_model(model).command_fields[1], RIGID_BODY)


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

CMD_VEL_FIELDS = ('twist.linear.x', 'twist.angular.z')
"""The fields of an aircraft's autopilot demand, a geometry_msgs/TwistStamped on ``cmd_vel``:
airspeed (m/s) and turn rate (rad/s, counter-clockwise); the others are not read."""


def get_fields(msg: Any, fields: Iterable[str]) -> tuple[Any, ...]:
    return tuple(attrgetter(name)(msg) for name in fields)


def set_fields(msg: M, fields: Iterable[str], values: Iterable[float]) -> M:
    for name, value in zip(fields, values):
        owner, _, attr = name.rpartition('.')
        setattr(attrgetter(owner)(msg) if owner else msg, attr, float(value))
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
    if vehicle_model(model).particle:
        rel = 1.0 + 0j
    return np.array([x, y, theta, yaw_rate, rel.real, rel.imag])


def ground_velocity_of(values: Sequence[float]) -> complex:
    """Return the ground velocity (complex m/s, world frame) of :data:`ODOM_FIELDS` values."""
    _, _, qz, qw, vx, vy, _ = values
    theta = 2.0 * math.atan2(qz, qw)
    return complex(vx, vy) * complex(math.cos(theta), math.sin(theta))


@lru_cache(maxsize=None)
def _slots(model: str) -> tuple[int, int]:
    """Return the :data:`CMD_FIELDS` index of each input row of ``model`` (4: not sent)."""
    first, second = ((CMD_FIELDS + ('',)).index(name)
                     for name in vehicle_model(model).command_fields)
    return first, second


def cmd_values(u: Sequence[float] | RealArray,
               model: str) -> tuple[float, float, float, float]:
    """
    Return the :data:`CMD_FIELDS` of one vehicle's input column u (2,).

    Each input row in the field the model names (``VehicleModel.command_fields``): rigid
    bodies thrust, steering force; a second-order particle the angular acceleration; a
    first-order one the turn rate; the other fields are 0.
    """
    out = [0.0, 0.0, 0.0, 0.0, 0.0]
    first, second = _slots(model)
    out[first], out[second] = float(u[0]), float(u[1])
    return out[0], out[1], out[2], out[3]


def input_from_cmd_values(values: Sequence[float], model: str) -> tuple[float, float]:
    """Return the input column (2,) of the :data:`CMD_FIELDS` of a command."""
    padded = (*values, 0.0)
    first, second = _slots(model)
    return padded[first], padded[second]


def odom_values_of(msg: Any) -> tuple[float, ...]:
    """Return the :data:`ODOM_FIELDS` of an Odometry."""
    return get_fields(msg, ODOM_FIELDS)


def state_from_odom(msg: Any, flow: complex, model: str) -> RealArray:
    """Return the state column (6,) of a vehicle from its Odometry and the flow it measures."""
    return state_from_odom_values(odom_values_of(msg), flow, model)


def input_from_cmd(msg: Any, model: str) -> tuple[float, float]:
    """Return the input column (2,) of a VehicleCommand."""
    return input_from_cmd_values(get_fields(msg, CMD_FIELDS), model)


class FormationState(NamedTuple):
    """
    One vehicle's formation_state as named values: what it tells its neighbours each step.

    ``stamp`` is that of the odometry sample, ``ahead`` the ns from it to the instant the
    state is predicted to (``predicted_stamp``). ``hears`` maps each graph neighbour j of the
    sender to whether it hears j (empty on the complete graph); ``flow_hat`` is its flow
    estimate (m/s, world frame) if it estimates the flow. :meth:`of_message` reads a
    formation_control_msgs/FormationState, :class:`StateWire` is the same as CDR bytes.
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
    ahead: int = 0

    @classmethod
    def of_vehicle(cls, ns: int, X: RealArray, view_row: ViewRow,
                   hears: Optional[Mapping[int, bool]] = None,
                   flow_hat: Optional[complex] = None, ahead: int = 0) -> FormationState:
        """
        Return the state of stamp ``ns`` of a vehicle's state column X (6,).

        ``view_row`` is its (r, phase, rate, speed) of the law's particle view, X predicted
        ``ahead`` ns past ``ns``.
        """
        r, phase, rate, speed = view_row
        return cls(int(ns), float(r.real), float(r.imag), float(X[ROW_THETA]),
                   float(X[ROW_OMEGA]), float(phase), float(rate), float(speed),
                   {j: bool(h) for j, h in (hears or {}).items()},
                   None if flow_hat is None else complex(flow_hat), int(ahead))

    @classmethod
    def of_message(cls, msg: Any) -> FormationState:
        """Return the state of a FormationState message (its attributes are read)."""
        stamp = stamp_ns(msg.header.stamp)
        values = map(float, get_fields(msg, STATE_FIELDS))
        x, y, heading, yaw_rate, phase, phase_rate, speed = values
        return cls(stamp, x, y, heading, yaw_rate, phase, phase_rate, speed,
                   dict(zip(map(int, msg.neighbour_ids), map(bool, msg.hears))),
                   complex(msg.flow_hat_x, msg.flow_hat_y) if msg.estimates_flow else None,
                   stamp_ns(msg.predicted_stamp) - stamp)

    @property
    def r(self) -> complex:
        """Position (complex m, world frame)."""
        return complex(self.x, self.y)

    @property
    def row(self) -> ViewRow:
        """(r, phase, phase_rate, speed): the sender's row of the law's particle view."""
        return self.r, self.phase, self.phase_rate, self.speed

    @property
    def predicted_stamp(self) -> int:
        """Return the instant (ns) the state is predicted to."""
        return self.stamp + self.ahead

    def fields(self) -> dict[str, Any]:
        """Return the FormationState message fields of the values, by name (not the header)."""
        flow = 0j if self.flow_hat is None else self.flow_hat
        return {**dict(zip(STATE_FIELDS, self[1:8])),
                'neighbour_ids': list(self.hears), 'hears': list(self.hears.values()),
                'estimates_flow': self.flow_hat is not None, 'flow_hat_x': flow.real,
                'flow_hat_y': flow.imag}

    def finite(self) -> bool:
        """Return whether every value is finite."""
        flow = 0j if self.flow_hat is None else self.flow_hat
        return all(map(math.isfinite, (*self[1:8], flow.real, flow.imag)))

    def hears_vehicle(self, k: int) -> bool:
        """Return whether the sender hears vehicle k (always, k not a flagged neighbour)."""
        return self.hears.get(k, True)


_HEARS = len(STATE_FIELDS) + 4


class StateWire:
    """
    Vehicle k's formation_state as serialized bytes, without message objects.

    formation_control_msgs/FormationState in little-endian CDR (:data:`FORMATION_STATE`): every
    vehicle sends one and hears one from each neighbour every step. ``encode`` writes a
    :class:`FormationState` in the canonical layout of vehicle k (zero padding, the world
    frame, its graph neighbours ``hears`` and, ``estimates``, its flow estimate), which
    ``decode`` reads in place; it returns None for any other bytes, which the caller then
    deserializes and checks as a message (:mod:`formation_control.protocol.intake`).
    """

    def __init__(self, k: int, hears: Iterable[int] = (), frames: Frames = DEFAULT_FRAMES,
                 estimates: bool = False) -> None:
        self.k, self.hears, self.frame = k, tuple(hears), frames.world
        self.estimates = estimates
        n = len(self.hears)
        layout = Layout(FORMATION_STATE, {'header.frame_id': len(self.frame.encode()),
                                          'neighbour_ids': n, 'hears': n})
        self.codec = Codec(layout, {
            'interface_version': INTERFACE_VERSION, 'header.frame_id': self.frame,
            'vehicle_id': k, **{f'neighbour_ids.{i}': j for i, j in enumerate(self.hears)},
            'estimates_flow': estimates},
            ('header.stamp.sec', 'header.stamp.nanosec', 'predicted_stamp.sec',
             'predicted_stamp.nanosec', *STATE_FIELDS, *(f'hears.{i}' for i in range(n)),
             'flow_hat_x', 'flow_hat_y'))

    @classmethod
    def of(cls, sc: Scenario, k: int, frames: Frames = DEFAULT_FRAMES) -> StateWire:
        """Return vehicle k's wire in scenario ``sc`` (its graph neighbours, its estimate)."""
        hears = () if sc.all_to_all else tuple(sc.comm_graph.neighbours(k))
        return cls(k, hears, frames, sc.flow_source == 'estimated')

    def encode(self, state: FormationState) -> bytes:
        """Return the bytes of a :class:`FormationState` in this layout."""
        flow = state.flow_hat if self.estimates and state.flow_hat is not None else 0j
        return self.codec.encode((*stamp_parts(state.stamp), *stamp_parts(state.predicted_stamp),
                                  *state[1:8], *(state.hears[j] for j in self.hears),
                                  flow.real, flow.imag))

    def decode(self, data: bytes) -> FormationState | None:
        """Return the :class:`FormationState` of canonical bytes, else None."""
        got = self.codec.decode(data)
        if got is None:
            return None
        stamp = got[0] * 1_000_000_000 + got[1]
        x, y, heading, yaw_rate, phase, phase_rate, speed = got[4:_HEARS]
        return FormationState(stamp, x, y, heading, yaw_rate, phase, phase_rate, speed,
                              dict(zip(self.hears, got[_HEARS:-2])),
                              complex(got[-2], got[-1]) if self.estimates else None,
                              got[2] * 1_000_000_000 + got[3] - stamp)


class CommandWire:
    """
    Vehicle k's formation_control_msgs/VehicleCommand as CDR bytes (:data:`VEHICLE_COMMAND`).

    The canonical layout has its base frame, its id and the ``kind`` of ``model``: ``encode``
    writes the stamp and the :data:`CMD_FIELDS` values, ``decode`` reads them back as (stamp
    ns, values), or returns None for any other bytes.
    """

    def __init__(self, k: int, model: str, frames: Frames = DEFAULT_FRAMES) -> None:
        self.k, self.kind, self.frame = k, command_kind(model), frames.base(k)
        layout = Layout(VEHICLE_COMMAND, {'header.frame_id': len(self.frame.encode())})
        self.codec = Codec(layout, {'interface_version': INTERFACE_VERSION,
                                    'header.frame_id': self.frame, 'vehicle_id': k,
                                    'kind': self.kind},
                           ('header.stamp.sec', 'header.stamp.nanosec', *CMD_FIELDS))

    def encode(self, ns: int, values: Sequence[float]) -> bytes:
        """Return the bytes of the command stamped ``ns`` with the :data:`CMD_FIELDS` values."""
        return self.codec.encode((*stamp_parts(ns), *values))

    def decode(self, data: bytes) -> tuple[int, tuple[float, ...]] | None:
        """Return (stamp ns, CMD_FIELDS values) of canonical bytes, else None."""
        got = self.codec.decode(data)
        if got is None:
            return None
        return got[0] * 1_000_000_000 + got[1], got[2:]
