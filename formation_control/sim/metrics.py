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
Formation metrics of the thesis' analysis, and the convergence test.

Order parameter ``|p|``, circle centres, potentials, composite Lyapunov values, centre spread,
radius, crab angles; the steady states the analysis predicts for rigid bodies.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any, TYPE_CHECKING

from formation_control.core import formations, laws, steering
from formation_control.core.flow import flowfield, vehicle_speed
from formation_control.core.geometry import BoolArray, ComplexArray, RealArray
from formation_control.core.laws import Value
from formation_control.core.models import ROW_THETA, ROW_U, ROW_V, ROW_X, ROW_Y
from formation_control.core.scenario import practical
from formation_control.core.vehicles import vehicle_model
from formation_control.sim.backends import backend_of
import numpy as np
from numpy.typing import ArrayLike

if TYPE_CHECKING:
    from formation_control.core.control import Controller
    from formation_control.core.parameters import Scenario

ORDER_TOL = 0.999        # parallel: |p| above this
RATE_TOL = 1e-2          # parallel: |turning rate| below this (rad/s)
SPREAD_TOL = 1e-2        # circular: max |c_k - mean(c)| below this (m)
RADIUS_TOL = 1e-2        # circular: relative error of the mean radius
PHASE_ORDERS = 8         # patterns: |p_m| reported for m = 1..min(floor(N/2), PHASE_ORDERS)
MOMENT_TOL = 1e-2        # patterns: |p_m| below this, |p_M| within this of 1/M
SEPARATION_TOL = 0.1     # splay: the smallest distance at least (1 - this) of the chord


@dataclass(frozen=True)
class Snapshot:
    """Formation quantities at one instant (SI units; nan where the scenario has no such value)."""

    order: Value           # |p| of the steered phase (1.10)
    potential: Value       # V of the formation (1.11), (1.14), (7.18)
    lyapunov: Value        # V_c = V + sum z^2 / 2 (2.10)
    spread: Value          # max_k |c_k - mean(c)| (m)
    radius: Value          # mean_k |r_k - mean(c)| (m)
    max_rate: Value        # max_k |phase rate| (rad/s)
    centre: complex | ComplexArray = complex(np.nan, np.nan)   # mean(c) (m)
    speed_error: Value = np.nan      # mean_k |u_k - u0| (m/s), rigid bodies (7.1)
    crab: Value = np.nan             # mean_k beta_k = atan2(v, u) (rad) (7.11)
    crab_inertial: Value = np.nan    # mean_k beta_hat_k = gamma_k - theta_k (rad) (8.1)
    phase_orders: tuple[Value, ...] = ()  # pattern: |p_m|, m = 1, 2, ... (Sepulchre et al. 2007)
    min_separation: Value = np.nan   # min_{j != k} |r_j - r_k| (m)
    course_spread: Value = np.nan    # max_k |arg(e^{i phase_k} / p)| (rad), parallel; the band
    # test's (steady_errors), not among values(): the metrics topic's fields are fixed

    def values(self) -> dict[str, Any]:
        """
        Return the named values for messages and reports, without those that do not apply.

        Floats for one fleet; for a batch (:func:`snapshot` of (6, ..., N) states) arrays of
        the batch's shape, without the values that apply to none of its fleets.
        """
        out = {'order_parameter': self.order, 'potential': self.potential,
               'lyapunov': self.lyapunov, 'max_turn_rate': self.max_rate,
               'centre_spread': self.spread, 'radius': self.radius,
               'centre_x': self.centre.real, 'centre_y': self.centre.imag,
               'speed_error': self.speed_error, 'crab_angle': self.crab,
               'crab_angle_inertial': self.crab_inertial, 'min_separation': self.min_separation}
        out.update({f'phase_order_{m}': v for m, v in enumerate(self.phase_orders, start=1)})
        if np.ndim(self.order):
            return {k: np.broadcast_to(v, np.shape(self.order)) for k, v in out.items()
                    if not np.all(np.isnan(v))}
        return {k: float(v) for k, v in out.items() if not np.isnan(v)}


