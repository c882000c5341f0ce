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
Which member of a fleet to restart when the fleet waits on it: the swarm's healing rule.

The middleware can leave a live process out of the fleet: a TLS member whose TCP links to a
peer never formed (the plant then waits at step 0 for good), or a survivor that a killed
neighbour left blocked inside Fast DDS's shared memory (it stops answering). The plant says
whom it waits for and how long on each (its ``/diagnostics`` values ``silent`` and
``silent_for``,
:meth:`~formation_control.protocol.plant.Plant.silent`); each vehicle says which neighbours'
states it waits for (``awaiting``). From those, :class:`Healer` names the members to stop and
start again, each with the reason, after :data:`HEAL_AFTER` wall seconds and at most
:data:`HEAL_LIMIT` times. Pure: the swarm (``formation_control.swarm``) feeds it what its
supervisor hears, with the wall clock.
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
import json
import math
import re

from formation_control.protocol import names

HEAL_AFTER = 15.0
"""Wall seconds the fleet waits on a member before it is restarted: past a TLS fleet's start
(10-30 s for a whole run of 3 here) and the 3 s at which the plant warns."""

HEAL_LIMIT = 3
"""Restarts of one member in a run, after which it is left as it is (and said so)."""

STARTUP = 2.5
"""Wall seconds a fleet's start-up may take per process, added to the deadline at step 0. A
vehicle process takes 0.5 s of CPU to start here (rclpy, the scenario); 8 processes started on
2 loaded cores took 12 s to all answer step 0 (a fleet waited 12 s on a healthy vehicle)."""


@dataclass(frozen=True)
class Heard:
    """
    What a vehicle's last status said, and when (wall s) it came.

    Attributes
    ----------
    at : float
        Wall time the status arrived (s).
    awaiting : tuple of int
        Ids of the neighbours whose state of the step it waits for (lockstep).

    """

    at: float
    awaiting: tuple[int, ...] = ()


class Hearing:
    """
    What the plant and the vehicles of the fleet in ``namespace`` last said on ``/diagnostics``.

    The plant's status (``formation_control/plant``) says its step and whom it waits on, each
    vehicle's links status (``formation_control/vehicle_<k>/links``) whom it awaits; other
    statuses, and values that do not parse, are passed over.
    """

    def __init__(self, namespace: str = '/') -> None:
        prefix = re.escape(names.status_prefix(namespace) + 'formation_control/')
        self.pattern = re.compile(prefix + r'(?:plant|vehicle_(\d+)/links)')
        self.plant_status: tuple[int, dict[int, float]] | None = None
        self.heard: dict[int, Heard] = {}
        self.plants: dict[str, float] = {}
        """Each plant's ``run`` identity -> when its status last came (wall s)."""

    def hear(self, name: str, values: Mapping[str, str], now: float) -> None:
        """Take one status ``name`` with its key/value pairs, heard at wall ``now``."""
        found = self.pattern.fullmatch(name)
        if found is None:
            return
        try:
            if found[1] is None:
                self.plants[values.get('run', '')] = now
                ids, waited = json.loads(values['silent']), json.loads(values['silent_for'])
                self.plant_status = (int(values['step']),
                                     dict(zip(map(int, ids), map(float, waited))))
            else:
                self.heard[int(found[1])] = Heard(
                    now, tuple(map(int, json.loads(values.get('awaiting', '[]')))))
        except (KeyError, ValueError, TypeError):
            return

    def plants_within(self, seconds: float, now: float) -> list[str]:
        """Return the ``run`` identities of the plants heard within ``seconds`` of ``now``."""
        return sorted(run for run, at in self.plants.items() if now - at <= seconds)

    def take_plant_status(self) -> tuple[int, dict[int, float]] | None:
        """Return the plant's status heard since the last call (or None): each is judged once."""
        status, self.plant_status = self.plant_status, None
        return status


