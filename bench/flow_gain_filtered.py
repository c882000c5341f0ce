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
The flow filter fed by the navigation filter: bandwidth against noise, measured and derived.

    .venv/bin/python bench/flow_gain_filtered.py [--seeds 2]

rigid_parallel_flow estimating the flow with ``position_filter: kalman`` (the flow estimator
takes the filter's ground and through-water velocities), Doppler and DVL noise 0.04 and
0.03 m/s, without a gust and in a 0.05 m/s gust (gust_time 5 s): the rms error of the flow
estimate per axis over the last 30 s of 40 against the filter's bandwidth, measured (dots,
seeds 200 on) and derived (``navigation.flow_error``, the discrete Lyapunov equation of the
cascade), beside the derived error of the raw feed (the unit gains) and the bandwidth
``navigation.best_flow_gain`` chooses (``flow_gain_from_noise``). Writes
docs/images/flow_gain_filtered.png.
"""
import argparse
from pathlib import Path

from formation_control.core import navigation, parameters, scenario
from formation_control.sim import simulator
import matplotlib.pyplot as plt
import numpy as np

IMAGES = Path(__file__).resolve().parents[1] / 'docs' / 'images'
GAINS = (0.3, 1.0, 3.0, 10.0, 40.0)
GUSTS = (0.0, 0.05)


def error(gain, seed, gust):
    """Return the measured rms error per axis (m/s) and the scenario."""
    sc = scenario.load(parameters.find('rigid_parallel_flow'), flow_source='estimated',
                       seed=seed, world_seed=seed, duration=40.0, gust_intensity=gust,
                       gust_time=5.0, velocity_sigma=0.04, water_sigma=0.03, flow_gain=gain,
                       position_filter='kalman')
    return simulator.rms_flow_error(sc, 10.0), sc


def panel(ax, gust, seeds):
    """Measure and draw one gust intensity; print the figures."""
    measured = {g: [error(g, s, gust)[0] for s in seeds] for g in GAINS}
    sc = error(1.0, seeds[0], gust)[1]
    lam = np.geomspace(0.1, 1.0 / sc.dt_control, 200)
    filtered = [navigation.flow_error(sc, float(x)) for x in lam]
    raw = [navigation.flow_error(sc, float(x), gains=(1.0, 1.0)) for x in lam]
    best = navigation.best_flow_gain(sc)
    print(f'gust {gust:g} m/s, channel gains k_g, k_w = {navigation.velocity_gains(sc)}')
    for g in GAINS:
        unit = navigation.flow_error(sc, g, gains=(1.0, 1.0))
        print(f'  lambda_f {g:5.1f}: measured {np.mean(measured[g]):.4f} m/s, derived '
              f'{navigation.flow_error(sc, g):.4f} (raw feed {unit:.4f}), lag '
              f'{navigation.flow_lag(sc, g):.3f} s')
    print(f'  chosen lambda_f = {best:.3g} 1/s: derived {navigation.flow_error(sc, best):.4f}; '
          f'raw feed at its best {min(raw):.4f} m/s')
    ax.loglog(lam, filtered, 'k-', label='derived, filtered feed')
    ax.loglog(lam, raw, 'r--', label='derived, raw feed')
    for g in GAINS:
        ax.plot([g] * len(measured[g]), measured[g], 'ko', ms=3)
    ax.axvline(best, color='g', lw=1, label=f'chosen {best:.2g} 1/s')
    ax.set_xlabel('flow filter bandwidth lambda_f (1/s)')
    ax.set_title(f'gust {gust:g} m/s (dots: measured)', fontsize=8)
    ax.legend(fontsize=6)


def main():
    """Measure, print and draw."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[1])
    parser.add_argument('--seeds', type=int, default=2)
    args = parser.parse_args()
    seeds = list(range(200, 200 + args.seeds))
    fig, axes = plt.subplots(1, len(GUSTS), figsize=(8.0, 3.4), sharey=True)
    for ax, gust in zip(axes, GUSTS):
        panel(ax, gust, seeds)
    axes[0].set_ylabel('flow estimate error per axis (m/s)')
    fig.tight_layout()
    IMAGES.mkdir(exist_ok=True)
    fig.savefig(IMAGES / 'flow_gain_filtered.png', dpi=110)


if __name__ == '__main__':
    main()
