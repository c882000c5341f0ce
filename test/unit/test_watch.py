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

"""The monitor's rules with a fake clock (no ROS, no DDS): gains, sampling, latch, status."""
from formation_control.core import scenario
from formation_control.core.errors import ScenarioError
from formation_control.core.models import ground_velocity, ROW_THETA, ROW_U, ROW_X, ROW_Y
from formation_control.protocol import messages, watch
from formation_control.protocol.watch import ERROR, OK, WARN
from formation_control.sim import metrics
import numpy as np
import pytest
from runs import CONFIG
from test_protocol import FakeClock

MS = 1_000_000


def _scenario(name='particle_parallel', **values):
    return scenario.load(CONFIG / f'{name}.yaml', [], **values)


def _watch(sc, clock, period=0.0, converge_within=60.0, trail_length=300):
    return watch.Watch(sc, '/', period, stale_timeout=2.0, converge_within=converge_within,
                       trail_length=trail_length, clock=clock)


def _aligned(n, theta=0.5):
    """Parallel states of n particles at unit speed, every heading ``theta``, no turning."""
    X = np.zeros((6, n))
    X[ROW_X], X[ROW_THETA], X[ROW_U] = np.arange(n), theta, 1.0
    return X


@pytest.fixture
def clock():
    return FakeClock()


def test_a_gain_is_taken_once_every_vehicle_announced_the_same_value():
    sc = _scenario(num_vehicles=3)
    gains = watch.GainAgreement(sc, 'fleet_a')
    assert gains.announce('/fleet_a/vehicle_1', {'kappa': 2.5}) == {}
    assert gains.announce('/fleet_a/vehicle_2', {'kappa': 2.5}) == {}
    assert gains.announce('/fleet_a/vehicle_3', {'kappa': 4.0}) == {}   # the fleet disagrees
    assert gains.held['kappa'] == [2.5, 2.5, 4.0]
    assert gains.announce('/fleet_a/vehicle_3', {'kappa': 2.5}) == {'kappa': 2.5}
    assert gains.take({'kappa': 2.5}).kappa == 2.5 and gains.sc.kappa == 2.5
    assert gains.sc.num_vehicles == 3 and gains.sc.K == sc.K


def test_one_vehicle_changed_by_hand_keeps_the_last_common_value():
    gains = watch.GainAgreement(_scenario(num_vehicles=2, kappa=2.0))
    for k in (1, 2):
        agreed = gains.announce(f'/vehicle_{k}', {'kappa': 3.0})
    gains.take(agreed)
    assert gains.announce('/vehicle_2', {'kappa': 7.0}) == {}
    assert gains.sc.kappa == 3.0
    assert gains.announce('/vehicle_2', {'kappa': 3.0}) == {}            # back: nothing new


def test_gains_of_other_nodes_and_read_only_parameters_are_ignored():
    gains = watch.GainAgreement(_scenario(num_vehicles=1))
    assert gains.announce('/fleet_b/vehicle_1', {'kappa': 9.0}) == {}   # another fleet
    assert gains.announce('/formation_plant', {'kappa': 9.0}) == {}
    assert gains.announce('/vehicle_1', {'num_vehicles': 4, 'use_sim_time': True}) == {}
    assert gains.announce('/vehicle_1', {'c0': [1.0, 2.0]}) == {'c0': (1.0, 2.0)}
    assert gains.take({'c0': (1.0, 2.0)}).c0_c == 1 + 2j


def test_only_the_run_time_values_of_the_fleets_vehicles_are_converted():
    gains = watch.GainAgreement(_scenario(num_vehicles=1, kappa=2.0))
    seen = []

    def convert(text):
        seen.append(text)
        return float(text)
    assert gains.announce('/plant', {'kappa': '1.5'}, convert) == {}
    assert gains.announce('/vehicle_1', {'seed': 'x', 'kappa': '1.5'}, convert) == {'kappa': 1.5}
    assert seen == ['1.5']


