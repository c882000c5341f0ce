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
Measure the offline simulator's throughput on one core.

A Stepper runs control periods, each one ``command()`` (every vehicle's command) then
``advance()`` (``substeps`` RK4 steps of ``dt_integration`` with the command held; 4 steps of
5 ms in the scenarios measured).

Two rates are printed, both dividing by the time of whole periods (command + integration):

  RK4 veh-steps/s     one vehicle through ONE RK4 step:  N * substeps / (s per period)
  period veh-steps/s  one vehicle through ONE control period (command + substeps RK4 steps):
                      N / (s per period)

The first is the headline figure (target: >= 5e6 RK4 veh-steps/s at N = 100 000). ``cmd %``
is the share of the period spent in ``command()`` (views and control law).

    .venv/bin/python bench/sim_throughput.py [--sizes 10 100 1000 10000 100000] [--repeat 5]
"""
import argparse
import os
from pathlib import Path
import statistics
import time

from formation_control.core import scenario
from formation_control.sim.simulator import Stepper
import numpy as np

CONFIG = Path(__file__).resolve().parents[1] / 'config'
SCENARIOS = ('rigid_circular_flow', 'particle_circular')


def period_times(name, n, min_time=1.0):
    """Seconds per control period and the share of it in ``command()``, and the substeps."""
    sc = scenario.load(CONFIG / f'{name}.yaml', [f'num_vehicles:={n}'])
    stepper = Stepper(sc)
    periods, spent, commanding = 0, 0.0, 0.0
    while spent < min_time:
        start = time.perf_counter()
        stepper.command()
        middle = time.perf_counter()
        stepper.advance()
        spent += time.perf_counter() - start
        commanding += middle - start
        periods += 1
    assert np.all(np.isfinite(stepper.X))
    return spent / periods, commanding / spent, sc.substeps


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--sizes', type=int, nargs='+', default=[10, 100, 1000, 10_000, 100_000])
    parser.add_argument('--repeat', type=int, default=5)
    args = parser.parse_args()
    os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    print(f'# one core pinned of {os.cpu_count()}; median of {args.repeat} runs')
    print('# RK4 veh-step = one vehicle through one RK4 step; period veh-step = one vehicle '
          'through one control period (its command + substeps RK4 steps)')
    print(f"{'scenario':22s} {'N':>7s} {'substeps':>8s} {'ms/period':>10s} {'cmd %':>6s} "
          f"{'RK4 veh-steps/s':>16s} {'period veh-steps/s':>19s}")
    for name in SCENARIOS:
        per_period = {}
        for n in args.sizes:
            runs = [period_times(name, n) for _ in range(args.repeat)]
            per_period[n] = statistics.median(r[0] for r in runs)
            share = statistics.median(r[1] for r in runs)
            substeps = runs[0][2]
            print(f'{name:22s} {n:7d} {substeps:8d} {1e3 * per_period[n]:10.3f} '
                  f'{100 * share:6.1f} {n * substeps / per_period[n]:16.4g} '
                  f'{n / per_period[n]:19.4g}', flush=True)
        lo, hi = 1000, max(args.sizes)
        if lo in per_period and hi > lo:
            ratio = per_period[hi] / per_period[lo]
            exponent = np.log(ratio) / np.log(hi / lo)
            print(f'{name:22s} time({hi})/time({lo}) = {ratio:.1f}, scaling exponent '
                  f'{exponent:.2f}')


if __name__ == '__main__':
    main()