def snapshot(ctrl: Controller, X: RealArray, inputs: RealArray,
             t: float | RealArray = 0.0, separation: bool = True,
             gust: complex | ComplexArray = 0.0) -> Snapshot:
    """
    Return the formation metrics of the fleet at one instant.

    Parameters
    ----------
    ctrl : control.Controller
        The controller of the scenario (its formation law and view).
    X : array_like, shape (6, N)
        States of the whole fleet; or (6, ..., N), fleets of a batch or samples of a run.
    inputs : array_like, shape (2, N)
        Inputs held at that instant (the held steering force enters the full law's view);
        (2, ..., N) with a batch.
    t : float or array_like, optional
        The time (s): the metrics are those of the true flow at each vehicle then; for samples
        of a run, their times broadcast against ``X.shape[1:]`` (e.g. shape (T, 1)).
    separation : bool, optional
        Whether to compute the minimum separation (:func:`min_separation`, the costliest
        value: O(N log^2 N) per fleet); nan if not.
    gust : complex or array_like of complex, optional
        Each vehicle's gust (m/s, :func:`world.recorded_gust`), broadcast against
        ``X.shape[1:]``: the metrics read the true motion, the course and centres from the
        ground velocity (8.1) in the flowfield and the gust, the flow each vehicle moves in
        (:func:`moving_flow`), not the flowfield alone the vehicles are told; the flow's
        derivatives are the flowfield's (:meth:`control.Controller.view`).

    Returns
    -------
    Snapshot
        Of floats; for a batch, of arrays of shape ``X.shape[1:-1]`` (one value per fleet),
        computed with the same per-fleet reductions.
        ``|p|`` (1.10), V (1.11), (1.14), (7.18), V_c (2.10), max ``|phase rate|``, the smallest
        distance between two vehicles; circular: centre spread, mean radius and centre, with a
        pattern the moments ``|p_m|`` (:func:`phase_orders`); rigid bodies: mean ``|u - u0|``
        and mean crab angles (:func:`crab_angles`).

    """
    field = ctrl.plant.flow(t, X[ROW_X], X[ROW_Y])
    view = ctrl.view(X, inputs[1], field, gust)
    flow = field + gust
    f = ctrl.formation
    nan = np.full(np.shape(view.r)[:-1], np.nan)
    extra: dict[str, Any] = {'min_separation': min_separation(view.r) if separation else nan}
    if isinstance(f, laws.Circular):
        c = f.centres(view)
        mean_c = c.mean(axis=-1, keepdims=True)
        extra.update(spread=np.max(abs(c - mean_c), axis=-1),
                     radius=np.mean(abs(view.r - mean_c), axis=-1), centre=mean_c[..., 0])
        if f.pattern is not None:
            extra['phase_orders'] = phase_orders(view.phase)
    else:
        p = view.e.mean(axis=-1, keepdims=True)
        extra.update(spread=nan, radius=nan,
                     course_spread=np.max(abs(np.angle(view.e / p)), axis=-1))
    if ctrl.rigid:
        beta, beta_hat = crab_angles(X, flow)
        extra.update(speed_error=np.mean(abs(X[ROW_U] - ctrl.sc.u0), axis=-1),
                     crab=beta.mean(axis=-1), crab_inertial=beta_hat.mean(axis=-1))
    extra.update(order=abs(view.e.mean(axis=-1)), potential=f.potential(view),
                 lyapunov=laws.composite_lyapunov(f, view),
                 max_rate=np.max(abs(view.rate), axis=-1))
    if nan.ndim:
        return Snapshot(**extra)
    one: dict[str, Any] = {k: complex(v) if k == 'centre' else v if k == 'phase_orders'
                           else float(v) for k, v in extra.items()}
    return Snapshot(**one)


