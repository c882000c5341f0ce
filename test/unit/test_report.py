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
The report and figure data of a run, and the command limits.

Final values meet the steady state the thesis predicts, per-vehicle convergence agrees with the
fleet's test, limits clip and flag.
"""
from dataclasses import replace

from formation_control.core import scenario
from formation_control.core.control import Controller
from formation_control.core.errors import ScenarioError
from formation_control.sim import metrics, report
import numpy as np
import pytest
from runs import CONFIG, run_of

CONVERGING = [
    ('particle_parallel', ()), ('particle_circular', ()), ('particle_circular_flow', ()),
    ('first_order_circular', ()), ('rigid_parallel_flow', ()), ('rigid_circular', ()),
    ('rigid_parallel', ()),
]


@pytest.mark.slow
@pytest.mark.parametrize('name, overrides', CONVERGING)
def test_final_values_meet_every_prediction(name, overrides):
    run = run_of(name, 1, overrides)
    out, rows = report.report(run)
    assert out['converged']
    checked = [(n, v, p) for n, v, p, _ in rows if p is not None]
    assert {'lyapunov', 'potential'} <= {n for n, _, _ in checked}
    for row_name, value, predicted in checked:
        scale = 1e-2 * max(1.0, abs(predicted))
        assert value == pytest.approx(predicted, abs=scale), row_name


def test_rigid_turn_predictions_are_the_corrected_steady_turn():
    sc = scenario.load(CONFIG / 'rigid_circular.yaml')
    v0, s0, beta0, yaw_rate = metrics.steady_turn(sc)
    pred = report.predictions(sc, np.zeros((6, sc.num_vehicles)))
    assert pred['crab_angle'][0] == pytest.approx(np.arctan2(v0, sc.u0)) == beta0
    assert beta0 < 0
    assert pred['max_turn_rate'][0] == pytest.approx(abs(yaw_rate))
    assert pred['radius'][0] == pytest.approx(1 / abs(sc.omega0))


def test_prescribed_centre_is_predicted_only_when_someone_knows_it():
    sc = scenario.load(CONFIG / 'rigid_circular_center.yaml')
    assert sc.informed
    pred = report.predictions(sc, np.zeros((6, sc.num_vehicles)))
    assert (pred['centre_x'][0], pred['centre_y'][0]) == tuple(sc.c0)
    uninformed = scenario.load(CONFIG / 'rigid_circular.yaml')
    assert 'centre_x' not in report.predictions(uninformed, np.zeros((6, 5)))


def test_parallel_flow_crab_prediction_follows_the_heading():
    sc = scenario.load(CONFIG / 'rigid_parallel_flow.yaml')
    X = np.zeros((6, sc.num_vehicles))
    X[2] = 0.3
    pred = report.predictions(sc, X)['crab_angle_inertial'][0]
    f_body = sc.flow_c * np.exp(-0.3j)
    assert pred == pytest.approx(np.arctan2(f_body.imag, sc.u0 + f_body.real))


@pytest.mark.slow
def test_series_lyapunov_never_increases_under_backstepping():
    run = run_of('particle_circular', 1)
    d = report.series(run)
    assert np.all(np.diff(d['lyapunov']) <= 1e-9 * d['lyapunov'][0])
    assert d['x'].shape == d['theta'].shape == (len(run.t), run.sc.num_vehicles)


@pytest.mark.slow
def test_series_ground_speed_is_unit_speed_through_the_flow():
    run = run_of('particle_circular_flow', 1)
    d = report.series(run)
    expected = abs(np.exp(1j * d['theta']) + run.sc.flow_c)
    np.testing.assert_allclose(d['speed'], expected, atol=1e-12)


@pytest.mark.slow
def test_vehicles_converged_agrees_with_the_fleet_test_at_the_end():
    for name in ('particle_circular', 'rigid_parallel'):
        run = run_of(name, 1)
        ctrl = Controller(run.sc)
        X, U = run.X[-1], run.U[-1]
        assert metrics.converged(run.sc, metrics.snapshot(ctrl, X, U))
        assert metrics.vehicles_converged(ctrl, ctrl.view(X, U[1])).all()
        early = metrics.vehicles_converged(ctrl, ctrl.view(run.X[0], run.U[0][1]))
        assert not early.all()


@pytest.mark.parametrize('paired', [False, True])
def test_vehicles_converged_refuses_a_splay_in_coincident_pairs(paired):
    """The twisted state 4 pi k / N of a ring: N/2 pairs on one circle, centres together."""
    sc = scenario.load(CONFIG / 'particle_circular_splay.yaml')
    n, ctrl = sc.num_vehicles, Controller(sc)
    phase = 2 * np.pi * np.arange(n) / n * (2 if paired else 1)
    r = -1j * np.exp(1j * phase) / sc.omega0               # c_k = r_k + i e_k / omega0 = 0
    X = np.zeros((6, n))
    X[0], X[1], X[2], X[3], X[4] = r.real, r.imag, phase, sc.omega0, 1.0
    view = ctrl.view(X)
    np.testing.assert_allclose(ctrl.formation.centres(view), 0, atol=1e-12)
    ok = metrics.vehicles_converged(ctrl, view)
    assert ok.shape == (n,)
    assert bool(metrics.converged(sc, metrics.snapshot(ctrl, X, np.zeros((2, n))))) != paired
    assert not ok.any() if paired else ok.all()
    if paired:
        separated = replace(sc, pattern='symmetric', pattern_M=n // 2)
        assert metrics.vehicles_converged(Controller(separated), view).all()


@pytest.mark.parametrize('model, limit, row', [
    ('rigid', 'max_thrust', 0), ('rigid', 'max_steering_force', 1),
    ('second_order', 'max_angular_accel', 1), ('first_order', 'max_turn_rate', 1),
])
def test_command_limits_clip_and_flag(model, limit, row):
    controller = 'first_order' if model == 'first_order' else 'backstepping'
    sc = scenario.resolve({'model': model, 'controller': controller, 'num_vehicles': 4,
                           'formation': 'circular', limit: 0.05, 'seed': 3})
    ctrl = Controller(sc)
    X = scenario.initial_state(sc)
    U = ctrl.command(ctrl.view(X), X)
    assert np.all(abs(U[row]) <= 0.05 + 1e-15)
    assert np.any(abs(U[row]) == 0.05)
    np.testing.assert_array_equal(ctrl.saturated(U), abs(U[row]) >= 0.05 * (1 - 1e-9))
    free = Controller(scenario.resolve({**sc.to_dict(), limit: 0.0}))
    assert not free.saturated(free.command(free.view(X), X)).any()


def test_negative_limit_is_refused_with_its_name():
    with pytest.raises(ScenarioError, match="'max_thrust' = -1.0 .*>= 0 \\(0 = no limit\\)"):
        scenario.resolve({'model': 'rigid', 'max_thrust': -1.0})


def test_the_report_names_the_conditions_a_run_fails():
    run = run_of('particle_circular_splay', 1, ('duration:=2.0',))
    out, rows = report.report(run)
    assert not out['converged'] and 'phase_moments' in out['unmet']
    line = report.format_report('t', out, rows).splitlines()[1]
    assert line == f"  converged          no (fails: {', '.join(out['unmet'])})"
