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

"""Separation: sizes, the refusals, the pair searches, a run's verdict, its report, the monitor."""
from dataclasses import replace
import math

from formation_control.core import separation
from formation_control.core.errors import ScenarioError
from formation_control.core.parameters import DEFAULTS
from formation_control.core.scenario import load, resolve
from formation_control.protocol import watch
from formation_control.protocol.watch import ERROR, OK, WARN
from formation_control.sim import report, simulator
from formation_control.sim import separation as apart
import numpy as np
import pytest
from runs import CONFIG
from test_protocol import FakeClock

SPLAY = {'num_vehicles': 12, 'formation': 'circular', 'pattern': 'splay', 'omega0': 1.0}
CHORD_12 = 2.0 * math.sin(math.pi / 12)               # the splay's spacing on the unit circle


def brute_pairs(p):
    """Return every pair i < j and its distance, computed the definition's way."""
    i, j = np.triu_indices(len(p), 1)
    return i, j, np.sqrt(np.sum((p[i] - p[j]) ** 2, axis=-1))


def fleets(rng):
    """Yield random fleets, 2-D and 3-D: spread, on a lattice, with coincident vehicles."""
    for trial in range(120):
        n, dim = int(rng.integers(2, 60)), int(rng.choice([2, 3]))
        p = rng.normal(size=(n, dim)) * float(rng.choice([1e-3, 1.0, 1e3]))
        if trial % 3 == 0:
            p = np.round(p * 2.0) / 2.0                  # ties, and coincident vehicles
        yield p


def test_every_scenario_derives_its_separation_from_its_vehicles_size():
    particle = resolve({})
    rigid = resolve({'model': 'rigid', 'l': 0.8, 'K': -1.0})
    assert separation.limits(particle) == separation.Limits(0.1, 0.1, math.inf, 0.1 + 2.0)
    lim = separation.limits(rigid)
    assert (lim.size, lim.d_min, lim.d_min_vertical) == (1.6, 1.6, math.inf)
    assert separation.size(resolve({'model': 'vessel', 'K': -1.0})) == 1.255
    given = separation.limits(resolve({'d_min': 0.3, 'sensing_range': 5.0}))
    assert (given.size, given.d_min, given.sensing_range) == (0.1, 0.3, 5.0)


def test_an_aircraft_is_as_large_as_its_wingspan_and_separated_in_altitude_too():
    sc = replace(DEFAULTS, plant_backend='jsbsim', jsbsim_aircraft='c172x', formation='circular',
                 omega0=1 / 600, K=0.085)
    lim = separation.limits(sc)
    assert lim.size == pytest.approx(36.0 * 0.3048)     # c172x.xml: 36 ft
    assert lim.d_min_vertical == lim.d_min == lim.size
    assert separation.limits(replace(sc, d_min_vertical=30.0)).d_min_vertical == 30.0


@pytest.mark.parametrize('values, name, words', [
    ({'d_min': -0.1}, 'd_min', 'must be >= 0'),
    ({'sensing_range': 0.05}, 'sensing_range', 'must be >= d_min = 0.1 m'),
    ({'d_min': 0.5, 'sensing_range': 0.4}, 'sensing_range', 'must be >= d_min = 0.5 m'),
    ({'d_min_vertical': 3.0}, 'd_min_vertical', 'plant_backend jsbsim only'),
    (dict(SPLAY, d_min=0.6), 'd_min', f'chord 2 R sin(pi/N) = {CHORD_12:.4g} m'),
    (dict(SPLAY, num_vehicles=64), 'd_min', 'derived: the vehicle size 0.1 m'),
])
def test_a_separation_that_cannot_hold_is_refused_naming_the_parameter(values, name, words):
    with pytest.raises(ScenarioError) as err:
        resolve(values)
    assert f"parameter '{name}'" in str(err.value) and words in str(err.value)


def test_a_splay_that_holds_d_min_is_taken_and_circles_that_promise_no_spacing_too():
    assert resolve(dict(SPLAY, d_min=0.99 * CHORD_12)).warnings == ()
    assert resolve({'formation': 'circular', 'num_vehicles': 12, 'd_min': 0.6}).warnings == ()
    assert load(CONFIG / 'particle_circular_symmetric.yaml').warnings == ()


