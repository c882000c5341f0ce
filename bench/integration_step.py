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
Choose each shipped scenario's RK4 step from an accuracy requirement, and time the defaults.

For each scenario file, runs of its whole ``duration`` at every candidate step that divides
``dt_control`` are compared with a reference run at ``dt_control / 40``: the error is the
largest distance between a vehicle's position and its reference position at any recorded
instant (m). The largest step whose error stays below ``--tolerance`` is the accurate one;
the step chosen is the smaller of it and ``dt_control / 4``, because the real-time plant samples
odometry and applies commands on its integration steps (a command waits up to one step to act).
The table also gives the throughput of the file's own step in simulated vehicle-seconds per second
of CPU time (one core; CPU time, so that a loaded machine does not change it much).

    .venv/bin/python bench/integration_step.py [--tolerance 1e-4] [names ...]
    .venv/bin/python bench/integration_step.py --throughput [names ...]

``--throughput`` skips the error study and prints the throughput at the file's step and at
2 ms, the step every scenario had before.
"""
import argparse
from pathlib import Path
import time

from formation_control.core import scenario
from formation_control.sim import simulator
import numpy as np

CONFIG = Path(__file__).resolve().parents[1] / 'config'
CANDIDATES = (1, 2, 4, 5, 10)
"""Substeps per control period tried (0.02, 0.01, 0.005, 0.004, 0.002 s at 50 Hz)."""


def run(path, dt_integration):
    """Return the recorded run of a scenario file at an integration step, and its CPU time."""
    sc = scenario.load(path, dt_integration=dt_integration)
    start = time.process_time()
    out = simulator.simulate(sc)
    return out, time.process_time() - start


def position_error(a, b):
    """Return the largest distance between a vehicle's positions in two runs (m)."""
    return float(np.max(np.hypot(a.X[:, 0] - b.X[:, 0], a.X[:, 1] - b.X[:, 1])))


def study(path, tolerance):
    """Return the errors per candidate step, the step chosen and the file step's throughput."""
    sc = scenario.load(path)
    reference, _ = run(path, sc.dt_control / 40)
    errors = {}
    for substeps in CANDIDATES:
        step = sc.dt_control / substeps
        errors[step] = position_error(run(path, step)[0], reference)
    accurate = max(step for step, err in errors.items() if err <= tolerance)
    _, wall = run(path, sc.dt_integration)
    return sc, errors, accurate, sc.num_vehicles * sc.duration / wall


def throughput(names):
    """Print each scenario's vehicle-seconds per CPU second at its file's step and at 2 ms."""
    print('| scenario | N | file step (ms) | veh-s per CPU s | at 2 ms | ratio |')
    print('|---|---|---|---|---|---|')
    for name in names:
        path = CONFIG / f'{name}.yaml'
        sc = scenario.load(path)
        rates = [sc.num_vehicles * sc.duration / run(path, step)[1]
                 for step in (sc.dt_integration, 0.002)]
        print(f'| {name} | {sc.num_vehicles} | {1000 * sc.dt_integration:g} | {rates[0]:.0f} '
              f'| {rates[1]:.0f} | {rates[0] / rates[1]:.2f} |', flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--tolerance', type=float, default=1e-4)
    parser.add_argument('names', nargs='*')
    parser.add_argument('--throughput', action='store_true')
    args = parser.parse_args()
    names = args.names or sorted(p.stem for p in CONFIG.glob('*.yaml'))
    if args.throughput:
        return throughput(names)
    steps = '/'.join(map(str, CANDIDATES))
    print(f'| scenario | N | duration (s) | error (m), {steps} steps per period | accurate '
          f'(ms) | chosen (ms) | file step (ms) | veh-s per CPU s |')
    print('|---|---|---|---|---|---|---|---|')
    for name in names:
        sc, errors, accurate, rate = study(CONFIG / f'{name}.yaml', args.tolerance)
        cells = ', '.join(f'{err:.1e}' for err in errors.values())
        chosen = min(accurate, sc.dt_control / 4)
        print(f'| {name} | {sc.num_vehicles} | {sc.duration:g} | {cells} | {1000 * accurate:g} '
              f'| {1000 * chosen:g} | {1000 * sc.dt_integration:g} | {rate:.0f} |', flush=True)


if __name__ == '__main__':
    main()
