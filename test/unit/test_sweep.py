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
Sweeps: batches of fleets equal single runs; workers, Dask, resume, retry and bad grids.

Batched runs are compared with :func:`simulator.simulate` and :func:`simulator.summary` of the
same seeds (the figures ``formation-control sim`` prints), to 1e-9.
"""
from dataclasses import replace
import json
import os
from pathlib import Path

from formation_control import cli
from formation_control.core import models, parameters, scenario
from formation_control.core.models import ROW_OMEGA, ROW_THETA, ROW_X, ROW_Y
from formation_control.sim import simulator, sweep
import numpy as np
import pytest

CONFIG = Path(__file__).resolve().parents[2] / 'config'
RIGID = ['-p', 'duration:=30.0', '-p', 'K:=[1.0, 2.0]']
SEEDS = 4


def rigid_base():
    return parameters.read_params(CONFIG / 'rigid_circular.yaml')


def run_cli(args, capsys):
    code = cli.main(['sweep', 'rigid_circular'] + args)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope='module')
def reference(tmp_path_factory):
    """Run a sweep in this process: 2 grid points x 4 seeds in batches of 3 (one of 1)."""
    out = tmp_path_factory.mktemp('sweep') / 'ref.npz'
    the_plan = sweep.plan(rigid_base(), RIGID[1::2], range(SEEDS), batch_size=3)
    assert sweep.execute(the_plan, out, workers=0) == {}
    return dict(sweep.merge(the_plan, out))


@pytest.mark.slow
def test_batched_runs_equal_single_runs(reference):
    d = reference
    assert d['seed'].tolist() == list(range(SEEDS)) * 2
    assert d['K'].tolist() == [1.0] * SEEDS + [2.0] * SEEDS
    assert d['converged'][:SEEDS].any() and not d['converged'].all()
    for row in range(2 * SEEDS):
        sc = scenario.resolve(dict(rigid_base(), duration=30.0, K=float(d['K'][row]),
                                   seed=int(d['seed'][row])))
        run = simulator.simulate(sc)
        want = simulator.summary(run)
        for name, r in (('final_x', ROW_X), ('final_y', ROW_Y), ('final_theta', ROW_THETA)):
            np.testing.assert_allclose(d[name][row], run.X[-1, r], rtol=0, atol=1e-9)
        assert bool(d['converged'][row]) == want['converged']
        if want['converged']:
            assert abs(d['convergence_time'][row] - want['convergence_time']) < 1e-9
        else:
            assert np.isnan(d['convergence_time'][row])
        for name in ('order_parameter', 'lyapunov', 'centre_spread', 'radius'):
            assert abs(d[name][row] - want[name]) < 1e-9, name


def test_parallel_fleets_of_16_equal_single_runs():
    sc = scenario.load(CONFIG / 'particle_parallel.yaml', duration=6.0)
    out = simulator.simulate(sc, simulator.initial_states(sc, [3, 8]), simulator.Outcome(sc))
    for b, seed in enumerate((3, 8)):
        run = simulator.simulate(replace(sc, seed=seed))
        np.testing.assert_allclose(out.X[:, b], run.X[-1], rtol=0, atol=1e-9)
        want = simulator.summary(run)
        assert abs(out.final.order[b] - want['order_parameter']) < 1e-9
        assert bool(out.flags[-1, b]) == want['converged']


@pytest.mark.slow
def test_results_do_not_depend_on_batch_size_or_workers(reference, tmp_path):
    out = tmp_path / 'w2.npz'
    the_plan = sweep.plan(rigid_base(), RIGID[1::2], range(SEEDS), batch_size=2)
    assert sweep.execute(the_plan, out, workers=2) == {}
    d = sweep.merge(the_plan, out)
    for name in ('final_x', 'final_theta', 'convergence_time', 'lyapunov'):
        np.testing.assert_array_equal(d[name], reference[name])
    assert (d['converged'] == reference['converged']).all()


@pytest.mark.slow
def test_dask_local_cluster_equals_local_sweep(reference, tmp_path, capsys):
    from distributed import LocalCluster                # the 'cluster' extra (make setup)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      protocol='tcp', dashboard_address=None) as cluster:
        out = tmp_path / 'dask.npz'
        code, text, err = run_cli(RIGID + ['--seeds', str(SEEDS), '--batch-size', '3', '--out',
                                           str(out), '--scheduler', cluster.scheduler_address],
                                  capsys)
    assert code == 0, err
    assert 'on tcp://' in err and f'{2 * SEEDS}/{2 * SEEDS} runs' in err
    with np.load(out) as d:
        for name in ('seed', 'converged', 'final_x', 'convergence_time', 'K'):
            np.testing.assert_array_equal(d[name], reference[name])


def fail_point_one(params, seeds):
    """Raise for grid point K = 2 (every try), run the others."""
    if params['K'] == 2.0:
        raise RuntimeError('injected failure')
    return sweep.run_batch(params, seeds)


def die_once(params, seeds):
    """Kill the worker process at the first try of seed 2's batch, then run normally."""
    marker = Path(os.environ['SWEEP_TEST_MARKER'])
    if 2 in seeds and not marker.exists():
        marker.write_text('died')
        os._exit(1)
    return sweep.run_batch(params, seeds)


