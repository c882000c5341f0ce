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
Flowfields in the plant, and vehicles that estimate the flow instead of being told it.

The flowfield models against their formulas; each vehicle integrated in the flow at its own
place and time (closed-form trajectories); the estimator's error following ``exp(-lambda_f t)``
along a closed-loop run (the cascade of docs/errata.md), the observer and consensus variants;
the bound on the formation error in a slowly turning flow; the measured robustness in shear
and vortex fields (docs/laws.md, "Flowfields"); bad inputs.
"""
from dataclasses import replace

from formation_control.core import estimation, flowfields, models, scenario
from formation_control.core.control import Controller
from formation_control.sim import metrics, simulator
import numpy as np
import pytest
from runs import CONFIG, run_of, SOURCES

ESTIMATED = SOURCES['estimated']


def _sc(**values):
    return scenario.resolve(values)


# --- flowfields -------------------------------------------------------------------------------

def test_flow_models_follow_their_formulas():
    x, y = np.array([0.0, 1.0, 3.0, -7.0]), np.array([0.0, 2.0, -9.0, 1.0])
    uniform = flowfields.Flowfield(_sc(flow=[0.3, -0.1]))
    np.testing.assert_array_equal(uniform(5.0, x, y), 0.3 - 0.1j)
    turning = flowfields.Flowfield(_sc(flow=[0.1, 0.0], flow_model='time_varying',
                                       flow_amplitude=0.2, flow_period=40.0))
    np.testing.assert_allclose(turning(10.0, x, y), 0.1 + 0.2j, atol=1e-15)     # a quarter turn
    assert turning.max_speed == pytest.approx(0.3)
    assert turning.max_rate() == pytest.approx(0.2 * 2 * np.pi / 40)
    shear = flowfields.Flowfield(_sc(flow_model='shear', flow_shear=0.05, flow_shear_width=5.0))
    np.testing.assert_allclose(shear(0.0, x, y), 0.05 * np.array([0.0, 2.0, -5.0, 1.0]))
    assert shear.max_speed == pytest.approx(0.25)


def test_rankine_vortex_turns_rigidly_inside_and_decays_outside():
    field = flowfields.Flowfield(_sc(flow_model='vortex', flow_circulation=2.0, flow_radius=2.0,
                                     flow_center=[1.0, -1.0]))
    rho = np.array([0.5, 2.0, 4.0, 8.0])
    f = field(0.0, 1.0 + rho, np.full(4, -1.0))                  # along +x from the centre
    np.testing.assert_allclose(f.real, 0.0, atol=1e-16)           # tangential: +y, CCW
    expected = np.where(rho < 2.0, 2.0 * rho / (2 * np.pi * 4.0), 2.0 / (2 * np.pi * rho))
    np.testing.assert_allclose(f.imag, expected)
    assert field.max_speed == pytest.approx(2.0 / (2 * np.pi * 2.0))


@pytest.mark.parametrize('suffix', ['.npz', '.csv'])
def test_grid_is_interpolated_bilinearly_and_held_at_its_border(tmp_path, suffix):
    gx, gy = np.array([-5.0, 0.0, 10.0]), np.array([-4.0, 4.0])
    X, Y = np.meshgrid(gx, gy)
    fx, fy = 0.01 * X - 0.02 * Y + 0.1, 0.03 * X * Y / 40
    path = tmp_path / f'grid{suffix}'
    if suffix == '.npz':
        np.savez(path, x=gx, y=gy, fx=fx, fy=fy)
    else:
        rows = np.column_stack([X.ravel(), Y.ravel(), fx.ravel(), fy.ravel()])[::-1]
        np.savetxt(path, rows, delimiter=',', header='x,y,fx,fy', comments='')
    field = flowfields.Flowfield(_sc(flow_model='grid', flow_grid_file=str(path)))
    px, py = np.array([-2.5, 7.0, 20.0]), np.array([1.0, -3.0, 9.0])
    cx, cy = np.clip(px, -5, 10), np.clip(py, -4, 4)
    expected = 0.01 * cx - 0.02 * cy + 0.1 + 1j * 0.03 * cx * cy / 40   # bilinear: exact
    np.testing.assert_allclose(field(0.0, px, py), expected, atol=1e-15)


def test_each_vehicle_is_integrated_in_the_flow_at_its_own_time_and_place():
    """Straight-running particles: r(t) in closed form in a turning flow and in a shear."""
    sc = _sc(model='first_order', controller='first_order', flow=[0.1, 0.0],
             flow_model='time_varying', flow_amplitude=0.3, flow_period=20.0)
    X0 = np.zeros((6, 2))
    X0[models.ROW_THETA] = [0.0, 1.0]
    X0[models.ROW_U] = 1.0
    plant = models.Plant.of(sc)
    t0, t1 = 3.0, 8.0
    X = models.integrate(X0, np.zeros((2, 2)), 0.01, 500, plant, t0)
    w = 2 * np.pi / 20.0
    drift = 0.1 * (t1 - t0) + 0.3 * (np.exp(1j * w * t1) - np.exp(1j * w * t0)) / (1j * w)
    np.testing.assert_allclose(models.position(X), (t1 - t0) * np.exp(1j * X0[2]) + drift,
                               atol=1e-9)
    shear = models.Plant.of(_sc(model='first_order', controller='first_order',
                                flow_model='shear', flow_shear=0.1, flow_shear_width=9.0))
    X0[models.ROW_THETA] = np.pi / 2
    X0[models.ROW_Y] = [0.0, 4.0]
    X = models.integrate(X0, np.zeros((2, 2)), 0.01, 500, shear)
    np.testing.assert_allclose(X[models.ROW_X], 0.1 * (X0[1] * 5.0 + 12.5), atol=1e-9)


# --- the estimator: uniform flows, the cascade --------------------------------------------------

@pytest.mark.parametrize('name', ['particle_parallel_flow', 'rigid_parallel_flow'])
def test_estimate_error_decays_as_exp_minus_lambda_t_along_the_closed_loop(name):
    """
    Cascade: e = fhat - f obeys e' = -lambda_f e whatever the control does (errata).

    The exact discretisation gives e_n = -f e^{-lambda_f (n + 1) dt} at step n; after 30 s the
    error is far below 1e-3 m/s with the default gain lambda_f = 1 1/s.
    """
    run = run_of(name, 1, ESTIMATED)
    sc = run.sc
    err = abs(run.flow_hat - sc.flow_c)
    predicted = abs(sc.flow_c) * np.exp(-sc.flow_gain * (run.t + sc.dt_control))
    np.testing.assert_allclose(err, np.broadcast_to(predicted[:, None], err.shape),
                               rtol=1e-9, atol=1e-14)
    assert np.max(err[-1]) < 1e-3 and run.t[-1] <= 30.0        # by 30 s, already by 20 s
    assert np.max(err[0]) > 0.1                                   # it did have to learn it


@pytest.mark.slow
def test_observer_from_the_position_only_learns_a_uniform_flow():
    """The position-only observer: error poles e^{s dt}, s^2 + l1 s + l2 = 0 (l1 = 2, l2 = 1)."""
    run = run_of('particle_parallel_flow', 1, ESTIMATED + ('flow_estimator:=observer',))
    err = np.max(abs(run.flow_hat - run.sc.flow_c), axis=1)
    assert err[-1] < 1e-3 and run.t[-1] == pytest.approx(30.0)
    # (1 + t) e^{-t} of the double pole s = -1: past 10 s the error shrinks ~ e^{-t} per second
    late = (run.t >= 10.0) & (run.t <= 20.0)
    rate = -np.polyfit(run.t[late], np.log(err[late] / (1 + run.t[late])), 1)[0]
    assert rate == pytest.approx(1.0, abs=0.05)
    ctrl = Controller(run.sc)
    assert abs(ctrl.view(run.X[-1], run.U[-1][1]).e.mean()) > 0.999


def test_observer_gains_place_the_poles_of_the_continuous_observer():
    dt, l1, l2 = 0.02, 3.0, 2.0                                   # s = -1, -2
    k1, k2 = estimation.observer_gains(l1, l2, dt)
    M = np.array([[1 - k1, (1 - k1) * dt], [-k2, 1 - k2 * dt]])
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(M).real), np.exp([-2 * dt, -dt]),
                               rtol=1e-12)


def test_consensus_pulls_the_estimates_of_a_shear_together():
    """Neighbours' estimates averaged: in a shear each vehicle's estimate nears the fleet's."""
    overrides = ['flow_model:=shear', 'flow_shear:=0.05', 'flow_source:=estimated',
                 'duration:=5.0', 'formation:=parallel', 'K:=-1.0']
    alone = simulator.simulate(scenario.load(CONFIG / 'particle_circular.yaml', overrides))
    shared = simulator.simulate(scenario.load(CONFIG / 'particle_circular.yaml',
                                              overrides + ['flow_consensus:=5.0']))
    spread = [np.ptp(r.flow_hat[-1].real) for r in (alone, shared)]
    assert spread[1] < 0.3 * spread[0]


