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
Vehicle k's side of the fleet's protocol, without DDS: what it does with each input.

The ``vehicle`` node decodes messages (:mod:`intake`), hands their values to a
:class:`Vehicle` and publishes what it returns. The vehicle keeps what it heard of its
neighbours (:class:`neighbours.NeighbourTable`), holds what the injected link faults delay
(:class:`links.Inbox`), pairs an odometry with the second sensor's message of its stamp
(:class:`onboard.Pairing`), predicts its state over its measured delay
(:class:`onboard.Delay`) and commands with :class:`onboard.Onboard`. Input it refuses comes
back as an :class:`intake.Rejection`.
"""
from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
import math
from typing import Any

from formation_control.core import aircraft
from formation_control.core.geometry import RealArray
from formation_control.core.parameters import Scenario
from formation_control.protocol import links
from formation_control.protocol.intake import Rejection, WRONG_FRAME
from formation_control.protocol.lockstep import REPEATED, STALE
from formation_control.protocol.messages import FormationState, ground_velocity_of, StateWire
from formation_control.protocol.names import DEFAULT_FRAMES, Frames
from formation_control.protocol.neighbours import NeighbourTable
from formation_control.protocol.onboard import (Delay, needs_second_sensor, Onboard, Pairing,
                                                sampled_state)
import numpy as np

NON_FINITE = 'non_finite'

Answer = FormationState | Rejection | str | None
"""What a vehicle makes of a measurement (:meth:`Vehicle.odometry`)."""


class Vehicle:
    """
    The protocol of vehicle ``k`` of scenario ``sc``.

    Parameters
    ----------
    sc : scenario.Scenario
    k : int
        Its id (1..N).
    lockstep : bool
        Lockstep (the plant waits for every command) or real time.
    link : dict
        Its link parameters (``neighbor_timeout`` and those of :class:`links.Faults`).
    clock : callable
        Returns the wall time (s), monotonic.
    frames : names.Frames

    Attributes
    ----------
    known : neighbours.NeighbourTable
    inbox : links.Inbox
    wire : messages.StateWire
        The layout of its own formation_state.
    saturated : int
        Commands sent on a limit.

    """

    def __init__(self, sc: Scenario, k: int, lockstep: bool, link: Mapping[str, Any],
                 clock: Callable[[], float], frames: Frames = DEFAULT_FRAMES) -> None:
        link = dict(link)
        self.sc, self.k, self.frames = sc, k, frames
        self.known = NeighbourTable(sc.num_vehicles, k, link.pop('neighbor_timeout'), clock,
                                    lockstep, sc.comm_graph.neighbours(k),
                                    sc.hold_prediction != 'none')
        self.inbox = links.Inbox(links.Faults(**link, vehicle_id=k), clock)
        self.delay = Delay(sc.dt_control, 0.0 if lockstep else 0.5 * sc.dt_integration)
        self.onboard, self.pairing = Onboard(sc), Pairing()
        self.flow, self.second = sc.flow_c, needs_second_sensor(sc)
        self.wire = StateWire.of(sc, k, frames)
        self.saturated = 0
        self.answered_at = -np.inf

    def retune(self, sc: Scenario) -> None:
        """Take the run-time parameters of ``sc``."""
        self.sc = sc
        self.onboard.retune(sc)

    @property
    def liveness_timeout(self) -> float:
        """Return the wall seconds of silence after which a neighbour is gone."""
        return float(self.known.liveness.timeout)

    @property
    def faults_active(self) -> bool:
        """Return whether injected faults may hold what it hears (then call :meth:`deliver`)."""
        return self.inbox.faults.active

    @property
    def cut(self) -> list[int]:
        """Return the ids of the neighbours whose links are cut, sorted."""
        return sorted(self.inbox.faults.cut)

    def cut_links(self, ids: Iterable[int]) -> list[int]:
        """Cut the links from the neighbours ``ids``, restoring the others; return :attr:`cut`."""
        self.inbox.faults.cut = set(ids)
        return self.cut

    @property
    def odom_ns(self) -> int:
        """Return the stamp (ns) of its last odometry, -1 before the first."""
        return self.known.odom_ns

    @property
    def answered(self) -> bool:
        """Return whether its last odometry has been commanded (a step asked again is)."""
        return self.known.commanded_ns == self.known.odom_ns

    def encode(self, state: FormationState) -> bytes:
        """Return the bytes of its own :class:`FormationState`, in the layout of its ``wire``."""
        return self.wire.encode(state)

    def measured_delay(self, seconds: float) -> None:
        """Take one measured delay (s) of the node, odometry in -> command out (real time)."""
        self.delay.add(seconds)

    def flow_heard(self, ns: int, flow: complex, frame: str) -> Answer:
        """Take the known flow (complex m/s) of stamp ns in ``frame``; see :meth:`odometry`."""
        if not (math.isfinite(flow.real) and math.isfinite(flow.imag)):
            return Rejection(NON_FINITE, 'a non-finite flow')
        if frame != self.frames.world:
            return Rejection(WRONG_FRAME, f'a flow in frame {frame!r}')
        self.flow = flow
        return self._measure(self.pairing.add_other(ns, flow)) if self.second == 'flow' else None

    def water_heard(self, ns: int, rel: Sequence[float], frame: str) -> Answer:
        """Take the water velocity (u, v) of stamp ns in ``frame``; see :meth:`odometry`."""
        if not all(map(math.isfinite, rel)):
            return Rejection(NON_FINITE, 'a non-finite water_velocity')
        if frame != self.frames.base(self.k):
            return Rejection(WRONG_FRAME, f'a water_velocity in frame {frame!r}')
        return self._measure(self.pairing.add_other(ns, rel))

    def odometry(self, ns: int, values: Sequence[float]) -> Answer:
        """
        Take its odometry's ODOM_FIELDS ``values`` of stamp ns.

        Returns
        -------
        FormationState, Rejection, REPEATED or None
            The state to send (its step is sampled), why the input is refused, REPEATED (a
            lockstep step asked again: answer as before) or None (waiting for the pair).

        """
        if not all(map(math.isfinite, values)):
            return Rejection(NON_FINITE, 'a non-finite odometry')
        if self.second is None:
            return self._measure((ns, values, None))
        return self._measure(self.pairing.add_odometry(ns, values))

    def _measure(self, pair: tuple[int, Sequence[float], Any] | None) -> Answer:
        if pair is None:
            return None
        ns, values, other = pair
        X, flow = sampled_state(self.second, values, other, self.flow, self.sc.model)
        if not np.all(np.isfinite(X)):
            return Rejection(NON_FINITE, 'a non-finite odometry')
        kind = self.known.odometry(ns)
        if kind == STALE:
            return Rejection('stale', f'an odometry stamped {ns * 1e-9:.3f} s, older than the '
                                      f'last one')
        if kind == REPEATED:
            return REPEATED
        delay = self.delay.ahead
        row = self.onboard.observe(X, flow, ground_velocity_of(values), delay)
        self.known.store(self.k, ns, row)
        ahead = 0 if self.sc.hold_prediction == 'none' else round(
            (delay + self.sc.command_lead) * 1e9)
        return FormationState.of_vehicle(ns, self.onboard.predicted[:, 0], row,
                                         self.known.hears(self.wire.hears),
                                         self.onboard.flow[0] if self.wire.estimates else None,
                                         ahead)

    def heard(self, j: int, state: FormationState) -> bool | Rejection:
        """
        Take neighbour j's :class:`FormationState` as it arrives (the faults may delay it).

        Returns True once it is in the table, False while the inbox holds or drops it, or the
        :class:`Rejection` of a non-finite or stale state.
        """
        if not state.finite():
            return Rejection(NON_FINITE, f'a non-finite formation_state of vehicle {j}')
        if self.inbox.receive(j, state, self.known.r[self.k - 1], state.r) != links.NOW:
            return False
        return self.accept(j, state)

    def deliver(self) -> Iterator[bool | Rejection]:
        """
        Put in the table, one by one, the states the faults held whose time has come.

        Yields what :meth:`accept` makes of each, in the order they fall due.
        """
        for j, state in self.inbox.due():
            yield self.accept(j, state)

    def accept(self, j: int, state: FormationState) -> bool | Rejection:
        """Put neighbour j's state in the table; see :meth:`heard`."""
        if not self.known.hear(j, state.stamp, state.row, state.hears_vehicle(self.k)):
            return Rejection('stale', f'a formation_state of vehicle {j} stamped '
                                      f'{state.stamp * 1e-9:.3f} s, older than the last one')
        return True

    def command(self) -> tuple[int, RealArray, bool] | None:
        """
        Return the command now due: (stamp ns, input (2,), whether it is the first), or None.

        :meth:`neighbours.NeighbourTable.ready` says when one is due and from whom.
        """
        members = self.known.ready()
        if members is None:
            return None
        view, own = self.known.view(members, self.onboard.speed_dot)
        u, saturated = self.onboard.command(view, own, members)
        self.saturated += saturated
        first = self.known.commanded_ns < 0
        self.known.commanded()
        self.answered_at = self.known.clock()
        return self.known.odom_ns, u, first

    def autopilot_demand(self, u: RealArray) -> tuple[float, float]:
        """
        Return an aircraft's autopilot demand for its input ``u`` (2,): airspeed, turn rate.

        :func:`aircraft.turn_demand` of the state sampled for the command: what the plant's
        autopilot holds (plant_backend jsbsim), the vehicle's ``cmd_vel``.
        """
        X = self.onboard.sampled
        if X is None:
            raise RuntimeError('no sampled state: a demand follows a command')
        demand = aircraft.turn_demand(self.sc, X, np.asarray(u, float)[:, None])
        return float(demand[0, 0]), float(demand[1, 0])

    def stalled(self, now: float, born: float,
                limit: float) -> str | float | tuple[float, list[int]] | None:
        """
        Return what the vehicle has waited for more than ``limit`` wall s, else None.

        ``'odometry'`` (none yet, ``born`` the start); lockstep, (seconds waited, the ids of
        the neighbours whose state of the step is awaited); or, its last odometry answered,
        the seconds since that command (a float): no new odometry came, because the plant
        waits for another vehicle, has ended, or this vehicle no longer hears it.
        """
        known = self.known
        if known.odom_ns < 0:
            return 'odometry' if now - born > limit else None
        if not self.answered:
            waited = now - known.since
            if not known.lockstep or waited <= limit:
                return None
            return waited, (np.flatnonzero(known.waiting()) + 1).tolist()
        silence = now - self.answered_at
        return silence if silence > limit else None

    def status(self, counts: Mapping[str, int]) -> tuple[list[int], str, dict[str, Any]]:
        """
        Return (gone neighbours' ids, text, the diagnostic values) of its links.

        ``counts`` are the node's counts of rejected input, listed among the values.
        """
        gone = (np.flatnonzero(self.known.gone()) + 1).tolist()
        live = int(np.count_nonzero(self.known.live())) - 1
        delayed = self.inbox.counts[links.DELAYED]
        fhat = complex(self.onboard.flow[0])
        values = {'live_neighbours': live, 'gone_neighbours': gone, **counts,
                  'flow_source': self.sc.flow_source, 'flow_hat_x': f'{fhat.real:.6f}',
                  'flow_hat_y': f'{fhat.imag:.6f}', **self.inbox.counts,
                  'saturated': self.saturated,
                  'mean_delay': f'{self.inbox.delay_total / max(1, delayed):.4f}'}
        text = f'neighbours {gone} silent' if gone else f'{live} neighbours live'
        return gone, text, values
