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
held over a control period closes a sampled loop: a loop of gain ``g`` (1/s) held over
``dt_control`` maps an error ``e`` to ``(1 - g dt_control) e``, stable only for
``g dt_control < HOLD_LIMIT``; the gains are the steering bandwidth (kappa (3.7), K_p (5.5),
K_P (8.24), ``|K|`` of the first-order laws) and the thrust gain K_f (7.1). :func:`step_warnings`
warns about a step beyond half its limit, :func:`diverging` finds the vehicles whose state is
no longer finite or has exploded, :func:`divergence` names the likely cause.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from formation_control.core.errors import ScenarioError
from formation_control.core.geometry import BoolArray, RealArray
from formation_control.core.models import RIGID_MODELS, ROW_OMEGA
import numpy as np

if TYPE_CHECKING:
    from formation_control.core.scenario import Scenario

RK4_LIMIT = 2.785
"""Classical RK4 is stable on the negative real axis for ``a dt <= 2.785``."""
HOLD_LIMIT = 2.0
"""A first-order loop with its command held over T is stable for ``g T < 2``."""
EXPLODING = 1e6
"""A turn rate (rad/s) or a speed (m/s) beyond this has exploded."""
Mode = tuple[str, str, float, str, float, float]
"""A fast mode: name, formula, rate (1/s), step parameter, step (s), limit of rate * step."""


STEERING_GAINS = {'first_order': 'K', 'backstepping': 'kappa', 'proportional': 'K_p',
                  'pi': 'K_P'}
"""The gain of each controller whose modulus is its steering bandwidth (1/s)."""


class DivergenceError(ScenarioError):
    """The integration of a run diverged (non-finite or exploding state)."""


def steering_bandwidth(sc: Scenario) -> float:
    """Return how fast the steering loop acts (1/s): kappa, K_p, K_P or ``|K|`` by controller."""
    return abs(getattr(sc, STEERING_GAINS[sc.controller]))


def modes(sc: Scenario) -> list[Mode]:
    """
    Return the fast modes of a scenario and the step each must be resolved by.

    Returns
    -------
    list of tuple
        ``(name, formula, rate (1/s), step parameter, step (s), stability limit of rate * step)``.

    """
    name = STEERING_GAINS[sc.controller]
    formula = f'|{name}|' if name == 'K' else name
    out = [('steering loop', formula, steering_bandwidth(sc), 'dt_control', sc.dt_control,
            HOLD_LIMIT)]
    if sc.model in RIGID_MODELS:
        out += [('surge drag', '2 h u0 / m0', 2.0 * sc.h * sc.u0 / sc.m0, 'dt_integration',
                 sc.dt_integration, RK4_LIMIT),
                ('thrust loop', 'K_f', sc.K_f, 'dt_control', sc.dt_control, HOLD_LIMIT)]
    return out


def _text(mode: Mode) -> str:
    name, formula, rate, step, dt, limit = mode
    return (f'{step} = {dt:g} s against the {name} {formula} = {rate:.3g} 1/s: {formula} * '
            f'{step} = {rate * dt:.3g} (stable below {limit:g}; {step} <= {limit / rate:.3g} s)')


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