def test_pairs_within_finds_exactly_the_pairs_of_the_definition():
    rng = np.random.default_rng(42)
    for p in fleets(rng):
        i, j, dist = brute_pairs(p)
        d = float(rng.choice([0.0, np.median(dist), np.quantile(dist, 0.1)]))
        got = separation.pairs_within(p, d)
        keep = dist <= d
        for mine, theirs in zip(got, (i[keep], j[keep], dist[keep])):
            np.testing.assert_array_equal(mine, theirs)


def test_closest_pair_is_the_first_pair_at_the_smallest_distance():
    rng = np.random.default_rng(7)
    for p in fleets(rng):
        i, j, dist = brute_pairs(p)
        k = int(np.argmin(dist))
        assert separation.closest_pair(p) == (dist[k], i[k], j[k])
    assert math.isnan(separation.closest_pair(np.zeros((1, 2)))[0])


def crossing(d_min):
    """Return two vehicles that pass 0.1 m apart between two samples 2 m apart."""
    t = np.array([0.0, 1.0])
    P = np.zeros((2, 2, 3))
    P[0, 0, :2], P[1, 0, :2] = (-1.0, 0.05), (1.0, 0.05)
    P[0, 1, :2], P[1, 1, :2] = (1.0, -0.05), (-1.0, -0.05)
    return apart.of_samples(t, P, d_min)


def test_a_pair_that_passes_too_close_between_two_samples_is_not_kept_apart():
    out = crossing(0.5)
    assert out.final == out.final_2d == math.hypot(2.0, 0.1)     # both samples far apart
    assert not out.kept_apart and not out.final_too_close
    assert out.closest == pytest.approx(0.1) and out.closest_time == pytest.approx(0.5)
    assert out.closest_pair == [1, 2]
    assert out.below == pytest.approx(math.sqrt(0.5 ** 2 - 0.1 ** 2) / 2.0)   # |x| < 0.245 m
    assert crossing(0.09).kept_apart


def test_aircraft_apart_in_altitude_are_not_too_close():
    t = np.array([0.0, 1.0])
    P = np.zeros((2, 2, 3))
    P[:, 1, 2] = [20.0, 4.0]                  # vehicle 2 descends through 10 m above the other
    P[:, 1, 0] = 3.0
    out = apart.of_samples(t, P, 11.0, 10.0)
    assert out.closest_2d == 3.0 and not out.kept_apart
    assert out.below == pytest.approx(6.0 / 16.0)           # |dz| < 10 from 20 m down to 10 m
    assert apart.of_samples(t, P, 11.0, 3.9).kept_apart
    assert 'horizontally 3 m' in out.text()


def interpolated(t, P, d, fine=401):
    """Return the closest 3-D distance, the time too close and any, on dense interpolation."""
    s = np.linspace(0.0, 1.0, fine)[:, None, None]
    closest, below, close = np.inf, 0.0, False
    for k in range(len(t) - 1):
        Q = P[k] + s * (P[k + 1] - P[k])
        i, j = np.triu_indices(P.shape[1], 1)
        dist = np.sqrt(np.sum((Q[:, i] - Q[:, j]) ** 2, axis=-1))
        closest = min(closest, float(dist.min()))
        too = (dist < d).any(axis=1)
        close |= bool(too.any())
        below += too.mean() * (t[k + 1] - t[k])
    return closest, below, close


@pytest.mark.parametrize('name, values', [
    ('particle_circular', ['num_vehicles:=6', 'duration:=12.0', 'init_box:=2.0', 'd_min:=0.3']),
    ('rigid_circular', ['duration:=10.0', 'record_dt:=0.5', 'seed:=4']),
])
def test_a_runs_separation_is_that_of_its_recorded_states(name, values):
    run = simulator.simulate(load(CONFIG / f'{name}.yaml', values))
    out = apart.of_run(run)
    P = np.stack([run.X[:, 0], run.X[:, 1], np.zeros_like(run.X[:, 0])], axis=-1)
    i, j, last = brute_pairs(P[-1])
    assert out.final == out.final_2d == last.min()
    sampled = min(brute_pairs(p)[2].min() for p in P)
    closest, below, close = interpolated(run.t, P, run.sc.d_min or 1.0)
    assert out.closest <= sampled and out.closest <= closest <= out.closest + 1e-3
    assert out.kept_apart is not close
    assert out.below == pytest.approx(below, abs=0.01 * run.t[-1])
    assert out.path_error > 0


