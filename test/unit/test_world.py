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
The world a real fleet meets (core/world.py): model mismatch, actuators, gusts.

Off, the plant is the nominal model, and unit factors integrate it to rounding; the draws are
per vehicle and seeded; the controllers keep the nominal values; the steady speed under drag
and thrust mismatch and the actuator-lag limit derived in docs/errata.md hold in simulation
over a census of seeds; the actuators lag and rate-limit as asked; the gust has the intensity
and correlation asked, is recorded, and the metrics read the course flown in it; the PI law's
anti-windup; bad input refused naming the parameter.
"""
from dataclasses import replace

from formation_control.core import formations, scenario, world
from formation_control.core.control import Controller
from formation_control.core.errors import ScenarioError
from formation_control.core.models import ROW_U, ROW_V
from formation_control.core.steering import LAWS
from formation_control.protocol.fleet import FleetPlant
from formation_control.sim import backends, metrics, simulator
import numpy as np
import pytest
from runs import CONFIG


def _rigid(**values):
    return scenario.load(CONFIG / 'rigid_parallel.yaml', **values)


def test_the_world_is_off_by_default_and_unit_factors_are_the_nominal_plant():
    """The world takes its RK4 steps one by one (deriv), the nominal plant a period at a time."""
    sc = _rigid(duration=2.0)
    assert not world.active(sc) and type(simulator.Stepper(sc).backend) is backends.Native
    ones = _rigid(duration=2.0, mismatch_m0=[1.0] * sc.num_vehicles)
    assert world.active(ones) and type(simulator.Stepper(ones).backend) is backends.NativeInWorld
    np.testing.assert_allclose(simulator.simulate(ones).X, simulator.simulate(sc).X,
                               rtol=0, atol=1e-12)


def test_mismatch_is_drawn_per_vehicle_and_seed_and_the_controller_keeps_the_nominal():
    sc = _rigid(mismatch=0.2, num_vehicles=6)
    f = world.mismatch_factors(sc)
    for name in world.MISMATCH_NAMES:
        assert np.all(abs(f[name] - 1.0) <= 0.2) and np.ptp(f[name]) > 0.05
    bigger = world.mismatch_factors(_rigid(mismatch=0.2, num_vehicles=9))
    np.testing.assert_array_equal(bigger['h'][:6], f['h'])          # a vehicle's own stream
    other = world.mismatch_factors(_rigid(mismatch=0.2, num_vehicles=6, world_seed=1))
    assert not np.allclose(other['h'], f['h'])
    given = world.mismatch_factors(_rigid(mismatch=0.2, num_vehicles=6,
                                          mismatch_h=[2.0] * 6))
    np.testing.assert_array_equal(given['h'], 2.0)
    np.testing.assert_array_equal(given['m0'], f['m0'])
    stepper = simulator.Stepper(sc)
    np.testing.assert_allclose(stepper.backend.world.plant.h, sc.h * f['h'])
    assert Controller(sc).plant.h == sc.h and Controller(sc).plant.m0 == sc.m0


def test_a_batch_of_fleets_draws_as_each_fleet_alone():
    sc = _rigid(mismatch=0.02, gust_intensity=0.05, actuator_lag=0.05, duration=1.0)
    seeds = [3, 4]
    batch = simulator.simulate(sc, simulator.initial_states(sc, seeds), seeds=seeds)
    for b, seed in enumerate(seeds):
        alone = simulator.simulate(scenario.load(CONFIG / 'rigid_parallel.yaml', mismatch=0.02,
                                                 gust_intensity=0.05, actuator_lag=0.05,
                                                 duration=1.0, seed=seed))
        np.testing.assert_allclose(batch.X[:, :, b], alone.X, rtol=0, atol=1e-12)


@pytest.mark.parametrize('seed', range(1, 7))
def test_the_steady_speed_under_drag_and_thrust_mismatch_is_the_derived_root(seed):
    """
    Straight motion (parallel, no flow) over a census of seeds: each vehicle's speed.

    With the plain hold: the midpoint prediction, made with the nominal model, moves the root
    by O(dt_control) (docs/errata.md, "Model mismatch").
    """
    sc = _rigid(seed=seed, world_seed=seed, duration=25.0, mismatch=0.025,
                hold_prediction='none')
    f = world.mismatch_factors(sc)
    predicted = world.steady_speed(sc, f['thrust'], f['h'])
    assert np.all(np.isfinite(predicted)) and np.ptp(predicted) > 0.01
    X = simulator.simulate(sc).X[-1]
    assert np.max(abs(X[ROW_V])) < 1e-3
    np.testing.assert_allclose(X[ROW_U], predicted, rtol=0, atol=2e-3)


@pytest.mark.slow
def test_past_the_derived_limit_the_speed_runs_away():
    sc = _rigid(duration=30.0)
    c = sc.m0 * sc.K_f                                     # f_T = 1: d = h - h_true
    for margin, bounded in ((0.9, True), (1.2, False)):
        h_true = (sc.h - margin * c / (4 * sc.u0)) / sc.h
        run = _rigid(duration=30.0, mismatch_h=[h_true] * sc.num_vehicles,
                     hold_prediction='none')
        predicted = world.steady_speed(sc, np.ones(1), np.full(1, h_true))[0]
        u = simulator.simulate(run).X[-1, ROW_U]
        if bounded:
            np.testing.assert_allclose(u, predicted, atol=5e-3)
        else:
            assert np.isnan(predicted) and np.all(u > 3 * sc.u0)


def test_the_actuator_lags_and_its_rate_is_limited():
    sc = _rigid(actuator_lag=0.2, max_thrust_rate=20.0, num_vehicles=1)
    w = world.World(sc, (1,))
    w.actuate(np.zeros((2, 1)))
    steps = np.arange(1, 201)
    out = np.array([w.actuate(np.array([[5.0], [1.0]]))[:, 0].copy() for _ in steps])
    t = steps * sc.dt_integration
    np.testing.assert_allclose(out[:, 1], 1.0 - np.exp(-t / 0.2), atol=1e-12)   # the lag
    rate = np.diff(out[:, 0], prepend=0.0) / sc.dt_integration
    np.testing.assert_allclose(rate[:8], 20.0)              # the rate limit binds at first,
    assert np.all(rate <= 20.0 + 1e-9) and rate[-1] < 10.0  # then the lag
    np.testing.assert_allclose(rate[-1], (5.0 - out[-2, 0]) * (1 - np.exp(-0.025)) / 0.005)


def _misalignment(sc):
    e = np.exp(1j * simulator.simulate(sc).X[:, 2])
    return 1.0 - abs(e.mean(axis=1))


@pytest.mark.slow
def test_a_lag_below_the_limit_settles_and_past_it_the_phases_keep_oscillating():
    """
    Particles (second order, kappa = 2, K = -1): the Routh limit 1/kappa + 1/|K| = 1.5 s.

    At 0.8 of it the formation is reached; at 1.2 it never settles. The sampled hold adds
    delay, so the true limit lies a little below the continuous one (measured: 0.95 of it
    already leaves a limit cycle), which is why half of it is warned about.
    """
    sc = scenario.load(CONFIG / 'particle_parallel.yaml', duration=80.0, kappa=2.0,
                       num_vehicles=4)
    limit = LAWS['backstepping'].lag_limit(2.0, 1.0)
    below = _misalignment(replace(sc, actuator_lag=0.8 * limit))
    past = _misalignment(replace(sc, actuator_lag=1.2 * limit))
    assert below[-1] < 1e-3 and below[-1] < 0.1 * below[len(below) // 4]
    assert past[-200:].min() > 0.05
    with pytest.raises(ScenarioError, match="'actuator_lag'"):
        scenario.load(CONFIG / 'particle_parallel.yaml', kappa=2.0, actuator_lag=limit)
    warned = scenario.load(CONFIG / 'particle_parallel.yaml', kappa=2.0, actuator_lag=0.8 * limit)
    assert any('actuator_lag' in w for w in warned.warnings)
    assert scenario.load(CONFIG / 'particle_parallel.yaml', kappa=2.0,
                         actuator_lag=0.4 * limit).warnings == ()


def _centre_spread(sc):
    """Return the largest distance of a circle centre from the mean one (m), per sample."""
    X = simulator.simulate(sc).X
    c = X[:, 0] + 1j * X[:, 1] + 1j * np.exp(1j * X[:, 2]) / sc.omega0        # (1.14)
    return abs(c - c.mean(axis=1, keepdims=True)).max(axis=1)


@pytest.mark.slow
@pytest.mark.parametrize('values', [
    {'num_vehicles': 6, 'kappa': 3.0, 'K': 0.5, 'duration': 100.0},
    {'num_vehicles': 5, 'kappa': 4.0, 'K': 0.8, 'omega0': 0.5, 'duration': 120.0},
])
def test_the_circle_settles_below_its_centre_loops_lag_limit_and_not_past_it(values):
    """
    The circle's centre loop, not the steering loop, bounds the lag (docs/errata.md).

    particle_circular (seed 7): the centre loop's limit (1.06 s, 0.65 s) lies far below the
    steering loop's 1/kappa + 1/K (2.33 s, 1.5 s). At 0.8 of it the centres meet from these
    starts (spread from the recorded states; the limit is local: some starts keep a limit
    cycle there, errata); at 1.2 they stay metres apart. A lag of 1.2 of it is refused at
    start-up, 0.8 warned about, 0.4 accepted in silence.
    """
    sc = scenario.load(CONFIG / 'particle_circular.yaml', seed=7, **values)
    limit, loop = formations.of(sc).lag_limit(sc)
    assert 'centre loop' in loop and limit < 0.5 * (1 / sc.kappa + 1 / sc.K)
    below = _centre_spread(replace(sc, actuator_lag=0.8 * limit))
    past = _centre_spread(replace(sc, actuator_lag=1.2 * limit))
    radius = 1 / sc.omega0
    assert below[-len(below) // 5:].max() < 1e-2 * radius
    assert below[len(below) // 10] > 1e-3 * radius                  # it started apart
    assert past[-len(past) // 5:].min() > 0.5 * radius
    with pytest.raises(ScenarioError, match="'actuator_lag'.*centre loop"):
        scenario.load(CONFIG / 'particle_circular.yaml', actuator_lag=1.2 * limit, **values)
    warned = scenario.load(CONFIG / 'particle_circular.yaml', actuator_lag=0.8 * limit,
                           **values)
    assert any('actuator_lag' in w for w in warned.warnings)
    assert scenario.load(CONFIG / 'particle_circular.yaml', actuator_lag=0.4 * limit,
                         **values).warnings == ()


def _course_centre_spread(sc):
    """Return the centre spread (m) over the last fifth, centres from the course (7.11)."""
    X = simulator.simulate(sc).X
    course = np.angle(np.exp(1j * (X[:, 2] + np.arctan2(X[:, 5], X[:, 4]))) + complex(*sc.flow))
    c = X[:, 0] + 1j * X[:, 1] + 1j * np.exp(1j * course) / sc.omega0
    spread = abs(c - c.mean(axis=1, keepdims=True)).max(axis=1)
    return spread[-len(spread) // 5:]


@pytest.mark.slow
@pytest.mark.parametrize('name, duration, held, lost', [
    ('rigid_circular', 120.0, 0.15, 0.25), ('particle_circular_flow', 100.0, 0.088, 0.44)])
def test_the_measured_lags_the_caveat_quotes_where_the_limit_is_not_derived(
        name, duration, held, lost):
    """Measured, not derived (seed 12): held below the figure the warning quotes, lost past it."""
    sc = scenario.load(CONFIG / f'{name}.yaml', seed=12, duration=duration)
    assert _course_centre_spread(replace(sc, actuator_lag=held)).max() < 0.05
    assert _course_centre_spread(replace(sc, actuator_lag=lost)).min() > 1.0


def test_the_gust_has_the_intensity_and_correlation_asked():
    sc = _rigid(gust_intensity=0.1, gust_time=0.5, num_vehicles=3)
    w = world.World(sc, (3,))
    g = np.array([w.blow().copy() for _ in range(40000)])            # 200 s of steps
    a = np.exp(-sc.dt_integration / sc.gust_time)
    for part in (g.real, g.imag):
        assert np.all(abs(part.std(axis=0) / 0.1 - 1) < 0.1)
        lag1 = (part[1:] * part[:-1]).mean(axis=0) / (part * part).mean(axis=0)
        np.testing.assert_allclose(lag1, a, atol=2e-3)
        assert np.all(abs(part.mean(axis=0)) < 0.03)
    assert abs(np.corrcoef(g.real[:, 0], g.real[:, 1])[0, 1]) < 0.05  # vehicles independent


def test_a_gust_moves_the_vehicles_and_a_told_rigid_body_reads_it_in_its_water_speed():
    sc = _rigid(gust_intensity=0.1, gust_time=2.0, duration=1.0)
    stepper = simulator.Stepper(sc)
    stepper.command()
    stepper.advance()
    seen = stepper.observed()
    rel = (seen[ROW_U] - stepper.X[ROW_U]) + 1j * (seen[ROW_V] - stepper.X[ROW_V])
    gust = stepper.backend.world.gust
    np.testing.assert_allclose(rel, gust * np.exp(-1j * stepper.X[2]), atol=1e-12)
    np.testing.assert_allclose(stepper.true_flow() - stepper.local_flow(), gust)


def _centre_spread_flown(run):
    """
    Return the centre spread (m) at the inner samples of ``run``, from its positions alone.

    The course is the direction of the central difference of the recorded positions (the
    motion flown, gusts and all), the centres ``r + i e^{i course} / omega0`` (thesis 2.6).
    """
    r = run.X[:, 0] + 1j * run.X[:, 1]
    course = np.angle(r[2:] - r[:-2])
    c = r[1:-1] + 1j * np.exp(1j * course) / run.sc.omega0
    return abs(c - c.mean(axis=1, keepdims=True)).max(axis=1)


def test_the_metrics_read_the_course_flown_in_a_gust_not_the_flowfields_alone():
    """
    Issue 43, item 2: the band test's centres come from the true ground velocity.

    A 0.1 m/s gust the vehicles are not told (estimating the flow, the envelope's cell C2): the
    centre spread of the record and of a study's batch equals that of the course flown, taken
    from the recorded positions by finite differences, to the differences' error (the gust's
    steps and the turn over a sample); the course through the flowfield alone is 20 times
    further off. Both from the sample 5 s in, every 0.02 s (one integration step).
    """
    sc = scenario.load(CONFIG / 'rigid_circular_flow_center.yaml', gust_intensity=0.1,
                       gust_time=30.0, duration=20.0, dt_integration=0.02, record_dt=0.02,
                       flow_source='estimated', seed=7)
    run = simulator.simulate(sc)
    flown = _centre_spread_flown(run)
    ctrl, inner = Controller(sc), range(1, len(run.t) - 1)
    measured = np.array([metrics.snapshot(ctrl, run.X[i], run.U[i], run.t[i],
                                          gust=run.gust[i]).spread for i in inner])
    proxy = np.array([metrics.snapshot(ctrl, run.X[i], run.U[i], run.t[i]).spread
                      for i in inner])
    study = simulator.simulate(sc, simulator.initial_states(sc, [7]), simulator.Outcome(sc),
                               seeds=[7])
    batch = np.array([e['centre_spread'][0] for e in study.errors])[1:-1]
    after = run.t[1:-1] >= 5.0
    for spread in (measured, batch):
        off = abs(spread - flown)[after]
        assert np.median(off) < 0.01 and off.max() < 0.05
    assert np.median(abs(proxy - flown)[after]) > 0.05


def test_the_plant_nodes_record_carries_the_gust_the_simulators_does(tmp_path):
    """The plant node's record (FleetPlant) holds each vehicle's gust, saved and read back."""
    sc = _rigid(gust_intensity=0.1, gust_time=2.0, duration=0.5, record_dt=0.1)
    fleet = FleetPlant(sc)
    while fleet.hold(np.zeros(sc.num_vehicles, bool), True):
        fleet.integrate()
        fleet.next_period()
    fleet.run({}).save(tmp_path / 'plant.npz')
    run, ref = simulator.load_run(tmp_path / 'plant.npz'), simulator.simulate(sc)
    assert set(world.GUST_CHANNELS) <= set(run.channels) and np.all(abs(run.gust) > 0)
    np.testing.assert_array_equal(run.gust, ref.gust)         # the draws ignore the commands
    np.testing.assert_array_equal(run.gust[-1], fleet.stepper.backend.world.gust)
    assert not simulator.simulate(_rigid(duration=0.5)).channels    # no gust, nothing more


def test_anti_windup_holds_the_pi_integrator_while_the_steering_force_is_on_its_limit():
    integrals, clipped = {}, {}
    for anti in (False, True):
        sc = scenario.load(CONFIG / 'rigid_circular_flow.yaml', num_vehicles=3, seed=2,
                           max_steering_force=0.02, anti_windup=anti)
        stepper = simulator.Stepper(sc)
        clipped[anti] = 0
        for _ in range(100):
            before = stepper.ctrl.integral
            U = stepper.command()
            on_limit = abs(U[1]) >= 0.02 * (1 - 1e-9)
            if anti and before is not None:
                np.testing.assert_array_equal(stepper.ctrl.integral[on_limit], before[on_limit])
            clipped[anti] += int(on_limit.sum())
            stepper.advance()
        integrals[anti] = stepper.ctrl.integral.copy()
    assert clipped[True] > 20 and clipped[False] > 20
    assert np.max(abs(integrals[True])) < 0.5 * np.max(abs(integrals[False]))


@pytest.mark.parametrize('values, name', [
    ({'mismatch': 1.0}, 'mismatch'), ({'mismatch': -0.1}, 'mismatch'),
    ({'num_vehicles': 2, 'mismatch_m0': [1.0, 0.0]}, 'mismatch_m0'),
    ({'num_vehicles': 2, 'mismatch_h': [1.0]}, 'mismatch_h'),
    ({'gust_intensity': -0.1}, 'gust_intensity'), ({'gust_time': 0.0}, 'gust_time'),
    ({'actuator_lag': -1.0}, 'actuator_lag'), ({'actuator_lag': 1.2}, 'actuator_lag'),
    ({'max_steering_rate': -1.0}, 'max_steering_rate'),
    ({'convergence': 'sometimes'}, 'convergence')])
def test_bad_world_input_is_refused_naming_the_parameter(values, name):
    with pytest.raises(ScenarioError, match=f"'{name}'"):
        scenario.resolve(values)


def test_a_gust_past_the_vehicle_speed_is_warned_about():
    sc = scenario.resolve({'flow': [0.5, 0.0], 'gust_intensity': 0.2})
    assert any('gust_intensity' in w for w in sc.warnings)


@pytest.mark.parametrize('seed', (11, 12, 13))
def test_an_untold_steady_gust_moves_the_speed_by_the_amplified_error(seed):
    """
    A rigid body told the flow reads an untold gust in its water speed (a bias b along x).

    The gust held nearly constant (gust_time 1e5 s); the drag cancellation amplifies b by
    ``2 h u0 / (m0 K_f) - 1`` = 9 in the steady speed (:func:`world.speed_under_bias`).
    """
    sc = _rigid(seed=seed, world_seed=seed, duration=25.0, gust_intensity=0.01,
                gust_time=1e5, hold_prediction='none')
    stepper = simulator.Stepper(sc)
    for _ in range(sc.periods):
        stepper.command()
        stepper.advance()
    X = stepper.X
    b = (stepper.backend.world.gust * np.exp(-1j * X[2])).real
    predicted = world.speed_under_bias(sc, b)
    assert np.max(abs(predicted - sc.u0)) > 0.03                   # a measurable offset
    np.testing.assert_allclose(X[ROW_U], predicted, rtol=0, atol=2e-3)
    np.testing.assert_allclose(predicted - sc.u0, 9 * b, rtol=0.3)   # first order in b