def test_the_estimate_is_clamped_below_the_vehicle_speed():
    sc = _sc(flow_source='estimated')
    est = estimation.FlowEstimator(sc, 2)
    X = np.zeros((6, 2))
    X[models.ROW_U] = 1.0
    for _ in range(500):
        fhat = est.update(X, np.array([3.0 + 0j, 2.5 + 0.5j]))        # a faulty sensor
    np.testing.assert_allclose(abs(fhat), estimation.CLAMP)


# --- every thesis flow scenario converges on estimates: test_convergence.py, test_rigid.py ------

def test_run_record_holds_the_estimates(tmp_path):
    run = run_of('particle_parallel_flow', 1, ESTIMATED)
    run.save(tmp_path / 'run.npz')
    with np.load(tmp_path / 'run.npz') as d:
        assert d['flow_hat_x'].shape == d['x'].shape == (run.t.size, run.sc.num_vehicles)
    back = simulator.load_run(tmp_path / 'run.npz')
    np.testing.assert_array_equal(back.flow_hat, run.flow_hat)


# --- a slowly turning flow: the bound from the estimator bandwidth -----------------------------

def turning_flow_run(seed, source='estimated', run=True):
    """Return 6 particles in f = [0.3, 0] + 0.2 e^{i 2 pi t / 60} m/s, 150 s: (sc, run), or sc."""
    sc = scenario.load(CONFIG / 'particle_circular_flow.yaml',
                       ['flow_model:=time_varying', 'flow_amplitude:=0.2', 'flow_period:=60.0',
                        'flow:=[0.3, 0.0]', 'num_vehicles:=6', *SOURCES[source]], seed=seed,
                       duration=150.0)
    return (sc, simulator.simulate(sc)) if run else sc


