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
Cell C2 of docs/envelope.md on seeds no test or doc uses, from the recorded true states alone.

    .venv/bin/python tools/true_course.py [seed ...]     # 9137-9148 by default

rigid_circular_flow_center, flow estimated, no mismatch, a 0.05 m/s gust (gust_time 5 s), the
envelope's settings (band test, settle_window 10 s, dt_integration 0.02, 150 s). Each seed runs
once recorded every control period (0.02 s); the band verdict is recomputed here, without the
package's metrics, on the samples every 0.1 s (the envelope's record_dt): the course is the
direction of the central difference of the recorded positions (the motion flown, gust and all),
the centres ``r + i e^{i course} / omega0``, the speed error from the recorded u; the hold window
is derived here too (the orbit at the slowest ground speed, at least settle_window). It prints
that verdict beside the package's on the same run recorded every 0.1 s (the report's summary
and a sweep's batch) and the old proxy's (the record without its gust: the course through the
flowfield alone), with the centre spread's p95 over the last 10 s of each (issue 43, item 2).
"""
from dataclasses import replace
import sys

from formation_control.core import parameters
from formation_control.core.scenario import resolve
from formation_control.sim import simulator
import numpy as np

SEEDS = [int(s) for s in sys.argv[1:]] or list(range(9137, 9149))
BANDS = {'spread': 0.2, 'radius': 0.05, 'speed': 0.05}


def scenario(seed, record_dt):
    """Return cell C2's scenario with ``seed``, recorded every ``record_dt`` (s)."""
    base = parameters.read_params(parameters.find('rigid_circular_flow_center'))
    base.update(duration=150.0, mismatch=0.0, gust_intensity=0.05, gust_time=5.0,
                convergence='band', settle_window=10.0, dt_integration=0.02,
                flow_source='estimated', seed=seed, record_dt=record_dt)
    return resolve(base)


def velocities(r, h):
    """Return the ground velocities of positions r (T, N) sampled every h: second order."""
    v = np.empty_like(r)
    v[1:-1] = (r[2:] - r[:-2]) / (2 * h)
    v[0] = (-3 * r[0] + 4 * r[1] - r[2]) / (2 * h)
    v[-1] = (3 * r[-1] - 4 * r[-2] + r[-3]) / (2 * h)
    return v


def band_verdict(run, every=5):
    """Return (converged, centre spread p95 over the last settle_window) of a fine record."""
    sc = run.sc
    r = run.X[:, 0] + 1j * run.X[:, 1]
    v = velocities(r, run.t[1] - run.t[0])
    idx = np.unique(np.append(np.arange(0, len(run.t), every), len(run.t) - 1))
    t, r, v, u = run.t[idx], r[idx], v[idx], run.X[idx, 4]
    c = r + 1j * np.exp(1j * np.angle(v)) / sc.omega0
    mean = c.mean(axis=1, keepdims=True)
    spread = abs(c - mean).max(axis=1)
    radius_error = abs(abs(r - mean).mean(axis=1) * abs(sc.omega0) - 1)
    speed_error = abs(u - sc.u0).mean(axis=1)
    ok = (spread < BANDS['spread']) & (radius_error < BANDS['radius']) & \
        (speed_error < BANDS['speed'])
    hold = max(sc.settle_window, 2 * np.pi / (abs(sc.omega0) * (sc.u0 - abs(complex(*sc.flow)))))
    trailing = int(np.cumprod(ok[::-1]).sum())            # samples that hold to the end
    since = t[len(t) - trailing] if trailing else np.inf
    last = t >= t[-1] - sc.settle_window - 1e-9
    return bool(t[-1] - since >= hold - 1e-9), float(np.quantile(spread[last], 0.95))


def main():
    """Print each seed's verdicts and the agreement."""
    rows = []
    for seed in SEEDS:
        fine = simulator.simulate(scenario(seed, 0.02))
        mine, p95 = band_verdict(fine)
        sc = scenario(seed, 0.1)
        run = simulator.simulate(sc)
        now, old = simulator.summary(run), simulator.summary(replace(run, channels={}))
        batch = simulator.simulate(sc, simulator.initial_states(sc, [seed]),
                                   simulator.Outcome(sc), seeds=[seed]).converged()[0]
        rows.append((mine, now['converged'], bool(batch), old['converged']))
        print(f'seed {seed}: here {mine} (p95 {p95:.3f} m), package {now["converged"]} '
              f'(p95 {now["steady_state"]["centre_spread"]["p95"]:.3f} m), sweep {bool(batch)}, '
              f'old proxy {old["converged"]} '
              f'(p95 {old["steady_state"]["centre_spread"]["p95"]:.3f} m)', flush=True)
    mine, now, batch, old = np.array(rows).T
    n = len(SEEDS)
    print(f'converged: here {mine.sum()}/{n}, package {now.sum()}/{n}, sweep {batch.sum()}/{n}, '
          f'old proxy {old.sum()}/{n}; verdicts agreeing with here: package '
          f'{(now == mine).sum()}/{n}, sweep {(batch == mine).sum()}/{n}, old proxy '
          f'{(old == mine).sum()}/{n}')


if __name__ == '__main__':
    main()
