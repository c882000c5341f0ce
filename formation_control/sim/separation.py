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
The separation of a recorded run: how close its vehicles came, when, and whether they kept apart.

Between two samples each vehicle is taken to fly the straight chord between its recorded
positions, so the relative position of a pair is linear in time over the interval and its
distance squared a quadratic: the closest approach in the interval is exact
(``_closest``), and so is the set of times a pair is too close (``_too_close``: closer
than d_min horizontally and than d_min_vertical in altitude). A vehicle's flown path leaves
the chord by at most ``sqrt(L^2 - c^2) / 2`` if it flies at most L between samples a chord c
apart; ``path_error`` is this for a pair at the top ground speed.

:func:`of_samples` takes the samples of one run, :func:`of_run` a recorded run;
:class:`Tracker` the samples of a batch of runs as they come (the sweep's
:class:`simulator.Outcome`).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass
import math
from typing import Any

from formation_control.core import separation
from formation_control.core.flow import flowfield
from formation_control.core.geometry import BoolArray, IntArray, RealArray
from formation_control.core.models import ROW_U, ROW_V, ROW_X, ROW_Y
import numpy as np
from numpy.typing import ArrayLike

ROWS = 1 << 16
"""Pairs x intervals evaluated at once, at most (all pairs of a small fleet, many intervals)."""


@dataclass(frozen=True)
class Separation:
    """
    The separation of one run (distances in m, times in s; vehicle ids from 1).

    Attributes
    ----------
    d_min, d_min_vertical : float
        The separation it is judged by (:func:`separation.limits`); d_min_vertical None where
        the vehicles fly one altitude (a pair is too close on horizontal distance alone).
    closest, closest_pair, closest_time : float, list of int, float
        The smallest 3-D distance between two vehicles over the run (on the chords between
        samples), the pair and when; nan, None, nan with one vehicle.
    closest_2d, closest_2d_pair, closest_2d_time : float, list of int, float
        The same, horizontally.
    final, final_2d : float
        The smallest 3-D and horizontal distance at the last sample.
    final_too_close : bool
        A pair is too close at the last sample.
    below : float
        How long some pair was too close (s): closer than d_min horizontally and than
        d_min_vertical in altitude.
    kept_apart : bool
        No pair was ever too close: not at a sample, not between two.
    path_error : float
        How far a pair's flown path may leave the chords between its samples (m), at the top
        ground speed (``_path_error``); the distances between samples are exact on the
        chords and within it of the flown ones.

    """

    d_min: float
    d_min_vertical: float | None
    closest: float
    closest_pair: list[int] | None
    closest_time: float
    closest_2d: float
    closest_2d_pair: list[int] | None
    closest_2d_time: float
    final: float
    final_2d: float
    final_too_close: bool
    below: float
    kept_apart: bool
    path_error: float

    def values(self) -> dict[str, Any]:
        """Return the fields as plain values, a summary's ``separation``."""
        return asdict(self)

    def text(self) -> str:
        """Return the report's line: 'kept apart: closest 0.44 m (vehicles 2-4, t = 3 s) ...'."""
        return text(self.values())


def text(values: dict[str, Any]) -> str:
    """
    Return the report's separation verdict of a summary's ``separation`` values.

    E.g. ``no: closest 0.012 m (vehicles 1-3, t = 4.1 s) < d_min 0.1 m, 2.3 s too close;
    final 0.44 m``; aircraft name the horizontal closest and the vertical separation too.
    """
    v = values
    if v['closest_pair'] is None:
        return 'one vehicle'
    pair = '{}-{}'.format(*v['closest_pair'])
    sign = '>=' if v['kept_apart'] else '<'
    head = 'kept apart' if v['kept_apart'] else 'no'
    vertical = v['d_min_vertical']
    out = (f"{head}: closest {v['closest']:.4g} m (vehicles {pair}, t = "
           f"{v['closest_time']:.4g} s)")
    if vertical is None:
        out += f" {sign} d_min {v['d_min']:.4g} m"
    else:
        out += (f", horizontally {v['closest_2d']:.4g} m (vehicles "
                f"{'{}-{}'.format(*v['closest_2d_pair'])}, t = {v['closest_2d_time']:.4g} s); "
                f"too close: within d_min {v['d_min']:.4g} m and {vertical:.4g} m in altitude")
    if not v['kept_apart']:
        out += f", {v['below']:.4g} s too close"
    final = f"final {v['final']:.4g} m"
    if vertical is not None:
        final += f" ({v['final_2d']:.4g} m horizontally)"
    return f'{out}; {final}'