def true_centres(sc, run, since):
    """Return the true circle centres (T, N), or (T, B, N), of the samples from ``since`` on."""
    ctrl = Controller(sc)
    late = run.t >= since
    return np.array([ctrl.formation.centres(ctrl.view(X, U[1], ctrl.plant.flow(t, X[0], X[1])))
                     for t, X, U in zip(run.t[late], run.X[late], run.U[late])])


TURNING_LOOP = {'known': (0.17, 0.20), 'estimated': (0.32, 0.36)}
"""Regression figures (measured, seeds 1-3): the common centre's loop max |mean c - its mean|
(m) over 90-150 s in the turning flow, of laws that take the flow as steady: the estimating
one, and (before issue 28, item 4) the known one. The known one now takes df/dt: 1.4 mm."""
KNOWN_LOOP = 0.01
"""The issue's target (m): a known turning flow keeps the circle's centre within 1 cm."""


@pytest.mark.slow
@pytest.mark.parametrize('seed', [1, 2, 3])
def test_turning_flow_keeps_the_true_circle_within_the_estimator_lag_bound(seed):
    """
    In f = f0 + A e^{i w t} the estimation error settles at |e| = A w / sqrt(lambda_f^2 + w^2).

    Each vehicle's believed course gamma_hat = arg(e^{i theta} + fhat) is then within
    delta = asin(|e| / (1 - max|f| - |e|)) of its true course, so its believed centre is within
    delta / |omega0| of its true one (errata, "Flow estimation"). The law gathers the believed
    centres (to SPREAD_TOL), so the true centres lie within ``SPREAD_TOL + delta / |omega0|``
    of their mean: a closed-loop property of the true circle. A controller that ignores its
    estimate (f = 0) spreads them by 0.36 m and drifts 9 m, and fails.
    """
    sc, run = turning_flow_run(seed)
    ctrl, w = Controller(sc), 2 * np.pi / sc.flow_period
    e_bound = sc.flow_amplitude * w / np.hypot(sc.flow_gain, w)
    delta = np.arcsin(e_bound / (1 - 0.5 - e_bound)) / abs(sc.omega0)
    c = true_centres(sc, run, 90.0)
    spread = np.max(abs(c - c.mean(axis=1, keepdims=True)))
    assert spread <= metrics.SPREAD_TOL + 2 * delta
    radius = np.mean(abs(run.X[-1][0] + 1j * run.X[-1][1] - c[-1].mean()))
    assert radius == pytest.approx(1 / abs(sc.omega0), rel=0.1)
    loop = np.max(abs(c.mean(axis=1) - c.mean()))
    low, high = TURNING_LOOP['estimated']
    assert low <= loop <= high
    settled = run.t >= 60.0
    true_flow = np.array([ctrl.plant.flow(t, X[0], X[1]) for t, X in zip(run.t, run.X)])
    err = abs(run.flow_hat - true_flow)[settled]
    assert np.max(err) <= e_bound * 1.001 and np.max(err) > 0.9 * e_bound


