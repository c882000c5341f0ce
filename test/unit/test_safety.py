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
The safety layer of constant-speed particles (core/safety.py, docs/separation.md).

The closed form against a QP solver, the barrier's rate against finite differences, and
simulated encounters judged by the run's separation verdict, with the layer on and off and on
both sides of the conditions it keeps d_min under.
"""
import math

from formation_control.core import safety
from formation_control.core.errors import ScenarioError
from formation_control.core.scenario import resolve
from formation_control.sim import separation
from formation_control.sim.simulator import simulate, summary
import numpy as np
import pytest
import quadprog

LAYER = safety.Layer(d_min=0.1, sensing_range=2.1, speed=1.0, turn_rate=10.0, gain=20.0,
                     side=1.0, dt=0.02)


def qp(u_nom, a, b, u_max):
    """Return argmin (u - u_nom)^2 subject to a u <= b, |u| <= u_max, by quadprog."""
    C = np.r_[-a, 1.0, -1.0][None, :]                  # quadprog: C^T x >= b
    bound = np.r_[-b, -u_max, -u_max]
    return quadprog.solve_qp(np.eye(1), np.array([u_nom]), C, bound)[0][0]


def test_the_closed_form_is_the_qp_solution_on_random_feasible_cases():
    rng = np.random.default_rng(7)
    solved = 0
    while solved < 400:
        m = int(rng.integers(1, 8))
        a, b = rng.normal(size=m), rng.normal(size=m) * 3.0
        u_nom, u_max = rng.normal() * 8.0, rng.uniform(0.5, 10.0)
        u, feasible = safety.closest([u_nom], a, b, np.zeros(m, int), u_max)
        lo, hi, _ = safety.bounds(a, b, np.zeros(m, int), 1, u_max)
        assert feasible[0] == (lo[0] <= hi[0])
        if not feasible[0]:
            continue
        assert u[0] == pytest.approx(qp(u_nom, a, b, u_max), abs=1e-7)
        assert np.all(a * u[0] <= b + 1e-9) and abs(u[0]) <= u_max
        solved += 1


def test_an_empty_intersection_gives_the_least_violating_turn_rate_and_says_so():
    rng = np.random.default_rng(3)
    grid = np.linspace(-5.0, 5.0, 200_001)
    cases = 0
    while cases < 100:
        m = int(rng.integers(2, 6))
        a, b = rng.normal(size=m), rng.normal(size=m) * 3.0 - 4.0
        u, feasible = safety.closest([0.3], a, b, np.zeros(m, int), 5.0)
        if feasible[0]:
            continue
        worst = np.max(a[:, None] * grid - b[:, None], axis=0)
        assert np.max(a * u[0] - b) == pytest.approx(worst.min(), abs=1e-4)
        cases += 1


def test_the_backup_turn_meets_every_half_line_while_every_barrier_holds():
    rng = np.random.default_rng(11)
    r = rng.uniform(-2, 2, 40) + 1j * rng.uniform(-2, 2, 40)
    heading = rng.uniform(-np.pi, np.pi, 40)
    i, j = np.triu_indices(40, 1)
    ok = safety.barrier(LAYER, r[i], heading[i], r[j], heading[j]) >= 0
    a, b = safety.half_lines(LAYER, r[i][ok], heading[i][ok], r[j][ok], heading[j][ok])
    assert ok.sum() > 100
    assert np.all(a * LAYER.side * LAYER.turn_rate <= b + 1e-12)


def test_the_barrier_rate_agrees_with_finite_differences_along_trajectories():
    rng = np.random.default_rng(5)
    for _ in range(20):
        r, th = rng.normal(size=2) + 1j * rng.normal(size=2), rng.uniform(-np.pi, np.pi, 2)
        u = rng.uniform(-LAYER.turn_rate, LAYER.turn_rate, 2)

        def at(t):
            """Return the exact arcs of the two unicycles at time t."""
            heading = th + u * t
            return r + (np.exp(1j * heading) - np.exp(1j * th)) / (1j * u), heading

        for t in np.linspace(0.0, 0.5, 6):
            (p, h), step = at(t), 1e-6
            (p1, h1), (p0, h0) = at(t + step), at(t - step)
            numeric = (safety.barrier(LAYER, p1[0], h1[0], p1[1], h1[1])
                       - safety.barrier(LAYER, p0[0], h0[0], p0[1], h0[1])) / (2 * step)
            assert safety.barrier_rate(LAYER, p[0], h[0], u[0], p[1], h[1], u[1]) == \
                pytest.approx(numeric, rel=1e-6, abs=1e-7)


def encounter(model, x, y, theta, **extra):
    """Return the separation verdict of a parallel-law encounter, safety off and on."""
    controller = 'first_order' if model == 'first_order' else 'backstepping'
    out = []
    for on in ('off', 'on'):
        sc = resolve({'model': model, 'controller': controller, 'num_vehicles': len(x),
                      'K': -0.05, 'duration': 8.0, 'record_dt': 0.02, 'init_x': list(x),
                      'init_y': list(y), 'init_theta': list(theta), 'safety': on,
                      **(extra if on == 'on' else {})})
        run = simulate(sc)
        out.append((separation.of_run(run), summary(run)))
    return out


HEAD_ON = ([-1.5, 1.5], [0.0, 0.02], [0.0, math.pi - 0.01])    # exactly: no mean course
CROSSING = ([-2.0, 0.0], [0.0, -2.0], [0.0, math.pi / 2])


@pytest.mark.parametrize('model', ['first_order', 'second_order'])
@pytest.mark.parametrize('start', [HEAD_ON, CROSSING], ids=['head-on', 'crossing'])
def test_a_head_on_pair_and_a_crossing_keep_apart_with_the_layer_only(model, start):
    (off, _), (on, out) = encounter(model, *start)
    assert not off.kept_apart and off.closest < 0.5 * off.d_min
    assert on.kept_apart and on.closest >= on.d_min
    assert out['safety']['active_fraction'] > 0 and out['safety']['infeasible_periods'] == 0


@pytest.mark.parametrize('model', ['first_order', 'second_order'])
def test_a_dense_box_converging_to_a_circle_keeps_apart_with_the_layer_only(model):
    x, y = np.meshgrid(np.arange(4) * 0.6 - 0.9, np.arange(4) * 0.6 - 0.9)
    theta = np.random.default_rng(2).uniform(-np.pi, np.pi, 16)
    runs = []
    for on in ('off', 'on'):
        sc = resolve({'model': model, 'controller': 'first_order' if model == 'first_order'
                      else 'backstepping', 'formation': 'circular', 'K': 1.0,
                      'num_vehicles': 16, 'duration': 30.0, 'init_x': list(x.ravel()),
                      'init_y': list(y.ravel()), 'init_theta': list(theta), 'safety': on})
        runs.append(separation.of_run(simulate(sc)))
    assert not runs[0].kept_apart and runs[1].kept_apart


def head_on_at(gap, **extra):
    """Return the verdict of a head-on pair ``gap`` apart, layer on."""
    return encounter('first_order', [-gap / 2, gap / 2], [0.0, 0.0], [0.0, math.pi],
                     **extra)[1][0]


def test_a_pair_is_kept_apart_from_a_start_inside_the_barrier_and_not_from_one_outside():
    # head-on, backup centres (-g/2, rho), (g/2, -rho): h = sqrt(g^2 + 4 rho^2) - D
    lim = safety.of(resolve({'model': 'first_order', 'controller': 'first_order',
                             'num_vehicles': 2, 'safety': 'on'}))
    edge = math.sqrt(lim.reach ** 2 - 4 * lim.rho ** 2)
    assert head_on_at(1.05 * edge).kept_apart
    outside = head_on_at(0.95 * edge)
    assert not outside.kept_apart and outside.closest > 0.5 * lim.d_min
    assert edge > 2 * lim.d_min                          # outside: apart at the start


def test_the_sensing_range_the_condition_asks_keeps_apart_and_one_below_it_does_not():
    base = resolve({'model': 'first_order', 'controller': 'first_order', 'num_vehicles': 2,
                    'safety': 'on'})
    needed = safety.of(base).needed_range
    assert head_on_at(3.0, sensing_range=needed).kept_apart
    short = resolve({'model': 'first_order', 'controller': 'first_order', 'num_vehicles': 2,
                     'safety': 'on', 'sensing_range': 0.2})
    assert any('sensing_range 0.2 m is below what the safety layer needs' in w
               for w in short.warnings)
    assert not head_on_at(3.0, sensing_range=0.2).kept_apart


@pytest.mark.parametrize('changes, match', [
    ({'model': 'rigid', 'formation': 'circular', 'K': 1.0},
     r"'safety' = 'on' is invalid: not read by this run: it applies to model first_order or "
     r'second_order only'),
    ({'flow_model': 'vortex', 'flow_circulation': 0.5},
     r"'safety' = 'on' is invalid: 'off' in a flow that is not uniform"),
    ({'model': 'first_order', 'controller': 'first_order', 'max_turn_rate': 2.0,
      'safety_turn_rate': 3.0}, r"'safety_turn_rate' = 3.0 is invalid: <= max_turn_rate"),
    ({'formation': 'circular', 'K': 1.0, 'safety_turn_rate': 0.8},
     r"'safety_turn_rate' = 0.8 is invalid: > V \|omega0\| = 1 rad/s"),
])
def test_a_layer_that_cannot_act_is_refused_naming_the_parameter(changes, match):
    with pytest.raises(ScenarioError, match=match):
        resolve({'num_vehicles': 4, 'safety': 'on', **changes})


def test_a_bare_yaml_on_is_the_switch_on():
    assert resolve({'num_vehicles': 2, 'safety': True}).safety == 'on'
    assert resolve({'num_vehicles': 2, 'safety': False}).safety == 'off'


def test_the_layer_is_inactive_where_no_pair_is_near_and_the_parallel_law_still_converges():
    sc = resolve({'num_vehicles': 6, 'K': -1.0, 'duration': 40.0, 'safety': 'on',
                  'init_x': [0.0, 3.0, 6.0, 0.0, 3.0, 6.0], 'init_y': [0, 0, 0, 3.0, 3.0, 3.0],
                  'init_theta': [0.0, 0.3, -0.3, 0.2, -0.2, 0.1]})
    out = summary(simulate(sc))
    assert out['converged'] and out['separation']['kept_apart']
    assert out['safety']['active_fraction'] == 0.0
