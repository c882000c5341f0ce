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
Measure Monte-Carlo sweeps: one core against single runs, workers, Dask, the batch path.

    .venv/bin/python bench/sweep.py [--seeds 1000] [--scaling-seeds 400] [--single 3]

1. ``--seeds`` runs of rigid_circular (N = 5, 60 s) as one sweep pinned to one core (one
   worker process), against single runs of the same scenario: ``formation-control sim`` as a
   process (what a user ran before), and ``simulate`` + ``summary`` in this process; the
   speed-up is per run.
2. ``--scaling-seeds`` runs with 1 and 2 local workers and on a Dask LocalCluster of 2 worker
   processes (one thread each), as ratios to 1 worker.
3. The batch path at B x N = 1e5 (20 000 fleets of 5): simulated vehicle-seconds per wall
   second, one core.

The load average is printed first: the machine is shared.
"""
import argparse
import os
from pathlib import Path
import statistics
import subprocess
import sys
import tempfile
import time

from formation_control.core import parameters, scenario
from formation_control.sim import simulator, sweep
import numpy as np

CONFIG = Path(__file__).resolve().parents[1] / 'config'
CLI = Path(sys.executable).parent / 'formation-control'


def base():
    """Return rigid_circular's parameters, for 60 s (the file says 100)."""
    return dict(parameters.read_params(CONFIG / 'rigid_circular.yaml'), duration=60.0)


def timed_sweep(seeds, workers=1, scheduler=None):
    """Return the wall time of a sweep of rigid_circular over ``seeds`` seeds, and its data."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / 's.npz'
        the_plan = sweep.plan(base(), [], range(seeds), workers=max(1, workers))
        start = time.perf_counter()
        assert sweep.execute(the_plan, out, workers, scheduler) == {}
        data = sweep.merge(the_plan, out)
        return time.perf_counter() - start, data


def single_runs(count):
    """Return the median seconds of a ``sim`` process, and of simulate + summary in-process."""
    cli, inproc = [], []
    for seed in range(count):
        start = time.perf_counter()
        subprocess.run([str(CLI), 'sim', 'rigid_circular', '--duration', '60', '--seed',
                        str(seed)], check=True, capture_output=True)
        cli.append(time.perf_counter() - start)
        start = time.perf_counter()
        sc = scenario.resolve(dict(base(), seed=seed))
        simulator.summary(simulator.simulate(sc))
        inproc.append(time.perf_counter() - start)
    return statistics.median(cli), statistics.median(inproc)


def batch_rate(fleets=20000):
    """Return simulated vehicle-seconds per wall second of ``fleets`` fleets of 5 (2 s)."""
    sc = scenario.resolve(dict(base(), duration=2.0))
    X0 = simulator.initial_states(sc, range(fleets))
    start = time.perf_counter()
    out = simulator.simulate(sc, X0, simulator.Outcome(sc))
    wall = time.perf_counter() - start
    assert np.all(np.isfinite(out.X))
    return X0.shape[1] * X0.shape[2] * sc.duration / wall, wall


def dask_sweep(seeds):
    """Return the wall time of the sweep on a LocalCluster of 2 processes, 1 thread each."""
    from distributed import LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster:
        return timed_sweep(seeds, scheduler=cluster.scheduler_address)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--seeds', type=int, default=1000)
    parser.add_argument('--scaling-seeds', type=int, default=400)
    parser.add_argument('--single', type=int, default=3, help='single runs timed')
    args = parser.parse_args()
    print(f'load average {os.getloadavg()}, {os.cpu_count()} cores')
    cores = os.sched_getaffinity(0)
    os.sched_setaffinity(0, {min(cores)})             # one core, inherited by the worker
    wall, data = timed_sweep(args.seeds, workers=1)
    cli, inproc = single_runs(args.single)
    per_run = wall / args.seeds
    print(f'1. {args.seeds} seeds rigid_circular N=5 60 s, one core: {wall:.1f} s '
          f'({per_run * 1e3:.1f} ms/run, {data["converged"].mean():.3f} converged); single '
          f'runs: sim process {cli:.2f} s, in-process {inproc:.2f} s; per-run speed-up '
          f'{cli / per_run:.0f}x (sim process), {inproc / per_run:.0f}x (in-process)')
    rate, t = batch_rate()
    print(f'3. batch path B x N = 1e5: {rate:.3g} vehicle-seconds per wall second '
          f'({t:.1f} s for 2 s), one core')
    os.sched_setaffinity(0, cores)
    one, ref = timed_sweep(args.scaling_seeds, workers=1)
    two, d2 = timed_sweep(args.scaling_seeds, workers=2)
    dask, dd = dask_sweep(args.scaling_seeds)
    for d in (d2, dd):
        assert np.array_equal(d['final_x'], ref['final_x'], equal_nan=True)
    print(f'2. {args.scaling_seeds} seeds: 1 worker {one:.1f} s, 2 workers {two:.1f} s '
          f'(x{one / two:.2f}), Dask LocalCluster 2x1 {dask:.1f} s (x{one / dask:.2f}); '
          f'results identical')
    print(f'load average {os.getloadavg()}')


if __name__ == '__main__':
    main()
