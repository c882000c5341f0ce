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
What a run shows, whatever recorded it (offline simulator, the plant's ``.npz``, a bag).

The series the figures draw, and the final values next to the steady state the thesis
predicts.
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any, TypeAlias

from formation_control.core import formations
from formation_control.core.control import Controller
from formation_control.core.geometry import RealArray
from formation_control.core.models import (ground_velocity, ROW_OMEGA, ROW_THETA, ROW_U, ROW_X,
                                           ROW_Y)
from formation_control.core.parameters import Scenario
from formation_control.core.vehicles import vehicle_model
from formation_control.sim import metrics, separation
from formation_control.sim.simulator import Run, summary
import numpy as np
from numpy.typing import NDArray

Series: TypeAlias = dict[str, NDArray[Any]]
"""The time series of a run by name (:func:`series`)."""
Row: TypeAlias = tuple[str, float, float | None, str]
"""A line of a report: the metric, its final value, the predicted one and its source."""


def series(run: Run) -> Series:
    """
    Return the per-sample data of the figures.

    Parameters
    ----------
    run : simulator.Run
        A recorded run of T samples of N vehicles.

    Returns
    -------
    dict of str to ndarray
        ``t`` (T,) s; ``x``, ``y`` (m), ``theta`` (rad), ``omega`` (rad/s), ``u`` (m/s), each
        (T, N); ``ground`` (T, N) complex, the ground velocity (8.1) (m/s), and ``speed`` its
        modulus; ``beta``, ``beta_hat`` (T, N), the crab angles (rad); ``lyapunov`` (T,) V_c
        (2.10) and ``order`` (T,) ``|p|`` (1.10); with a symmetric pattern ``phase_orders``
        (T, m) the moduli ``|p_m|`` (:func:`metrics.phase_orders`) and ``centre`` (T,) complex,
        the mean circle centre (m).

    """
    ctrl = Controller(run.sc)
    snaps = [metrics.snapshot(ctrl, X, inputs, t, separation=False, gust=run.gust[i])
             for i, (t, X, inputs) in enumerate(zip(run.t, run.X, run.U))]
    X = run.X.transpose(1, 0, 2)
    flow = metrics.moving_flow(ctrl, X, run.t[:, None], run.gust)
    beta, beta_hat = metrics.crab_angles(X, flow)
    ground = ground_velocity(X, flow)
    out = {'t': run.t, 'x': X[ROW_X], 'y': X[ROW_Y], 'theta': X[ROW_THETA],
           'omega': X[ROW_OMEGA], 'u': X[ROW_U],
           'ground': ground, 'speed': abs(ground), 'beta': beta, 'beta_hat': beta_hat,
           'lyapunov': np.array([s.lyapunov for s in snaps]),
           'order': np.array([s.order for s in snaps])}
    if run.sc.pattern != 'none':
        out['phase_orders'] = np.array([s.phase_orders for s in snaps])
        out['centre'] = np.array([s.centre for s in snaps])
    return out


def pattern_groups(sc: Scenario) -> int | None:
    """Return the number of evenly spaced groups of the pattern: N (splay), M, or None."""
    return {'splay': sc.num_vehicles, 'symmetric': sc.pattern_M}.get(sc.pattern)


def pattern_text(sc: Scenario) -> str | None:
    """
    Return the pattern the scenario predicts, in words.

    Parameters
    ----------
    sc : scenario.Scenario
        A circular scenario (pattern, pattern_M, pattern_form, num_vehicles, omega0).

    Returns
    -------
    str or None
        E.g. ``splay: 12 vehicles 30 deg apart, chord 0.5176 m (moments)``; None without a
        pattern.

    """
    groups = pattern_groups(sc)
    if groups is None:
        return None
    form = 'slots' if sc.pattern_slots else 'moments'
    if sc.pattern == 'splay':
        chord = 2.0 * np.sin(np.pi / groups) / abs(sc.omega0)
        return (f'splay: {groups} vehicles {360.0 / groups:.4g} deg apart, chord {chord:.4g} m '
                f'({form})')
    return (f'({groups}, {sc.num_vehicles}): {groups} clusters of {sc.num_vehicles // groups}, '
            f'{360.0 / groups:.4g} deg apart ({form})')


def predictions(sc: Scenario, X: RealArray) -> dict[str, tuple[float, str]]:
    """
    Return the steady-state values the thesis' analysis predicts.

    Parameters
    ----------
    sc : scenario.Scenario
        The scenario.
    X : array_like, shape (6, N)
        The final state: it gives the common heading the crab angle (8.17) depends on.

    Returns
    -------
    dict of str to (float, str)
        Metric name (:meth:`metrics.Snapshot.values`) -> (predicted value, its source in the
        thesis or the errata).

    """
    model = vehicle_model(sc.model)
    rigid = model.rigid
    drag = 'h' in model.params          # the thesis' steady states (7.9)-(7.10), (8.17) need h
    still = sc.flow_c == 0
    out = {'potential': (0.0, 'minimum of V'), 'lyapunov': (0.0, '(2.10) V_c -> 0')}
    radius = formations.of(sc).radius(sc)
    if radius is None:
        out['order_parameter'] = (1.0, '(1.11) V = (1 - |p|^2)/2 -> 0')
        out['max_turn_rate'] = (0.0, 'synchronised straight motion')
    else:
        out['centre_spread'] = (0.0, '(1.14) common centre')
        out['radius'] = (radius, 'radius 1/|omega0|')
        if sc.informed:
            out['centre_x'] = (sc.c0[0], '(7.17) centre -> c0')
            out['centre_y'] = (sc.c0[1], '(7.17) centre -> c0')
        if still and (drag or not rigid):
            rate = abs(sc.omega0) * (metrics.steady_turn(sc)[1] if rigid else 1.0)
            out['max_turn_rate'] = (rate, '(7.9)-(7.10) yaw rate omega0 s0' if rigid
                                    else 'turn rate omega0')
    groups = pattern_groups(sc)
    if groups is not None:
        source = f'{sc.pattern} pattern, {groups} groups: |p_m| = 1/m if {groups} | m, else 0'
        for m in range(1, len(metrics.phase_orders(np.zeros(sc.num_vehicles))) + 1):
            out[f'phase_order_{m}'] = (1.0 / m if m % groups == 0 else 0.0, source)
        chord = 2.0 * np.sin(np.pi / groups) / abs(sc.omega0)
        out['min_separation'] = ((chord, 'splay: chord 2 sin(pi/N)/|omega0|')
                                 if sc.pattern == 'splay'
                                 else (0.0, 'the vehicles of a cluster coincide'))
    if rigid:
        out['speed_error'] = (0.0, '(7.1) u -> u0')
        if radius is not None and still and drag:
            out['crab_angle'] = (metrics.steady_turn(sc)[2], '(7.9)-(7.10) corrected: beta0')
        if radius is None:
            out['crab_angle'] = (0.0, 'straight motion: v -> 0')
        if radius is None and drag:
            crab = float(np.mean(metrics.parallel_flow_crab(sc, X[ROW_THETA])[0]))
            out['crab_angle_inertial'] = (crab, '(8.17) at the final heading' if not still
                                          else 'no flow: 0')
    return out


def report(run: Run) -> tuple[dict[str, Any], list[Row]]:
    """
    Return the report of a run.

    Parameters
    ----------
    run : simulator.Run
        A recorded run.

    Returns
    -------
    summary : dict
        :func:`simulator.summary`, with ``pattern`` (:func:`pattern_text`) when the scenario
        has a symmetric pattern.
    rows : list of (str, float, float or None, str)
        For each final metric: its name, the measured value, the predicted one (None if the
        analysis predicts none) and the source of the prediction.

    """
    out = summary(run)
    if run.sc.pattern != 'none':
        out = dict(out, pattern=pattern_text(run.sc))
    final = metrics.snapshot(Controller(run.sc), run.X[-1], run.U[-1], run.t[-1],
                             gust=run.gust[-1]).values()
    predicted = predictions(run.sc, run.X[-1])
    rows = [(name, value, *predicted.get(name, (None, ''))) for name, value in final.items()]
    return out, rows


def format_report(title: str, out: Mapping[str, Any], rows: Iterable[Row]) -> str:
    """Return the text ``formation-control report`` prints of a report (:func:`report`)."""
    verdict = metrics.Settling(out['converged'], out['convergence_time'], out['held'],
                               out['hold_window'])
    lines = [title,
             f'  converged          {verdict.text()}'
             + (f" (fails: {', '.join(out['unmet'])})" if out.get('unmet') else ''),
             f"  {'quantity':20s} {'final':>12s} {'predicted':>12s}  source"]
    if out.get('pattern'):
        lines.insert(2, f"  predicted pattern  {out['pattern']}")
    if 'airspeed_held' in out:
        lines.insert(2, f"  held from t = {out['hold_from']:.4g} s: airspeed "
                        f"{'{:.4g}-{:.4g}'.format(*out['airspeed_held'])} m/s, altitude "
                        f"{'{:.4g}-{:.4g}'.format(*out['altitude_held'])} m"
                        + (f" ({out['flight']})" if out['flight'] else ''))
    if out.get('steady_state'):
        lines[2:2] = [f"  band test over the last {out['settle_window']:g} s: steady-state "
                      'error median / p95 (band)'] + [
            f"    {name:18s} {v['median']:.4g} / {v['p95']:.4g} ({v['band']:g})"
            for name, v in out['steady_state'].items()]
    if out.get('separation'):
        lines.insert(2, f"  separation         {separation.text(out['separation'])}")
    for name, value, predicted, source in rows:
        pred = '' if predicted is None else f'{predicted:12.6g}'
        lines.append(f'  {name:20s} {value:12.6g} {pred:>12s}  {source}'.rstrip())
    return '\n'.join(lines)