def die_always(params, seeds):
    """Kill the worker process whenever seed 0 is in the batch."""
    if 0 in seeds:
        os._exit(1)
    return sweep.run_batch(params, seeds)


@pytest.mark.slow
def test_failed_batches_are_reported_and_resume_completes(reference, tmp_path):
    out = tmp_path / 'resume.npz'
    the_plan = sweep.plan(rigid_base(), RIGID[1::2], range(SEEDS), batch_size=3)
    failures = sweep.execute(the_plan, out, workers=0, task=fail_point_one)
    assert sorted(failures) == [2, 3]
    assert failures[2] == 'grid point 1, seeds 0-2: RuntimeError: injected failure'
    parts = sorted(p.name for p in sweep.parts_dir(out).glob('point*.npz'))
    assert parts == ['point0000_seed00000000.npz', 'point0000_seed00000003.npz']
    with pytest.raises(sweep.SweepError, match='--resume'):
        sweep.execute(the_plan, out, workers=0)
    other = sweep.plan(rigid_base(), ['duration:=30.0', 'K:=[1.0, 3.0]'], range(SEEDS),
                       batch_size=3)
    with pytest.raises(sweep.SweepError, match='another sweep'):
        sweep.execute(other, out, workers=0, resume=True)
    ran = []

    def counting(params, seeds):
        ran.append(list(seeds))
        return sweep.run_batch(params, seeds)
    again = sweep.plan(rigid_base(), RIGID[1::2], range(SEEDS), batch_size=2)
    assert sweep.execute(again, out, workers=0, resume=True, task=counting) == {}
    assert ran == [[0, 1, 2], [3]]                     # K = 2 again, in the stored batches
    d = sweep.merge(again, out)
    np.testing.assert_array_equal(d['final_x'], reference['final_x'])
    assert not sweep.parts_dir(out).exists()


@pytest.mark.slow
def test_a_dead_worker_is_retried_once_then_reported(reference, tmp_path, monkeypatch):
    monkeypatch.setenv('SWEEP_TEST_MARKER', str(tmp_path / 'marker'))
    the_plan = sweep.plan(rigid_base(), ['duration:=30.0', 'K:=1.0'], range(SEEDS),
                          batch_size=2)
    out = tmp_path / 'retry.npz'
    assert sweep.execute(the_plan, out, workers=2, task=die_once) == {}
    assert (tmp_path / 'marker').read_text() == 'died'
    d = sweep.merge(the_plan, out)
    np.testing.assert_array_equal(d['final_x'], reference['final_x'][:SEEDS])
    out = tmp_path / 'dead.npz'
    failures = sweep.execute(the_plan, out, workers=2, task=die_always)
    assert list(failures) == [0] and 'died' in failures[0]
    assert [p.name for p in sweep.parts_dir(out).glob('point*.npz')] == [
        'point0000_seed00000002.npz']


