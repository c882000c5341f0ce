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
The monitor's rules, without ROS.

What it samples, when the formation counts as converged, the status of each vehicle and of
the formation, the marker trails and the gains it follows.

:class:`Watch` holds one fleet's latest odometry and commands and is driven by the monitor's
callbacks; ``clock`` (wall seconds) dates what it hears, so a fake clock tests it.
"""
from __future__ import annotations

from collections.abc import Callable, Hashable, Mapping
from typing import Any, TypeAlias

from formation_control.core import graphs, laws, separation
from formation_control.core.control import Controller
from formation_control.core.geometry import BoolArray, ComplexArray, IntArray, RealArray
from formation_control.core.models import ground_velocity, position, ROW_X, ROW_Y
from formation_control.core.parameters import RUNTIME, Scenario
from formation_control.core.scenario import resolve
from formation_control.protocol import names
from formation_control.sim import metrics
import numpy as np
from numpy.typing import ArrayLike

OK, WARN, ERROR = 0, 1, 2
"""Status levels (those of diagnostic_msgs/DiagnosticStatus)."""
STREAMS = {'odom': 'odom', 'cmd': 'cmd', 'state': 'formation_state'}
"""The streams heard of each vehicle, with the topic each is named by in a status."""
StatusValue: TypeAlias = 'str | float | bool'
"""A value of a status (a diagnostic key/value pair shows its ``str``)."""
Status: TypeAlias = 'tuple[str, int, str, dict[str, StatusValue]]'
"""A status: (name, level, message, values)."""
Picture: TypeAlias = ('tuple[RealArray, int, ComplexArray, ComplexArray | None, '
                      'ComplexArray | None, complex | None]')
"""What a sample shows (:meth:`Watch.picture`)."""


def _hashable(value: Any) -> Hashable:
    return tuple(value) if isinstance(value, (list, tuple)) else value


class GainAgreement:
    """
    The run-time parameters every vehicle of the fleet holds (``/parameter_events``).

    A new value is taken once every vehicle announced it; one vehicle changed on its own keeps
    the last common value.

    Parameters
    ----------
    sc : scenario.Scenario
        The fleet's scenario: every vehicle holds its values at first.
    namespace : str
        The fleet's namespace: vehicle k is the node ``<namespace>/vehicle_k``.

    """

    def __init__(self, sc: Scenario, namespace: str = '/') -> None:
        self.sc = sc
        prefix = names.namespace_prefix(namespace)
        self.vehicle_of = {f'{prefix}vehicle_{k}': k for k in range(1, sc.num_vehicles + 1)}
        self.held = {name: [_hashable(getattr(sc, name))] * sc.num_vehicles for name in RUNTIME}

    def announce(self, node: str, changed: Mapping[str, Any],
                 convert: Callable[[Any], Any] | None = None) -> dict[str, Hashable]:
        """
        Note the parameters ``node`` announced ({name: value}); return those the fleet agrees on.

        The returned values ({name: value}, {} none) differ from the scenario's; :meth:`take`
        makes them the scenario's. ``convert`` turns an announced value into a Python one; it
        is called only for the run-time parameters of the fleet's vehicles.
        """
        k = self.vehicle_of.get(node)
        changed = {name: v for name, v in changed.items() if name in RUNTIME}
        if k is None or not changed:
            return {}
        for name, value in changed.items():
            self.held[name][k - 1] = _hashable(value if convert is None else convert(value))
        return {name: values[0] for name, values in self.held.items()
                if len(set(values)) == 1 and values[0] != _hashable(getattr(self.sc, name))}

    def take(self, agreed: Mapping[str, Hashable]) -> Scenario:
        """Return the scenario with the ``agreed`` values, now the current one (ScenarioError)."""
        self.sc = resolve({**self.sc.to_dict(), **{
            name: list(v) if isinstance(v, tuple) else v for name, v in agreed.items()}})
        return self.sc


class Sampling:
    """
    When the monitor samples: once it holds an odometry of every vehicle from the current period.

    Parameters
    ----------
    n : int
        Number of vehicles.
    period : float
        Fleet seconds between two samples (0: every step).

    """

    def __init__(self, n: int, period: float) -> None:
        self.period_ns = int(round(period * 1e9))
        self.odom_ns = np.full(n, -1, np.int64)
        self.t0_ns: int | None = None
        self.next_ns: int | None = None
        self.t = 0.0
        """Fleet seconds of the last sample from the first (0 before any)."""

    def odom(self, i: int, ns: int) -> bool:
        """Note vehicle ``i``'s (0-based) odometry stamped ``ns``; return whether to sample now."""
        self.odom_ns[i] = ns
        oldest = self.odom_ns.min()
        if oldest < 0 or (self.next_ns is not None and oldest < self.next_ns):
            return False
        if self.t0_ns is None:
            self.t0_ns = ns
        self.next_ns = ns + self.period_ns
        self.t = (ns - self.t0_ns) * 1e-9
        return True


