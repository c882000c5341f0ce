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
The marine surface vessel (core/vehicles/vessel.py) added through the vehicle-model seam.

Its inverse gives the accelerations the laws demand (and the thesis bodies' inverses are
today's thrust (7.1) and steering force (7.3), (A.20)); its dynamics keep the kinetic energy
``1/2 nu^T M nu`` without damping and input (C(nu) is skew-symmetric) and obey the power
balance ``T' = tau . nu - nu^T D nu`` with damping; without a compiled kernel it integrates with
numpy RK4; its parameters are checked; and the parallel and circular formations converge in a
current, the verdict recomputed from the states.
"""
from dataclasses import replace

from formation_control.core import models, parameters, scenario
from formation_control.core.control import steering_force, thrust
from formation_control.core.errors import ScenarioError
from formation_control.core.models import Plant, ROW_OMEGA, ROW_U, ROW_V, ROW_X, ROW_Y
from formation_control.core.vehicles import vehicle_model, VEHICLE_MODELS
from formation_control.core.vehicles.vessel import COEFFICIENTS, Vessel
from formation_control.sim.simulator import simulate, summary
import numpy as np
import pytest
from runs import CONFIG

VESSEL = {'model': 'vessel', 'm0': 23.8, 'I0': 1.76, 'u0': 0.6, 'num_vehicles': 5}
RIGID_NAMES = [name for name, m in VEHICLE_MODELS.items() if m.rigid]


def _plant(name, **values):
    base = VESSEL if name == 'vessel' else {'model': name, 'l1': 0.2}
    return Plant.of(parameters.Scenario(**{**base, **values}))


def _states(n, rng):
    return np.vstack([rng.normal(0.0, 5.0, (2, n)), rng.uniform(-3.0, 3.0, n),
                      rng.normal(0.0, 0.3, n), rng.uniform(0.1, 1.0, n), rng.normal(0.0, 0.2, n)])


@pytest.mark.parametrize('name', RIGID_NAMES)
def test_the_inverse_gives_the_demanded_surge_and_yaw_accelerations(name):
    """``body_accel(X, inverse(X, u', omega'))`` returns u' and omega' for every rigid model."""
    rng = np.random.default_rng(4)
    plant = _plant(name)
    X = _states(50, rng)
    du, dw = rng.normal(0.0, 0.5, 50), rng.normal(0.0, 0.5, 50)
    U = plant.model.inverse(X, du, dw, plant)
    got_du, _, got_dw = models.body_accel(X, U, plant)
    np.testing.assert_allclose(got_du, du, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(got_dw, dw, rtol=1e-12, atol=1e-13)


@pytest.mark.parametrize('name', ['rigid', 'rigid_couple', 'rigid_cop'])
def test_the_thesis_bodies_inverse_is_the_thrust_7_1_and_the_steering_force_7_3(name):
    """The model's inverse is (7.1) ``T = m0 K_f (u0 - u) + h s u - m0 v omega`` and (A.20)."""
    rng = np.random.default_rng(5)
    plant = _plant(name)
    X, a = _states(20, rng), rng.normal(0.0, 1.0, 20)
    u, v, w = X[ROW_U], X[ROW_V], X[ROW_OMEGA]
    s = np.hypot(u, v)
    np.testing.assert_allclose(thrust(X, 1.2, 0.7, plant),
                               plant.m0 * 0.7 * (1.2 - u) + plant.h * s * u - plant.m0 * v * w,
                               rtol=1e-12, atol=1e-14)
    h_dot = -plant.l1 * plant.h * s * v / plant.I0 if name == 'rigid_cop' else 0.0
    np.testing.assert_allclose(steering_force(a, X, plant), -(plant.I0 / plant.l) * (a - h_dot),
                               rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(steering_force(a, X, plant, cancel_drag_moment=False),
                               -(plant.I0 / plant.l) * a, rtol=1e-12, atol=1e-14)


def _energy(X, plant):
    m11, m22, m33 = Vessel.masses(plant)
    return 0.5 * (m11 * X[ROW_U] ** 2 + m22 * X[ROW_V] ** 2 + m33 * X[ROW_OMEGA] ** 2)


def test_kinetic_energy_is_kept_without_damping_and_input():
    """C(nu) is skew-symmetric: with D = 0 and tau = 0, ``1/2 nu^T M nu`` stays along RK4 runs."""
    plant = _plant('vessel', **{name: 0.0 for name in COEFFICIENTS if name[-4:] != 'dot'})
    X = _states(8, np.random.default_rng(6))
    before = _energy(X, plant)
    after = models.integrate(X, np.zeros((2, 8)), 0.01, 2000, plant)
    np.testing.assert_allclose(_energy(after, plant), before, rtol=1e-8)
    assert not np.allclose(after[ROW_V], X[ROW_V])               # the Munk moment did turn it


def test_the_rates_obey_the_power_balance():
    """``d/dt 1/2 nu^T M nu = tau_u u + tau_r r - nu^T D(nu) nu`` from deriv, and a step agrees."""
    rng = np.random.default_rng(7)
    plant = _plant('vessel')
    X, U = _states(30, rng), rng.normal(0.0, 2.0, (2, 30))
    dX = models.deriv(X, U, plant)
    m11, m22, m33 = Vessel.masses(plant)
    power = m11 * X[ROW_U] * dX[ROW_U] + m22 * X[ROW_V] * dX[ROW_V] + \
        m33 * X[ROW_OMEGA] * dX[ROW_OMEGA]
    du, dv, dr = Vessel.damping(X, plant)
    expected = U[0] * X[ROW_U] + U[1] * X[ROW_OMEGA] - (
        du * X[ROW_U] + dv * X[ROW_V] + dr * X[ROW_OMEGA])
    np.testing.assert_allclose(power, expected, rtol=1e-10, atol=1e-12)
    dt = 1e-4
    step = (_energy(models.rk4_step(X, U, dt, plant), plant) - _energy(X, plant)) / dt
    np.testing.assert_allclose(step, expected, rtol=1e-3, atol=1e-6)


def test_a_model_without_a_kernel_integrates_with_numpy_rk4_and_moves_with_the_current():
    """The vessel's ``integrate`` is ``rk4_step`` repeated; the current adds to its track."""
    plant = _plant('vessel', flow=(0.1, -0.05))
    assert plant.model.kernel is None and plant.coeffs['Y_vv'] == -36.2823
    X, U = _states(6, np.random.default_rng(8)), np.full((2, 6), 0.3)
    want = X
    for _ in range(5):
        want = models.rk4_step(want, U, 0.02, plant)
    assert np.array_equal(models.integrate(X, U, 0.02, 5, plant), want)
    still = models.integrate(X, U, 0.02, 5, replace(plant, flow=_plant('vessel').flow))
    np.testing.assert_allclose(want[ROW_X] - still[ROW_X], 0.1 * 0.1, rtol=1e-9)
    np.testing.assert_allclose(want[ROW_Y] - still[ROW_Y], -0.05 * 0.1, rtol=1e-9)
    np.testing.assert_allclose(want[ROW_U:], still[ROW_U:], rtol=1e-12)


def test_the_registry_declares_every_parameter_a_model_reads():
    """Each model's params are scenario parameters; the table's ranges apply to their readers."""
    for model in VEHICLE_MODELS.values():
        assert set(model.params) <= set(parameters.PARAMETERS), model.name
        assert vehicle_model(model.name) is model
    for name in COEFFICIENTS:
        assert parameters.PARAMETERS[name].models == ('vessel',)
    assert 'vessel' in parameters.PARAMETERS['m0'].models
    assert 'vessel' not in parameters.PARAMETERS['h'].models
    with pytest.raises(ValueError, match="model 'boat' is not one of first_order, "):
        vehicle_model('boat')


@pytest.mark.parametrize('name, value', [('X_u', 0.5), ('Y_vv', 1.0), ('N_rdot', 0.1)])
def test_a_positive_hydrodynamic_derivative_is_refused(name, value):
    """The derivatives are <= 0 (damping dissipates, added mass adds): a sign slip is named."""
    with pytest.raises(ScenarioError, match=rf"parameter '{name}' = {value} is invalid: "
                                            rf'must be <= 0'):
        scenario.resolve({**VESSEL, name: value})
    with pytest.raises(ScenarioError, match=rf"parameter '{name}' = {value} is invalid: not "
                                            r'read by this run: it applies to model vessel '
                                            r"only \(model is 'rigid'\)"):
        scenario.resolve({'model': 'rigid', name: value})         # not read: refused as such


def _course_centres(run):
    """Return the circle centres ``r + i e^{i psi} / omega0`` of the last state (psi: course)."""
    sc, X = run.sc, run.X[-1]
    ground = models.ground_velocity(X, complex(*sc.flow))
    return X[ROW_X] + 1j * X[ROW_Y] + 1j * ground / abs(ground) / sc.omega0


@pytest.mark.slow
@pytest.mark.parametrize('seed', [3, 11])
def test_the_circular_formation_converges_in_a_current(seed):
    """Five vessels in a 0.05 m/s current share one circle of radius 1/omega0 = 4 m."""
    run = simulate(scenario.load(CONFIG / 'vessel_circular.yaml', seed=seed))
    c = _course_centres(run)
    spread = np.max(abs(c - c.mean()))
    radius = np.mean(abs(run.X[-1][ROW_X] + 1j * run.X[-1][ROW_Y] - c.mean()))
    assert spread < 0.2 and abs(radius * run.sc.omega0 - 1.0) < 0.05, (spread, radius)
    assert summary(run)['converged']
    assert np.all(run.X[-1][ROW_V] < -0.1)                        # they turn crabbing outward


@pytest.mark.parametrize('seed', [3, 11])
def test_the_parallel_formation_converges_in_a_current(seed):
    """Five vessels in a current sail one course: order parameter 1, no turning, no sideslip."""
    run = simulate(scenario.load(CONFIG / 'vessel_parallel.yaml', seed=seed, duration=120.0))
    X = run.X[-1]
    ground = models.ground_velocity(X, complex(*run.sc.flow))
    order = abs(np.mean(ground / abs(ground)))
    assert order > 0.999 and np.max(abs(X[ROW_OMEGA])) < 1e-3, (order, X[ROW_OMEGA])
    np.testing.assert_allclose(X[ROW_U], run.sc.u0, rtol=1e-4)
    assert np.max(abs(X[ROW_V])) < 1e-3
    assert summary(run)['converged']
