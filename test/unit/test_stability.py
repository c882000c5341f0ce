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

"""Numerical safety: step limits derived from the model, a diverging run stopped with its cause."""
from dataclasses import replace
import warnings

from formation_control import cli
from formation_control.core import models, stability
from formation_control.core.scenario import resolve
from formation_control.protocol.fleet import FleetPlant
from formation_control.sim.simulator import simulate, summary
import numpy as np
import pytest

RIGID = {'model': 'rigid', 'num_vehicles': 3}


def test_the_limits_are_those_of_rk4_and_of_a_held_command():
    def rk4(z):
        return 1 + z + z ** 2 / 2 + z ** 3 / 6 + z ** 4 / 24
    assert abs(rk4(-stability.RK4_LIMIT + 0.005)) < 1 < abs(rk4(-stability.RK4_LIMIT - 0.005))

    def held(gT):                              # e -> (1 - g T) e over one held period
        return abs(1 - gT)
    assert held(stability.HOLD_LIMIT - 0.005) < 1 < held(stability.HOLD_LIMIT + 0.005)


def test_the_surge_drag_rate_is_the_linearised_model():
    sc = resolve(RIGID)
    plant = models.Plant.of(sc)
    X = np.zeros((6, 2))
    X[models.ROW_U] = sc.u0 + np.array([-1e-6, 1e-6])
    du, _, _ = models.body_accel(X, np.array([[sc.h * sc.u0 ** 2] * 2, [0.0, 0.0]]), plant)
    rate = -(du[1] - du[0]) / 2e-6
    (drag,) = [m for m in stability.modes(sc) if m[0] == 'surge drag']
    assert drag[2] == pytest.approx(rate, rel=1e-6) and drag[2] == 10.0


def test_a_step_too_large_for_the_fastest_mode_is_warned_about():
    assert resolve(RIGID).warnings == ()
    fallback, note = resolve({**RIGID, 'dt_integration': 0.025, 'dt_control': 0.25,
                              'record_dt': 0.25}).warnings
    assert fallback.startswith('hold_prediction: midpoint is unstable for the steering loop')
    assert note.startswith('dt_control = 0.25 s against the steering loop kappa = 5 1/s')
    assert '(stable below 1.67; dt_control <= 0.333 s)' in note
    *_, note = resolve({**RIGID, 'dt_integration': 0.2, 'dt_control': 0.2,
                        'record_dt': 0.2}).warnings
    assert 'dt_integration = 0.2 s against the surge drag 2 h u0 / m0 = 10 1/s' in note
    assert 'dt_integration <= 0.279 s' in note and 'may oscillate or diverge' in note


def test_a_diverging_run_stops_with_its_time_vehicle_and_cause(capsys):
    with warnings.catch_warnings():
        warnings.simplefilter('error')                   # no numpy overflow warning at all
        code = cli.main(['sim', 'rigid_circular', '-p', 'dt_control:=0.5', '-p',
                         'dt_integration:=0.25', '-p', 'record_dt:=0.5'])
    err = capsys.readouterr().err
    assert code == 2
    assert 'warning: dt_control = 0.5 s against the steering loop kappa' in err
    assert 'the run will diverge' in err
    assert 'error: the integration diverged at t = 1.000 s: vehicle ' in err
    assert 'Likely cause: dt_control = 0.5 s against the steering loop kappa = 5 1/s: ' \
           'kappa * dt_control = 2.5 (stable below 0.794; dt_control <= 0.159 s)' in err


def test_the_plant_stops_a_vehicle_whose_state_explodes_before_it_overflows():
    fleet = FleetPlant(resolve(RIGID))
    fleet.stepper.X[models.ROW_U, 1] = 2 * stability.EXPLODING
    fleet.hold([False] * 3, True)
    assert fleet.integrate().tolist() == [1]
    assert fleet.stopped.tolist() == [False, True, False]


def _radius(a, hold):
    """Spectral radius of the single held loop e' = -g e, a = g h, from its recursion."""
    if hold == 'none':
        return abs(1 - a)
    return max(abs(np.roots([1.0, -(1.0 - 1.5 * a), -0.5 * a])))


