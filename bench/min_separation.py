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
Measure ``metrics.min_separation``: CPU time and peak memory against N.

On the initial state of rigid_circular_flow, one core; the CPU time is the median of
``--repeat`` calls, the peak the one tracemalloc sees.

    .venv/bin/python bench/min_separation.py [--sizes 1000 10000 100000] [--repeat 7]
"""
import argparse
import os
from pathlib import Path
import statistics
import time
import tracemalloc

from formation_control.core import scenario
from formation_control.core.scenario import initial_state
from formation_control.sim import metrics

CONFIG = Path(__file__).resolve().parents[1] / 'config'


def measure(n, repeat):
    """Return the median CPU seconds and the peak bytes of one call at N = n."""
    sc = scenario.load(CONFIG / 'rigid_circular_flow.yaml', [f'num_vehicles:={n}'])
    X = initial_state(sc)
    r = X[0] + 1j * X[1]
    times = []
    for _ in range(repeat):
        start = time.process_time()
        metrics.min_separation(r)
        times.append(time.process_time() - start)
    tracemalloc.start()
    metrics.min_separation(r)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return statistics.median(times), peak


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--sizes', type=int, nargs='+', default=[1000, 10_000, 100_000])
    parser.add_argument('--repeat', type=int, default=7)
    args = parser.parse_args()
    os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    print(f"{'N':>7s} {'ms (CPU)':>9s} {'peak MB':>8s} {'B/vehicle':>9s} {'all pairs GB':>12s}")
    for n in args.sizes:
        seconds, peak = measure(n, args.repeat)
        print(f'{n:7d} {1e3 * seconds:9.2f} {peak / 1e6:8.2f} {peak / n:9.0f} '
              f'{16 * n * n / 1e9:12.3g}', flush=True)


if __name__ == '__main__':
    main()