@pytest.mark.slow
def test_a_known_turning_flow_keeps_the_circle_centre_within_a_centimetre():
    """With df/dt in the laws the centre's loop is 1.4 mm from seeds 1-3 (0.17-0.20 m without)."""
    sc = turning_flow_run(1, 'known', run=False)
    run = simulator.simulate(sc, simulator.initial_states(sc, [1, 2, 3]))
    late = run.t >= 90.0
    c = np.moveaxis(true_centres(sc, run, 90.0), 0, -2)              # (B, T, N)
    assert c.shape == (3, np.count_nonzero(late), sc.num_vehicles)
    assert np.max(abs(c - c.mean(axis=-1, keepdims=True))) <= metrics.SPREAD_TOL
    loop = np.max(abs(c.mean(axis=-1) - c.mean(axis=(-1, -2))[:, None]), axis=-1)
    assert np.all(loop <= KNOWN_LOOP)


# --- bad inputs -------------------------------------------------------------------------------

@pytest.mark.parametrize('values, message', [
    ({'flow_model': 'eddies'}, r"'flow_model' = 'eddies' is invalid: allowed values: uniform"),
    ({'flow_source': 'guessed'}, r"'flow_source' = 'guessed' is invalid: allowed values: known"),
    ({'flow_model': 'grid', 'flow_grid_file': '/no/such/grid.npz'},
     r"'flow_grid_file' = '/no/such/grid.npz' is invalid: no such file"),
    ({'flow_model': 'vortex', 'flow_circulation': 13.0},
     r"'flow_model' = 'vortex' is invalid: unit-speed particles need the vortex flow reaches "
     r'1.03 m/s: max \|f\| < 1'),
    ({'flow_model': 'time_varying', 'flow': [0.5, 0.0], 'flow_amplitude': 0.6},
     r"'flow_model' = 'time_varying' is invalid: unit-speed particles need .* < 1 m/s"),
    ({'model': 'rigid', 'flow_model': 'shear', 'flow_shear': 0.3, 'flow_shear_width': 5.0},
     r"'flow_model' = 'shear' is invalid: rigid bodies need .* < u0 = 1.0 m/s"),
    ({'flow_gain': -1.0}, r"'flow_gain' = -1.0 is invalid: must be > 0"),
    ({'flow_observer_l1': 0.0}, r"'flow_observer_l1' = 0.0 is invalid: must be > 0"),
    ({'flow_observer_l2': -2.0}, r"'flow_observer_l2' = -2.0 is invalid: must be > 0"),
    ({'flow_consensus': -0.5}, r"'flow_consensus' = -0.5 is invalid: must be >= 0"),
    ({'flow_amplitude': -0.1}, r"'flow_amplitude' = -0.1 is invalid: must be >= 0"),
    ({'flow_period': 0.0}, r"'flow_period' = 0.0 is invalid: must be > 0"),
    ({'flow_radius': 0.0}, r"'flow_radius' = 0.0 is invalid: must be > 0"),
    ({'flow_center': [1.0]}, r"'flow_center' = \[1.0\] is invalid: must be a list of 2"),
    ({'pattern': 'splay', 'formation': 'circular', 'flow_model': 'shear', 'flow_shear': 0.01},
     'in a flow no fixed phase pattern'),
])
def test_bad_flow_parameters_are_refused(values, message):
    with pytest.raises(scenario.ScenarioError, match=message):
        scenario.resolve(values)


