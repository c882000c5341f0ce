"""
Offline simulator throughput in vehicle-steps per second (one vehicle through one control
period: its command, then dt_control / dt_integration RK4 steps), on one core.

    .venv/bin/python bench/sim_throughput.py [--sizes 10 100 1000 10000 100000] [--repeat 5]
"""
import argparse
import os
from pathlib import Path
import statistics
import time

import numpy as np

from formation_control.core import scenario
from formation_control.core.simulator import Stepper

CONFIG = Path(__file__).resolve().parents[1] / 'config'
SCENARIOS = ('rigid_circular_flow', 'particle_circular')


def seconds_per_step(name, n, min_time=1.0):
    sc = scenario.load(CONFIG / f'{name}.yaml', [f'num_vehicles:={n}'])
    stepper = Stepper(sc)
    steps, spent = 0, 0.0
    while spent < min_time:
        start = time.perf_counter()
        stepper.command()
        stepper.advance()
        spent += time.perf_counter() - start
        steps += 1
    assert np.all(np.isfinite(stepper.X))
    return spent / steps


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument('--sizes', type=int, nargs='+', default=[10, 100, 1000, 10_000, 100_000])
    parser.add_argument('--repeat', type=int, default=5)
    args = parser.parse_args()
    os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    print(f'# one core pinned of {os.cpu_count()}; median of {args.repeat} runs')
    print(f"{'scenario':22s} {'N':>7s} {'ms/step':>9s} {'vehicle-steps/s':>16s}")
    for name in SCENARIOS:
        per_step = {}
        for n in args.sizes:
            per_step[n] = statistics.median(seconds_per_step(name, n) for _ in range(args.repeat))
            print(f'{name:22s} {n:7d} {1e3 * per_step[n]:9.3f} {n / per_step[n]:16.4g}',
                  flush=True)
        lo, hi = 1000, max(args.sizes)
        if lo in per_step and hi > lo:
            ratio = per_step[hi] / per_step[lo]
            exponent = np.log(ratio) / np.log(hi / lo)
            print(f'{name:22s} time({hi})/time({lo}) = {ratio:.1f}, scaling exponent '
                  f'{exponent:.2f}')


if __name__ == '__main__':
    main()
