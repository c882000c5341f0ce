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
The safety layer on the shipped particle circles, seed by seed (docs/separation.md).

Each scenario over the seeds with ``safety`` off and on, every run recorded and summarised
(:func:`sim.simulator.summary`): the share kept apart over the whole run with its Wilson 95 %
interval, the share converged with its interval and the median convergence time, and with the
layer on its mean active share of the vehicle-periods and the runs in which no turn kept a
pair apart (infeasible).

    .venv/bin/python bench/safety.py [--seeds 50] [--first-seed 101]
        [--scenarios particle_circular first_order_circular] [-p NAME:=VALUE ...]
"""
from pathlib import Path
import time

from formation_control.core import scenario
from formation_control.sim import simulator
from formation_control.sim.sweep import wilson
import numpy as np
from separation import seeded

CONFIG = Path(__file__).resolve().parents[1] / 'config'
SCENARIOS = ('particle_circular', 'first_order_circular')


def share(count, total):
    """Return 'p [low, high]' of count out of total, with the Wilson 95 % interval."""
    low, high = wilson(count, total)
    return f'{count / total:.2f} [{low:.2f}, {high:.2f}]'


def study(name, seeds, safety, overrides):
    """Print one scenario's line over the seeds with the layer off or on."""
    start = time.perf_counter()
    outs = [simulator.summary(simulator.simulate(scenario.load(
        CONFIG / f'{name}.yaml', [*overrides, f'seed:={s}', f'safety:={safety}'])))
        for s in seeds]
    kept = sum(o['separation']['kept_apart'] for o in outs)
    conv = [o for o in outs if o['converged']]
    when = f"{np.median([o['convergence_time'] for o in conv]):.3g} s" if conv else '-'
    layer = [o.get('safety', {}) for o in outs]
    active = f"{np.mean([s['active_fraction'] for s in layer]):.3f}" if safety == 'on' else '-'
    stuck = sum(bool(s.get('infeasible_periods')) for s in layer) if safety == 'on' else '-'
    closest = min(o['separation']['closest'] for o in outs)
    print(f'| {name} | {safety} | {share(kept, len(outs))} | {share(len(conv), len(outs))} | '
          f'{when} | {closest:.3g} m | {active} | {stuck} | '
          f'{time.perf_counter() - start:.0f} s |', flush=True)


def main():
    args, seeds = seeded(__doc__, SCENARIOS, 50)
    print('| scenario | safety | kept apart [95% Wilson] | converged [95% Wilson] | median '
          'convergence time | closest of all | active share | runs infeasible | wall |')
    print('|---|---|---|---|---|---|---|---|---|')
    for name in args.scenarios:
        for safety in ('off', 'on'):
            study(name, seeds, safety, args.overrides)


if __name__ == '__main__':
    main()