class Latch:
    """
    The convergence latch: ``since`` is when the formation last entered its test.

    It counts as converged only once the test has held at every sample for ``hold`` seconds
    (:func:`metrics.hold_window`), the rule of :func:`metrics.verdict` in real time; leaving
    the test starts the wait again.
    """

    def __init__(self, hold: float = 0.0) -> None:
        self.hold = hold
        self.entered: float | None = None
        self.t = 0.0

    @property
    def converged(self) -> bool:
        return self.entered is not None and self.t - self.entered >= self.hold - 1e-9

    @property
    def since(self) -> float | None:
        """Return when the formation entered the test it still meets, once converged."""
        return self.entered if self.converged else None

    def update(self, converged: bool, t: float) -> bool:
        """Note whether the formation meets its test at ``t``; return whether that changed."""
        was = self.converged
        self.t = t
        if not converged:
            self.entered = None
        elif self.entered is None:
            self.entered = t
        return was != self.converged


class Trails:
    """The last ``length`` sampled positions of each of ``n`` vehicles (a ring)."""

    def __init__(self, length: int, n: int) -> None:
        self.ring = np.full((length, n), np.nan, complex)
        self.count = 0

    def add(self, positions: ComplexArray) -> None:
        self.ring[self.count % len(self.ring)] = positions
        self.count += 1

    def ordered(self) -> ComplexArray:
        """Return the trails, shape (N, count), each vehicle's oldest position first."""
        count = min(self.count, len(self.ring))
        order = (np.arange(count) + self.count - count) % len(self.ring)
        return self.ring[order].T


def vehicle_level(ages: Mapping[str, float], stale: float, saturated: bool,
                  lagging: float | None = None) -> tuple[int, list[str]]:
    """
    Return the status level and reasons of one vehicle.

    Parameters
    ----------
    ages : dict of str to float
        Wall seconds since each stream of :data:`STREAMS` was heard.
    stale : float
        The ``stale_timeout`` (s): a stream older is stale; a stale odometry is an error.
    saturated : bool
        Its command is saturated.
    lagging : float, optional
        The fleet time (s) when the formation is late and this vehicle has not reached its
        share; None: neither.

    Returns
    -------
    (int, list of str)

    """
    reasons = [f'stale {topic} ({ages[s]:.1f} s)' for s, topic in STREAMS.items()
               if ages[s] > stale]
    if saturated:
        reasons.append('command saturated')
    if lagging is not None:
        reasons.append(f'not converging after {lagging:.1f} s')
    level = ERROR if ages['odom'] > stale else WARN if reasons else OK
    return level, reasons


def formation_level(t: float, since: float | None, converge_within: float) -> tuple[int, str]:
    """Return the formation's status level and message at fleet time ``t``."""
    if since is not None:
        return OK, f'converged in {since:.2f} s'
    if t > converge_within:
        return WARN, f'not converged after {t:.1f} s'
    return OK, 'converging'