@pytest.mark.parametrize('content, message', [
    ({'x': [0.0, 1.0], 'y': [0.0, 1.0], 'fx': [[0.0, np.nan], [0.0, 0.0]],
      'fy': np.zeros((2, 2))}, 'NaN or inf'),
    ({'x': [0.0, 1.0], 'y': [0.0, 1.0], 'fx': np.zeros((3, 2)), 'fy': np.zeros((3, 2))},
     r'fx, fy \(ny, nx\) expected'),
    ({'x': [1.0, 0.0], 'y': [0.0, 1.0], 'fx': np.zeros((2, 2)), 'fy': np.zeros((2, 2))},
     'strictly increasing'),
    ({'x': [0.0, 1.0], 'y': [0.0, 1.0], 'fx': np.zeros((2, 2))}, 'cannot read the grid'),
    ({'x': [0.0, 1.0], 'y': [0.0, 1.0], 'fx': np.full((2, 2), 1.5), 'fy': np.zeros((2, 2))},
     r'the grid flow reaches 1.5 m/s'),
])
def test_bad_grid_files_are_refused(tmp_path, content, message):
    path = tmp_path / 'grid.npz'
    np.savez(path, **content)
    with pytest.raises(scenario.ScenarioError, match=message):
        scenario.resolve({'flow_model': 'grid', 'flow_grid_file': str(path)})


def test_controller_refuses_to_guess_a_flow_that_is_not_uniform():
    ctrl = Controller(_sc(flow_model='shear', flow_shear=0.01))
    with pytest.raises(ValueError, match="the shear flow is not uniform: give each vehicle's"):
        ctrl.view(np.zeros((6, 2)))


# --- robustness in shear and vortex fields (docs/laws.md, "Flowfields") --------------------------

FIELDS = {
    'shear': ('flow_model:=shear', 'flow_shear:=0.05', 'flow_shear_width:=5.0'),
    'vortex': ('flow_model:=vortex', 'flow_circulation:=1.0', 'flow_radius:=2.0',
               'flow_center:=[3.0, 0.0]'),
}
ROBUSTNESS_SEEDS = range(101, 106)
ROBUSTNESS = {
    # Regression figures, not derived bounds: the (lowest, highest) over seeds 101-105 of the
    # centre spread (m), centre drift (m/s), true course-rate error |gamma' - omega0 s| (rad/s)
    # and speed error |u - u0| (m/s), over the last 20 s of 100 s (README, "Shear and vortex").
    # Known flows: the particles' laws take grad f (issue 28; before, spread 0.045-0.056 m in
    # the shear, 0.013-0.04 m in the vortex); a vortex whose core rim the circle crosses kicks
    # the course rate (f' jumps there) and leaves a few mm. The rigid bodies' practical law
    # drops every rate, the flow's too (errata).
    ('particle_circular', 'shear', 'known'):
        ((3.6e-05, 4.2e-05), (1.9e-06, 1.9e-05), (4.4e-05, 6.3e-05), (0.0, 0.0)),
    ('particle_circular', 'shear', 'estimated'):
        ((0.047, 0.059), (0.00025, 0.0016), (0.073, 0.082), (0.0, 0.0)),
    ('particle_circular', 'vortex', 'known'):
        ((2.7e-05, 0.0084), (8.4e-06, 0.0033), (5.2e-05, 0.077), (0.0, 0.0)),
    ('particle_circular', 'vortex', 'estimated'):
        ((0.028, 0.046), (0.00017, 0.0059), (0.043, 0.084), (0.0, 0.0)),
    ('rigid_circular', 'shear', 'known'):
        ((0.053, 0.066), (0.00087, 0.015), (0.0, 0.0), (4.5e-05, 5.4e-05)),
    ('rigid_circular', 'shear', 'estimated'):
        ((0.074, 0.086), (0.001, 0.019), (0.0, 0.0), (3.1e-05, 4.8e-05)),
    ('rigid_circular', 'vortex', 'known'):
        ((0.026, 0.041), (0.02, 0.027), (0.0, 0.0), (2.4e-05, 3.7e-05)),
    ('rigid_circular', 'vortex', 'estimated'):
        ((0.029, 0.05), (0.02, 0.026), (0.0, 0.0), (2.5e-05, 3.5e-05)),
}
ENVELOPE_MARGIN = 1.1
"""The envelopes are rounded to 2 digits: a figure may lie this factor outside them."""