def test_a_particles_path_stays_within_the_path_error_of_the_chords():
    run = simulator.simulate(load(CONFIG / 'particle_circular_flow.yaml',
                                  ['num_vehicles:=6', 'duration:=12.0', 'record_dt:=0.02']))
    every = 25                                                     # samples 0.5 s apart
    kept = np.arange(0, len(run.t), every)
    coarse = simulator.Run(run.sc, run.t[kept], run.X[kept], run.U[kept])
    r = run.X[:, 0] + 1j * run.X[:, 1]
    worst = 0.0
    for a, b in zip(kept[:-1], kept[1:]):
        s = (run.t[a:b + 1] - run.t[a]) / (run.t[b] - run.t[a])
        worst = max(worst, float(np.max(abs(r[a:b + 1] - (r[a] + s[:, None] * (r[b] - r[a]))))))
    error = apart.of_run(coarse).path_error
    assert 2.0 * worst <= error


def test_the_sweeps_tracker_agrees_with_each_run_alone():
    sc = load(CONFIG / 'rigid_circular.yaml', ['duration:=8.0', 'record_dt:=0.2'])
    seeds = [3, 4, 5]
    out = simulator.simulate(sc, simulator.initial_states(sc, seeds), simulator.Outcome(sc))
    rows = out.apart.rows()
    for b, seed in enumerate(seeds):
        alone = apart.of_run(simulator.simulate(replace(sc, seed=seed)))
        assert rows['closest'][b] == pytest.approx(alone.closest, abs=1e-12)
        assert rows['time_too_close'][b] == pytest.approx(alone.below, abs=1e-9)
        assert rows['kept_apart'][b] == alone.kept_apart


def test_the_summary_and_the_report_carry_the_separation_verdict():
    run = simulator.simulate(load(CONFIG / 'particle_circular.yaml',
                                  ['num_vehicles:=5', 'duration:=4.0', 'd_min:=0.3']))
    out, rows = report.report(run)
    sep = out['separation']
    assert sep == apart.of_run(run).values() and sep['d_min'] == 0.3
    text = report.format_report('title', out, rows).splitlines()
    assert text[1].startswith('  converged')
    assert text[2] == f'  separation         {apart.text(sep)}'
    assert text[2].split()[1] == ('kept' if sep['kept_apart'] else 'no:')


@pytest.mark.parametrize('distance, level, words', [
    (2.5, OK, 'kept apart'), (1.99, WARN, 'vehicles 2 and 5 1.99 m apart: below 2 d_min = 2 m'),
    (0.31, ERROR, 'vehicles 2 and 5 0.31 m apart: below d_min = 1 m'),
    (math.nan, OK, 'one vehicle')])
def test_the_monitors_separation_level(distance, level, words):
    assert watch.separation_level(distance, (2, 5), 1.0) == (level, words)


def test_the_monitors_separation_status_names_the_closest_pair():
    w = watch.Watch(load(CONFIG / 'particle_parallel.yaml', ['num_vehicles:=3']), '/', 0.0,
                    stale_timeout=2.0, converge_within=60.0, trail_length=10, clock=FakeClock())
    X = np.zeros((6, 3))
    X[0], X[4] = [0.0, 5.0, 5.15], 1.0
    for k in (1, 2, 3):
        w.odom(k, X[:, k - 1], 0)
    w.sample(0)
    name, level, message, values = w.separation_status()
    assert (name, level) == ('separation', WARN) and message.startswith('vehicles 2 and 3')
    assert values == {'d_min': '0.1', 'closest': '0.15', 'pair': '2 3'}
    assert [s[0] for s in w.statuses(0)][:3] == ['formation', 'separation', 'vehicle_1']
