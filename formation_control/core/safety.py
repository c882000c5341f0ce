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
The decentralized safety layer of constant-speed vehicles: a turning-circle barrier per pair.

A vehicle of speed V whose only input is its turn rate ``u = theta'``, ``|u| <= u_max``, that
turns at ``sigma u_max`` (the layer's side sigma = +1 left, -1 right) flies a circle of radius
``rho = V / u_max`` about its **backup centre**::

    c_k = r_k + sigma rho i e^{i theta_k},   c_k' = V (1 - sigma u_k / u_max) e^{i theta_k}   (S.1)

which stands still while it turns so. For each pair within the sensing range the barrier is::

    h = |c_k - c_j| - D,   D = 2 rho + d_min + epsilon                                    (S.2)

and ``|r_k - r_j| >= |c_k - c_j| - 2 rho >= d_min + epsilon + h``: h >= 0 keeps the pair apart.
Its rate ``h' = g_k(u_k) + g_j(u_j)``, ``g_k(u) = V (1 - sigma u / u_max) <c_hat, e^{i theta_k}>``
with ``c_hat`` the unit vector from c_j to c_k, has relative degree 1 in each vehicle's turn
rate. Each vehicle keeps its half of the pair's condition ``h' >= -alpha h``:

    g_k(u_k) >= -alpha h / 2  <=>  a u_k <= b,   a = sigma rho p,   b = V p + alpha h / 2    (S.3)

with ``p = <c_hat, e^{i theta_k}>``: a half-line in u_k (:func:`half_lines`), from the
neighbour's position and heading alone. The neighbour keeps the other half, by the same rule
seen from its side, so the two add up to ``h' >= -alpha h``. ``u = sigma u_max`` gives
``g_k = 0``: it meets every half-line of every neighbour at once while every h >= 0, so the
filtered command (:func:`closest`: the nominal clipped to the intersection, a max/min of the
bounds) always exists then. See docs/separation.md, "The safety layer", for the conditions
(sensing range, control period) and the second-order chain.
"""
from __future__ import annotations

from dataclasses import dataclass
import math

from formation_control.core import aircraft
from formation_control.core.errors import refuse as _fail
from formation_control.core.flow import vehicle_speed
from formation_control.core.geometry import BoolArray, ComplexArray, IntArray, RealArray
from formation_control.core.laws import Index
from formation_control.core.parameters import Scenario
from formation_control.core.separation import limits, pairs_within
from formation_control.core.steering import law
from formation_control.core.vehicles import vehicle_model
import numpy as np
from numpy.typing import ArrayLike

DENSE = 128
"""Up to this many vehicles a fleet's pairs are all evaluated; beyond, a grid finds them."""


@dataclass(frozen=True)
class Layer:
    """
    The safety layer of a scenario (S.1)-(S.3).

    Attributes
    ----------
    d_min : float
        Separation distance (m).
    sensing_range : float
        Each vehicle hears every vehicle within it (m).
    speed : float
        V, the vehicles' speed (m/s).
    turn_rate : float
        u_max (rad/s): the filtered turn rate lies in [-u_max, u_max], and every vehicle can
        turn at it.
    gain : float
        alpha (1/s) of ``h' >= -alpha h``.
    side : float
        sigma, +1 (backup circles turn left, counter-clockwise) or -1.
    dt : float
        The control period (s): each filtered command is held this long.

    """

    d_min: float
    sensing_range: float
    speed: float
    turn_rate: float
    gain: float
    side: float
    dt: float

    @property
    def rho(self) -> float:
        """Return the radius of the backup circle ``V / u_max`` (m)."""
        return self.speed / self.turn_rate

    @property
    def margin(self) -> float:
        """
        Return the sampling margin epsilon (m) of (S.2): ``H dt^2 / 8``.

        ``H = 4 V u_max + 16 V^2 / (2 rho + d_min)`` bounds ``|h''|`` under held turn rates
        near h = 0 (``|c''| <= 2 V u_max`` per vehicle, ``|c_k' - c_j'| <= 4 V``): the
        condition met at the middle of a hold (the commands are computed for that state) keeps
        h >= -H dt^2 / 8 over it.
        """
        v, d = self.speed, self.d_min
        return (4.0 * v * self.turn_rate + 16.0 * v * v / (2.0 * self.rho + d)) * self.dt ** 2 / 8

    @property
    def reach(self) -> float:
        """Return D of (S.2): the distance of backup centres at which h = 0 (m)."""
        return 2.0 * self.rho + self.d_min + self.margin

    @property
    def needed_range(self) -> float:
        """
        Return the smallest sensing range that keeps d_min (m): ``D + 2 rho + 4 V dt``.

        A pair farther apart than ``D + 2 rho`` has h > 0 whatever the headings; h falls at
        most 4 V (``|c'| <= 2 V``) in the period before a newly heard neighbour is filtered.
        """
        return self.reach + 2.0 * self.rho + 4.0 * self.speed * self.dt


def turn_rate(sc: Scenario) -> float:
    """
    Return u_max (rad/s): safety_turn_rate, else first order's max_turn_rate, else V / d_min.

    The derived ``V / d_min`` makes the backup circle's radius d_min (particles: 10 rad/s).
    """
    if sc.safety_turn_rate > 0:
        return sc.safety_turn_rate
    if vehicle_model(sc.model).first_order and sc.max_turn_rate > 0:
        return sc.max_turn_rate
    return vehicle_speed(sc) / limits(sc).d_min


def of(sc: Scenario) -> Layer | None:
    """Return the scenario's :class:`Layer`, None with ``safety: off``."""
    if sc.safety == 'off':
        return None
    lim = limits(sc)
    u_max = turn_rate(sc)
    side = math.copysign(1.0, sc.omega0) if sc.formation == 'circular' else 1.0
    return Layer(lim.d_min, lim.sensing_range, vehicle_speed(sc), u_max,
                 sc.safety_gain or 2.0 * u_max, side, sc.dt_control)


def check(sc: Scenario) -> tuple[str, ...]:
    """
    Refuse a safety layer that is not built or cannot act; warn where it cannot keep d_min.

    Returns
    -------
    tuple of str
        A warning when ``sensing_range`` is below :attr:`Layer.needed_range`.

    Raises
    ------
    ScenarioError
        ``safety: on`` for aircraft, in a flow that is not uniform, or with the PI law;
        ``safety_turn_rate`` above first order's ``max_turn_rate`` or not above the circle's
        own turn rate ``V |omega0|``.

    """
    layer = of(sc)
    if layer is None:
        return ()
    if aircraft.flown(sc):
        _fail('safety', sc.safety, "'off' for aircraft: their layer (vertical resolution) "
              'is not built')
    if sc.flow_model != 'uniform':
        _fail('safety', sc.safety, "'off' in a flow that is not uniform: the layer takes the "
              'flow as the same at both vehicles of a pair')
    if law(sc).integrates:
        _fail('safety', sc.safety, "'off' with the PI law: the layer filters the rate of the "
              'backstepping and proportional laws and the first-order command')
    first = vehicle_model(sc.model).first_order
    if first and 0 < sc.max_turn_rate < layer.turn_rate:
        _fail('safety_turn_rate', sc.safety_turn_rate, f'<= max_turn_rate = '
              f'{sc.max_turn_rate:.4g} rad/s: the layer commands it')
    circle = layer.speed * abs(sc.omega0) if sc.formation == 'circular' else 0.0
    if layer.turn_rate <= circle:
        _fail('safety_turn_rate', layer.turn_rate, f'> V |omega0| = {circle:.4g} rad/s, the '
              'turn rate of the formation circle')
    if layer.sensing_range < layer.needed_range:
        return (f'sensing_range {layer.sensing_range:.4g} m is below what the safety layer '
                f'needs to keep d_min: D + 2 rho + 4 V dt = {layer.needed_range:.4g} m '
                f'(rho = V/u_max = {layer.rho:.4g} m): a pair may be heard too late',)
    return ()


def centres(layer: Layer, r: ArrayLike, heading: ArrayLike) -> ComplexArray:
    """Return the backup centres ``r + sigma rho i e^{i theta}`` (S.1), complex (m)."""
    return np.asarray(r) + layer.side * layer.rho * 1j * np.exp(1j * np.asarray(heading))


def barrier(layer: Layer, r_k: ArrayLike, heading_k: ArrayLike, r_j: ArrayLike,
            heading_j: ArrayLike) -> RealArray:
    """Return h of (S.2) of each pair (m): ``|c_k - c_j| - D``."""
    return abs(centres(layer, r_k, heading_k) - centres(layer, r_j, heading_j)) - layer.reach


def centre_velocity(layer: Layer, heading: ArrayLike, u: ArrayLike) -> ComplexArray:
    """Return ``c' = V (1 - sigma u / u_max) e^{i theta}`` (S.1), complex (m/s)."""
    rate = layer.speed * (1.0 - layer.side * np.asarray(u, float) / layer.turn_rate)
    return np.asarray(rate * np.exp(1j * np.asarray(heading)), complex)


def barrier_rate(layer: Layer, r_k: ArrayLike, heading_k: ArrayLike, u_k: ArrayLike,
                 r_j: ArrayLike, heading_j: ArrayLike, u_j: ArrayLike) -> RealArray:
    """Return ``h' = <c_hat, c_k' - c_j'>`` (m/s) at turn rates u_k, u_j (rad/s)."""
    c = centres(layer, r_k, heading_k) - centres(layer, r_j, heading_j)
    dc = centre_velocity(layer, heading_k, u_k) - centre_velocity(layer, heading_j, u_j)
    return np.real(np.conj(c) * dc) / abs(c)


def half_lines(layer: Layer, r_k: ArrayLike, heading_k: ArrayLike, r_j: ArrayLike,
               heading_j: ArrayLike) -> tuple[RealArray, RealArray]:
    """
    Return (a, b) of vehicle k's half-line ``a u_k <= b`` against each neighbour j, (S.3).

    ``a = sigma rho p`` (m), ``b = V p + alpha h / 2`` (m/s), ``p = <c_hat, e^{i theta_k}>``.
    """
    c = centres(layer, r_k, heading_k) - centres(layer, r_j, heading_j)
    dist = abs(c)
    p = np.real(np.conj(c) * np.exp(1j * np.asarray(heading_k))) / dist
    return layer.side * layer.rho * p, layer.speed * p + 0.5 * layer.gain * (dist - layer.reach)


def bounds(a: RealArray, b: RealArray, owner: IntArray, n: int,
           u_max: float) -> tuple[RealArray, RealArray, BoolArray]:
    """
    Return each vehicle's interval [lo, hi] of the half-lines ``a u <= b`` it owns, and a flag.

    Parameters
    ----------
    a, b : ndarray, shape (m,)
        The half-lines.
    owner : ndarray of int, shape (m,)
        The vehicle (0..n-1) each one constrains.
    n : int
        The number of vehicles.
    u_max : float
        The turn-rate limit: each interval lies in [-u_max, u_max].

    Returns
    -------
    lo, hi : ndarray, shape (n,)
        ``max(-u_max, max_{a<0} b/a)``, ``min(u_max, min_{a>0} b/a)``.
    void : ndarray of bool, shape (n,)
        A half-line with ``a = 0 > b`` (no turn meets it).

    """
    lo, hi = np.full(n, -u_max), np.full(n, u_max)
    with np.errstate(divide='ignore', invalid='ignore'):
        bound = b / a
    up, down = a > 0, a < 0
    np.minimum.at(hi, owner[up], bound[up])
    np.maximum.at(lo, owner[down], bound[down])
    void = np.zeros(n, bool)
    void[owner[(a == 0) & (b < 0)]] = True
    return lo, hi, void


def least_violating(u_nom: float, a: RealArray, b: RealArray, u_max: float) -> float:
    """
    Return the turn rate in [-u_max, u_max] whose largest violation ``max(a u - b)`` is least.

    A convex piecewise-linear function of u: its minimum lies at an end, at the nominal or
    where two of its lines cross; of the minimizers, the one closest to ``u_nom``.
    """
    with np.errstate(divide='ignore', invalid='ignore'):
        cross = ((b[:, None] - b[None, :]) / (a[:, None] - a[None, :])).ravel()
    candidates = np.clip(np.r_[-u_max, u_max, u_nom, cross[np.isfinite(cross)]], -u_max, u_max)
    worst = np.max(a[None, :] * candidates[:, None] - b[None, :], axis=1)
    best = worst <= worst.min() + 1e-12 * (1.0 + abs(worst.min()))
    return float(candidates[best][np.argmin(abs(candidates[best] - u_nom))])


def closest(u_nom: ArrayLike, a: RealArray, b: RealArray, owner: IntArray,
            u_max: float) -> tuple[RealArray, BoolArray]:
    """
    Return the turn rates closest to the nominal that meet every half-line, and feasibility.

    Parameters
    ----------
    u_nom : array_like, shape (n,)
        The nominal turn rates (rad/s).
    a, b, owner : ndarray, shape (m,)
        The half-lines ``a u <= b`` and the vehicle each constrains (:func:`bounds`).
    u_max : float
        The turn-rate limit (rad/s).

    Returns
    -------
    u : ndarray, shape (n,)
        ``clip(u_nom, lo, hi)`` where the interval is not empty: the solution of
        ``min (u - u_nom)^2`` subject to the half-lines and ``|u| <= u_max``; elsewhere
        :func:`least_violating`.
    feasible : ndarray of bool, shape (n,)
        Whether the interval was not empty.

    """
    u_nom = np.asarray(u_nom, float)
    lo, hi, void = bounds(a, b, owner, u_nom.size, u_max)
    feasible = (lo <= hi) & ~void
    u = np.clip(u_nom, lo, np.maximum(lo, hi))
    for k in np.flatnonzero(~feasible):
        mine = owner == k
        u[k] = least_violating(float(u_nom[k]), a[mine], b[mine], u_max)
    return u, feasible


@dataclass
class Filtered:
    """
    What the layer did to the commanded vehicles' turn rates.

    Attributes
    ----------
    u : ndarray
        The filtered turn rates (rad/s).
    active : ndarray of bool
        Where a neighbour's half-line moved the (clipped) nominal.
    infeasible : ndarray of bool
        Where no turn rate met every half-line (:func:`least_violating` was flown).

    """

    u: RealArray
    active: BoolArray
    infeasible: BoolArray


def neighbours(r: ComplexArray, reach: float) -> tuple[IntArray, IntArray]:
    """
    Return the pairs (i, j), i != j, each way, of vehicles within ``reach`` of each other.

    ``r`` (B, N) complex: the indices are into its flattened fleets, never across two.
    """
    fleets, n = r.shape
    if n <= DENSE:
        i, j = np.triu_indices(n, 1)
        near = abs(r[:, i] - r[:, j]) <= reach
        fleet, pair = np.nonzero(near)
        i, j = i[pair] + fleet * n, j[pair] + fleet * n
    else:
        found = [pairs_within(np.stack([r[f].real, r[f].imag], axis=1), reach)[:2]
                 for f in range(fleets)]
        i = np.concatenate([p[0] + f * n for f, p in enumerate(found)])
        j = np.concatenate([p[1] + f * n for f, p in enumerate(found)])
    return np.r_[i, j], np.r_[j, i]


def filter_turn_rates(layer: Layer, r: ArrayLike, heading: ArrayLike, u_nom: ArrayLike,
                      ego: Index = slice(None)) -> Filtered:
    """
    Filter the nominal turn rates of vehicles ``ego`` against every vehicle within range.

    Parameters
    ----------
    layer : Layer
        The layer.
    r, heading : array_like, shape (..., N)
        Positions (complex, m) and headings (rad) of the vehicles known: each vehicle hears
        all those within ``sensing_range`` (the simulator: all of them, at the states the
        commands are computed for).
    u_nom : array_like, shape (..., n)
        The nominal turn rates of the vehicles ``ego`` (rad/s).
    ego : index, optional
        The commanded vehicles, into the last axis of ``r``; all by default.

    Returns
    -------
    Filtered
        Arrays of the shape of ``u_nom``.

    """
    r, heading = np.asarray(r, complex), np.asarray(heading, float)
    n = r.shape[-1]
    flat_r, flat_h = r.reshape(-1, n), heading.reshape(-1, n)
    k, j = neighbours(flat_r, layer.sensing_range)
    a, b = half_lines(layer, flat_r.ravel()[k], flat_h.ravel()[k], flat_r.ravel()[j],
                      flat_h.ravel()[j])
    ids = np.arange(n)[ego]
    chosen = (np.arange(flat_r.shape[0])[:, None] * n + ids).ravel()
    where = np.full(flat_r.size, -1)
    where[chosen] = np.arange(chosen.size)
    mine = where[k] >= 0
    u_nom = np.asarray(u_nom, float)
    nominal = np.clip(u_nom.ravel(), -layer.turn_rate, layer.turn_rate)
    u, feasible = closest(nominal, a[mine], b[mine], where[k][mine], layer.turn_rate)
    active = (u != nominal) | ~feasible
    shape = u_nom.shape
    return Filtered(u.reshape(shape), active.reshape(shape), ~feasible.reshape(shape))


class Tally:
    """
    Count what the layer did over a run, per fleet: the active and infeasible vehicle-periods.

    Attributes
    ----------
    periods : int
        The control periods counted.
    active, infeasible : ndarray of int, shape (B,) or ()
        Per fleet, the vehicle-periods the layer moved the command, and found no turn rate
        that kept every pair apart.
    first_infeasible : float or None
        The first time (s) of an infeasible vehicle-period.
    vehicles : int
        Vehicles per fleet.

    """

    def __init__(self) -> None:
        self.periods = 0
        self.vehicles = 0
        self.active: IntArray = np.zeros((), np.int64)
        self.infeasible: IntArray = np.zeros((), np.int64)
        self.first_infeasible: float | None = None

    def add(self, t: float, filtered: Filtered) -> None:
        """Count one control period at time t (s)."""
        self.periods += 1
        self.vehicles = filtered.active.shape[-1]
        self.active = self.active + filtered.active.sum(axis=-1)
        self.infeasible = self.infeasible + filtered.infeasible.sum(axis=-1)
        if self.first_infeasible is None and filtered.infeasible.any():
            self.first_infeasible = t

    def fractions(self) -> tuple[RealArray, RealArray]:
        """Return the active and infeasible shares of the vehicle-periods, per fleet."""
        total = max(1, self.periods * self.vehicles)
        return self.active / total, self.infeasible / total

    def values(self) -> dict[str, float | int | None]:
        """Return the figures of one fleet: active and infeasible shares, first infeasible."""
        active, infeasible = self.fractions()
        return {'active_fraction': float(np.sum(active)),
                'infeasible_fraction': float(np.sum(infeasible)),
                'infeasible_periods': int(np.sum(self.infeasible)),
                'first_infeasible': self.first_infeasible}
