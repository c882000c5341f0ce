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
What ``formation-control play`` replays: a rosbag2 bag's messages, their QoS and their times.

Pure (``rosbags``, no ROS): the node (:mod:`formation_control.ros.player`) publishes what
:class:`Bag` yields when :class:`Schedule` says it is due. Any rosbag2 bag (metadata version
4..9, sqlite3 or MCAP storage) is read, not only the package's own.
"""
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
import struct
from typing import Any

from formation_control.bags.repair import unclosed
from formation_control.protocol import names
from rosbags.rosbag2 import Reader, ReaderError

CLOCK_TOPIC = 'clock'
"""The player's clock, relative: ``/clock``, or ``/fleet_a/clock`` in a fleet's namespace."""
DEFAULT_DEPTH = 10
"""The replay history of a topic whose bag names no offered QoS (rosbag2's default)."""


class BagError(ValueError):
    """A bag that cannot be replayed: missing, not a bag, truncated or corrupt."""


def resolve_name(name: str, namespace: str = '/') -> str:
    """
    Return the absolute name a bag holds of a topic ``name`` given in ``namespace``.

    A bag records resolved names: an absolute name stays as it is, a relative one is prefixed
    with the namespace (``vehicle_1/odom`` in ``/fleet_a``: ``/fleet_a/vehicle_1/odom``).
    """
    return names.resolve(namespace, name)


@dataclass(frozen=True)
class ReplayQos:
    """The QoS a replayed topic is published with: keep last ``depth``."""

    reliable: bool
    transient_local: bool
    depth: int


def replay_qos(offered: Sequence[Any]) -> ReplayQos:
    """
    Return the QoS to replay a topic with, from the profiles its recorded publishers offered.

    As ``ros2 bag play``: reliable only if every publisher offered reliable, transient local
    only if every one offered it (so that every subscriber the recorded ones matched still
    matches), the largest depth; a topic without offered profiles is reliable, volatile,
    :data:`DEFAULT_DEPTH`.

    Parameters
    ----------
    offered : sequence of rosbags.interfaces.Qos
        The topic's ``offered_qos_profiles`` (metadata.yaml).

    Returns
    -------
    ReplayQos

    """
    if not offered:
        return ReplayQos(True, False, DEFAULT_DEPTH)
    depth = max((q.depth for q in offered if q.depth > 0), default=DEFAULT_DEPTH)
    return ReplayQos(all(q.reliability.name == 'RELIABLE' for q in offered),
                     all(q.durability.name == 'TRANSIENT_LOCAL' for q in offered), depth)


@dataclass(frozen=True)
class Topic:
    """A replayed topic: name, ROS type (``pkg/msg/Name``), QoS."""

    name: str
    msgtype: str
    qos: ReplayQos


def _corrupt(path: str | Path, err: BaseException) -> BagError:
    return BagError(f'{path}: the bag is truncated or corrupt ({type(err).__name__}: {err}); a '
                    f'bag whose recorder was killed: `formation-control repair {path}`')


class Bag:
    """
    A bag opened for replay; ``topics`` (iterable of names) selects topics, None: all.

    ``topics`` and ``skip`` are absolute names or names relative to ``namespace``
    (:func:`resolve_name`).

    Raises
    ------
    BagError
        Not a bag directory, an unreadable or corrupt one, or a named topic it lacks.

    """

    def __init__(self, path: str | Path, topics: Iterable[str] | None = None,
                 skip: Iterable[str] = (), namespace: str = '/') -> None:
        self.path = Path(path)
        wanted_names = None if topics is None else {resolve_name(t, namespace) for t in topics}
        skipped = {resolve_name(t, namespace) for t in skip}
        if not (self.path / 'metadata.yaml').is_file():
            raise BagError(unclosed(path) or f'{path}: not a rosbag2 bag (a directory with '
                           f'metadata.yaml)')
        try:
            with Reader(self.path) as reader:
                conns = list(reader.connections)
                self.start = reader.start_time
                self.end = max(self.start, reader.end_time - 1)     # rosbags: one past the last
        except (ReaderError, OSError, ValueError, KeyError, MemoryError) as err:
            raise _corrupt(path, err) from None
        names = {c.topic for c in conns}
        missing = sorted(set(wanted_names or ()) - names)
        if missing:
            raise BagError(f'{path}: no topic {", ".join(missing)} in the bag (it has: '
                           f'{", ".join(sorted(names))})')
        wanted = (wanted_names or names) - skipped
        self.connections = [c for c in conns if c.topic in wanted]
        self.topics = self._topics()

    def _topics(self) -> list[Topic]:
        by_name: dict[str, list[Any]] = {}
        for c in self.connections:
            by_name.setdefault(c.topic, []).append(c)
        out = []
        for name, conns in sorted(by_name.items()):
            types = {c.msgtype for c in conns}
            if len(types) > 1:
                raise BagError(f'{self.path}: topic {name} has several types: {sorted(types)}')
            offered = [q for c in conns for q in (getattr(c.ext, 'offered_qos_profiles', None)
                                                  or [])]
            out.append(Topic(name, types.pop(), replay_qos(offered)))
        return out

    def messages(self) -> Iterator[tuple[str, int, bytes]]:
        """
        Yield (topic, recorded time in ns, CDR bytes) of the selected topics in time order.

        Raises
        ------
        BagError
            The bag turns out to be corrupt while it is read.

        """
        if not self.connections:
            return
        try:
            with Reader(self.path) as reader:
                conns = [c for c in reader.connections
                         if c.topic in {t.name for t in self.topics}]
                for conn, ns, data in reader.messages(connections=conns):
                    yield conn.topic, ns, data
        except (ReaderError, OSError, ValueError, KeyError, MemoryError, struct.error) as err:
            raise _corrupt(self.path, err) from None


class Schedule:
    """
    When a recorded time is due in wall time: ``rate`` recorded seconds per wall second.

    Parameters
    ----------
    start : int
        The bag's first recorded time (ns), replayed at wall time ``wall0`` (s).
    rate : float
        Playback rate, > 0.
    wall0 : float
        Wall time (s, any monotonic clock) at which the replay starts.

    """

    def __init__(self, start: int, rate: float, wall0: float) -> None:
        self.start, self.rate, self.wall0 = start, rate, wall0

    def due(self, ns: int) -> float:
        """Return the wall time (s) at which the message recorded at ``ns`` is published."""
        return self.wall0 + (ns - self.start) * 1e-9 / self.rate

    def now(self, wall: float) -> int:
        """Return the recorded time (ns) that plays at wall time ``wall`` (s): the clock."""
        return self.start + int(round((wall - self.wall0) * self.rate * 1e9))