@pytest.mark.parametrize('args, message', [
    (['-p', 'K:=[]'], "grid of 'K' is empty"),
    (['-p', 'seed:=[1, 2]'], "'seed' cannot be swept (the seeds are the runs: use --seeds); "
                             'sweepable: num_vehicles, model'),
    (['-p', 'init_x:=[[1, 2]]'], "'init_x' cannot be swept"),
    (['-p', 'gain:=[1, 2]'], "'gain' cannot be swept (not a scenario parameter); sweepable: "),
    (['-p', 'K:=[1.0, -1.0]', '-p', 'kappa:=[5.0]'],
     "grid point K=-1.0, kappa=5.0: parameter 'K' = -1.0 is invalid: formation circular "
     'needs K > 0'),
    (['-p', 'flow:=[[0.0, 0.0], [2.0, 0.0]]'], 'grid point flow=[2.0, 0.0]: '
                                               "parameter 'flow' = [2.0, 0.0] is invalid"),
    (['--seeds', '0'], '--seeds must be >= 1'),
])
def test_bad_grids_are_refused_before_anything_runs(args, message, tmp_path, capsys):
    out = tmp_path / 'bad.npz'
    code, text, err = run_cli(args + ['--out', str(out)], capsys)
    assert code == 2 and message in err, err
    assert not out.exists() and not sweep.parts_dir(out).exists()


def test_cli_table_plot_and_columns(tmp_path, capsys):
    out, png = tmp_path / 's.npz', tmp_path / 's.png'
    code, text, err = run_cli(['--seeds', '3', '--duration', '2', '-p', 'kappa:=[4.0, 6.0]',
                               '--workers', '0', '--out', str(out), '--plot', str(png)], capsys)
    assert code == 0, err
    assert 'kappa=4.0' in text and 'kappa=6.0' in text and '95% CI' in text
    assert '6/6 runs' in err and 'ETA' in err
    assert png.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    with np.load(out) as d:
        assert d['final_x'].shape == (6, 5) and d['kappa'].tolist() == [4.0] * 3 + [6.0] * 3
        assert set(json.loads(str(d['axes']))) == {'kappa'}
        assert not d['converged'].any() and np.isnan(d['convergence_time']).all()
        assert not d['met_centre_spread'].any()
    assert text.splitlines()[0].endswith('failed on')
    assert 'centre_spread 3' in text.splitlines()[1]


def test_the_table_counts_the_conditions_each_grid_point_fails():
    data = {'axes': json.dumps(['K']), 'params': json.dumps([{'K': 1.0}, {'K': 2.0}]),
            'grid_point': np.array([0, 0, 1, 1]), 'converged': np.array([True, False] * 2),
            'convergence_time': np.array([1.0, np.nan] * 2),
            'met_separation': np.array([True, False, True, np.nan]),
            'met_radius': np.array([True, True, True, False])}
    rows = sweep.table(data)
    assert rows[0]['failed'] == {'separation': 1}
    assert rows[1]['failed'] == {'radius': 1}
    assert sweep.format_table(rows).splitlines()[1].endswith('separation 1')


def test_wilson_interval():
    low, high = sweep.wilson(0, 10)
    assert low == 0.0 and high == pytest.approx(0.2775, abs=1e-4)
    assert sweep.wilson(10, 10) == pytest.approx((1 - high, 1.0), abs=1e-12)
    low, high = sweep.wilson(5, 10)
    assert (low, high) == pytest.approx((0.2366, 0.7634), abs=1e-4)


def test_integration_takes_each_vehicle_on_its_own_numbers():
    """
    A vehicle integrated in a batch, in a fleet or alone: the same numbers, bit for bit.

    Batches equal single runs (and a vehicle node's prediction the simulator's) only so. Turn
    rates on both sides of the series' 0.05 rad share every block of the compiled RK4.
    """
    sc = scenario.load(CONFIG / 'rigid_circular.yaml')
    X = simulator.initial_states(sc, range(200))            # (6, 200, 5): 1000 vehicles
    X[ROW_OMEGA] = np.random.default_rng(1).normal(0.0, 15.0, X.shape[1:])
    U = np.stack([np.full(X.shape[1:], 2.0), np.sin(X[ROW_THETA])])
    plant = simulator.Controller(sc).plant
    batch = models.integrate(X, U, 0.005, 4, plant)
    assert np.sum(abs(X[ROW_OMEGA]) * 0.005 > 0.05) > 100    # both paths of the turns taken
    np.testing.assert_array_equal(
        models.integrate(X.reshape(6, -1), U.reshape(2, -1), 0.005, 4, plant),
        batch.reshape(6, -1))
    for b in (0, 77, 199):
        np.testing.assert_array_equal(models.integrate(X[:, b], U[:, b], 0.005, 4, plant),
                                      batch[:, b])
        for k in range(5):
            np.testing.assert_array_equal(
                models.integrate(X[:, b, k:k + 1], U[:, b, k:k + 1], 0.005, 4, plant),
                batch[:, b, k:k + 1])