def moving_flow(ctrl: Controller, X: RealArray, t: float | RealArray = 0.0,
                gust: complex | ComplexArray = 0.0) -> ComplexArray:
    """
    Return the flow each vehicle moves in (m/s): the flowfield at its place at ``t``, and its gust.

    ``ground_velocity(X, moving_flow(...))`` is the true ground velocity (8.1), its direction
    the course every metric and verdict reads (:func:`snapshot`).
    """
    return ctrl.plant.flow(t, X[ROW_X], X[ROW_Y]) + gust


def min_separation(r: ComplexArray) -> Value:
    """
    Return the smallest distance between two vehicles of each fleet.

    Parameters
    ----------
    r : ndarray of complex, shape (..., N)
        Positions (m): one fleet, or fleets of a batch or samples of a run.

    Returns
    -------
    float or ndarray, shape ``r.shape[:-1]``
        ``min_{j != k} |r_j - r_k|`` (m); nan with fewer than two vehicles. It equals the
        minimum over all pairs bit for bit, in O(N log^2 N) time and O(N) memory per fleet.

    Notes
    -----
    Divide and conquer, all fleets and all blocks of a level at once (Shamos and Hoey 1975):
    positions sorted by x; blocks of 8 consecutive vehicles compared pair by pair; then each
    level merges pairs of blocks, comparing across the boundary only the vehicles closer to it
    in x than the smallest distance found so far, each with the next 7 of them by y (no more
    fit in that strip at that distance from one another).

    """
    n = r.shape[-1]
    if n < 2:
        return np.full(r.shape[:-1], np.nan)[()]
    flat = r.reshape(-1, n)
    p = np.take_along_axis(flat, np.argsort(flat.real, axis=-1), axis=-1)
    best = np.min([abs(p[:, k:] - p[:, :-k]).min(axis=1) for k in range(1, min(n, 8))], axis=0)
    x, size = np.ascontiguousarray(p.real), 8
    while size < n:
        _merge_level(p, x, best, size)
        size *= 2
    return best.reshape(r.shape[:-1])[()]


def _merge_level(p: ComplexArray, x: RealArray, best: RealArray, size: int) -> None:
    """Lower ``best`` (M,) by the pairs across the block boundaries of one level, in place."""
    n = p.shape[-1]
    block = np.arange(n) // (2 * size)
    boundary = block * 2 * size + size
    paired = boundary < n
    near = abs(x - x[:, np.minimum(boundary, n - 1)]) < best[:, None]
    fleet, k = np.nonzero(near & paired)
    order = np.lexsort((p.imag[fleet, k], block[k], fleet))
    fleet, k = fleet[order], k[order]
    group, q = fleet * n + block[k], p[fleet, k]
    for shift in range(1, 8):
        same = group[shift:] == group[:-shift]
        if not same.any():
            break
        np.minimum.at(best, fleet[shift:][same], abs(q[shift:] - q[:-shift])[same])