def test_an_agreed_value_the_scenario_refuses_is_not_taken(clock):
    sc = _scenario(num_vehicles=1)
    w = _watch(sc, clock)
    agreed = w.gains.announce('/vehicle_1', {'kappa': -1.0})
    assert agreed == {'kappa': -1.0}
    with pytest.raises(ScenarioError, match='kappa'):
        w.take(agreed)
    assert w.sc == sc and w.ctrl.sc == sc


def test_the_controller_follows_the_gains_taken(clock):
    w = _watch(_scenario(num_vehicles=1), clock)
    w.take(w.gains.announce('/vehicle_1', {'kappa': 2.5}))
    assert w.sc.kappa == 2.5 and w.ctrl.sc.kappa == 2.5


def test_a_sample_waits_for_an_odometry_of_every_vehicle_from_the_period():
    sampling = watch.Sampling(2, period=0.1)
    assert not sampling.odom(0, 0)
    assert sampling.odom(1, 0) and sampling.t == 0.0
    for ns in (20 * MS, 40 * MS):
        assert not sampling.odom(0, ns) and not sampling.odom(1, ns)
    assert not sampling.odom(0, 100 * MS)
    assert sampling.odom(1, 120 * MS)                      # the oldest one is of the period
    assert sampling.t == pytest.approx(0.12)
    assert not sampling.odom(0, 140 * MS)                  # the next is due at 0.22 s


def test_a_sample_takes_each_vehicles_state_and_command_as_of_its_stamp(clock):
    """A monitor joining late gets vehicle 1's last samples before vehicle 2's first."""
    sc = _scenario(num_vehicles=2)
    w = _watch(sc, clock)
    X = _aligned(2)
    for n in range(10):
        x = X[:, 0] + [0.02 * n, 0, 0, 0, 0, 0]
        assert not w.odom(1, x, n * 20 * MS)
        w.cmd(1, [0.0, 0.1 * n], n * 20 * MS)
    assert w.odom(2, X[:, 1], 0)
    w.sample(0)
    _, _, shown_X, shown_U, _ = w.shown
    np.testing.assert_array_equal(shown_X, X)
    assert shown_U[1, 0] == 0.0
    assert w.odom(2, X[:, 1], 20 * MS)
    w.sample(20 * MS)
    assert w.shown[2][ROW_X, 0] == X[ROW_X, 0] + 0.02 and w.shown[3][1, 0] == 0.1
    held = watch.History(1, 1, depth=2)
    for n in (1, 2, 3):
        held.add(0, n, [n])
    assert held.as_of(0, np.array([[9.0]]))[0, 0] == 9.0      # older than all it keeps
    assert held.as_of(2, np.array([[9.0]]))[0, 0] == 2.0


def test_with_period_0_every_step_is_sampled_and_times_count_from_the_first():
    sampling = watch.Sampling(1, period=0.0)
    assert sampling.odom(0, 5000 * MS) and sampling.t == 0.0
    assert sampling.odom(0, 5020 * MS) and sampling.t == pytest.approx(0.02)


def test_the_latch_holds_the_time_the_formation_became_converged():
    latch = watch.Latch()
    assert not latch.update(False, 1.0) and latch.since is None
    assert latch.update(True, 2.0) and latch.since == 2.0
    assert not latch.update(True, 3.0) and latch.since == 2.0
    assert latch.update(False, 4.0) and not latch.converged
    assert latch.update(True, 5.0) and latch.since == 5.0


def test_the_trail_ring_keeps_the_last_positions_oldest_first():
    trails = watch.Trails(3, 2)
    assert trails.ordered().shape == (2, 0)
    for i in range(5):
        trails.add(np.array([i, 10j * i]))
    np.testing.assert_array_equal(trails.ordered(), [[2, 3, 4], [20j, 30j, 40j]])