def separation_level(distance: float, pair: tuple[int, int], d_min: float) -> tuple[int, str]:
    """
    Return the separation's status level and message: ERROR below d_min, WARN below 2 d_min.

    Parameters
    ----------
    distance : float
        The smallest distance between two vehicles (m); nan with fewer than two.
    pair : (int, int)
        Their ids (from 1).
    d_min : float
        The separation distance (m), :func:`separation.limits`.

    Returns
    -------
    (int, str)
        E.g. ``(ERROR, 'vehicles 2 and 5 0.31 m apart: below d_min = 1 m')``.

    """
    if not distance < 2.0 * d_min:
        return OK, 'kept apart' if np.isfinite(distance) else 'one vehicle'
    where = f'vehicles {pair[0]} and {pair[1]} {distance:.3g} m apart'
    if distance < d_min:
        return ERROR, f'{where}: below d_min = {d_min:.4g} m'
    return WARN, f'{where}: below 2 d_min = {2.0 * d_min:.4g} m'


HISTORY = 16
"""Odometry samples and commands kept per vehicle, so that a sample takes each vehicle's as of
its stamp: a monitor that joins late gets each vehicle's last samples at once (transient local),
one vehicle after the other, and vehicle 1 is steps ahead when vehicle 2's first one arrives."""


class History:
    """
    The last :data:`HISTORY` values (``rows`` each) of each of ``n`` vehicles, with their stamps.

    :meth:`as_of` reads, for each vehicle, its latest value stamped at or before a time.
    """

    def __init__(self, rows: int, n: int, depth: int = HISTORY) -> None:
        self.ns = np.full((depth, n), -1, np.int64)
        self.values = np.full((depth, rows, n), np.nan)
        self.head = np.zeros(n, int)

    def add(self, i: int, ns: int, value: ArrayLike) -> None:
        """Keep vehicle ``i``'s (0-based) ``value`` stamped ``ns``, over its oldest."""
        h = self.head[i]
        self.ns[h, i], self.values[h, :, i] = ns, value
        self.head[i] = (h + 1) % len(self.ns)

    def as_of(self, ns: int, latest: RealArray) -> RealArray:
        """Return (rows, n): each vehicle's last value stamped at most ``ns``, else ``latest``."""
        stamps = np.where(self.ns <= ns, self.ns, -1)
        best = stamps.argmax(axis=0)
        found = np.flatnonzero(stamps[best, np.arange(stamps.shape[1])] >= 0)
        out = np.array(latest, float)
        out[:, found] = self.values[best[found], :, found].T
        return out