@pytest.mark.parametrize('hold, limit', [('none', 2.0), ('midpoint', 1.0)])
def test_the_single_held_loop_is_stable_exactly_below_its_jury_bound(hold, limit):
    assert stability.hold_limit(hold) == limit
    assert _radius(limit - 0.01, hold) < 1 < _radius(limit + 0.01, hold)
    # The midpoint recursion is the model's: e' = u held, u_n = -g (e_n + h/2 u_{n-1}).
    g, h = 1.0, 0.7
    e, u = [1.0, 1.0], 0.0
    for _ in range(3):
        u = -g * (e[-1] + 0.5 * h * u)
        e.append(e[-1] + h * u)
    a = g * h
    assert e[-1] == pytest.approx((1 - 1.5 * a) * e[-2] + 0.5 * a * e[-3])


def test_the_cascade_limit_is_the_jury_bound_without_formation_and_lower_with_it():
    assert stability.cascade_limit(5.0, 1e-9, 'midpoint') == pytest.approx(1.0, abs=1e-3)
    assert stability.cascade_limit(5.0, 1e-9, 'none') == pytest.approx(2.0, abs=1e-3)
    assert stability.cascade_limit(5.0, 1.0, 'midpoint') == pytest.approx(0.794, abs=1e-3)
    assert stability.cascade_limit(5.0, 1.0, 'none') == pytest.approx(1.667, abs=1e-3)


CIRCLE = {'formation': 'circular', 'num_vehicles': 6}


def _held_run(dt, hold=None):
    sc = resolve({**CIRCLE, 'dt_control': dt, 'dt_integration': dt / 4, 'record_dt': dt,
                  'duration': round(80 / dt) * dt})
    if hold is not None:                         # past resolve's fallback: the hold as asked
        sc = replace(sc, hold_prediction=hold)
    return sc, simulate(sc)


def test_the_predicted_boundary_of_the_default_loop_holds_on_both_sides():
    """Default gains (kappa = 5, K = 1), midpoint: the cascade limit 0.794 (0.1588 s) +- 10 %."""
    (mode,) = stability.modes(resolve(CIRCLE))
    h = mode[5] / mode[2]
    sc, run = _held_run(round(0.9 * h, 4))
    assert sc.hold_prediction == 'midpoint' and summary(run)['converged']
    with pytest.raises(stability.DivergenceError, match='stable below 0.794'):
        _held_run(round(1.1 * h, 4), 'midpoint')


def test_midpoint_falls_back_to_the_plain_hold_where_only_that_is_stable():
    sc, run = _held_run(0.2)
    assert sc.hold_prediction == 'none'
    assert sc.warnings[0].startswith('hold_prediction: midpoint is unstable for the steering '
                                     'loop kappa * dt_control = 1 (stable below 0.794')
    assert summary(run)['converged']
    assert resolve({**CIRCLE, 'hold_prediction': 'none', 'dt_control': 0.2,
                    'dt_integration': 0.05, 'record_dt': 0.2}).warnings[0].endswith(
        'may oscillate or diverge')


def _phi_jacobian(sc, phase):
    """Return the numerical Jacobian d phi / d phase of the first-order law (N, N)."""
    from formation_control.core import laws
    from formation_control.core.control import Controller
    f = Controller(sc).formation
    n = sc.num_vehicles
    r = -1j * np.exp(1j * phase) / sc.omega0 if sc.formation == 'circular' else np.zeros(n)

    def phi(ph):
        view = laws.View(r, ph, np.zeros(n), np.ones(n), np.zeros(n))
        return f.terms(view).phi
    h = 1e-6
    return np.array([(phi(phase + h * e) - phi(phase - h * e)) / (2 * h)
                     for e in np.eye(n)]).T


@pytest.mark.parametrize('params', [
    {'formation': 'parallel', 'K': -0.7},
    {'formation': 'parallel', 'K': -0.7, 'graph': 'ring'},
    {'formation': 'parallel', 'K': -0.7, 'graph': 'circulant', 'graph_offsets': [1, 3],
     'graph_nu': 4.0},
])
def test_the_formation_rate_is_the_largest_eigenvalue_of_the_law_at_synchrony(params):
    sc = resolve({'model': 'first_order', 'controller': 'first_order', 'num_vehicles': 8,
                  **params})
    eig = np.linalg.eigvals(_phi_jacobian(sc, np.full(8, 0.3)))
    assert max(abs(eig)) == pytest.approx(stability.formation_rate(sc), rel=1e-6)


def test_the_formation_rate_bounds_the_splay_pattern_law():
    sc = resolve({'model': 'first_order', 'controller': 'first_order', 'num_vehicles': 8,
                  'formation': 'circular', 'pattern': 'splay'})
    J = _phi_jacobian(sc, 2 * np.pi * np.arange(8) / 8)
    assert max(abs(np.linalg.eigvals(J))) <= stability.formation_rate(sc) * (1 + 1e-6)