def _closest(a: RealArray, b: RealArray) -> tuple[RealArray, RealArray]:
    """
    Return where on [0, 1] ``|a + s b|`` is smallest, and that distance, row by row.

    ``s* = clip(-<a, b> / |b|^2, 0, 1)`` (0 where b = 0): the closest approach of a pair whose
    relative position moves from a to a + b.
    """
    bb = np.sum(b * b, axis=-1)
    with np.errstate(divide='ignore', invalid='ignore'):
        s = np.where(bb > 0, np.clip(-np.sum(a * b, axis=-1) / bb, 0.0, 1.0), 0.0)
    return s, np.sqrt(np.sum((a + s[:, None] * b) ** 2, axis=-1))


def _too_close(a: RealArray, b: RealArray, d: float,
               dv: float) -> tuple[RealArray, RealArray]:
    """
    Return the times ``(lo, hi)`` in [0, 1] a pair is too close; ``lo >= hi``: never.

    Horizontally ``|a_h + s b_h|^2 < d^2``, a quadratic ``A s^2 + B s + C < 0``, between its
    roots; in altitude ``|a_z + s b_z| < dv``, between two times; the pair is too close where
    both hold.
    """
    ah, bh = a[:, :2], b[:, :2]
    A, B = np.sum(bh * bh, axis=-1), 2.0 * np.sum(ah * bh, axis=-1)
    C = np.sum(ah * ah, axis=-1) - d * d
    disc = B * B - 4.0 * A * C
    with np.errstate(divide='ignore', invalid='ignore'):
        q = -0.5 * (B + np.where(B >= 0, 1.0, -1.0) * np.sqrt(np.maximum(disc, 0.0)))
        r1, r2 = q / A, C / q
        crossing = (A > 0) & (disc > 0)
        lo = np.where(crossing, np.minimum(r1, r2), np.where((A == 0) & (C < 0), -np.inf, 1.0))
        hi = np.where(crossing, np.maximum(r1, r2), np.where((A == 0) & (C < 0), np.inf, 0.0))
        if math.isfinite(dv):
            c, e = a[:, 2], b[:, 2]
            v1, v2 = (-dv - c) / e, (dv - c) / e
            level = e == 0
            lo = np.maximum(lo, np.where(level, np.where(abs(c) < dv, -np.inf, 1.0),
                                         np.minimum(v1, v2)))
            hi = np.minimum(hi, np.where(level, np.where(abs(c) < dv, np.inf, 0.0),
                                         np.maximum(v1, v2)))
    return np.maximum(lo, 0.0), np.minimum(hi, 1.0)


def _sample_too_close(a: RealArray, d: float, dv: float) -> BoolArray:
    """Return whether each pair of relative position ``a`` (M, 3) is too close."""
    return (np.sum(a[:, :2] ** 2, axis=-1) < d * d) & (abs(a[:, 2]) < dv)


@dataclass
class Frames:
    """
    Per interval of F: the closest approach 3-D and horizontal, the time too close.

    Arrays of shape (F,): ``min3, min2`` (m), ``pair3, pair2`` (F, 2) 0-based (-1: none),
    ``at3, at2`` (share of the interval, 0-1), ``below`` (share of it with a pair too close),
    ``close`` (a pair too close at some time of it, its ends included).
    """

    min3: RealArray
    pair3: IntArray
    at3: RealArray
    min2: RealArray
    pair2: IntArray
    at2: RealArray
    below: RealArray
    close: BoolArray


def _near(P0: RealArray, P1: RealArray, d: float) -> tuple[IntArray, IntArray]:
    """
    Return the pairs (i, j) that may matter in an interval from P0 (N, 3) to P1 (m).

    Those within ``max(d, m) + 2 D`` horizontally at its start (:func:`separation.pairs_within`),
    with m the smaller closest 3-D distance of its two ends and D the longest step of a vehicle
    in it: a pair closer than d or m at some time of the interval is among them.
    """
    step = float(np.max(np.sqrt(np.sum((P1 - P0) ** 2, axis=-1))))
    m = min(separation.closest_pair(P0)[0], separation.closest_pair(P1)[0])
    i, j, _ = separation.pairs_within(P0[:, :2], max(d, m) + 2.0 * step)
    return i, j


