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
Scripted faults of a fleet run (``formation-control swarm --fault ...``), in fleet time.

A fault is ``kill:K@T`` (SIGKILL vehicle K's process), ``restart:K@T`` (start it again,
killed first if it still runs), ``stop:K@T`` / ``cont:K@T`` (SIGSTOP / SIGCONT: the vehicle
freezes, then resumes) or ``cut:I-J@T1..T2`` (the link between neighbours I and J is down from
T1 to T2: each drops every message of the other, through its ``cut_links`` parameter). Times
are fleet (simulated) seconds. :func:`schedule` parses and checks a script against the
scenario; :class:`Schedule` hands the faults out as fleet time passes. The swarm runner
applies them.
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
import re

from formation_control.core.control import Controller
from formation_control.core.errors import UsageError
from formation_control.core.parameters import Scenario
from formation_control.core.scenario import resolve
from formation_control.sim import metrics
from formation_control.sim.simulator import Run

PROCESS_KINDS = ('kill', 'restart', 'stop', 'cont')
LINK_KINDS = ('cut', 'mend')
"""``mend`` ends a cut; it is written as the end of ``cut:I-J@T1..T2``."""
SYNTAX = 'kill|restart|stop|cont:K@T or cut:I-J@T1..T2 (K, I, J vehicle ids; T fleet seconds)'

_NUMBER = r'(\d+(?:\.\d*)?|\.\d+)'
_PROCESS = re.compile(rf'^({"|".join(PROCESS_KINDS)}):(\d+)@{_NUMBER}$')
_CUT = re.compile(rf'^cut:(\d+)-(\d+)@{_NUMBER}\.\.{_NUMBER}$')


@dataclass(frozen=True)
class Fault:
    """
    One scripted fault.

    Attributes
    ----------
    kind : str
        One of ``PROCESS_KINDS`` or :data:`LINK_KINDS`.
    vehicles : tuple of int
        The vehicle (process faults) or the two ends of the link (1-based ids).
    time : float
        Fleet time at which it applies (s).
    text : str
        The script entry it comes from.

    """

    kind: str
    vehicles: tuple[int, ...]
    time: float
    text: str

    def describe(self) -> str:
        """Return a one-line description, e.g. ``kill vehicle 3`` or ``cut link 1-2``."""
        if self.kind in LINK_KINDS:
            return f'{self.kind} link {self.vehicles[0]}-{self.vehicles[1]}'
        return f'{self.kind} vehicle {self.vehicles[0]}'


def parse(text: str) -> list[Fault]:
    """
    Parse one script entry.

    Parameters
    ----------
    text : str
        ``kill:3@8``, ``restart:3@40``, ``stop:2@10``, ``cont:2@15`` or ``cut:1-2@5..10``.

    Returns
    -------
    list of Fault
        One fault, or a ``cut`` and its ``mend``.

    Raises
    ------
    UsageError
        If the entry does not follow ``SYNTAX`` or a cut ends before it starts.

    """
    entry = text.strip()
    m = _PROCESS.match(entry)
    if m:
        return [Fault(m[1], (int(m[2]),), float(m[3]), entry)]
    m = _CUT.match(entry)
    if not m:
        raise UsageError(f'--fault {text!r} is invalid: expected {SYNTAX}')
    pair, start, end = (int(m[1]), int(m[2])), float(m[3]), float(m[4])
    if not start < end:
        raise UsageError(f'--fault {text!r} is invalid: the cut must end after it starts '
                         f'({start:g} .. {end:g} s)')
    return [Fault('cut', pair, start, entry), Fault('mend', pair, end, entry)]


def _check_ids(fault: Fault, sc: Scenario) -> None:
    n = sc.num_vehicles
    bad = [k for k in fault.vehicles if not 1 <= k <= n]
    if bad:
        raise UsageError(f'--fault {fault.text!r} is invalid: vehicle ids must lie in '
                         f'1..num_vehicles = {n}')
    if not fault.time <= sc.duration:
        raise UsageError(f'--fault {fault.text!r} is invalid: {fault.time:g} s is after the '
                         f'end of the run (duration {sc.duration:g} s)')
    if fault.kind == 'cut':
        i, j = fault.vehicles
        if i == j or j not in sc.comm_graph.neighbours(i):
            raise UsageError(f'--fault {fault.text!r} is invalid: vehicles {i} and {j} are '
                             f'not neighbours in the communication graph ({sc.graph})')


_STATES = {'kill': ('running', 'stopped'), 'stop': ('running',), 'cont': ('stopped',),
           'restart': ('running', 'stopped', 'killed')}
