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
Links between vehicles: who is alive, and the faults a study injects on what a vehicle hears.

Node parameters (not scenario parameters: the offline simulator has no links), with their
defaults, units and allowed ranges in :data:`PARAMETERS`.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
import heapq
import itertools
import math
from typing import Any, TypeVar

from formation_control.core.errors import ScenarioError
from formation_control.core.geometry import BoolArray
from formation_control.core.parameters import Spec
import numpy as np

M = TypeVar('M', bound=Mapping[str, Any])

PARAMETERS = {
    'neighbor_timeout': (1.0, Spec('s', 'wall seconds of silence after which a neighbour leaves '
                                   'the formation sums until it speaks again',
                                   low=0.01, high=3600.0)),
    'command_timeout': (2.0, Spec('s', 'plant: wall seconds without a command after which a '
                                  'vehicle that was heard is gone (lockstep: no longer waited '
                                  'for; both modes: zero command); keep it above '
                                  'neighbor_timeout', low=0.01, high=3600.0)),
    'drop_probability': (0.0, Spec('', 'probability that a neighbour message is dropped',
                                   low=0.0, high=1.0)),
    'delay': (0.0, Spec('s', 'fixed delay added to every neighbour message', low=0.0,
                        high=10.0)),
    'delay_jitter': (0.0, Spec('s', 'random extra delay, uniform in [0, delay_jitter]',
                               low=0.0, high=10.0)),
    'comm_range': (0.0, Spec('m', 'neighbours farther than this are not heard; 0 = no limit',
                             low=0.0, high=1e9)),
    'fault_links': ((), Spec('', 'neighbour ids the faults apply to; empty = every neighbour',
                             rule='ids in 1..num_vehicles other than its own')),
    'fault_seed': (0, Spec('', 'seed of the drops and delays (with the vehicle id)', low=0,
                           high=2 ** 31 - 1)),
    'cut_links': ((), Spec('', 'neighbour ids whose every message is dropped (the link is '
                           'down; swarm --fault cut:I-J@T1..T2 sets it at run time)',
                           rule='ids in 1..num_vehicles other than its own', runtime=True)),
}
"""name -> (default, :class:`parameters.Spec`): node parameters of the links (not scenario
parameters: the offline simulator has no links)."""


def check(values: M, n: int, own: int) -> M:
    """Validate link parameters of vehicle ``own`` in a fleet of n; returns the values."""
    for name, value in values.items():
        low, high = PARAMETERS[name][1].low, PARAMETERS[name][1].high
        if low is not None and not (math.isfinite(value) and low <= value <= high):
            raise ScenarioError(f"parameter '{name}' = {value!r} is invalid: allowed range "
                                f'[{low:g}, {high:g}]')
    for name in ('fault_links', 'cut_links'):
        bad = [j for j in values.get(name, ()) if not 1 <= j <= n or j == own]
        if bad:
            raise ScenarioError(f"parameter '{name}' = {list(values[name])} is invalid: "
                                f'neighbour ids in 1..{n} other than {own}')
    return values


class Liveness:
    """
    When each of n peers was last heard (wall seconds).

    A peer never heard is waited for
    (start-up); one heard, then silent for longer than ``timeout`` is ``gone`` until it is heard
    again.

    In lockstep a peer has nothing to say until the step it answers has begun, and nothing
    more once it has answered: silence is counted from ``since``, the wall time the current
    step began, when that is later, and only for the peers not ``answered`` yet.
    """

    def __init__(self, n: int, timeout: float) -> None:
        self.timeout = timeout
        self.last = np.full(n, np.nan)
        self.out = np.zeros(n, bool)

    def heard(self, i: int, now: float) -> None:
        self.last[i] = now
        self.out[i] = False

    def gone(self, now: float, since: float = -np.inf,
             answered: bool | BoolArray = False) -> BoolArray:
        silent = (now - np.fmax(self.last, since)) > self.timeout
        self.out |= ~np.isnan(self.last) & silent & ~np.asarray(answered)
        return self.out.copy()

    def alive(self, now: float, since: float = -np.inf,
              answered: bool | BoolArray = False) -> BoolArray:
        return ~self.gone(now, since, answered) & ~np.isnan(self.last)