def frames(P0: RealArray, P1: RealArray, d: float, dv: float) -> Frames:
    """
    Return the separation of F intervals, each from positions P0 (F, N, 3) to P1 (m).

    Each vehicle on the chord between its two positions; ``d``, ``dv`` the horizontal and
    vertical separation (dv inf: horizontal alone). An interval of zero length (P0 = P1)
    gives the separation of one sample. A small fleet's pairs are all evaluated, intervals
    :data:`ROWS` pairs at a time; a large one's, interval by interval, only those that may
    matter (``_near``).
    """
    F, n = P0.shape[:2]
    out = Frames(np.full(F, np.inf), np.full((F, 2), -1), np.zeros(F), np.full(F, np.inf),
                 np.full((F, 2), -1), np.zeros(F), np.zeros(F), np.zeros(F, bool))
    pairs = n * (n - 1) // 2
    if pairs == 0:
        return out
    if pairs <= ROWS:
        i, j = np.triu_indices(n, 1)
        block = ROWS // i.size
        for start in range(0, F, block):
            f = np.arange(start, min(start + block, F))
            _add(out, np.repeat(f, i.size), np.tile(i, f.size), np.tile(j, f.size), P0, P1,
                 d, dv)
        return out
    for frame in range(F):
        near_i, near_j = _near(P0[frame], P1[frame], d)
        _add(out, np.full(near_i.size, frame), near_i, near_j, P0, P1, d, dv)
    return out


def _add(out: Frames, f: IntArray, i: IntArray, j: IntArray, P0: RealArray, P1: RealArray,
         d: float, dv: float) -> None:
    """Lower ``out``'s minima and add its time too close by the rows (f, i, j), in place."""
    if f.size == 0:
        return
    a = P0[f, j] - P0[f, i]
    b = P1[f, j] - P1[f, i] - a
    for dims, (low, pair, at) in ((3, (out.min3, out.pair3, out.at3)),
                                  (2, (out.min2, out.pair2, out.at2))):
        s, dist = _closest(a[:, :dims], b[:, :dims])
        order = np.lexsort((j, i, dist, f))                     # the closest of each frame
        first = order[np.r_[True, f[order][1:] != f[order][:-1]]]
        better = dist[first] < low[f[first]]
        k, rows = f[first][better], first[better]
        low[k], pair[k, 0], pair[k, 1], at[k] = dist[rows], i[rows], j[rows], s[rows]
    lo, hi = _too_close(a, b, d, dv)
    ends = _sample_too_close(a, d, dv) | _sample_too_close(a + b, d, dv)
    np.logical_or.at(out.close, f, (hi > lo) | ends)
    some = hi > lo
    out.below += _union(f[some], lo[some], hi[some], out.below.size)


def _union(f: IntArray, lo: RealArray, hi: RealArray, count: int) -> RealArray:
    """Return, per frame (count,), the length of the union of its intervals [lo, hi] in [0, 1]."""
    order = np.lexsort((lo, f))
    f, lo, hi = f[order], lo[order] + 2.0 * f[order], hi[order] + 2.0 * f[order]
    reach = np.maximum.accumulate(hi)
    before = np.r_[-np.inf, reach[:-1]]
    covered = np.maximum(hi - np.maximum(lo, before), 0.0)
    return np.asarray(np.bincount(f, covered, minlength=count), float)


def _path_error(t: RealArray, P: RealArray, speed: float) -> float:
    """
    Return how far a pair's flown path may leave the chords between its samples (m).

    A vehicle that flies at most ``L = speed dt`` between two samples a chord c apart stays
    within ``sqrt(L^2 - c^2) / 2`` of the chord (the path is in the ellipse with the samples
    for foci and L for major axis); a pair within twice the largest of these. P (T, N, 3) at
    times t (T,); 0 with fewer than two samples.
    """
    if len(t) < 2:
        return 0.0
    flown = (speed * np.diff(t)) ** 2
    chord = np.sum(np.diff(P, axis=0) ** 2, axis=-1)
    return float(np.max(np.sqrt(np.maximum(flown[:, None] - chord, 0.0))))


def positions(X: RealArray, altitude: ArrayLike | None = None) -> RealArray:
    """Return the positions x, y, z (..., N, 3) of states (6, ..., N) at an altitude (..., N)."""
    z = np.zeros_like(X[ROW_X]) if altitude is None else np.asarray(altitude, float)
    return np.stack([X[ROW_X], X[ROW_Y], z], axis=-1)


