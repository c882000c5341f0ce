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
The plant's side of the time protocol: which commands a step waits for, and real-time pacing.

Pure state machines with an injected clock (a callable returning wall seconds), so that every
rule is tested without DDS; the ``plant`` node converts messages and calls them.

Lockstep: the plant publishes step n and waits for the command of every vehicle stamped with
step n, except the vehicles that are gone (heard, then silent for ``command_timeout``) or
stopped. While one has not answered, every vehicle waited for is asked again
(:meth:`CommandGate.nudge`) with a back-off, and a second answer to a step asked again is counted
apart from a stale command.
Real time: the plant integrates the steps the wall clock has reached (:class:`Pacer`) and
samples vehicle k's odometry at integration step (k - 1) mod substeps of each period
(:func:`sample_slots`).
"""
from __future__ import annotations

from collections.abc import Callable
import math

from formation_control.core.geometry import BoolArray, IntArray
from formation_control.protocol.links import Liveness
import numpy as np

NUDGE_AFTER = 4.0
"""A step is asked again once it lasted this many times the previous one (at least 1 s)."""

FRESH, REPEATED, STALE = 'fresh', 'repeated', 'stale'
"""What a command is to the step under way (:meth:`CommandGate.command`)."""


class CommandGate:
    """
    The commands of ``n`` vehicles that one plant step waits for.

    Parameters
    ----------
    n : int
        Number of vehicles.
    command_timeout : float
        Wall seconds of silence after which a vehicle that was heard is gone (s).
    clock : callable
        Returns the wall time (s), monotonic.
    lockstep : bool
        Lockstep (commands are stamped with the step they answer) or real time (the latest
        command of each vehicle is held, whatever its stamp).

    """

    def __init__(self, n: int, command_timeout: float, clock: Callable[[], float],
                 lockstep: bool = True) -> None:
        self.clock = clock
        self.lockstep = lockstep
        self.liveness = Liveness(n, command_timeout)
        self.got = np.zeros(n, bool)
        self.cmd_ns = np.full(n, -1, np.int64)
        self.step_ns: int | None = None
        self.since = math.inf if lockstep else -math.inf
        self.last_length = 0.0
        self.nudged = -math.inf
        self.step_nudges = 0
        self.nudges = 0
        self.repeated = 0

    def begin(self, step_ns: int) -> None:
        """
        Start waiting for the commands of the step stamped ``step_ns`` (ns).

        Parameters
        ----------
        step_ns : int
            Stamp of the step just published (ns).

        """
        now = self.clock()
        if math.isfinite(self.since):
            self.last_length = now - self.since
        self.since, self.nudged, self.step_nudges = now, now, 0
        self.step_ns = step_ns
        self.got[:] = False

    def command(self, i: int, ns: int) -> str:
        """
        Note a well-formed command of vehicle index ``i`` (0-based) stamped ``ns``.

        Returns
        -------
        str
            :data:`FRESH` (hold it; it answers the step under way in lockstep),
            :data:`REPEATED` (the second answer to a step asked again: ignore) or
            :data:`STALE` (lockstep: it answers another step, or no step is under way).

        """
        self.liveness.heard(i, self.clock())
        if not self.lockstep:
            return FRESH
        if ns == self.cmd_ns[i]:
            self.repeated += 1
            return REPEATED
        if ns != self.step_ns:
            return STALE
        self.got[i], self.cmd_ns[i] = True, ns
        return FRESH

    def close(self) -> None:
        """End the run: every later command is stale."""
        self.step_ns = None

    def gone(self) -> BoolArray:
        """(n,) bool: vehicles no longer waited for (heard, then silent; see :class:`Liveness`)."""
        return self.liveness.gone(self.clock(), self.since, self.got)

    def waited(self, stopped: BoolArray) -> BoolArray:
        """(n,) bool: vehicles the step waits for: neither gone nor ``stopped``."""
        return ~self.gone() & ~np.asarray(stopped)

    def ready(self, stopped: BoolArray) -> bool:
        """Whether every vehicle waited for has answered (and at least one is waited for)."""
        waited = self.waited(stopped)
        return bool(waited.any() and np.all(self.got[waited]))

    def missing(self, stopped: BoolArray) -> BoolArray:
        """(n,) bool: vehicles waited for that have not answered this step."""
        return self.waited(stopped) & ~self.got

    def nudge(self, stopped: BoolArray) -> BoolArray | None:
        """
        Return the vehicles to ask again for this step, or None when it is not time yet.

        The first time once the step has lasted :data:`NUDGE_AFTER` times the previous one (at
        least a second), then after twice that wait, and so on: a slow start-up of a large fleet
        is not flooded, and a sample that DDS matched but never handed over cannot stall it.
        Every vehicle waited for is asked, not only those missing: one that lost a neighbour's
        state waits for it, and only the neighbour, answering again, sends it again.
        """
        now = self.clock()
        wait = max(1.0, NUDGE_AFTER * self.last_length) * 2.0 ** self.step_nudges
        if now - self.nudged <= wait or not self.missing(stopped).any():
            return None
        self.nudged = now
        self.nudges += 1
        self.step_nudges += 1
        return self.waited(stopped)

    def waiting_for(self) -> float:
        """Wall seconds the step under way has lasted (0 before the first step)."""
        return self.clock() - self.since if math.isfinite(self.since) else 0.0


class Pacer:
    """
    Real time: how many integration steps the wall clock has reached.

    Parameters
    ----------
    tick_rate : float
        Integration steps per wall second, ``real_time_factor / dt_integration`` (1/s).
    substeps : int
        Integration steps per control period.
    t0_wall : float
        Wall time of simulated t = 0 (s).

    """

    def __init__(self, tick_rate: float, substeps: int, t0_wall: float) -> None:
        self.tick_rate = tick_rate
        self.substeps = substeps
        self.t0_wall = t0_wall
        self.tick = 0
        self.behind = 0.0
        """Wall seconds the simulated time has slipped so far (:meth:`due`)."""

    def due(self, now: float) -> int:
        """
        Integration steps to take at wall time ``now`` (s) to catch up with the clock.

        A late timer skips its missed periods, so they are counted here. More than a control
        period behind, the machine is overloaded: simulated time slips (``t0_wall`` moves)
        rather than the commands waiting behind a long catch-up.
        """
        due = int((now - self.t0_wall) * self.tick_rate)
        behind = due - self.tick - self.substeps
        if behind > 0:
            self.t0_wall += behind / self.tick_rate
            self.behind += behind / self.tick_rate
            due -= behind
        return max(0, due - self.tick)

    def advance(self) -> int:
        """Count one integration step taken; returns the new tick."""
        self.tick += 1
        return self.tick

    @property
    def boundary(self) -> bool:
        """Whether the next step starts a control period."""
        return self.tick % self.substeps == 0


def sample_slots(n: int, substeps: int) -> IntArray:
    """
    (n,) int: the integration step of each period at which vehicle k's odometry is sampled.

    Vehicle k (1-based) is sampled at step (k - 1) mod substeps, as unsynchronised sensors
    would be: the fleet's control callbacks are spread over the period.
    """
    return np.arange(n) % substeps
