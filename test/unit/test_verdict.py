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
Converged 'yes' rests on the test held over a window, not on a sample (issue 43, item 1).

Synthetic runs that touch the test and leave it, flicker, hold only at the end or from the
start; the derived hold window; and real runs cut just after the formation enters its test
(no) and run on past the window (yes), their figures recomputed from the recorded states.
"""
from formation_control.core import scenario
from formation_control.core.errors import ScenarioError
from formation_control.core.models import ROW_THETA, ROW_X, ROW_Y
from formation_control.protocol.watch import Latch
from formation_control.sim import metrics, simulator
from formation_control.sim.report import format_report, report
import numpy as np
import pytest
from runs import CONFIG

T = np.round(np.arange(0.0, 20.01, 0.1), 10)


def _sc(**values):
    return scenario.load(CONFIG / 'particle_circular.yaml', hold_window=3.0, **values)


def _flags(*spans):
    """Return flags over T that hold exactly in the half-open spans [a, b) (s)."""
    return np.any([(T >= a - 1e-9) & (T < b - 1e-9) for a, b in spans], axis=0)


@pytest.mark.parametrize('spans, yes, since, held', [
    ([(0.0, 99.0)], True, 0.0, 20.0),                  # holds from t0
    ([(7.0, 99.0)], True, 7.0, 13.0),                  # enters, stays past the window
    ([(18.8, 99.0)], False, 18.8, 1.2),                # holds at the end only
    ([(20.0, 99.0)], False, 20.0, 0.0),                # the last sample only
    ([(2.0, 15.0)], False, None, None),                # holds 13 s, then leaves
    ([(10.0, 12.0), (12.5, 14.0), (14.5, 16.0), (16.5, 18.0), (19.0, 99.0)], False, 19.0,
     1.0),                                             # flickers in and out
    ([(0.0, 16.9), (17.0, 99.0)], True, 17.0, 3.0),    # out at one sample, back 3 s before
    ([(0.0, 17.1), (17.2, 99.0)], False, 17.2, 2.8),   # one sample out inside the window
])
def test_the_verdict_needs_every_sample_over_the_hold_window(spans, yes, since, held):
    sc = _sc()
    flags = _flags(*spans)
    got = metrics.settling(sc, T, flags)
    assert got.converged is yes and got.hold == 3.0
    assert got.since == pytest.approx(since) if since is not None else got.since is None
    assert got.held == pytest.approx(held) if held is not None else got.held is None
    assert metrics.verdict(sc, T, flags) is yes
    batch = np.stack([flags, np.ones_like(flags), np.zeros_like(flags)], axis=1)
    assert metrics.verdict(sc, T, batch).tolist() == [yes, True, False]


def test_the_report_line_says_how_long_an_unsettled_run_held():
    sc = _sc()
    assert metrics.settling(sc, T, _flags((18.8, 99.0))).text() == (
        'no, not settled: held only the last 1.2 s of the 3 s hold window')
    assert metrics.settling(sc, T, _flags((20.0, 99.0))).text() == (
        'no, not settled: held only the last sample of the 3 s hold window')
    assert metrics.settling(sc, T, _flags((2.0, 15.0))).text() == 'no'
    assert metrics.settling(sc, T, _flags((7.0, 99.0))).text() == (
        'yes, from t = 7 s (held 13 s, hold window 3 s)')


def test_the_monitor_latch_gives_the_verdict_of_the_samples():
    """The latch, fed the samples one by one, converges when and only when verdict says so."""
    rng = np.random.default_rng(43)
    sc = _sc()
    for _ in range(40):
        flags = np.repeat(rng.random(20) < 0.7, 11)[:T.size]
        latch = Latch(metrics.hold_window(sc))
        for i, (t, ok) in enumerate(zip(T, flags)):
            latch.update(bool(ok), float(t))
            assert latch.converged is metrics.verdict(sc, T[:i + 1], flags[:i + 1])
        assert latch.since == metrics.settling(sc, T, flags).since or not latch.converged


def test_the_derived_hold_window_is_one_cycle_of_the_laws_and_of_the_steering_loop():
    circle = scenario.load(CONFIG / 'particle_circular.yaml', omega0=0.5, kappa=5.0)
    assert metrics.hold_window(circle) == pytest.approx(2 * np.pi / 0.5)      # one orbit
    flow = scenario.load(CONFIG / 'particle_circular.yaml', omega0=0.5, flow=[0.3, 0.0])
    assert metrics.hold_window(flow) == pytest.approx(2 * np.pi / (0.5 * 0.7))  # slowest orbit
    line = scenario.load(CONFIG / 'particle_parallel.yaml', K=-0.25, kappa=5.0)
    assert metrics.hold_window(line) == pytest.approx(2 * np.pi / 0.25)       # 2 pi / |K|
    slow = scenario.load(CONFIG / 'particle_parallel.yaml', K=-2.0, kappa=0.4)
    assert metrics.hold_window(slow) == pytest.approx(2 * np.pi / 0.4)        # steering loop
    sparse = scenario.load(CONFIG / 'particle_parallel.yaml', K=-4.0, kappa=8.0, record_dt=0.2)
    assert metrics.hold_window(sparse) == pytest.approx(10 * 0.2)           # 10 samples
    band = scenario.load(CONFIG / 'particle_parallel.yaml', K=-4.0, convergence='band',
                         settle_window=12.0)
    assert metrics.hold_window(band) == 12.0
    given = scenario.load(CONFIG / 'particle_parallel.yaml', hold_window=0.7)
    assert metrics.hold_window(given) == 0.7
    with pytest.raises(ScenarioError, match='hold_window.*-1.*>= 0'):
        scenario.load(CONFIG / 'particle_parallel.yaml', hold_window=-1.0)


def _recomputed(run):
    """Return the exact circular test at each sample, from the recorded states alone."""
    w0 = run.sc.omega0
    r = run.X[:, ROW_X] + 1j * run.X[:, ROW_Y]                    # (T, N)
    c = r + 1j * np.exp(1j * run.X[:, ROW_THETA]) / w0          # (1.14), unit speed
    mean = c.mean(axis=1, keepdims=True)
    spread = abs(c - mean).max(axis=1)
    radius = abs(r - mean).mean(axis=1)
    return (spread < 1e-2) & (abs(radius * abs(w0) - 1.0) < 1e-2)


def _held(t, flags):
    out = 0.0
    for i in range(len(t) - 1, -1, -1):
        if not flags[i]:
            return None if i == len(t) - 1 else out
        out = t[-1] - t[i]
    return out


def test_a_run_cut_as_it_enters_the_test_is_not_converged_and_one_held_past_it_is():
    base = {'num_vehicles': 6, 'seed': 7}
    long = simulator.simulate(scenario.load(CONFIG / 'particle_circular.yaml', duration=40.0,
                                            **base))
    flags = _recomputed(long)
    since = long.t[np.flatnonzero(~flags)[-1] + 1]
    assert 15.0 < since < 30.0 and flags[long.t >= since].all()
    hold = metrics.hold_window(long.sc)
    assert hold == pytest.approx(2 * np.pi)
    for extra, yes in ((1.2, False), (hold + 0.2, True)):
        run = simulator.simulate(scenario.load(CONFIG / 'particle_circular.yaml',
                                               duration=round(since + extra, 1), **base))
        mine = _recomputed(run)
        assert _held(run.t, mine) == pytest.approx(round(since + extra, 1) - since)
        out, rows = report(run)
        assert out['converged'] is yes and out['held'] == pytest.approx(_held(run.t, mine))
        line = format_report('run', out, rows).splitlines()[1]
        if yes:
            assert out['convergence_time'] == pytest.approx(since)
            assert line.startswith(f'  converged          yes, from t = {since:.4g} s (held ')
        else:
            assert out['convergence_time'] is None
            assert line == ('  converged          no, not settled: held only the last 1.2 s '
                            'of the 6.283 s hold window')


def test_a_formation_that_leaves_its_test_is_not_converged():
    """Sampled out of the test at the end (mid-transient): no, with no time."""
    run = simulator.simulate(scenario.load(CONFIG / 'particle_circular.yaml', duration=6.0,
                                           num_vehicles=6, seed=7))
    mine = _recomputed(run)
    assert not mine[-1]
    out = simulator.summary(run)
    assert not out['converged'] and out['held'] is None and out['convergence_time'] is None
