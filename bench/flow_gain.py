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
The flow filter's bandwidth against sensor noise and gusts: measured and derived.

    .venv/bin/python bench/flow_gain.py [--seeds 3]

rigid_parallel_flow estimating the flow, a gust of 0.05 m/s per axis (gust_time 5 s), ground
and water velocity noise 0.04 and 0.03 m/s: the rms error of the flow estimate per axis over
the last 40 s of 50, for bandwidths from 0.1 to 40 1/s, against
``estimation.tracking_error`` (its gust-lag and noise terms drawn apart) and the bandwidth
``estimation.best_gain`` chooses (``flow_gain_from_noise``). Writes docs/flow_gain.png.
"""
import argparse
from pathlib import Path

from formation_control.core import estimation, parameters, scenario
from formation_control.sim import simulator
import matplotlib.pyplot as plt
import numpy as np

DOCS = Path(__file__).resolve().parents[1] / 'docs'
GAINS = (0.1, 0.3, 1.0, 2.0, 4.0, 8.0, 16.0, 40.0)


def error(gain, seed):
    """Return the measured rms error per axis (m/s) and the scenario."""
    sc = scenario.load(parameters.find('rigid_parallel_flow'), flow_source='estimated',
                       seed=seed, world_seed=seed, duration=50.0, gust_intensity=0.05,
                       gust_time=5.0, velocity_sigma=0.04, water_sigma=0.03, flow_gain=gain)
    return simulator.rms_flow_error(sc, 10.0), sc


def main():
    """Measure, print and draw."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[1])
    parser.add_argument('--seeds', type=int, default=3)
    args = parser.parse_args()
    seeds = range(100, 100 + args.seeds)
    measured = {g: [error(g, s)[0] for s in seeds] for g in GAINS}
    sc = error(1.0, 100)[1]
    lam = np.geomspace(GAINS[0], GAINS[-1], 200)
    b = 1.0 / sc.gust_time
    lag = sc.gust_intensity * np.sqrt(b / (lam + b))
    noise = np.array([estimation.filter_noise(scenario.resolve(dict(
        sc.to_dict(), flow_gain=float(x)))) for x in lam])
    best = estimation.best_gain(sc)
    for g in GAINS:
        print(f'lambda_f {g:6.2f}: measured {np.mean(measured[g]):.4f} m/s, derived '
              f'{estimation.tracking_error(sc, g):.4f}')
    print(f'chosen from the noise and the gust: lambda_f = {best:.3g} 1/s')
    fig, ax = plt.subplots(figsize=(5.5, 3.4))
    ax.loglog(lam, np.hypot(lag, noise), 'k-', label='derived rms error')
    ax.loglog(lam, lag, 'b--', label='gust lag term')
    ax.loglog(lam, noise, 'r--', label='noise term')
    for g in GAINS:
        ax.plot([g] * len(measured[g]), measured[g], 'ko', ms=3)
    ax.axvline(best, color='g', lw=1, label=f'best_gain {best:.2g} 1/s')
    ax.set_xlabel('filter bandwidth lambda_f (1/s)')
    ax.set_ylabel('flow estimate error per axis (m/s)')
    ax.set_title('flow filter: gust lag against sensor noise (dots: measured)', fontsize=8)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(DOCS / 'flow_gain.png', dpi=110)


if __name__ == '__main__':
    main()