def of_samples(t: ArrayLike, P: ArrayLike, d: float, dv: float = math.inf,
               speed: float = 0.0) -> Separation:
    """
    Return the separation of one run from its samples.

    Parameters
    ----------
    t : array_like, shape (T,)
        Sample times (s), T >= 1.
    P : array_like, shape (T, N, 3) or (T, N, 2)
        Positions (m): x, y and the altitude (2: one altitude).
    d, dv : float
        The horizontal and vertical separation (m); dv inf: horizontal distance alone.
    speed : float, optional
        The vehicles' top ground speed (m/s), for ``path_error`` (0: none).

    Returns
    -------
    Separation
        On the chords between samples (:func:`frames`), exact for them.

    """
    t = np.asarray(t, float)
    P = np.asarray(P, float)
    if P.shape[-1] == 2:
        P = np.concatenate([P, np.zeros(P.shape[:-1] + (1,))], axis=-1)
    fr = frames(P[:-1], P[1:], d, dv) if len(t) > 1 else frames(P, P, d, dv)
    span = np.diff(t) if len(t) > 1 else np.zeros(1)
    start = t[:-1] if len(t) > 1 else t
    close = bool(fr.close.any())
    best: dict[int, tuple[float, list[int] | None, float]] = {}
    for dims, (low, pair, at) in ((3, (fr.min3, fr.pair3, fr.at3)),
                                  (2, (fr.min2, fr.pair2, fr.at2))):
        k = int(np.argmin(low))
        known = bool(np.isfinite(low[k]))
        best[dims] = (float(low[k]) if known else math.nan,
                      [int(pair[k, 0]) + 1, int(pair[k, 1]) + 1] if known else None,
                      float(start[k] + at[k] * span[k]) if known else math.nan)
    last = P[-1]
    return Separation(d, dv if math.isfinite(dv) else None, *best[3], *best[2],
                      separation.closest_pair(last)[0],
                      separation.closest_pair(last[:, :2])[0],
                      bool(frames(last[None], last[None], d, dv).close[0]),
                      float(np.sum(fr.below * span)), not close, _path_error(t, P, speed))


def of_run(run: Any) -> Separation:
    """
    Return :func:`of_samples` of a recorded run, by its scenario's :func:`separation.limits`.

    ``run`` is a :class:`simulator.Run` (its ``sc``, ``t``, ``X`` (T, 6, N) and the altitude
    among its ``channels``, if any). The top ground speed is the largest recorded speed
    through the flow ``|u + i v|`` plus the flow's largest ``max |f|``.
    """
    lim = separation.limits(run.sc)
    P = positions(np.moveaxis(run.X, 1, 0), run.channels.get('altitude'))
    speed = float(np.max(np.hypot(run.X[:, ROW_U], run.X[:, ROW_V]))) + flowfield(
        run.sc).max_speed
    return of_samples(run.t, P, lim.d_min, lim.d_min_vertical, speed)


class Tracker:
    """
    The separation of a batch of runs, sample by sample (the states are not kept).

    Parameters
    ----------
    d, dv : float
        The horizontal and vertical separation (m); dv inf: horizontal alone.

    Attributes
    ----------
    closest, below : ndarray, shape (B,)
        Each run's smallest 3-D distance so far (m) and time with a pair too close (s).
    kept_apart : ndarray of bool, shape (B,)
        No pair too close so far, at a sample or between two.

    """

    def __init__(self, d: float, dv: float = math.inf) -> None:
        self.d, self.dv = d, dv
        self.last: tuple[float, RealArray] | None = None

    def add(self, t: float, P: RealArray) -> None:
        """Take the sample at ``t`` (s) of positions P (B, N, 3) (m)."""
        if self.last is None:
            fr = frames(P, P, self.d, self.dv)
            self.closest, self.below = fr.min3, np.zeros(len(P))
            self.kept_apart = ~fr.close
        else:
            t0, P0 = self.last
            fr = frames(P0, P, self.d, self.dv)
            self.closest = np.minimum(self.closest, fr.min3)
            self.below = self.below + fr.below * (t - t0)
            self.kept_apart = self.kept_apart & ~fr.close
        self.last = t, P.copy()

    def rows(self) -> dict[str, RealArray]:
        """Return a sweep's columns: ``kept_apart``, ``closest`` and ``time_too_close`` (B,)."""
        return {'kept_apart': self.kept_apart.copy(), 'closest': np.where(
            np.isfinite(self.closest), self.closest, np.nan), 'time_too_close': self.below}
