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
A vehicle's side of the time protocol: what it knows of its neighbours, and when it commands.

:class:`NeighbourTable` keeps the latest formation state heard from each vehicle of the fleet
(its own included), who is live, and, in lockstep, which states the step under way still waits
for. It is pure, with an injected clock (a callable returning wall seconds); the ``vehicle`` node
converts messages and calls it.

Lockstep: the command for step t is computed once the vehicle holds its own odometry and the
state stamped t of every neighbour not gone; a neighbour never heard is waited for (start-up,
processes in any order). Real time: the command follows each odometry, from the latest states of
the live neighbours. A neighbour silent for ``timeout`` wall seconds leaves the formation sums
until it speaks again (:class:`links.Liveness`).

On a communication graph other than the complete one, each formation state also says which of
its sender's graph neighbours the sender hears; a neighbour is in the Laplacian sums only while
the link is mutual (it hears this vehicle too), so the sums stay symmetric however links drop.
"""
from __future__ import annotations

from collections.abc import Callable, Iterable
import math

from formation_control.core.geometry import BoolArray
from formation_control.core.laws import View
from formation_control.protocol.links import Liveness
from formation_control.protocol.lockstep import FRESH, REPEATED, STALE
from formation_control.protocol.messages import ViewRow
import numpy as np


class NeighbourTable:
    """
    The latest formation state of each of ``n`` vehicles, as vehicle ``own`` knows them.

    Parameters
    ----------
    n : int
        Number of vehicles in the fleet.
    own : int
        This vehicle's id k (1..n).
    timeout : float
        Wall seconds of silence after which a neighbour is gone (s).
    clock : callable
        Returns the wall time (s), monotonic.
    lockstep : bool
        Lockstep (wait for every neighbour's state of the step) or real time.
    neighbours : iterable of int, optional
        The ids this vehicle hears on the communication graph; every other vehicle by default.
    carry : bool, optional
        Carry the states of neighbours sampled earlier forward to this vehicle's stamp
        (:meth:`view`); off for the plain zero-order hold (``hold_prediction: none``).

    Attributes
    ----------
    r : (n,) complex
        Positions (m, world frame).
    table : (3, n) float
        Phase (rad), phase rate (rad/s) and speed (m/s) of each vehicle.
    stamp : (n,) int
        Stamp of each vehicle's state (ns); -1 = never heard.
    hears_me : (n,) bool
        Whether each vehicle's latest state says it hears this one (True until told).

    """

    def __init__(self, n: int, own: int, timeout: float, clock: Callable[[], float],
                 lockstep: bool = True, neighbours: Iterable[int] | None = None,
                 carry: bool = True) -> None:
        self.own = own - 1
        self.carry = carry
        self.linked = np.ones(n, bool)
        if neighbours is not None:
            self.linked[:] = False
            self.linked[[j - 1 for j in neighbours]] = True
        self.linked[self.own] = True
        self.clock = clock
        self.lockstep = lockstep
        self.liveness = Liveness(n, timeout)
        self.r = np.zeros(n, complex)
        self.table = np.zeros((3, n))
        self.stamp = np.full(n, -1, np.int64)
        self.hears_me = np.ones(n, bool)
        self.since = math.inf if lockstep else -math.inf
        self.odom_ns = -1
        self.commanded_ns = -1

    def odometry(self, ns: int) -> str:
        """
        Note this vehicle's odometry stamped ``ns`` (ns).

        Returns
        -------
        str
            :data:`~lockstep.FRESH` (a new step or sample), :data:`~lockstep.REPEATED` (lockstep:
            the plant asks the same step again; answer with the same state and command) or
            :data:`~lockstep.STALE` (older than the last one: drop it).

        """
        if ns < self.odom_ns:
            return STALE
        if self.lockstep:
            if ns == self.odom_ns:
                return REPEATED
            self.since = self.clock()
        self.odom_ns = ns
        return FRESH

    def store(self, j: int, ns: int, row: ViewRow) -> None:
        """
        Keep the state of vehicle ``j`` (1-based) stamped ``ns``.

        Parameters
        ----------
        j : int
            The vehicle's id (1-based).
        ns : int
            The stamp of its state (ns).
        row : tuple
            ``(r, phase, rate, speed)``: position (complex, m), phase (rad), rate (rad/s),
            speed (m/s).

        """
        i = j - 1
        self.r[i] = row[0]
        self.table[:, i] = row[1:]
        self.stamp[i] = ns

    def hear(self, j: int, ns: int, row: ViewRow, hears_me: bool = True) -> bool:
        """
        Keep a neighbour's state and mark ``j`` live, unless the state is older than the last.

        ``hears_me``: whether the state says ``j`` hears this vehicle.

        Returns
        -------
        bool
            False when the state is stale (dropped).

        """
        if ns < self.stamp[j - 1]:
            return False
        self.liveness.heard(j - 1, self.clock())
        self.store(j, ns, row)
        self.hears_me[j - 1] = hears_me
        return True

    def answered(self) -> BoolArray:
        """(n,) bool: vehicles whose state answers the step under way."""
        return self.stamp == self.odom_ns

    def _step(self) -> tuple[float, bool | BoolArray]:
        """Lockstep: silence counts from the step's start and only for who has not answered."""
        if self.lockstep:
            return self.since, self.answered()
        return -math.inf, False

    def gone(self) -> BoolArray:
        """(n,) bool: neighbours out of the formation sums (heard, then silent)."""
        gone = self.liveness.gone(self.clock(), *self._step())
        gone[self.own] = False
        return gone

    def live(self) -> BoolArray:
        """(n,) bool: the live neighbours, and the vehicle itself."""
        live = self.liveness.alive(self.clock(), *self._step())
        live[self.own] = True
        return live

    def hearing(self) -> BoolArray:
        """
        (n,) bool: the vehicles this one says it hears.

        Lockstep: every neighbour not gone (one not heard yet is waited for, so it will be);
        real time: the live ones.
        """
        return ~self.gone() if self.lockstep else self.live()

    def hears(self, ids: Iterable[int]) -> dict[int, bool]:
        """Return {j: whether this vehicle says it hears j} for each j of ``ids``."""
        hearing = self.hearing()
        return {j: bool(hearing[j - 1]) for j in ids}

    def waiting(self) -> BoolArray:
        """(n,) bool: lockstep, the vehicles whose state of the step under way is still awaited."""
        return ~self.gone() & ~self.answered() & self.linked

    def ready(self) -> BoolArray | None:
        """
        Members of the command now due, or None.

        Lockstep: once the vehicle has its odometry and every neighbour not gone has answered
        the step, and it has not commanded the step yet, the members are the vehicles whose state
        answers the step. Real time: after each odometry, the live vehicles ever heard. Either
        way only those that hear this vehicle too.
        """
        if self.odom_ns < 0:
            return None
        if not self.lockstep:
            return self.live() & (self.stamp >= 0) & self.hears_me
        if self.commanded_ns == self.odom_ns or self.waiting().any():
            return None
        return self.answered() & self.hears_me

    def commanded(self) -> None:
        """Note that the command of the step under way was sent."""
        self.commanded_ns = self.odom_ns

    def view(self, members: BoolArray, speed_dot: float) -> tuple[View, int]:
        """
        Return the particle view of the vehicles ``members`` and this vehicle's index in it.

        Parameters
        ----------
        members : (n,) bool
            The vehicles in the formation sums (this vehicle among them).
        speed_dot : float
            This vehicle's own s' (m/s^2); the neighbours' are taken as 0 (the laws use s' of
            the commanded vehicle only).

        A neighbour's state stamped earlier than this vehicle's odometry (real time: each
        vehicle samples in its own slot of the period) is carried forward to the odometry's
        stamp along its arc, from the rate and speed it sent (:meth:`laws.View.ahead`); in
        lockstep every state answers the step, so none is.

        Returns
        -------
        (laws.View, int)

        """
        own = int(np.count_nonzero(members[:self.own]))
        s_dot = np.zeros(np.count_nonzero(members))
        s_dot[own] = speed_dot
        phase, rate, speed = self.table[:, members]
        view = View(self.r[members], phase, rate, speed, s_dot)
        behind = self.odom_ns - self.stamp[members]
        if not (self.carry and behind.any()):
            return view, own
        return view.ahead(1e-9 * behind), own