@dataclass
class Healer:
    """
    The healing rule of one fleet.

    Parameters
    ----------
    members : sequence of sequence of int
        The vehicle ids of each process, by process index (the plant's and the monitor's:
        empty).
    after : float
        :data:`HEAL_AFTER`; 0 turns healing off.
    limit : int
        :data:`HEAL_LIMIT`.
    startup : float
        Wall seconds added to ``after`` at step 0, while the fleet starts, and after a process
        is started again until it answers (:meth:`grace`; the swarm gives :data:`STARTUP` per
        process).

    """

    members: Sequence[Sequence[int]]
    after: float = HEAL_AFTER
    limit: int = HEAL_LIMIT
    startup: float = 0.0
    restarts: dict[int, int] = field(default_factory=dict)
    last: dict[int, float] = field(default_factory=dict)
    given_up: set[int] = field(default_factory=set)

    def resumed(self, process: int, now: float) -> None:
        """Note that ``process`` was started or continued at wall ``now`` (:meth:`grace`)."""
        self.last[process] = now

    def culprits(self, silent: Iterable[int], heard: Mapping[int, Heard],
                 now: float) -> list[int]:
        """
        Return the ids, among the ``silent`` ones the plant waits for, that hold the fleet.

        A silent vehicle whose own status has not come for ``after`` s (wedged, or its links
        never formed); then those the others' fresh statuses name as awaited; else (each
        silent vehicle speaks and waits for nobody: its link to the plant is the broken one)
        every silent vehicle.
        """
        silent = sorted(set(silent))
        mute = [k for k in silent if now - heard.get(k, Heard(-math.inf)).at > self.after]
        if mute:
            return mute
        awaited = {j for k, h in heard.items() if now - h.at <= self.after for j in h.awaiting}
        return [k for k in silent if k in awaited] or silent

    def due(self, step: int, silent: Mapping[int, float], heard: Mapping[int, Heard],
            running: Iterable[int], now: float) -> list[tuple[int, str]]:
        """
        Return the processes to restart now, each with its reason.

        Parameters
        ----------
        step : int
            The plant's step (0: the fleet never started).
        silent : mapping
            The plant's silent vehicles: id -> how long it has waited on it (wall s).
        heard : mapping
            Vehicle id -> its last :class:`Heard` status.
        running : iterable of int
            Indices of the processes that run (neither dead nor stopped by the fault script).
        now : float
            Wall time (s).

        """
        deadline = self.after + (self.startup if step == 0 else 0.0)
        late = [k for k, waited in silent.items() if waited > deadline]
        if not self.after or not late:
            return []
        ids = self.culprits(late, heard, now)
        process = {k: i for i, group in enumerate(self.members) for k in group}
        running = set(running)
        out = []
        for i in sorted({process[k] for k in ids if k in process} & running):
            mine = [k for k in ids if process.get(k) == i]
            if i in self.given_up or now - self.last.get(i, -math.inf) <= self.grace(
                    i, min(silent[k] for k in mine), now):
                continue
            if self.restarts.get(i, 0) >= self.limit:
                self.given_up.add(i)
                continue
            self.restarts[i] = self.restarts.get(i, 0) + 1
            self.last[i] = now
            out.append((i, self.reason(step, mine, max(silent[k] for k in mine))))
        return out

    def grace(self, process: int, silent_for: float, now: float) -> float:
        """
        Return the wall seconds ``process`` is left alone after its last (re)start.

        ``after``, once the plant has heard it since (it is silent for less than the time since
        its start); until then ``after + startup``: a process started again on a loaded machine
        may take as long to join as the whole fleet at its start.
        """
        answered = silent_for < now - self.last.get(process, -math.inf)
        return self.after + (0.0 if answered else self.startup)

    @staticmethod
    def reason(step: int, ids: Sequence[int], silent_for: float) -> str:
        """Return why vehicles ``ids`` are restarted, in words."""
        if step == 0:
            return (f'vehicles {list(ids)} never joined: the plant waited {silent_for:.1f} s '
                    'on them')
        return (f'vehicles {list(ids)} stopped answering: silent {silent_for:.1f} s at step '
                f'{step}')