@dataclass
class Faults:
    """Seeded drops, delays and range limit on the messages one vehicle hears; links cut."""

    drop_probability: float = 0.0
    delay: float = 0.0
    delay_jitter: float = 0.0
    comm_range: float = 0.0
    fault_links: tuple[int, ...] = ()
    fault_seed: int = 0
    cut_links: tuple[int, ...] = ()
    vehicle_id: int = 1

    def __post_init__(self) -> None:
        self.rng = np.random.default_rng([self.fault_seed, self.vehicle_id])
        self.links = set(self.fault_links)
        self.cut = set(self.cut_links)

    @property
    def active(self) -> bool:
        return bool(self.drop_probability or self.delay or self.delay_jitter or self.comm_range)

    def applies(self, j: int) -> bool:
        return not self.links or j in self.links

    def out_of_range(self, j: int, own_r: complex, their_r: complex) -> bool:
        return self.comm_range > 0 and self.applies(j) and abs(their_r - own_r) > self.comm_range

    def admit(self, j: int) -> float | None:
        """None: the message from j is dropped; else the delay (s) before it is delivered."""
        if j in self.cut:
            return None
        if not self.applies(j):
            return 0.0
        if self.drop_probability and self.rng.random() < self.drop_probability:
            return None
        jitter = self.rng.uniform(0.0, self.delay_jitter) if self.delay_jitter else 0.0
        return self.delay + jitter


OUT_OF_RANGE, DROPPED, DELAYED, NOW = 'out_of_range', 'dropped', 'delayed', 'now'
"""What :meth:`Inbox.receive` did with a message."""


class Inbox:
    """
    The neighbour messages of one vehicle through its injected faults.

    A message is out of range, dropped, delayed (held until :meth:`due` releases it) or
    delivered now. Counts of each outcome, and the sum of the delays, are in ``counts`` and
    ``delay_total`` (s).

    Parameters
    ----------
    faults : Faults
        The faults of the vehicle.
    clock : callable
        Returns the wall time (s), monotonic.

    """

    def __init__(self, faults: Faults, clock: Callable[[], float]) -> None:
        self.faults = faults
        self.clock = clock
        self.queue: list[tuple[float, int, int, Any]] = []
        self.arrivals = itertools.count()
        self.counts = dict.fromkeys((OUT_OF_RANGE, DROPPED, DELAYED), 0)
        self.delay_total = 0.0

    def receive(self, j: int, message: object, own_r: complex, their_r: complex) -> str:
        """
        Route ``message`` of neighbour ``j`` (positions ``own_r``, ``their_r``, complex, m).

        Returns
        -------
        str
            :data:`NOW` (deliver it), :data:`DELAYED`, :data:`DROPPED` or :data:`OUT_OF_RANGE`.

        """
        if self.faults.out_of_range(j, own_r, their_r):
            outcome = OUT_OF_RANGE
        else:
            delay = self.faults.admit(j)
            if delay is None:
                outcome = DROPPED
            elif delay > 0:
                heapq.heappush(self.queue, (self.clock() + delay, next(self.arrivals), j,
                                            message))
                self.delay_total += delay
                outcome = DELAYED
            else:
                return NOW
        self.counts[outcome] += 1
        return outcome

    def due(self) -> list[tuple[int, Any]]:
        """Release the delayed ``(j, message)`` whose time has come, in the order they fall due."""
        now, out = self.clock(), []
        while self.queue and self.queue[0][0] <= now:
            _, _, j, message = heapq.heappop(self.queue)
            out.append((j, message))
        return out
