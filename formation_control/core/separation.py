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
Separation: how far apart two vehicles must stay, and who is within a distance of whom.

Every vehicle has a size (:func:`size`: the model's :meth:`vehicles.base.VehicleModel.size`, a
JSBSim aircraft's wingspan), the diameter of the disc that holds it seen from above; two
vehicles may touch once their centres are closer than it. The scenario's separation
(:func:`limits`) is three distances, each derived when left at 0:

- ``d_min`` (m): two vehicles closer than this horizontally are too close; the size;
- ``d_min_vertical`` (m, aircraft): unless they are this far apart in altitude, the half-height
  of a protected cylinder as TCAS has one (its ALIM beside the DMOD); d_min (Paparazzi's TCAS
  takes 15 m and 10 m for small aircraft: the same order);
- ``sensing_range`` (m): each vehicle hears every vehicle within it; ``d_min + 2 s_max tau``,
  the distance two vehicles close at their top ground speed ``s_max = s + max |f|`` in one time
  constant ``tau = 1 / rate`` of the formation law (:meth:`formations.FormationKind.law_rate`),
  plus d_min.

:func:`check` refuses what cannot hold together: a sensing range below d_min, a splay whose
chord is below d_min (:func:`chord`: no placement of N vehicles on a circle keeps them further
apart, so a free-phase circle below it cannot keep them apart either, but promises nothing).
:func:`pairs_within` and :func:`closest_pair` find the pairs of a fleet within a distance, and
the closest, in 2-D or 3-D, without the N^2 table of all pairs.
"""
from __future__ import annotations

from dataclasses import dataclass
import itertools
import math

from formation_control.core import aircraft, formations
from formation_control.core.errors import refuse as _fail
from formation_control.core.flow import flowfield, vehicle_speed
from formation_control.core.geometry import IntArray, RealArray
from formation_control.core.parameters import Scenario
from formation_control.core.vehicles import vehicle_model
import numpy as np
from numpy.typing import ArrayLike

MAX_CELLS = 1 << 19
"""Grid cells per axis at most, so that a cell key of three axes fits an int64."""


@dataclass(frozen=True)
class Limits:
    """
    The separation of a scenario (m), each derived where the scenario leaves it at 0.

    Attributes
    ----------
    size : float
        The vehicle's size (:func:`size`).
    d_min : float
        Horizontal separation distance.
    d_min_vertical : float
        Vertical separation distance; inf where vehicles fly one altitude (every native
        model): a pair is then too close on horizontal distance alone.
    sensing_range : float
        The range within which a vehicle hears every other vehicle.

    """

    size: float
    d_min: float
    d_min_vertical: float
    sensing_range: float


def size(sc: Scenario) -> float:
    """
    Return the size of the scenario's vehicles (m).

    A JSBSim aircraft's wingspan (:func:`aircraft.wingspan`); else the model's
    (:meth:`vehicles.base.VehicleModel.size`: particles 0.1 m, rigid bodies ``2 l``, the
    vessel CyberShip II's 1.255 m).
    """
    if aircraft.flown(sc):
        return aircraft.wingspan(sc.jsbsim_aircraft)
    return vehicle_model(sc.model).size(sc)


def limits(sc: Scenario) -> Limits:
    """
    Return the separation of a scenario: its values, or those derived from the vehicle.

    ``d_min`` 0: :func:`size`; ``d_min_vertical`` 0: d_min for aircraft (inf for the others,
    which fly one altitude); ``sensing_range`` 0: ``d_min + 2 (s + max |f|) / rate``, with s
    the speed through the flow and rate the formation law's at the slowest ground speed
    ``s - max |f|`` (circular ``|omega0| (s - max |f|)``, parallel ``|K|``).
    """
    s = size(sc)
    d = sc.d_min or s
    vertical = (sc.d_min_vertical or d) if aircraft.flown(sc) else math.inf
    speed, flow = vehicle_speed(sc), flowfield(sc).max_speed
    rate, _ = formations.of(sc).law_rate(sc, speed - flow)
    return Limits(s, d, vertical, sc.sensing_range or d + 2.0 * (speed + flow) / rate)


def chord(sc: Scenario) -> float | None:
    """
    Return the largest smallest distance N vehicles can keep on the scenario's circle (m).

    ``2 R sin(pi / N)`` with ``R = 1/|omega0|``, the splay's chord: no other placement of N
    vehicles on a circle keeps them further apart. None for a straight formation or one
    vehicle.
    """
    radius = formations.of(sc).radius(sc)
    if radius is None or sc.num_vehicles < 2:
        return None
    return 2.0 * radius * math.sin(math.pi / sc.num_vehicles)


def check(sc: Scenario) -> tuple[str, ...]:
    """
    Refuse a separation that cannot hold.

    A free-phase circle or a symmetric pattern promises no spacing (their vehicles may end
    anywhere on the circle, or stacked in clusters): a run's verdict says whether they kept
    apart (:mod:`sim.separation`), no check does.

    Raises
    ------
    ScenarioError
        ``sensing_range`` below d_min; d_min above the chord of a splay
        (:func:`chord`), which spaces its vehicles by the chord and no more.

    """
    lim = limits(sc)
    derived = '' if sc.d_min else f' (derived: the vehicle size {lim.size:.4g} m)'
    if lim.sensing_range < lim.d_min:
        _fail('sensing_range', sc.sensing_range, f'must be >= d_min = {lim.d_min:.4g} m'
              f'{derived}: a vehicle must hear every vehicle it could come too close to')
    spaced = chord(sc)
    if sc.pattern == 'splay' and spaced is not None and spaced < lim.d_min:
        _fail('d_min', sc.d_min, f'{lim.d_min:.4g} m{derived} is more than the splay keeps: '
              f'{sc.num_vehicles} vehicles on the circle of radius {1 / abs(sc.omega0):.4g} m '
              f'(1/|omega0|) are a chord 2 R sin(pi/N) = {spaced:.4g} m apart; d_min must be '
              f'<= that (or fewer vehicles, or a larger circle)')
    return ()


def pairs_within(positions: ArrayLike, d: float) -> tuple[IntArray, IntArray, RealArray]:
    """
    Return every pair of vehicles at most ``d`` apart.

    Parameters
    ----------
    positions : array_like, shape (N, D)
        Positions (m), D = 2 (x, y) or 3 (x, y, z).
    d : float
        The distance (m), >= 0.

    Returns
    -------
    i, j : ndarray of int, shape (P,)
        The pairs, ``i < j`` (0-based), ordered by i then j.
    distance : ndarray, shape (P,)
        ``|p_i - p_j|`` (m), each <= d.

    Notes
    -----
    A grid of cells of side at least d (:data:`MAX_CELLS` per axis): a pair within d lies in
    one cell or in two adjacent ones, so each vehicle is compared with those of its own cell
    and of half its neighbours (4 in 2-D, 13 in 3-D), by sorting the cell keys. Time
    O(N log N + C), memory O(N + C), with C the pairs in adjacent cells.

    """
    p = np.asarray(positions, float)
    n, dim = p.shape
    if n < 2:
        empty = np.zeros(0, np.int64)
        return empty, empty, np.zeros(0)
    low = p.min(axis=0)
    span = float(np.max(p.max(axis=0) - low))
    side = max(d, span / MAX_CELLS, np.finfo(float).tiny)
    cells = np.floor((p - low) / side).astype(np.int64) + 1
    extent = cells.max(axis=0) + 2
    scale = np.cumprod(np.r_[1, extent[:0:-1]])[::-1]            # row-major key
    key = cells @ scale
    order = np.argsort(key, kind='stable')
    sorted_key = key[order]
    found = [_adjacent(p, order, sorted_key, int(np.dot(offset, scale)), d)
             for offset in _half_offsets(dim)]
    i, j, dist = (np.concatenate(parts) for parts in zip(*found))
    first = np.minimum(i, j)
    j, i = np.maximum(i, j), first
    rank = np.lexsort((j, i))
    return i[rank], j[rank], dist[rank]


def _half_offsets(dim: int) -> list[tuple[int, ...]]:
    """Return the zero offset and one of each pair of opposite neighbour offsets of a cell."""
    offsets = itertools.product((-1, 0, 1), repeat=dim)
    return [o for o in offsets if o >= (0,) * dim]


def _adjacent(p: RealArray, order: IntArray, sorted_key: IntArray, shift: int,
              d: float) -> tuple[IntArray, IntArray, RealArray]:
    """Return the pairs within d of each vehicle and those of the cell ``shift`` keys on."""
    start = np.searchsorted(sorted_key, sorted_key + shift, 'left')
    stop = np.searchsorted(sorted_key, sorted_key + shift, 'right')
    if shift == 0:
        start = np.arange(len(order)) + 1                        # same cell: each pair once
    counts = np.maximum(stop - start, 0)
    a = np.repeat(np.arange(len(order)), counts)
    b = start[a] + np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    i, j = order[a], order[b]
    dist = np.sqrt(np.sum((p[i] - p[j]) ** 2, axis=-1))
    near = dist <= d
    return i[near], j[near], dist[near]


def closest_pair(positions: ArrayLike) -> tuple[float, int, int]:
    """
    Return the smallest distance between two vehicles and the pair at it.

    Parameters
    ----------
    positions : array_like, shape (N, D)
        Positions (m), D = 2 or 3.

    Returns
    -------
    (float, int, int)
        ``min_{i < j} |p_i - p_j|`` (m) and that ``i, j`` (0-based; the first such pair by i,
        then j); ``(nan, -1, -1)`` with fewer than two vehicles.

    Notes
    -----
    Coincident vehicles first (a sort of the rows); then :func:`pairs_within` at a distance
    doubled from ``span / N`` until it finds a pair: its closest is the closest of all, and
    the cells, at most twice the smallest distance wide, hold few vehicles each.

    """
    p = np.asarray(positions, float)
    n = len(p)
    if n < 2:
        return math.nan, -1, -1
    rows = np.lexsort(p.T[::-1])
    same = np.flatnonzero(np.all(p[rows[1:]] == p[rows[:-1]], axis=1))
    if same.size:
        pairs = np.sort(np.stack([rows[same], rows[same + 1]], axis=1), axis=1)
        i, j = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))[0]]
        return 0.0, int(i), int(j)
    d = float(np.max(np.ptp(p, axis=0))) / n
    while True:
        i, j, dist = pairs_within(p, d)
        if dist.size:
            k = int(np.argmin(dist))                              # pairs ordered by i, j
            return float(dist[k]), int(i[k]), int(j[k])
        d *= 2.0
