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
The plant's side of the fleet's protocol, without DDS: commands in, steps and odometry out.

The ``plant`` node decodes each command (:mod:`intake`; an aircraft's is its autopilot demand
on ``cmd_vel``, :meth:`Plant.demand`), hands it to a :class:`Plant` and publishes the steps it
returns. The plant holds the fleet (:class:`fleet.FleetPlant`), the
commands each lockstep step waits for (:class:`lockstep.CommandGate`) and, in real time, the
pacing of the integration steps (:class:`lockstep.Pacer`). Refused commands come back as an
:class:`intake.Rejection`; vehicles that diverge are reported in ``Plant.errors``.
"""
from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any

from formation_control.core import stability
from formation_control.core.geometry import BoolArray, IntArray
from formation_control.core.parameters import Scenario
from formation_control.protocol.fleet import FleetPlant
from formation_control.protocol.intake import Rejection
from formation_control.protocol.lockstep import (CommandGate, Pacer, REPEATED, sample_slots,
                                                 STALE)
from formation_control.protocol.messages import FormationState, input_from_cmd_values
import numpy as np

Step = tuple[BoolArray, int, bool]
"""A step to send: the vehicles whose odometry, its stamp (ns), whether it begins a step."""


class Plant:
    """
    The time protocol of the fleet of scenario ``sc``.

    Parameters
    ----------
    sc : scenario.Scenario
    lockstep : bool
        Lockstep (each step waits for every command) or real time (paced by ``clock``).
    command_timeout : float
        Wall seconds after which a silent vehicle is gone (zero command).
    clock : callable
        Returns the wall time (s), monotonic.

    Attributes
    ----------
    fleet : fleet.FleetPlant
    gate : lockstep.CommandGate
    finished : bool
        The run is over: the last period recorded, or every vehicle diverged (``failed``).
    errors : list of str
        What went wrong since the node last read them (a vehicle diverged, the run stops).

    """

    def __init__(self, sc: Scenario, lockstep: bool, command_timeout: float,
                 clock: Callable[[], float]) -> None:
        self.sc, self.lockstep, self.clock = sc, lockstep, clock
        self.fleet = FleetPlant(sc)
        self.gate = CommandGate(sc.num_vehicles, command_timeout, clock, lockstep)
        self.pacer: Pacer | None = None
        self.slot: IntArray | None = None
        self.wall_start: float | None = None
        self.t0_ns, self.wall = 0, 0.0
        self.started = self.finished = self.failed = False
        self.errors: list[str] = []
        self.created = clock()

    def stamp_ns(self, t: float) -> int:
        """Return the stamp (ns) of simulated time ``t`` (s)."""
        return self.t0_ns + int(round(t * 1e9))

    def begin(self) -> int:
        """Lockstep: begin the step under way; return its stamp (ns), for its odometry."""
        self.started = True
        ns = self.stamp_ns(self.fleet.time)
        self.gate.begin(ns)
        return ns

    def start_clock(self, t0_ns: int, real_time_factor: float) -> float:
        """
        Real time: simulated time 0 is ``t0_ns``; return the tick period (wall s).

        ``slot`` says which vehicles' odometry each integration step sends, slot 0 now.
        """
        self.started, self.t0_ns = True, t0_ns
        tick_rate = real_time_factor / self.sc.dt_integration
        self.pacer = Pacer(tick_rate, self.sc.substeps, self.clock())
        self.slot = sample_slots(self.sc.num_vehicles, self.sc.substeps)
        return 1.0 / tick_rate

    def command(self, k: int, ns: int, values: Sequence[float]) -> bool | Rejection:
        """
        Take vehicle k's command: its CMD_FIELDS ``values`` stamped ns.

        Returns True when it is held, False for a second answer to the step, or the
        :class:`Rejection` of a non-finite or stale command.
        """
        u = input_from_cmd_values(values, self.sc.model)
        if not np.all(np.isfinite(u)):
            return Rejection('non_finite', f'a non-finite command of vehicle {k}')
        answer = self._answer(k, ns, 'command')
        if answer is True:
            self.fleet.set_command(k - 1, u)
        return answer

    def demand(self, k: int, ns: int, demand: Sequence[float]) -> bool | Rejection:
        """
        Take aircraft k's cmd_vel stamped ns: its autopilot's airspeed and turn-rate demand.

        It answers the step as a command does (:meth:`command`); its values are finite
        (:func:`intake.autopilot_demand` checked them).
        """
        answer = self._answer(k, ns, 'cmd_vel')
        if answer is True:
            self.fleet.set_demand(k - 1, demand)
        return answer

    def _answer(self, k: int, ns: int, what: str) -> bool | Rejection:
        kind = self.gate.command(k - 1, ns)
        if kind == REPEATED:
            return False
        if kind == STALE:
            return Rejection('stale', f'a {what} of vehicle {k} for another step')
        return True

    def estimate(self, k: int, state: FormationState) -> None:
        """Keep the flow estimate of vehicle k's :class:`messages.FormationState`, to record."""
        step = (state.stamp - self.t0_ns) // round(self.sc.dt_control * 1e9)
        flow_hat = complex(np.nan, np.nan) if state.flow_hat is None else state.flow_hat
        self.fleet.estimate(k - 1, int(step), flow_hat)

    def advance(self) -> Step | None:
        """
        Lockstep: advance once every vehicle still waited for has commanded the step.

        Returns
        -------
        ((N,) bool, int, bool) or None
            The vehicles whose odometry to send, its stamp (ns) and whether it begins a step:
            the next step (every vehicle), or the step under way again to the vehicles nudged
            (:meth:`lockstep.CommandGate.nudge`).

        """
        step_ns = self.gate.step_ns
        if not self.lockstep or self.finished or step_ns is None:     # None: not yet started
            return None
        stopped = self.fleet.stopped
        if not self.gate.ready(stopped):
            again = self.gate.nudge(stopped)
            return None if again is None else (again, step_ns, False)
        if not self._hold(True):
            return None
        self._integrate()
        if self.finished:
            return None
        self.fleet.next_period()
        return np.ones(self.sc.num_vehicles, bool), self.begin(), True

    def ticks(self) -> Iterator[Step]:
        """Real time: integrate the steps the clock has reached; yield each as :meth:`advance`."""
        pacer, slot = self.pacer, self.slot
        if pacer is None or slot is None:
            raise RuntimeError('start the clock before its ticks')
        for _ in range(pacer.due(self.clock())):
            if self.finished or not self._hold(pacer.boundary):
                return
            self._integrate(1)
            tick = pacer.advance()
            self.fleet.reach_tick(tick)
            yield (slot == tick % self.sc.substeps,
                   self.stamp_ns(tick * self.sc.dt_integration), False)

    def _hold(self, boundary: bool) -> bool:
        if self.wall_start is None:
            self.wall_start = self.clock()
        if self.fleet.hold(self.gate.gone(), boundary):
            return True
        self._finish()
        return False

    def _integrate(self, steps: int | None = None) -> None:
        for i in self.fleet.integrate(steps):
            self.errors.append(
                f'vehicle {i + 1}: its state became non-finite or exploded after t = '
                f'{self.fleet.time:.3f} s (command {self.fleet.pending[:, i].tolist()}); '
                f'vehicle {i + 1} is stopped. Likely cause: {stability.likely_cause(self.sc)}')
        if self.fleet.stopped.all() and not self.finished:
            self.errors.append(f'every vehicle diverged by t = {self.fleet.time:.3f} s: the run '
                               f'stops')
            self.failed = True
            self._finish()

    def progress(self) -> dict[str, float]:
        """Return the meta data of the record so far: the wall and simulated time reached."""
        wall = 0.0 if self.wall_start is None else self.clock() - self.wall_start
        return {'wall_time': self.wall if self.finished else wall,
                'simulated_time': self.fleet.time}

    def summary(self) -> tuple[dict[str, float], str]:
        """Return the meta data of the run's record and its one-line summary, once finished."""
        simulated, wall = self.fleet.time, self.wall
        return ({'wall_time': wall, 'simulated_time': simulated},
                f'plant: {simulated:g} s simulated in {wall:.3g} s of wall time '
                f'(real-time factor {simulated / max(wall, 1e-9):.3g})')

    def _finish(self) -> None:
        if self.wall_start is not None:
            self.wall = self.clock() - self.wall_start
        self.finished = True
        self.gate.close()

    def behind(self) -> float:
        """Real time: the wall seconds the simulated time has slipped from its pace (else 0)."""
        return 0.0 if self.pacer is None else self.pacer.behind

    def stalled(self, limit: float) -> tuple[float, list[int]] | None:
        """Lockstep: (seconds waited, ids of the vehicles missing) past ``limit`` s, else None."""
        waited = self.gate.waiting_for()
        if not self.lockstep or self.finished or waited <= limit:
            return None
        return waited, (np.flatnonzero(self.gate.missing(self.fleet.stopped)) + 1).tolist()

    def silent(self, unmatched: Sequence[int] = ()) -> dict[int, float]:
        """
        Return the silent vehicles: id -> wall seconds the fleet has waited on each.

        The vehicles gone (heard, then silent past the command timeout), since each was last
        heard; in lockstep those the step under way still waits for, as long as it has
        lasted; in real time before the clock starts, the ``unmatched`` ids (no command
        publisher matched yet), since the plant was made. What the swarm heals by
        (:mod:`formation_control.protocol.healing`).
        """
        if self.finished:
            return {}
        now, out = self.clock(), {}
        gone = self.gate.gone() & ~self.fleet.stopped
        for i in np.flatnonzero(gone):
            out[int(i) + 1] = now - float(self.gate.liveness.last[i])
        if self.lockstep and self.gate.step_ns is not None:
            waited = self.gate.waiting_for()
            for i in np.flatnonzero(self.gate.missing(self.fleet.stopped)):
                out[int(i) + 1] = max(out.get(int(i) + 1, 0.0), waited)
        if not self.lockstep and self.pacer is None:
            out.update(dict.fromkeys(map(int, unmatched), now - self.created))
        return dict(sorted(out.items()))

    def status(self, counts: Mapping[str, int],
               unmatched: Sequence[int] = ()) -> tuple[str, str, dict[str, Any]]:
        """
        Return the level ('ok', 'warn' or 'error'), text and values of the plant's status.

        ``counts`` are the node's counts of rejected input, listed among the values, with the
        silent vehicles (:meth:`silent`, ``unmatched`` its argument).
        """
        gone = (np.flatnonzero(self.gate.gone()) + 1).tolist()
        stopped = (np.flatnonzero(self.fleet.stopped) + 1).tolist()
        level, text = 'ok', f'step {self.fleet.n}'
        if gone:
            level, text = 'warn', f'vehicles {gone} gone (zero command)'
        if stopped:
            level, text = 'error', f'vehicles {stopped} stopped: non-finite state'
        silent = self.silent(unmatched)
        behind = self.behind()
        if self.pacer is not None and behind > 0 and level == 'ok':
            pace = self.pacer.tick_rate * self.sc.dt_integration
            level, text = 'warn', (f'{behind:.1f} s behind the wall clock: the machine does not '
                                   f'keep the pace asked (real_time_factor {pace:g})')
        values = {'step': self.fleet.n, 'gone': gone, 'stopped': stopped,
                  'behind': round(behind, 2),
                  'silent': list(silent), 'silent_for': [round(t, 2) for t in silent.values()],
                  **counts,
                  'nudges': self.gate.nudges, 'repeated_commands': self.gate.repeated}
        return level, text, values