_AFTER = {'kill': 'killed', 'stop': 'stopped', 'cont': 'running', 'restart': 'running'}


def schedule(texts: Iterable[str], sc: Scenario) -> Schedule:
    """
    Parse and check a fault script against scenario ``sc``.

    Each vehicle's faults must make sense in time order (ties in the order given): ``stop``
    and ``kill`` a running vehicle (``kill`` also a stopped one), ``cont`` a stopped one; a
    vehicle's cuts do not overlap on the same link.

    Returns
    -------
    Schedule

    Raises
    ------
    UsageError
        Naming the entry and what is wrong with it.

    """
    faults = [f for text in texts for f in parse(text)]
    state = dict.fromkeys(range(1, sc.num_vehicles + 1), 'running')
    down: set[frozenset[int]] = set()
    for f in sorted(faults, key=lambda f: f.time):
        _check_ids(f, sc)
        if f.kind in PROCESS_KINDS:
            k = f.vehicles[0]
            if state[k] not in _STATES[f.kind]:
                raise UsageError(f'--fault {f.text!r} is invalid: vehicle {k} is {state[k]} '
                                 f'at {f.time:g} s')
            state[k] = _AFTER[f.kind]
        else:
            link = frozenset(f.vehicles)
            if (f.kind == 'cut') == (link in down):
                raise UsageError(f'--fault {f.text!r} is invalid: it overlaps another cut of '
                                 f'link {f.vehicles[0]}-{f.vehicles[1]}')
            (down.add if f.kind == 'cut' else down.discard)(link)
    return Schedule(faults)


class Schedule:
    """
    The faults of a run, handed out as fleet time passes, and the links they leave down.

    Parameters
    ----------
    faults : list of Fault
        Checked by :func:`schedule`.

    """

    def __init__(self, faults: Iterable[Fault]) -> None:
        self.pending = sorted(faults, key=lambda f: f.time)
        self.down: set[frozenset[int]] = set()

    def __bool__(self) -> bool:
        return bool(self.pending)

    @property
    def acts_on_processes(self) -> bool:
        """Return whether a pending fault kills, restarts, stops or continues a process."""
        return any(f.kind in PROCESS_KINDS for f in self.pending)

    def due(self, t: float) -> list[Fault]:
        """Return the faults whose time has come at fleet time ``t`` (s), in time order, once."""
        count = next((i for i, f in enumerate(self.pending) if f.time > t), len(self.pending))
        out, self.pending = self.pending[:count], self.pending[count:]
        return out

    def cut_links(self, fault: Fault) -> dict[int, tuple[int, ...]]:
        """
        Apply a link fault; return ``{vehicle: cut_links}`` for its two ends.

        ``cut_links`` is the sorted tuple of the neighbours whose messages the vehicle drops.
        """
        link = frozenset(fault.vehicles)
        (self.down.add if fault.kind == 'cut' else self.down.discard)(link)
        return {k: tuple(sorted(j for pair in self.down if k in pair for j in pair if j != k))
                for k in fault.vehicles}


def survivors_converged(run: Run,
                        members: Sequence[int]) -> tuple[bool, float | None] | tuple[None, None]:
    """
    Return whether, and from when, the vehicles ``members`` reach the formation in ``run``.

    Parameters
    ----------
    run : simulator.Run
        A recorded run.
    members : sequence of int
        The 1-based ids of the vehicles still running at the end.

    Returns
    -------
    (bool or None, float or None)
        :func:`metrics.verdict` of :func:`metrics.converged` on the members' states alone,
        measured as a complete fleet of their number (the survivors' own formation), and the
        time from which it held (s; None unless converged); (None, None) without members.

    """
    rows = [k - 1 for k in members]
    if not rows:
        return None, None
    sub = resolve({**run.sc.to_dict(), 'num_vehicles': len(rows), 'graph': 'complete',
                   'graph_edges': [], 'graph_offsets': [1], 'graph_nu': 0.0, 'informed': [],
                   'pattern': 'none', 'pattern_form': 'auto', 'init_x': [], 'init_y': [],
                   'init_theta': [], 'init_omega': [], 'init_u': [], 'init_v': []})
    ctrl = Controller(sub)
    flags = [bool(metrics.converged(sub, metrics.snapshot(ctrl, X[:, rows], U[:, rows], t,
                                                          gust=gust[rows])))
             for t, X, U, gust in zip(run.t, run.X, run.U, run.gust)]
    verdict = metrics.settling(sub, run.t, flags)
    return verdict.converged, verdict.since if verdict.converged else None
