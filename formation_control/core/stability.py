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
Numerical safety: the fastest modes of a scenario against its steps, and diverging states.

Two steps can make a run diverge. RK4 integrates a decay of rate ``a`` stably only for
``a dt_integration <= RK4_LIMIT``; the fastest such rate of the rigid bodies is the surge drag
``2 h u0 / m0`` (the linearisation of ``(T - h s u) / m0`` (6.15) at ``u = u0``). A command
held over a control period closes a sampled loop. A loop of gain ``g`` (1/s), ``e' = -g e``,
with its command computed from the sampled state maps ``e`` to ``(1 - a) e``, ``a = g
dt_control``: stable for ``a < HOLD_LIMIT = 2``. Computed from the state predicted to the
middle of the hold with the previous command (``hold_prediction: midpoint``),
``e_{n+1} = (1 - 1.5 a) e_n + (a / 2) e_{n-1}``: characteristic polynomial
``l^2 - (1 - 1.5 a) l - a/2``, stable (Jury) only for ``0 < a < MIDPOINT_LIMIT = 1``
(docs/errata.md, "The held loop with the midpoint prediction"). The gains are the steering
bandwidth (kappa (3.7), K_p (5.5), K_P (8.24)) in cascade with the formation loop
``phase' = phi`` of rate at most ``(|K| + K_pattern) lambda_max(L) / nu``
(:func:`cascade_limit`: the cascade lowers the limit, e.g. to 0.794 at kappa = 5, K = 1), and
the thrust gain K_f (7.1). :func:`step_warnings` warns about a step beyond half its limit,
:func:`hold_fallback` turns the midpoint prediction off where only the plain hold is stable,
:func:`diverging` finds the vehicles whose state is no longer finite or has exploded,
:func:`divergence` names the likely cause.
"""
from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

from formation_control.core.errors import ScenarioError
from formation_control.core.geometry import BoolArray, RealArray
from formation_control.core.graphs import CONNECTIVITY_DENSE_MAX
from formation_control.core.models import ROW_OMEGA
from formation_control.core.steering import law
from formation_control.core.vehicles import vehicle_model
import numpy as np

if TYPE_CHECKING:
    from formation_control.core.parameters import Scenario

RK4_LIMIT = 2.785
"""Classical RK4 is stable on the negative real axis for ``a dt <= 2.785``."""
HOLD_LIMIT = 2.0
"""A first-order loop with its command held over T is stable for ``g T < 2``."""
MIDPOINT_LIMIT = 1.0
"""The same loop with its command computed at the predicted midpoint: stable for ``g T < 1``."""
EXPLODING = 1e6
"""A turn rate (rad/s) or a speed (m/s) beyond this has exploded."""
Mode = tuple[str, str, float, str, float, float]
"""A fast mode: name, formula, rate (1/s), step parameter, step (s), limit of rate * step."""


class DivergenceError(ScenarioError):
    """The integration of a run diverged (non-finite or exploding state)."""


def hold_limit(hold_prediction: str) -> float:
    """Return the limit of ``g dt_control`` of a held loop under the given hold_prediction."""
    return MIDPOINT_LIMIT if hold_prediction == 'midpoint' else HOLD_LIMIT


def formation_rate(sc: Scenario) -> float:
    """
    Return a bound on the rate of the formation loop ``phase' = phi`` (1/s).

    ``(|K| + K_pattern) lambda_max(L) / nu``: the Jacobian of phi in the phases is the sum of
    the formation's ``-|K| L / nu`` (all-to-all ``-|K| (I - 1 1^T / N)``: ``lambda_max / nu = 1``)
    and the pattern potential's Hessian, whose eigenvalues are at most the slot gain times
    ``lambda_max(L) / nu`` or the largest moment gain ``|K_m|`` (docs/errata.md). Past
    ``graphs.CONNECTIVITY_DENSE_MAX`` vehicles lambda_max(L) is bounded by twice the largest
    degree (Gershgorin; equal on even rings) instead of computed from the dense Laplacian
    (N^2 floats, N^3 work).
    """
    spread = 1.0
    if not sc.all_to_all:
        g = sc.comm_graph
        if g.n > CONNECTIVITY_DENSE_MAX:
            spread = 2.0 * float(g.degrees().max(initial=0)) / g.nu
        else:
            spread = float(np.linalg.eigvalsh(g.laplacian())[-1]) / g.nu
    pattern = 0.0
    if sc.pattern != 'none':
        pattern = max(abs(k) for k in sc.pattern_gains) if not sc.pattern_slots else \
            sc.pattern_gain
    return (abs(sc.K) + pattern) * spread


def cascade_matrix(kappa: float, f: float, h: float, hold_prediction: str = 'midpoint',
                   feedforward: bool = True) -> RealArray:
    """
    Return the one-period map of the linearised second-order steering loop with a held command.

    Parameters
    ----------
    kappa : float
        Steering gain (1/s): kappa (backstepping) or K_p (proportional).
    f : float
        Rate of the formation loop (1/s), :func:`formation_rate`.
    h : float
        The hold, dt_control (s).
    hold_prediction : str
        midpoint: the command is computed at the state predicted ``h/2`` ahead with the
        previous command; none: at the sampled state.
    feedforward : bool
        Whether the command adds ``phi'`` (backstepping) or not (proportional).

    Returns
    -------
    ndarray, shape (3, 3)
        The map of ``(e, w, u_prev)``: a phase error ``e`` with ``phi = -f e``, its rate ``w``
        (``e' = w``, ``w' = u`` held) and the previous command, under
        ``u = -kappa (w_p + f e_p) - f w_p`` (the feedforward ``phi' = -f w``) at the
        predicted ``(e_p, w_p)`` (docs/errata.md, "The held loop with the midpoint prediction").

    """
    lead = 0.5 * h if hold_prediction == 'midpoint' else 0.0
    predict = np.array([[1.0, lead, 0.5 * lead ** 2], [0.0, 1.0, lead]])
    u = np.array([-kappa * f, -kappa - (f if feedforward else 0.0)]) @ predict
    return np.array([[1.0, h, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]]) + np.outer(
        [0.5 * h * h, h, 1.0], u)


def cascade_limit(kappa: float, f: float, hold_prediction: str = 'midpoint',
                  feedforward: bool = True) -> float:
    """
    Return the largest ``kappa dt_control`` for which :func:`cascade_matrix` is stable.

    The spectral radius is found below 1 on a grid of ``a = kappa h`` in (0, HOLD_LIMIT] and
    the crossing refined by bisection; with ``f = 0`` the loop is the single one:
    :func:`hold_limit`.
    """
    if f <= 0 or kappa <= 0:
        return hold_limit(hold_prediction)

    def stable(a: float) -> bool:
        m = cascade_matrix(kappa, f, a / kappa, hold_prediction, feedforward)
        return float(max(abs(np.linalg.eigvals(m)))) < 1.0

    grid = np.linspace(HOLD_LIMIT / 400, HOLD_LIMIT, 400)
    bad = [a for a in grid if not stable(a)]
    if not bad:
        return HOLD_LIMIT
    high = bad[0]
    low = high - grid[0]
    for _ in range(40):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if stable(mid) else (low, mid)
    return float(low)


def modes(sc: Scenario) -> list[Mode]:
    """
    Return the fast modes of a scenario and the step each must be resolved by.

    Returns
    -------
    list of tuple
        ``(name, formula, rate (1/s), step parameter, step (s), stability limit of rate * step)``.
        The steering loop of the second-order laws is the cascade of :func:`cascade_limit`
        with the formation loop; that of the first-order law is the formation loop itself.

    """
    held = hold_limit(sc.hold_prediction)
    formation = formation_rate(sc)
    steer = law(sc)
    if steer.order == 1:
        formula = '|K|' if formation == abs(sc.K) else '(|K| + K_pattern) lambda_max(L)/nu'
        out = [('steering loop', formula, formation, 'dt_control', sc.dt_control, held)]
    else:
        gain = steer.bandwidth(sc)
        limit = cascade_limit(gain, formation, sc.hold_prediction, steer.feedforward)
        out = [('steering loop', steer.gain, gain, 'dt_control', sc.dt_control, limit)]
    surge = vehicle_model(sc.model).surge_mode(sc)
    if surge is not None:
        out += [('surge drag', *surge, 'dt_integration', sc.dt_integration, RK4_LIMIT),
                ('thrust loop', 'K_f', sc.K_f, 'dt_control', sc.dt_control, held)]
    return out


def hold_fallback(sc: Scenario) -> tuple[str, str | None]:
    """
    Return the hold_prediction to run and the note that says why, if it changes.

    Returns
    -------
    hold_prediction : str
        ``none`` when the midpoint prediction is asked for and a held loop has
        ``MIDPOINT_LIMIT <= g dt_control < HOLD_LIMIT`` (stable only without the prediction);
        the scenario's own otherwise.
    note : str or None
        The warning naming the loop, or None.

    """
    if sc.hold_prediction != 'midpoint':
        return sc.hold_prediction, None
    plain = modes(replace(sc, hold_prediction='none'))
    for m, p in zip(modes(sc), plain):
        a = m[2] * m[4]
        if m[3] == 'dt_control' and m[5] <= a < p[5]:
            return 'none', (
                f'hold_prediction: midpoint is unstable for the {m[0]} {m[1]} * dt_control = '
                f'{a:.3g} (stable below {m[5]:.3g} with the prediction); running with '
                f'hold_prediction: none (the plain hold, stable below {p[5]:.3g}; errors of '
                f'order dt_control)')
    return sc.hold_prediction, None


def _text(mode: Mode) -> str:
    name, formula, rate, step, dt, limit = mode
    return (f'{step} = {dt:g} s against the {name} {formula} = {rate:.3g} 1/s: {formula} * '
            f'{step} = {rate * dt:.3g} (stable below {limit:.3g}; {step} <= {limit / rate:.3g} s)')


def step_warnings(sc: Scenario) -> list[str]:
    """Return a warning for each mode whose rate times its step exceeds half its limit."""
    return [f'{_text(m)}: ' + ('the run will diverge' if m[2] * m[4] >= m[5] else
                               'the run may oscillate or diverge')
            for m in modes(sc) if m[2] > 0 and m[2] * m[4] > 0.5 * m[5]]


def diverging(X: RealArray) -> BoolArray:
    """
    Return the vehicles whose state diverged.

    Parameters
    ----------
    X : ndarray, shape (6, N)
        States of the fleet.

    Returns
    -------
    ndarray of bool, shape (N,)
        A non-finite entry, or a turn rate or speed beyond :data:`EXPLODING`.

    """
    with np.errstate(invalid='ignore'):
        return ~np.all(np.isfinite(X), axis=0) | np.any(abs(X[ROW_OMEGA:]) > EXPLODING, axis=0)


def likely_cause(sc: Scenario) -> str:
    """Return the text of the mode nearest to (or beyond) its stability limit."""
    worst = max(modes(sc), key=lambda m: m[2] * m[4] / m[5])
    return _text(worst)


def divergence(sc: Scenario, t: float, i: int, X: RealArray) -> DivergenceError:
    """
    Return the :class:`DivergenceError` of vehicle index ``i`` diverged by time ``t`` (s).

    The message names the time, the vehicle, its state and the likely cause.
    """
    state = ', '.join(f'{n} = {v:.3g}' for n, v in zip(('x', 'y', 'theta', 'omega', 'u', 'v'),
                                                       X[:, i]))
    return DivergenceError(f'the integration diverged at t = {t:.3f} s: vehicle {i + 1} '
                           f'({state}). Likely cause: {likely_cause(sc)}; lower the step')