def test_status_rules_of_a_vehicle():
    fresh = {'odom': 0.1, 'cmd': 0.1, 'state': 0.1}
    assert watch.vehicle_level(fresh, 2.0, False) == (OK, [])
    assert watch.vehicle_level({**fresh, 'odom': 2.5}, 2.0, False) == (
        ERROR, ['stale odom (2.5 s)'])
    assert watch.vehicle_level({**fresh, 'state': 3.0}, 2.0, True) == (
        WARN, ['stale formation_state (3.0 s)', 'command saturated'])
    assert watch.vehicle_level(fresh, 2.0, False, lagging=61.0) == (
        WARN, ['not converging after 61.0 s'])


def test_status_rules_of_the_formation():
    assert watch.formation_level(3.0, 1.234, 60.0) == (OK, 'converged in 1.23 s')
    assert watch.formation_level(30.0, None, 60.0) == (OK, 'converging')
    assert watch.formation_level(61.0, None, 60.0) == (WARN, 'not converged after 61.0 s')


def test_a_vehicle_unheard_goes_stale_from_the_start_of_the_watch(clock):
    w = _watch(_scenario(num_vehicles=2), clock)
    clock.t += 1.0
    w.odom(1, _aligned(2)[:, 0], 0)
    w.cmd(1, np.zeros(2), 0)
    w.state(1, {})
    clock.t += 1.5
    name, level, message, values = w.vehicle_status(1)
    assert (name, level) == ('vehicle_2', ERROR)
    assert message.startswith('stale odom (2.5 s); stale cmd (2.5 s)')
    assert values['odom_age'] == '2.500' and values['converged'] is False
    assert w.vehicle_status(0)[1:3] == (OK, 'ok')
    clock.t += 1.0
    assert w.vehicle_status(0)[1:3] == (
        ERROR, 'stale odom (2.5 s); stale cmd (2.5 s); stale formation_state (2.5 s)')


def test_the_formation_latches_converged_and_reports_the_time_it_took(clock):
    w = _watch(_scenario(num_vehicles=2, hold_window=0.2), clock, converge_within=0.05)
    X = _aligned(2)
    X[ROW_THETA, 1] = 0.5 + np.pi                                   # head to head
    for k in (1, 2):
        due = w.odom(k, X[:, k - 1], 0)
    assert due
    values, changed = w.sample(0)
    assert not changed and values['order_parameter'] < 1e-12
    assert w.formation_status(rejected=0)[1:3] == (OK, 'converging')
    aligned = _aligned(2)
    for ms in (100, 200):                                # in the test, not yet for the window
        for k in (1, 2):
            w.odom(k, aligned[:, k - 1], ms * MS)
        _, changed = w.sample(ms * MS)
        assert not changed and not w.latch.converged and w.latch.since is None
    for k in (1, 2):
        w.odom(k, aligned[:, k - 1], 300 * MS)
    _, changed = w.sample(300 * MS)
    assert changed and w.latch.since == pytest.approx(0.1)
    name, level, message, values = w.formation_status(rejected=3)
    assert (name, level, message) == ('formation', OK, 'converged in 0.10 s')
    assert values['convergence_time'] == '0.100' and values['rejected_messages'] == 3
    assert values['order_parameter'] == '1'
    for k in (1, 2):
        w.odom(k, X[:, k - 1], 400 * MS)
    _, changed = w.sample(400 * MS)
    assert changed
    assert w.formation_status(0)[1:3] == (WARN, 'not converged after 0.4 s')
    assert [w.vehicle_status(i)[2] for i in (0, 1)] == ['not converging after 0.4 s'] * 2


def test_the_monitor_latch_waits_the_derived_hold_window(clock):
    sc = _scenario(num_vehicles=2)
    w = _watch(sc, clock)
    assert w.latch.hold == pytest.approx(metrics.hold_window(sc)) == pytest.approx(2 * np.pi)
    aligned = _aligned(2)
    for ms in range(0, 6400, 100):                       # 0 .. 6.3 s, in the test throughout
        for k in (1, 2):
            w.odom(k, aligned[:, k - 1], ms * MS)
        assert w.sample(ms * MS)[1] is (ms == 6300)     # converged once held 2 pi / |K|
    assert w.latch.converged and w.latch.since == 0.0