def phase_orders(phase: RealArray) -> tuple[Value, ...]:
    """
    Return the moduli of the phase moments of a symmetric pattern.

    Parameters
    ----------
    phase : ndarray, shape (N,) or (..., N)
        The steered phases (rad).

    Returns
    -------
    tuple of float, or of arrays (one per fleet) for a batch
        ``|p_m| = |sum_j e^{i m phase_j}| / (m N)`` for m = 1..min(floor(N/2), PHASE_ORDERS):
        all 0 for the splay, ``|p_M| = 1/M`` and ``|p_m| = 0`` (m < M) for M clusters.

    """
    top = max(1, min(phase.shape[-1] // 2, PHASE_ORDERS))
    orders = (abs(np.exp(1j * m * phase).mean(axis=-1)) / m for m in range(1, top + 1))
    return tuple(laws._fleet(x) for x in orders)


def needs_separation(sc: Scenario) -> bool:
    """Return whether :func:`converged` reads the minimum separation (a splay pattern)."""
    return formations.of(sc).patterns and sc.pattern == 'splay'


BANDS = {'centre_spread': 'band_spread', 'radius_error': 'band_radius',
         'course_spread': 'band_course', 'speed_error': 'band_speed'}
"""Each steady-state error of the band test and the parameter of its band."""


def _radius_error(sc: Scenario, snap: Snapshot) -> Value:
    """Return the relative radius error ``|radius |omega0| - 1|``."""
    return np.abs(snap.radius * abs(sc.omega0) - 1.0)


def _spread_tol(sc: Scenario) -> float:
    """Return the centre-spread tolerance (m): the backend's (``PlantBackend.spread_tol``)."""
    return backend_of(sc).spread_tol(sc, SPREAD_TOL)


ERRORS: dict[str, Callable[[Scenario, Snapshot], Value]] = {
    'centre_spread': lambda sc, snap: snap.spread,
    'radius_error': _radius_error,
    'course_spread': lambda sc, snap: snap.course_spread}
"""Each formation error of the band test (:attr:`formations.FormationKind.band_errors`)."""

CONDITIONS: dict[str, Callable[[Scenario, Snapshot], Any]] = {
    'order': lambda sc, snap: snap.order > ORDER_TOL,
    'turn_rate': lambda sc, snap: snap.max_rate < RATE_TOL,
    'centre_spread': lambda sc, snap: snap.spread < _spread_tol(sc),
    'radius': lambda sc, snap: _radius_error(sc, snap) < RADIUS_TOL}
"""Each formation condition of the exact test (:attr:`formations.FormationKind.conditions`)."""


def steady_errors(sc: Scenario, snap: Snapshot) -> dict[str, Value]:
    """
    Return the errors the band test bounds, by name (:data:`BANDS`).

    Circular: the centre spread (m) and the relative radius error ``|radius |omega0| - 1|``;
    parallel: the course spread ``max_k |arg(e^{i phase_k} / p)|`` (rad); rigid bodies also the
    speed error ``mean_k |u_k - u0|`` (m/s). Floats, or arrays for a batch's snapshot.
    """
    out = {name: ERRORS[name](sc, snap) for name in formations.of(sc).band_errors}
    if vehicle_model(sc.model).rigid:
        out['speed_error'] = snap.speed_error
    return out


def window(sc: Scenario, t: ArrayLike) -> BoolArray:
    """Return which samples ``t`` (T,) lie in the last ``settle_window`` (or the whole run)."""
    t = np.asarray(t, float)
    return t >= t[-1] - min(sc.settle_window, t[-1] - t[0]) - 1e-9


HOLD_SAMPLES = 10
"""The derived hold window spans at least this many recorded periods (``record_dt``)."""


def hold_window(sc: Scenario) -> float:
    """
    Return how long every convergence condition must have held, to the end, for a 'yes' (s).

    Parameters
    ----------
    sc : scenario.Scenario
        Its ``hold_window`` (0: derived), formation, gains, speed, flow, ``record_dt`` and,
        with the band test (:func:`scenario.practical`), ``settle_window``.

    Returns
    -------
    float
        ``hold_window`` if given, else the longest of one cycle of the formation law
        ``2 pi / rate``, one cycle of the steering loop ``2 pi / bandwidth`` and
        :data:`HOLD_SAMPLES` recorded periods; with the band test at least ``settle_window``.

    Notes
    -----
    The formation law's rate is :meth:`formations.FormationKind.law_rate` at the slowest
    ground speed ``s - max |f|``: circular, the circle's turn rate ``|omega0| (s - max |f|)``,
    so the window is at least one orbit (every course is flown once, and a flow, whose effect
    on the formation turns with the course, has acted at every phase of it); parallel,
    ``|K|`` (1.12), so the window is ``2 pi`` time constants of the alignment, over which a
    transient that only passes through the test decays by ``e^{-2 pi}`` (0.2 %) and has
    left it. The steering loop's rate is its bandwidth (:meth:`steering.SteeringLaw.bandwidth`:
    kappa (3.7), K_p (5.5), K_P (8.24), K for first-order vehicles). The floor keeps a verdict
    from resting on a few samples. The band test also covers the window its steady-state
    errors are reported over.

    """
    hold = sc.hold_window
    if hold == 0.0:
        s_min = vehicle_speed(sc) - flowfield(sc).max_speed
        rate, _ = formations.of(sc).law_rate(sc, s_min)
        hold = max(2.0 * np.pi / rate, 2.0 * np.pi / steering.law(sc).bandwidth(sc),
                   HOLD_SAMPLES * sc.record_every * sc.dt_control)
    return max(hold, sc.settle_window) if practical(sc) else hold


def held(t: ArrayLike, flags: ArrayLike) -> Any:
    """
    Return how long each run's test has held at every sample, up to its last sample (s).

    Parameters
    ----------
    t : array_like, shape (T,)
        Sample times (s), T >= 1.
    flags : array_like of bool, shape (T,) or (T, B)
        The convergence test at each sample.

    Returns
    -------
    float or ndarray, shape (B,)
        ``t[-1] - since`` with ``since`` :func:`convergence_times` (the first sample from
        which every sample holds); 0 where the last sample does not hold, and for a run of
        one sample.

    """
    t, flags = np.asarray(t, float), np.asarray(flags, bool)
    since = convergence_times(t, flags.reshape(flags.shape[0], -1))
    out = np.where(np.isnan(since), 0.0, t[-1] - np.nan_to_num(since))
    return float(out[0]) if flags.ndim == 1 else out


def verdict(sc: Scenario, t: ArrayLike, flags: ArrayLike) -> Any:
    """
    Return whether each run converged, from its convergence test at each sample.

    Parameters
    ----------
    sc : scenario.Scenario
        Its :func:`hold_window`.
    t : array_like, shape (T,)
        Sample times (s).
    flags : array_like of bool, shape (T,) or (T, B)
        :func:`converged` at each sample (the exact or the band test).

    Returns
    -------
    bool or ndarray of bool, shape (B,)
        Every sample from some time X to the end holds, and ``t[-1] - X`` is at least the
        hold window (:func:`held`): a run that meets its test only over its last samples, or
        that left it within the window, is not converged.

    """
    out = np.asarray(held(t, flags)) >= hold_window(sc) - 1e-9
    return bool(out) if out.ndim == 0 else out


@dataclass(frozen=True)
class Settling:
    """
    The verdict of one run (:func:`settling`).

    Attributes
    ----------
    converged : bool
        :func:`verdict`.
    since : float or None
        The time from which every sample holds (s); None when the last sample fails.
    held : float or None
        How long that is, to the last sample (s), :func:`held`; None when the last sample
        fails.
    hold : float
        The hold window (s), :func:`hold_window`.

    """

    converged: bool
    since: float | None
    held: float | None
    hold: float

    def text(self) -> str:
        """Return the report's verdict: 'yes, from t = X s (...)', 'no, not settled: ...'."""
        if self.converged:
            return (f'yes, from t = {self.since:.4g} s (held {self.held:.4g} s, hold window '
                    f'{self.hold:.4g} s)')
        if self.held is None:
            return 'no'
        span = f'the last {self.held:.4g} s' if self.held > 0 else 'the last sample'
        return f'no, not settled: held only {span} of the {self.hold:.4g} s hold window'


def settling(sc: Scenario, t: ArrayLike, flags: ArrayLike) -> Settling:
    """
    Return the verdict of one run from its test at each sample (flags (T,), t (T,) s).

    ``since`` is :func:`convergence_time`, also for a run that did not hold it long enough.
    """
    since = convergence_time(t, flags)
    span = None if since is None else held(t, flags)
    return Settling(bool(verdict(sc, t, flags)), since, span, hold_window(sc))


def steady_state(sc: Scenario, t: ArrayLike,
                 errors: dict[str, ArrayLike]) -> dict[str, tuple[Any, Any]]:
    """
    Return the median and 95th percentile of each steady-state error over the last window.

    Parameters
    ----------
    sc : scenario.Scenario
        Its ``settle_window``.
    t : array_like, shape (T,)
        Sample times (s).
    errors : dict of str to array_like, shape (T,) or (T, B)
        :func:`steady_errors` at each sample.

    Returns
    -------
    dict of str to (median, p95)
        Floats, or arrays (B,) for a batch.

    """
    keep = window(sc, t)
    return {name: (np.median(np.asarray(v)[keep], axis=0),
                   np.quantile(np.asarray(v)[keep], 0.95, axis=0))
            for name, v in errors.items()}


def conditions(sc: Scenario, snap: Snapshot) -> dict[str, Any]:
    """
    Return each condition of the convergence test of the scenario, by name.

    Parameters
    ----------
    sc : scenario.Scenario
        The scenario (formation, omega0, pattern, pattern_M, num_vehicles).
    snap : Snapshot
        The fleet's metrics.

    Returns
    -------
    dict of str to bool, or to ndarray of bool for a batch's snapshot
        Parallel: ``order`` (``|p| > ORDER_TOL``) and ``turn_rate`` (every
        ``|phase rate| < RATE_TOL`` rad/s). Circular: ``centre_spread`` (below SPREAD_TOL m;
        aircraft below backends.AIRCRAFT_SPREAD_TOL of the radius, docs/aircraft.md)
        and ``radius`` (mean radius within RADIUS_TOL of ``1/|omega0|``); with a pattern also
        ``phase_moments`` (:func:`pattern_moments_reached`) and, for a splay, ``separation``
        (the smallest distance at least ``1 - SEPARATION_TOL`` of the chord
        ``2 sin(pi/N) / |omega0|``): a splay in coincident pairs is not converged.
        The band test (:func:`scenario.practical`): each of :func:`steady_errors` below its
        band (:data:`BANDS`), and a pattern's conditions as above.

    """
    if practical(sc):
        bands: dict[str, Any] = {name: np.asarray(err < getattr(sc, BANDS[name]))
                                 for name, err in steady_errors(sc, snap).items()}
        if sc.pattern != 'none':
            exact = conditions(replace(sc, convergence='exact'), snap)
            bands.update({k: v for k, v in exact.items() if k in ('phase_moments', 'separation')})
        return bands
    out = {name: CONDITIONS[name](sc, snap) for name in formations.of(sc).conditions}
    if sc.pattern != 'none':
        out['phase_moments'] = pattern_moments_reached(sc, snap.phase_orders)
    if sc.pattern == 'splay':
        chord = 2.0 * np.sin(np.pi / sc.num_vehicles) / abs(sc.omega0)
        with np.errstate(invalid='ignore'):
            out['separation'] = snap.min_separation >= (1.0 - SEPARATION_TOL) * chord
    return out


def pattern_moments_reached(sc: Scenario, orders: Any) -> Any:
    """
    Return whether the moduli ``orders`` (``|p_1|, |p_2|, ...``) are those of the pattern.

    Splay: every ``|p_m| < MOMENT_TOL``; (M, N) pattern: ``|p_m| < MOMENT_TOL`` for m < M and
    ``|p_M|`` within MOMENT_TOL of ``1/M`` (M clusters of equal size: the zero moments m < M
    make the cluster sizes equal). Moments beyond those reported (``PHASE_ORDERS``) are
    not tested; the splay's separation test covers them.
    """
    ok: Any = True
    for m, value in enumerate(orders, start=1):
        if sc.pattern == 'symmetric' and m == sc.pattern_M:
            ok = ok & (abs(value - 1.0 / m) < MOMENT_TOL)
        elif sc.pattern == 'splay' or m < sc.pattern_M:
            ok = ok & (value < MOMENT_TOL)
    return ok


def converged(sc: Scenario, snap: Snapshot) -> bool | BoolArray:
    """
    Return whether the formation of the scenario is reached: every one of :func:`conditions`.

    Returns
    -------
    bool, or ndarray of bool for a batch's snapshot

    """
    flags = list(conditions(sc, snap).values())
    out = flags[0]
    for flag in flags[1:]:
        out = out & flag
    return out


def unmet(sc: Scenario, snap: Snapshot) -> list[str]:
    """Return the names of the :func:`conditions` a one-fleet snapshot fails (a list)."""
    return [name for name, ok in conditions(sc, snap).items() if not bool(ok)]


def vehicles_converged(ctrl: Controller, view: laws.View) -> BoolArray:
    """
    Return whether each vehicle meets its own share of :func:`converged`.

    Parameters
    ----------
    ctrl : control.Controller
        The controller of the scenario.
    view : laws.View
        The fleet's view.

    Returns
    -------
    ndarray of bool, shape (N,)
        Parallel: phase within ``acos(ORDER_TOL)`` of the mean phase and ``|rate| < RATE_TOL``;
        circular: centre within SPREAD_TOL of the mean centre and radius within RADIUS_TOL;
        with a pattern also the fleet's ``phase_moments`` (:func:`pattern_moments_reached`:
        no vehicle is in its place while the pattern is not reached) and, for a splay, its
        nearest vehicle at least ``1 - SEPARATION_TOL`` of the chord away
        (:func:`nearest_distance`), as :func:`conditions` asks of the fleet.

    """
    f, sc = ctrl.formation, ctrl.sc
    if isinstance(f, laws.Circular):
        c = f.centres(view)
        radius_error = abs(abs(view.r - c.mean()) * abs(f.omega0) - 1.0)
        ok = (abs(c - c.mean()) < SPREAD_TOL) & (radius_error < RADIUS_TOL)
        if sc.pattern != 'none':
            ok = ok & pattern_moments_reached(sc, phase_orders(view.phase))
        if sc.pattern == 'splay':
            chord = 2.0 * np.sin(np.pi / sc.num_vehicles) / abs(sc.omega0)
            ok = ok & (nearest_distance(view.r) >= (1.0 - SEPARATION_TOL) * chord)
        return np.asarray(ok, bool)
    p = view.e.mean()
    aligned = np.cos(view.phase - np.angle(p)) > ORDER_TOL
    return aligned & (abs(view.rate) < RATE_TOL)


NEAREST_ROWS = 1024
"""Vehicles whose distances to all others :func:`nearest_distance` holds at once, at most."""
NEAREST_PAIRS = 1 << 21
"""Distances :func:`nearest_distance` holds at once, at most (fewer rows in a large fleet)."""


def nearest_distance(r: ComplexArray) -> RealArray:
    """
    Return each vehicle's distance to its nearest other vehicle (m), shape (N,).

    All pairs, up to ``NEAREST_ROWS`` vehicles at a time and ``NEAREST_PAIRS`` distances
    (O(N^2) time, bounded memory); inf for a vehicle alone.
    """
    r = np.asarray(r, complex)
    out = np.full(r.shape, np.inf)
    step = max(1, min(NEAREST_ROWS, NEAREST_PAIRS // max(r.size, 1)))
    for start in range(0, r.size, step):
        rows = np.arange(start, min(start + step, r.size))
        d = abs(r[rows, None] - r[None, :])
        d[np.arange(rows.size), rows] = np.inf
        out[rows] = d.min(axis=1, initial=np.inf)
    return out


def convergence_time(t: ArrayLike, flags: ArrayLike) -> float | None:
    """
    Return the first time from which ``flags`` holds at every sample to the end.

    Whether that is long enough for a 'yes' is :func:`verdict`'s to say (:func:`hold_window`).

    Parameters
    ----------
    t : array_like, shape (T,)
        Sample times (s).
    flags : array_like of bool, shape (T,)
        The convergence test at each sample.

    Returns
    -------
    float or None
        That time (s), or None when the last sample does not hold.

    """
    flags = np.asarray(flags, bool)
    if flags.size == 0 or not flags[-1]:
        return None
    return float(convergence_times(t, flags[:, None])[0])


def convergence_times(t: ArrayLike, flags: ArrayLike) -> RealArray:
    """
    Return :func:`convergence_time` of each run of a batch.

    Parameters
    ----------
    t : array_like, shape (T,)
        Sample times (s), T >= 1.
    flags : array_like of bool, shape (T, B)
        The convergence test of each of B runs at each sample.

    Returns
    -------
    ndarray, shape (B,)
        The first time from which each run's flags hold to the end (s); NaN where the last
        sample does not hold.

    """
    t, flags = np.asarray(t, float), np.asarray(flags, bool)
    last_bad = flags.shape[0] - 1 - np.argmax(~flags[::-1], axis=0)   # the last False
    since = np.where(np.all(flags, axis=0), 0, last_bad + 1)
    return np.where(flags[-1], t[np.minimum(since, t.size - 1)], np.nan)


def crab_angles(X: RealArray, flow: complex | ComplexArray) -> tuple[RealArray, RealArray]:
    """
    Return the crab angles of rigid bodies, relative to the flow and inertial.

    Parameters
    ----------
    X : array_like, shape (6, ...)
        States (rows of :mod:`models`).
    flow : complex or array_like of complex, shape (N,)
        The flow at each vehicle (m/s).

    Returns
    -------
    beta, beta_hat : ndarray, shape ``X.shape[1:]``
        ``beta = atan2(v, u)`` (7.11) and ``beta_hat = gamma - theta`` (8.1), the angle of the
        ground velocity in the body frame (rad, in (-pi, pi]).

    """
    beta = np.arctan2(X[ROW_V], X[ROW_U])
    beta_hat = np.angle(X[ROW_U] + 1j * X[ROW_V] + flow * np.exp(-1j * X[ROW_THETA]))
    return beta, beta_hat


def steady_turn(sc: Scenario) -> tuple[float, float, float, float]:
    """
    Return the steady turn of a rigid body on radius 1/``|omega0|``, (7.9)-(7.10) corrected.

    Parameters
    ----------
    sc : scenario.Scenario
        A rigid-body scenario (u0, omega0, m0, h, l, l1, model, cancel_drag_moment).

    Returns
    -------
    v0 : float
        Sideslip ``-m0 u0 omega0 / h_eff`` (m/s): the body skids outward (errata: the thesis
        prints +).
    s0 : float
        Speed ``u0 sqrt(1 + (m0 omega0 / h_eff)^2)`` (m/s) (errata: not the quartic root).
    beta0 : float
        Crab angle ``atan2(v0, u0)`` (rad).
    yaw_rate : float
        ``omega0 s0`` (rad/s).

    Notes
    -----
    ``h_eff = h``, except for the centre-of-pressure model with its drag moment cancelled
    (A.20): there the steady force ``F = -(l1/l) h s v`` adds to the drag,
    ``h_eff = h (1 + l1/l)``.

    """
    h_eff = sc.h
    if vehicle_model(sc.model).drag_moment and sc.cancel_drag_moment:
        h_eff = sc.h * (1.0 + sc.l1 / sc.l)
    v0 = -sc.m0 * sc.u0 * sc.omega0 / h_eff
    s0 = float(np.hypot(sc.u0, v0))
    return v0, s0, float(np.arctan2(v0, sc.u0)), sc.omega0 * s0


def parallel_flow_crab(sc: Scenario, theta: RealArray) -> tuple[RealArray, RealArray]:
    """
    Return the steady inertial crab angle and ground speed of rigid parallel motion in flow.

    Parameters
    ----------
    sc : scenario.Scenario
        A rigid-body scenario (u0, flow).
    theta : array_like
        Common heading (rad).

    Returns
    -------
    beta_hat0, s_hat0 : ndarray, shape of ``theta``
        ``atan2(<f, y_body>, u0 + <f, x_body>)`` (rad) and ``|u0 e^{i theta} + f|`` (m/s),
        (8.17).

    """
    heading = np.exp(1j * np.asarray(theta))
    f_body = sc.flow_c / heading
    return np.arctan2(f_body.imag, sc.u0 + f_body.real), abs(sc.u0 * heading + sc.flow_c)
