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

The ``plant`` node decodes each command (:mod:`intake`), hands it to a :class:`Plant` and
publishes the steps it returns. The plant holds the fleet (:class:`fleet.FleetPlant`), the
commands each lockstep step waits for (:class:`lockstep.CommandGate`) and, in real time, the
pacing of the integration steps (:class:`lockstep.Pacer`). Refused commands come back as an
:class:`intake.Rejection`; vehicles that diverge are reported in :attr:`Plant.errors`.
"""
from formation_control.core import stability
from formation_control.protocol.fleet import FleetPlant
from formation_control.protocol.intake import Rejection
from formation_control.protocol.lockstep import (CommandGate, Pacer, REPEATED, sample_slots,
                                                 STALE)
from formation_control.protocol.messages import input_from_cmd_values
import numpy as np


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

    def __init__(self, sc, lockstep, command_timeout, clock):
        self.sc, self.lockstep, self.clock = sc, lockstep, clock
        self.fleet = FleetPlant(sc)
        self.gate = CommandGate(sc.num_vehicles, command_timeout, clock, lockstep)
        self.pacer = self.slot = self.wall_start = None
        self.t0_ns, self.wall = 0, 0.0
        self.started = self.finished = self.failed = False
        self.errors = []

    def stamp_ns(self, t):
        """Return the stamp (ns) of simulated time ``t`` (s)."""
        return self.t0_ns + int(round(t * 1e9))

    def begin(self):
        """Lockstep: begin the step under way; return its stamp (ns), for its odometry."""
        self.started = True
        ns = self.stamp_ns(self.fleet.time)
        self.gate.begin(ns)
        return ns

    def start_clock(self, t0_ns, real_time_factor):
        """
        Real time: simulated time 0 is ``t0_ns``; return the tick period (wall s).

        :attr:`slot` says which vehicles' odometry each integration step sends, slot 0 now.
        """
        self.started, self.t0_ns = True, t0_ns
        tick_rate = real_time_factor / self.sc.dt_integration
        self.pacer = Pacer(tick_rate, self.sc.substeps, self.clock())
        self.slot = sample_slots(self.sc.num_vehicles, self.sc.substeps)
        return 1.0 / tick_rate

    def command(self, k, ns, values):
        """
        Take vehicle k's command: its CMD_FIELDS ``values`` stamped ns.

        Returns True when it is held, False for a second answer to the step, or the
        :class:`Rejection` of a non-finite or stale command.
        """
        u = input_from_cmd_values(values, self.sc.model)
        if not np.all(np.isfinite(u)):
            return Rejection('non_finite', f'a non-finite command of vehicle {k}')
        kind = self.gate.command(k - 1, ns)
        if kind == REPEATED:
            return False
        if kind == STALE:
            return Rejection('stale', f'a command of vehicle {k} for another step')
        self.fleet.set_command(k - 1, u)
        return True

    def estimate(self, k, state):
        """Keep the flow estimate of vehicle k's :class:`messages.FormationState`, to record."""
        step = (state.stamp - self.t0_ns) // round(self.sc.dt_control * 1e9)
        self.fleet.estimate(k - 1, int(step), state.flow_hat)

    def advance(self):
        """
        Lockstep: advance once every vehicle still waited for has commanded the step.

        Returns
        -------
        ((N,) bool, int, bool) or None
            The vehicles whose odometry to send, its stamp (ns) and whether it begins a step:
            the next step (every vehicle), or the step under way again to the vehicles nudged
            (:meth:`lockstep.CommandGate.nudge`).

        """
        if not self.lockstep or not self.started or self.finished:
            return None
        stopped = self.fleet.stopped
        if not self.gate.ready(stopped):
            again = self.gate.nudge(stopped)
            return None if again is None else (again, self.gate.step_ns, False)
        if not self._hold(True):
            return None
        self._integrate()
        if self.finished:
            return None
        self.fleet.next_period()
        return np.ones(self.sc.num_vehicles, bool), self.begin(), True

    def ticks(self):
        """Real time: integrate the steps the clock has reached; yield each as :meth:`advance`."""
        for _ in range(self.pacer.due(self.clock())):
            if self.finished or not self._hold(self.pacer.boundary):
                return
            self._integrate(1)
            tick = self.pacer.advance()
            self.fleet.reach_tick(tick)
            yield (self.slot == tick % self.sc.substeps,
                   self.stamp_ns(tick * self.sc.dt_integration), False)

    def _hold(self, boundary):
        if self.wall_start is None:
            self.wall_start = self.clock()
        if self.fleet.hold(self.gate.gone(), boundary):
            return True
        self._finish()
        return False

    def _integrate(self, steps=None):
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

    def summary(self):
        """Return the meta data of the run's record and its one-line summary, once finished."""
        simulated, wall = self.fleet.time, self.wall
        return ({'wall_time': wall, 'simulated_time': simulated},
                f'plant: {simulated:g} s simulated in {wall:.3g} s of wall time '
                f'(real-time factor {simulated / max(wall, 1e-9):.3g})')

    def _finish(self):
        self.wall = self.clock() - self.wall_start
        self.finished = True
        self.gate.close()

    def stalled(self, limit):
        """Lockstep: (seconds waited, ids of the vehicles missing) past ``limit`` s, else None."""
        waited = self.gate.waiting_for()
        if not self.lockstep or self.finished or waited <= limit:
            return None
        return waited, (np.flatnonzero(self.gate.missing(self.fleet.stopped)) + 1).tolist()

    def status(self, counts):
        """
        Return the level ('ok', 'warn' or 'error'), text and values of the plant's status.

        ``counts`` are the node's counts of rejected input, listed among the values.
        """
        gone = (np.flatnonzero(self.gate.gone()) + 1).tolist()
        stopped = (np.flatnonzero(self.fleet.stopped) + 1).tolist()
        level, text = 'ok', f'step {self.fleet.n}'
        if gone:
            level, text = 'warn', f'vehicles {gone} gone (zero command)'
        if stopped:
            level, text = 'error', f'vehicles {stopped} stopped: non-finite state'
        values = {'step': self.fleet.n, 'gone': gone, 'stopped': stopped, **counts,
                  'nudges': self.gate.nudges, 'repeated_commands': self.gate.repeated}
        return level, text, values