class Watch:
    """
    The monitor's view of one fleet: its latest odometry and commands, what it heard when.

    A sample stamped t takes each vehicle's state and command as of t (:class:`History`).

    Parameters
    ----------
    sc : scenario.Scenario
        The fleet's scenario.
    namespace : str
        The fleet's namespace (its vehicles' node names).
    period, stale_timeout, converge_within : float
        The monitor's parameters of the same names (s).
    trail_length : int
        Samples per marker trail.
    clock : callable
        Wall seconds (monotonic).

    """

    def __init__(self, sc: Scenario, namespace: str, period: float, stale_timeout: float,
                 converge_within: float, trail_length: int, clock: Callable[[], float]) -> None:
        n = sc.num_vehicles
        self.gains = GainAgreement(sc, namespace)
        self.ctrl = Controller(sc)
        self.clock, self.stale, self.converge_within = clock, stale_timeout, converge_within
        self.X = np.full((6, n), np.nan)
        self.U = np.zeros((2, n))
        self.gust = np.zeros((2, n))
        self.past = {'X': History(6, n), 'U': History(2, n), 'gust': History(2, n)}
        self.heard = {stream: np.full(n, np.nan) for stream in STREAMS}
        self.started = clock()
        self.sampling = Sampling(n, period)
        self.latch = Latch(metrics.hold_window(sc))
        self.trails = Trails(trail_length, n)
        self.vehicle_ok = np.zeros(n, bool)
        self.saturated = np.zeros(n, bool)
        self.values: dict[str, float] = {}
        self.deaf: set[tuple[int, int]] = set()     # (k, j): k's latest state does not hear j
        self.shown: tuple[int, float, RealArray, RealArray, ComplexArray] | None = None
        self.d_min = separation.limits(sc).d_min
        self.closest: tuple[float, int, int] = (np.nan, -1, -1)

    @property
    def sc(self) -> Scenario:
        return self.gains.sc

    @property
    def t(self) -> float:
        return self.sampling.t

    def take(self, agreed: Mapping[str, Hashable]) -> None:
        """Follow the gains the fleet agreed on (:meth:`GainAgreement.announce`; ScenarioError)."""
        self.ctrl = Controller(self.gains.take(agreed))
        self.latch.hold = metrics.hold_window(self.sc)
        self.d_min = separation.limits(self.sc).d_min

    def flow(self, x: RealArray, y: RealArray) -> ComplexArray:
        """Return the flow at (x, y) at the time of the last sample."""
        return self.ctrl.plant.flow(self.t, x, y)

    def odom(self, k: int, x: ArrayLike, ns: int, ground: complex | None = None) -> bool:
        """
        Note vehicle k's state ``x`` stamped ``ns``; return whether to sample now.

        ``ground``: the odometry's ground velocity (complex m/s), the true motion; what the
        state in the flowfield (:meth:`flow`) does not explain of it is the vehicle's gust, which
        the metrics then read (:func:`metrics.snapshot`): a particle's, whose speed through the
        water is its model's (a rigid body's u, v are read from the odometry, so none is left).
        """
        x = np.asarray(x, float)
        if ground is not None:
            gust = ground - complex(ground_velocity(x, self.flow(x[ROW_X], x[ROW_Y])))
            self.gust[:, k - 1] = gust.real, gust.imag
            self.past['gust'].add(k - 1, ns, self.gust[:, k - 1])
        self.X[:, k - 1] = x
        self.past['X'].add(k - 1, ns, x)
        self.heard['odom'][k - 1] = self.clock()
        return self.sampling.odom(k - 1, ns)

    def cmd(self, k: int, u: ArrayLike, ns: int) -> None:
        """Note vehicle k's command ``u`` stamped ``ns`` (the odometry it answers)."""
        self.U[:, k - 1] = u
        self.past['U'].add(k - 1, ns, u)
        self.heard['cmd'][k - 1] = self.clock()

    def state(self, k: int, hears: Mapping[int, bool]) -> None:
        """Note vehicle k's formation state: ``hears`` {neighbour id: heard} (from ``hears_j``)."""
        for j, heard in hears.items():
            if heard:
                self.deaf.discard((k - 1, j - 1))
            else:
                self.deaf.add((k - 1, j - 1))
        self.heard['state'][k - 1] = self.clock()

    def live_graph(self) -> tuple[BoolArray, IntArray]:
        """Return the live vehicles (N,) bool and the live links (L, 2), 0-based."""
        fresh = self.clock() - self.heard['state'] <= self.stale
        return fresh, graphs.live_edges(self.sc.comm_graph, fresh, self.deaf)

    def sample(self, ns: int) -> tuple[dict[str, float], bool]:
        """
        Take the sample stamped ``ns`` (after :meth:`odom` said so): return its metrics.

        Returns
        -------
        (dict of str to float, bool)
            The metrics and whether the convergence latch changed.

        """
        X, U = self.past['X'].as_of(ns, self.X), self.past['U'].as_of(ns, self.U)
        gust = self.past['gust'].as_of(ns, self.gust)
        gust = gust[0] + 1j * gust[1]
        snap = metrics.snapshot(self.ctrl, X, U, self.t, gust=gust)
        fresh, live = self.live_graph()
        self.values = {**snap.values(), 'live_links': float(len(live)),
                       'algebraic_connectivity': graphs.connectivity(fresh, live)}
        self.shown = ns, self.t, X, U, gust
        self.trails.add(position(X))
        flow = self.flow(X[ROW_X], X[ROW_Y])
        self.vehicle_ok = metrics.vehicles_converged(self.ctrl,
                                                     self.ctrl.view(X, U[1], flow, gust))
        self.saturated = self.ctrl.saturated(U)
        self.closest = separation.closest_pair(np.stack([X[ROW_X], X[ROW_Y]], axis=-1))
        return self.values, self.latch.update(bool(metrics.converged(self.sc, snap)), self.t)

    def vehicle_status(self, i: int) -> Status:
        """Return vehicle i's (0-based) status: (name, level, message, values)."""
        now = self.clock()
        ages = {s: now - (h[i] if np.isfinite(h[i]) else self.started)
                for s, h in self.heard.items()}
        late = self.t > self.converge_within and not self.latch.converged
        lagging = self.t if late and not self.vehicle_ok[i] else None
        level, reasons = vehicle_level(ages, self.stale, self.saturated[i], lagging)
        values: dict[str, StatusValue] = {f'{s}_age': f'{a:.3f}' for s, a in ages.items()}
        if self.ctrl.rigid:
            values.update(thrust=self.U[0, i], steering_force=self.U[1, i])
        else:
            values['turn_command'] = self.U[1, i]
        values['converged'] = bool(self.vehicle_ok[i])
        return f'vehicle_{i + 1}', level, '; '.join(reasons) or 'ok', values

    def formation_status(self, rejected: int) -> Status:
        """Return the formation's status: (name, level, message, values)."""
        values: dict[str, StatusValue] = {'time': f'{self.t:.3f}',
                                          'rejected_messages': rejected}
        values.update({k: f'{v:.6g}' for k, v in self.values.items()})
        if self.latch.converged:
            values['convergence_time'] = f'{self.latch.since:.3f}'
        level, message = formation_level(self.t, self.latch.since, self.converge_within)
        return 'formation', level, message, values

    def separation_status(self) -> Status:
        """
        Return the separation's status at the last sample (:func:`separation_level`).

        Horizontal distances: the odometry carries no altitude.
        """
        distance, i, j = self.closest
        level, message = separation_level(distance, (i + 1, j + 1), self.d_min)
        values: dict[str, StatusValue] = {'d_min': f'{self.d_min:.6g}'}
        if np.isfinite(distance):
            values.update(closest=f'{distance:.6g}', pair=f'{i + 1} {j + 1}')
        return 'separation', level, message, values

    def statuses(self, rejected: int) -> list[Status]:
        """Return the formation's status, the separation's, then every vehicle's."""
        return [self.formation_status(rejected), self.separation_status()] + [
            self.vehicle_status(i) for i in range(self.sc.num_vehicles)]

    def picture(self) -> Picture | None:
        """
        Return what the last sample shows (None before any).

        Returns
        -------
        (X, ns, trails, ground, centres, target)
            States, stamp, :meth:`Trails.ordered`, ground velocities (None: no flow), circle
            centres c_k and the prescribed centre c0 (None: not circular, not informed).

        """
        if self.shown is None:
            return None
        ns, t, X, U, gust = self.shown
        field = self.ctrl.plant.flow(t, X[ROW_X], X[ROW_Y])
        flow = field + gust
        ground = ground_velocity(X, flow) if np.any(flow != 0) else None
        centres: ComplexArray | None = None
        target: complex | None = None
        if isinstance(self.ctrl.formation, laws.Circular):
            centres = self.ctrl.formation.centres(self.ctrl.view(X, U[1], field, gust))
            target = self.sc.c0_c if self.sc.informed else None
        return X, ns, self.trails.ordered(), ground, centres, target
