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
Separation of the shipped circular scenarios, seed by seed (docs/separation.md).

Each scenario over the seeds, every run recorded and judged by ``sim.separation.of_run``
(the chords between samples, exact for them) at its scenario's derived d_min: how many runs
end too close (the last sample), how many pass too close at some time (not kept apart), with
the Wilson 95 % interval of the share kept apart, the median time too close and the closest
approach of all, as a share of d_min and of the radius.

    .venv/bin/python bench/separation.py [--seeds 20] [--first-seed 101]
        [--scenarios rigid_circular particle_circular ...] [-p NAME:=VALUE ...]
"""
import argparse
from pathlib import Path
import time

from formation_control.core import scenario
from formation_control.sim import separation, simulator
from formation_control.sim.sweep import wilson
import numpy as np

CONFIG = Path(__file__).resolve().parents[1] / 'config'
SCENARIOS = ('rigid_circular', 'particle_circular', 'first_order_circular',
             'particle_circular_splay', 'rigid_circular_splay', 'vessel_circular',
             'aircraft_circular', 'glider_circular')


def study(name, seeds, overrides):
    """Print one scenario's line over the seeds."""
    base = scenario.load(CONFIG / f'{name}.yaml', overrides)
    start = time.perf_counter()
    runs = [separation.of_run(simulator.simulate(scenario.load(
        CONFIG / f'{name}.yaml', [*overrides, f'seed:={s}']))) for s in seeds]
    kept = sum(r.kept_apart for r in runs)
    end = sum(r.final_too_close for r in runs)
    low, high = wilson(kept, len(runs))
    closest = min(runs, key=lambda r: r.closest)
    radius = 1.0 / abs(base.omega0)
    print(f'| {name} | {base.num_vehicles} | {runs[0].d_min:.4g} m | {end} | '
          f'{len(runs) - kept} | {kept / len(runs):.2f} [{low:.2f}, {high:.2f}] | '
          f'{np.median([r.below for r in runs]):.4g} s | {closest.closest:.3g} m '
          f'({closest.closest / runs[0].d_min:.2g} d_min, {closest.closest / radius:.2%} R) | '
          f'{max(r.path_error for r in runs):.2g} m | {time.perf_counter() - start:.0f} s |',
          flush=True)


def seeded(doc, scenarios, seeds):
    """Return the arguments of a seeded study (``--seeds``, ``--first-seed``...), its seeds."""
    parser = argparse.ArgumentParser(description=doc.split('\n\n')[0])
    parser.add_argument('--seeds', type=int, default=seeds)
    parser.add_argument('--first-seed', type=int, default=101)
    parser.add_argument('--scenarios', nargs='+', default=scenarios)
    parser.add_argument('-p', dest='overrides', action='append', default=[])
    args = parser.parse_args()
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    print(f'seeds {seeds.start}-{seeds.stop - 1}')
    return args, seeds


def main():
    args, seeds = seeded(__doc__, SCENARIOS, 20)
    print('| scenario | N | d_min | end too close | pass too close | kept apart [95% Wilson] '
          '| median time too close | closest of all | path error | wall |')
    print('|---|---|---|---|---|---|---|---|---|---|')
    for name in args.scenarios:
        study(name, seeds, args.overrides)


if __name__ == '__main__':
    main()
