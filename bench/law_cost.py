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
Measure the control-law cost per vehicle per step as a vehicle node computes it.

The node computes its own view from its odometry, then its command from the views of N
vehicles.

    .venv/bin/python bench/law_cost.py [--sizes 5 16 64]
"""
import argparse
from pathlib import Path
import statistics
import timeit

from formation_control.core import laws, scenario
from formation_control.core.control import Controller
import numpy as np

CONFIG = Path(__file__).resolve().parents[1] / 'config'


def cost(name, n, number=2000):
    sc = scenario.load(CONFIG / f'{name}.yaml', [f'num_vehicles:={n}'])
    ctrl = Controller(sc)
    X = scenario.initial_state(sc)
    fleet = ctrl.view(X)
    own = X[:, [0]]
    members = np.ones(n, bool)

    def step():
        mine = ctrl.view(own, np.zeros(1))
        view = laws.View(fleet.r, fleet.phase, fleet.rate, fleet.speed, fleet.speed_dot)
        view.speed_dot[0] = mine.speed_dot[0]
        ctrl.command(view, own, [0], members=members)
    return statistics.median(timeit.repeat(step, number=number, repeat=5)) / number


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument('--sizes', type=int, nargs='+', default=[5, 16, 64])
    args = parser.parse_args()
    print(f"{'scenario':22s} {'N':>4s} {'us/vehicle/step':>16s}")
    for name in ('particle_circular', 'rigid_circular', 'rigid_circular_flow'):
        for n in args.sizes:
            print(f'{name:22s} {n:4d} {1e6 * cost(name, n):16.1f}', flush=True)


if __name__ == '__main__':
    main()