def robustness(name, field, source, seconds=20.0):
    """
    Return the measured figures of ROBUSTNESS of each seed: one batch of 100 s runs.

    A batch of fleets runs each fleet as it would run alone (:func:`simulator.simulate`). The
    figures are of the true flow and the true course rate (the view of a known flow).
    """
    sc = scenario.load(CONFIG / f'{name}.yaml', [*FIELDS[field], *SOURCES[source]],
                       seed=ROBUSTNESS_SEEDS[0], duration=100.0)
    run = simulator.simulate(sc, simulator.initial_states(sc, ROBUSTNESS_SEEDS))
    truth = Controller(replace(sc, flow_source='known'))
    late = run.t >= run.t[-1] - seconds
    centres, spread, rate, speed = [], 0.0, 0.0, 0.0
    for t, X, U in zip(run.t[late], run.X[late], run.U[late]):
        view = truth.view(X, U[1], truth.plant.flow(t, X[0], X[1]))       # (B, N) each
        c = truth.formation.centres(view)
        centres.append(c.mean(axis=-1))
        spread = np.maximum(spread, np.max(abs(c - c.mean(axis=-1, keepdims=True)), axis=-1))
        if not truth.rigid:
            rate = np.maximum(rate, np.max(abs(view.rate - sc.omega0 * view.speed), axis=-1))
        else:
            speed = np.maximum(speed, np.mean(abs(X[models.ROW_U] - sc.u0), axis=-1))
    drift = abs(centres[-1] - centres[0]) / seconds
    return [tuple(np.broadcast_to(v, drift.shape)[b] for v in (spread, drift, rate, speed))
            for b in range(drift.size)]


@pytest.mark.slow
@pytest.mark.parametrize('name, field, source', list(ROBUSTNESS))
def test_robustness_in_shear_and_vortex_fields(name, field, source):
    """
    The laws in a flow that is not uniform: the table of docs/laws.md.

    From every seed the circle holds together to under 10 cm and the steady turn is kept to
    under 0.1 rad/s; each figure stays within its multi-seed envelope (a regression figure,
    not a bound: the drift of an estimating rigid fleet in shear ranges 0.001-0.019 m/s).
    With the flow known, the particles' laws take its gradient (issue 28): their circle
    holds to a centimetre from every seed.
    """
    for measured in robustness(name, field, source):
        spread, _, rate, speed = measured
        assert spread < 0.1 and rate < 0.1 and speed < 1e-4
        if name == 'particle_circular' and source == 'known':
            assert spread < metrics.SPREAD_TOL
        for value, (low, high) in zip(measured, ROBUSTNESS[name, field, source]):
            assert low / ENVELOPE_MARGIN <= value <= high * ENVELOPE_MARGIN


def test_pairing_matches_odometry_and_second_sensor_by_stamp_in_either_order():
    from formation_control.protocol.onboard import Pairing
    pairs = Pairing()
    assert pairs.add_odometry(10, 'odom 10') is None
    assert pairs.add_other(10, 'dvl 10') == (10, 'odom 10', 'dvl 10')
    assert pairs.add_other(20, 'dvl 20') is None                     # the sensor first
    assert pairs.add_odometry(30, 'odom 30') is None                 # a lost dvl 30 ...
    assert pairs.add_other(40, 'dvl 40') is None
    assert pairs.add_odometry(40, 'odom 40') == (40, 'odom 40', 'dvl 40')   # ... is skipped
    assert pairs.add_odometry(40, 'odom 40') == (40, 'odom 40', 'dvl 40')   # asked again
