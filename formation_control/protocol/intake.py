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
The one path of a node's incoming bytes: read in place, else deserialized and checked.

Odometry, commands and formation states come as CDR bytes. Bytes in the canonical layout (the
sender's frames and id, its graph, this interface version) are read in place by their wire
(:class:`~formation_control.protocol.messages.StateWire`,
:class:`~formation_control.protocol.messages.CommandWire`, ``interface.MessageWire``); any
other bytes are deserialized (by the caller's function: this module loads no ROS) and the
message is checked: its interface version, frames, vehicle id and, for a formation state, its
graph, for a command its kind; an aircraft's autopilot demand (``cmd_vel``) is checked for
finite values on either path. What fails is a :class:`Rejection` naming its kind
(``malformed``, ``interface_version``, ``wrong_frame``, ``foreign_id``, ``wrong_kind``,
``non_finite``); the node drops and counts it. Every formation_control_msgs message begins with
its ``interface_version``: the rejection of bytes that do not deserialize says what their
first byte reads when it is not this version.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
import math
from typing import Any, Generic, Protocol, TypeVar

from formation_control.protocol.messages import (CMD_FIELDS, CMD_VEL_FIELDS, CommandWire,
                                                 FormationState, get_fields, INTERFACE_VERSION,
                                                 ODOM_FIELDS, stamp_ns, StateWire)
from formation_control.protocol.names import Frames

MALFORMED, WRONG_FRAME, FOREIGN_ID = 'malformed', 'wrong_frame', 'foreign_id'
VERSION, WRONG_KIND, NON_FINITE = 'interface_version', 'wrong_kind', 'non_finite'

T = TypeVar('T')
T_co = TypeVar('T_co', covariant=True)
Stamped = tuple[int, tuple[float, ...]]
"""The value of an odometry or a command: (stamp ns, its ODOM_FIELDS or CMD_FIELDS values)."""


@dataclass(frozen=True)
class Rejection:
    """Why incoming bytes were dropped: a ``kind`` of rejection and what they were (text)."""

    kind: str
    what: str


class Wire(Protocol[T_co]):
    """A topic's canonical layout: reads its bytes in place."""

    def decode(self, data: bytes) -> T_co | None:
        """Return the value of canonical bytes, else None."""


class Intake(Generic[T]):
    """
    The decode-or-check rule of one topic.

    Parameters
    ----------
    wire : object
        Its ``decode(data)`` reads canonical bytes (or returns None).
    read : callable
        Message -> the value ``wire.decode`` gives for the same content.
    check : callable
        Message -> a :class:`Rejection`, or None for a message to read.
    what : str
        What the bytes are, for the rejections (``'odometry of vehicle 2'``).
    versioned : bool
        A formation_control_msgs message: its first field is its ``interface_version``.
    valid : callable, optional
        Value -> a :class:`Rejection`, or None: checks the value of either path.

    """

    def __init__(self, wire: Wire[T], read: Callable[[Any], T],
                 check: Callable[[Any], Rejection | None], what: str,
                 versioned: bool = False,
                 valid: Callable[[T], Rejection | None] | None = None) -> None:
        self.wire, self.read, self.check, self.what = wire, read, check, what
        self.versioned, self.valid = versioned, valid

    def __call__(self, data: bytes, deserialize: Callable[[bytes], Any]) -> T | Rejection:
        """
        Return the value of ``data``, or the :class:`Rejection` of the bytes.

        ``deserialize`` turns bytes into the topic's message (it may raise on garbage).
        """
        read = self.wire.decode(data)
        got: T | Rejection = self._message(data, deserialize) if read is None else read
        if self.valid is None or isinstance(got, Rejection):
            return got
        return self.valid(got) or got

    def _message(self, data: bytes, deserialize: Callable[[bytes], Any]) -> T | Rejection:
        try:
            msg = deserialize(data)
        except Exception:
            return Rejection(MALFORMED, f'undecodable {self.what} bytes{self._first(data)}')
        if self.versioned and msg.interface_version != INTERFACE_VERSION:
            return version_rejection(self.what, msg.interface_version)
        return self.check(msg) or self.read(msg)

    def _first(self, data: bytes) -> str:
        """Return what the first field says of undecodable bytes, if another version."""
        if not self.versioned or len(data) < 5 or data[4] == INTERFACE_VERSION:
            return ''
        return (f' (their first field, interface_version, reads {data[4]}; this node speaks '
                f'formation_control_msgs version {INTERFACE_VERSION})')


def version_rejection(what: str, version: int) -> Rejection:
    """Return the rejection of a ``what`` (text) of interface version ``version``."""
    return Rejection(VERSION, f'a {what} of interface version {version}: this node speaks '
                              f'formation_control_msgs version {INTERFACE_VERSION} (run the '
                              f'same formation_control_msgs on every node)')


class _NoWire:
    """The wire of a topic without a canonical layout: every message is deserialized."""

    def decode(self, data: bytes) -> None:
        return None


def message(what: str) -> Intake[Any]:
    """Return the rule of a topic whose messages are only deserialized: the message itself."""
    return Intake(_NoWire(), lambda msg: msg, lambda msg: None, what)


def clock(what: str) -> Intake[Any]:
    """
    Return the rule of ``/clock``: a message whose time is not negative (rclpy's is not).

    rclpy's time source raises on a negative ``sec``, in the callback: the node would die.
    """
    def check(msg: Any) -> Rejection | None:
        if msg.clock.sec < 0:
            return Rejection(MALFORMED, f'a {what} of negative time ({msg.clock.sec} s)')
        return None
    return Intake(_NoWire(), lambda msg: msg, check, what)


def odometry(wire: Wire[Stamped], k: int, world: str,
             base: str | None = None) -> Intake[Stamped]:
    """
    Return vehicle k's odometry rule: (stamp ns, ODOM_FIELDS values).

    Its frame must be ``world`` and, given, its child frame ``base``.
    """
    def check(msg: Any) -> Rejection | None:
        frame, child = msg.header.frame_id, msg.child_frame_id
        if base is not None and (frame, child) != (world, base):
            return Rejection(WRONG_FRAME, f'an odometry in frames {frame!r} -> {child!r} '
                                          f'(expected {world!r} -> {base!r}: world_frame, '
                                          f'base_frame)')
        if frame != world:
            return Rejection(WRONG_FRAME, f'an odometry of vehicle {k} in frame {frame!r} '
                                          f'(world_frame is {world!r})')
        return None
    return Intake(wire, lambda msg: (stamp_ns(msg.header.stamp), get_fields(msg, ODOM_FIELDS)),
                  check, f'odometry of vehicle {k}')


def command(wire: CommandWire, base: str | None = None) -> Intake[Stamped]:
    """
    Return the command rule of ``wire``'s vehicle: (stamp ns, CMD_FIELDS values).

    Its ``vehicle_id`` must be the wire's, its ``kind`` that of the wire's model (0 is a
    default-constructed message) and, given, its frame ``base``.
    """
    k = wire.k

    def check(msg: Any) -> Rejection | None:
        if msg.vehicle_id != k:
            return Rejection(FOREIGN_ID, f'a command of vehicle {msg.vehicle_id} on vehicle '
                                         f"{k}'s topic")
        if msg.kind != wire.kind:
            return Rejection(WRONG_KIND, f'a command of vehicle {k} of kind {msg.kind} (its '
                                         f'model takes kind {wire.kind}; 0 is no kind)')
        if base is not None and msg.header.frame_id != base:
            return Rejection(WRONG_FRAME, f"a command on vehicle {k}'s topic in frame "
                                          f'{msg.header.frame_id!r}')
        return None
    return Intake(wire, lambda msg: (stamp_ns(msg.header.stamp), get_fields(msg, CMD_FIELDS)),
                  check, f'command of vehicle {k}', versioned=True)


def autopilot_demand(wire: Wire[Stamped], k: int, base: str) -> Intake[Stamped]:
    """
    Return aircraft k's ``cmd_vel`` rule: (stamp ns, (airspeed, turn rate)) of a TwistStamped.

    Its frame must be ``base`` (the vehicle's base frame), its airspeed and turn rate
    (:data:`CMD_VEL_FIELDS`) finite; its other components are not read.
    """
    what = f'cmd_vel of vehicle {k}'

    def check(msg: Any) -> Rejection | None:
        if msg.header.frame_id != base:
            return Rejection(WRONG_FRAME, f"a cmd_vel on vehicle {k}'s topic in frame "
                                          f'{msg.header.frame_id!r} (expected {base!r})')
        return None

    def valid(got: Stamped) -> Rejection | None:
        if all(map(math.isfinite, got[1])):
            return None
        return Rejection(NON_FINITE, f'a non-finite {what}: airspeed, turn rate {got[1]}')
    return Intake(wire, lambda msg: (stamp_ns(msg.header.stamp),
                                     get_fields(msg, CMD_VEL_FIELDS)),
                  check, what, valid=valid)


def formation_state(wire: StateWire, frames: Frames | None = None) -> Intake[FormationState]:
    """
    Return the rule of the formation_state of ``wire``'s vehicle: a FormationState.

    Its ``vehicle_id`` must be the wire's vehicle (else ``foreign_id``), its neighbours those
    of the wire (its graph) and its flow estimate there if the wire's is; with ``frames``
    (:class:`~formation_control.protocol.names.Frames`), its frame the world frame.
    """
    k = wire.k

    def check(msg: Any) -> Rejection | None:
        if msg.vehicle_id != k:
            return Rejection(FOREIGN_ID, f'a formation_state of vehicle {msg.vehicle_id} on '
                                         f"vehicle {k}'s topic")
        ids = tuple(map(int, msg.neighbour_ids))
        if (ids != wire.hears or len(msg.hears) != len(ids)
                or bool(msg.estimates_flow) != wire.estimates):
            return Rejection(MALFORMED, f'a malformed formation_state of vehicle {k} (neighbours '
                                        f'{list(ids)}, {len(msg.hears)} hears flags, '
                                        f'estimates_flow {bool(msg.estimates_flow)}; its graph '
                                        f'and flow_source give {list(wire.hears)}, '
                                        f'{wire.estimates})')
        frame = msg.header.frame_id
        if frames is None or frame == frames.world:
            return None
        return Rejection(WRONG_FRAME, f"a formation_state on vehicle {k}'s topic in frame "
                                      f'{frame!r} (world_frame is {frames.world!r})')
    return Intake(wire, FormationState.of_message, check, f'formation_state of vehicle {k}',
                  versioned=True)
