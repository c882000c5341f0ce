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
sender's frames, the names of its graph) are read in place by their wire
(:class:`~formation_control.protocol.messages.StateWire`, ``interface.MessageWire``); any
other bytes are deserialized (by the caller's function: this module loads no ROS) and the
message is checked: its frames and, for a formation state, its names. What fails is a
:class:`Rejection` naming its kind (``malformed``, ``wrong_frame``, ``foreign_id``); the
node drops and counts it.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, Protocol, TypeVar

from formation_control.protocol.messages import (CMD_FIELDS, FormationState, get_fields,
                                                 ODOM_FIELDS, stamp_ns, StateWire)
from formation_control.protocol.names import Frames

MALFORMED, WRONG_FRAME, FOREIGN_ID = 'malformed', 'wrong_frame', 'foreign_id'

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

    """

    def __init__(self, wire: Wire[T], read: Callable[[Any], T],
                 check: Callable[[Any], Rejection | None], what: str) -> None:
        self.wire, self.read, self.check, self.what = wire, read, check, what

    def __call__(self, data: bytes, deserialize: Callable[[bytes], Any]) -> T | Rejection:
        """
        Return the value of ``data``, or the :class:`Rejection` of the bytes.

        ``deserialize`` turns bytes into the topic's message (it may raise on garbage).
        """
        got = self.wire.decode(data)
        if got is not None:
            return got
        try:
            msg = deserialize(data)
        except Exception:
            return Rejection(MALFORMED, f'undecodable {self.what} bytes')
        return self.check(msg) or self.read(msg)


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


def command(wire: Wire[Stamped], k: int, base: str | None = None) -> Intake[Stamped]:
    """Return vehicle k's command rule: (stamp ns, CMD_FIELDS values); frame ``base``."""
    def check(msg: Any) -> Rejection | None:
        if base is not None and msg.header.frame_id != base:
            return Rejection(WRONG_FRAME, f"a command on vehicle {k}'s topic in frame "
                                          f'{msg.header.frame_id!r}')
        return None
    return Intake(wire, lambda msg: (stamp_ns(msg.header.stamp), get_fields(msg, CMD_FIELDS)),
                  check, f'command of vehicle {k}')


def formation_state(wire: StateWire, frames: Frames | None = None) -> Intake[FormationState]:
    """
    Return the rule of the formation_state of ``wire``'s vehicle: a FormationState.

    Its names must be the wire's (its graph, its estimate) and, with ``frames``
    (:class:`~formation_control.protocol.names.Frames`), its frame that vehicle's base frame:
    another vehicle's is ``foreign_id``, any other frame ``wrong_frame``.
    """
    k = wire.k

    def check(msg: Any) -> Rejection | None:
        if tuple(msg.name) != wire.names or len(msg.position) != len(wire.names):
            return Rejection(MALFORMED, f'a malformed formation_state of vehicle {k}')
        frame = msg.header.frame_id
        if frames is None or frame == frames.base(k):
            return None
        kind = WRONG_FRAME if frames.vehicle_of(frame) is None else FOREIGN_ID
        return Rejection(kind, f"a formation_state on vehicle {k}'s topic from {frame!r}")
    return Intake(wire, lambda msg: FormationState.from_joint(
        stamp_ns(msg.header.stamp), msg.name, msg.position), check, f'formation_state of '
        f'vehicle {k}')