def test_the_live_graph_holds_the_links_both_ends_hear_within_the_timeout(clock):
    sc = _scenario(num_vehicles=3)
    w = _watch(sc, clock)
    assert w.live_graph()[0].tolist() == [False] * 3          # no state heard yet
    w.state(1, {2: True, 3: False})
    w.state(2, {1: True, 3: True})
    w.state(3, {1: True, 2: True})
    fresh, edges = w.live_graph()
    assert fresh.all() and sorted(map(tuple, edges)) == [(0, 1), (1, 2)]
    clock.t += 1.0
    w.state(2, {})
    w.state(3, {})
    clock.t += 1.5                                          # vehicle 1's state is 2.5 s old
    fresh, edges = w.live_graph()
    assert fresh.tolist() == [False, True, True] and sorted(map(tuple, edges)) == [(1, 2)]


def test_the_picture_shows_the_last_sample_with_its_trails_and_centres(clock):
    sc = _scenario('particle_circular', num_vehicles=2, c0=[1.0, -2.0], informed=[1])
    w = _watch(sc, clock, trail_length=2)
    assert w.picture() is None
    X = _aligned(2)
    for ns in (0, 20 * MS, 40 * MS):
        X[ROW_Y] = ns / (20 * MS)
        for k in (1, 2):
            w.odom(k, X[:, k - 1], ns)
        w.sample(ns)
    shown, ns, trails, ground, centres, target = w.picture()
    assert ns == 40 * MS and ground is None and target == 1 - 2j
    np.testing.assert_array_equal(shown, X)
    np.testing.assert_array_equal(trails, [[1j, 2j], [1 + 1j, 1 + 2j]])
    expected = (shown[ROW_X] + 1j * shown[ROW_Y]
                + 1j * np.exp(1j * shown[ROW_THETA]) / sc.omega0)
    np.testing.assert_allclose(centres, expected, atol=1e-12)


@pytest.mark.parametrize('name', ['particle_circular_flow', 'rigid_circular_flow_center'])
def test_the_monitor_measures_the_course_the_odometry_shows_gust_and_all(clock, name):
    """
    Issue 43, item 2: the plant's odometry carries the ground velocity in the flow and the gust.

    The monitor's centres are those of that motion (:func:`metrics.snapshot` with the gust),
    not of the flowfield it knows alone; particles included, whose state has no place for it.
    """
    sc = _scenario(name, num_vehicles=3, informed=[1])
    w = _watch(sc, clock)
    rng = np.random.default_rng(43)
    X = _aligned(3)
    X[ROW_THETA] = rng.uniform(-np.pi, np.pi, 3)
    gust = 0.2 * (rng.standard_normal(3) + 1j * rng.standard_normal(3))
    field = w.flow(X[ROW_X], X[ROW_Y])
    for k in (1, 2, 3):
        values = messages.odom_values(X[:, k - 1], field[k - 1] + gust[k - 1])
        state = messages.state_from_odom_values(values, complex(field[k - 1]), sc.model)
        w.odom(k, state, 0, messages.ground_velocity_of(values))
    got, _ = w.sample(0)
    truth = metrics.snapshot(w.ctrl, X, np.zeros((2, 3)), 0.0, gust=gust)
    assert got['centre_spread'] == pytest.approx(truth.spread, abs=1e-9)
    assert got['centre_x'] + 1j * got['centre_y'] == pytest.approx(truth.centre, abs=1e-9)

    def centres(flow):
        course = np.angle(ground_velocity(X, flow))
        return X[ROW_X] + 1j * X[ROW_Y] + 1j * np.exp(1j * course) / sc.omega0

    np.testing.assert_allclose(w.picture()[4], centres(field + gust), atol=1e-9)
    assert np.max(abs(centres(field) - centres(field + gust))) > 0.1
