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
The robustness envelope: sensor noise x model mismatch x gust intensity x seeds, per law.

    .venv/bin/python bench/envelope.py [--seeds 8] [--out /tmp/envelope] [--workers 1]
    .venv/bin/python bench/envelope.py --noise     # GNSS noise x the position filter

Each study is ``formation-control sweep`` of a shipped scenario over ``mismatch`` x
``gust_intensity`` (the band test, ``convergence: band``, at every grid point, the world-free
corner included), once per sensor level of :data:`LEVELS` (none: the vehicles measure their
state; good, moderate and poor: GNSS at 5 Hz, compass, gyro, Doppler and DVL noise, with the
onboard position filter, and an estimating vehicle's flow gain chosen from the noise),
``--seeds`` runs per point from seed 1000 on (not the seeds of the tests). It prints each
study's table (fraction converged with its Wilson interval, the steady-state errors' median /
p95 over the runs) and writes docs/envelope.md (the tables, and where each law stops holding
its bands) and docs/envelope.png (the fraction converged per grid point, a row of panels per
sensor level), again after each study; a study already merged in ``--out`` for the same plan
is read back, not run again. One integration step per control period (``dt_integration:
0.02``; the surge drag 2 h u0 / m0 = 10 1/s is resolved, 0.2 against RK4's 2.785) keeps it to
minutes of one core per study. ``--noise`` runs the sensor study instead:
GNSS noise x the position filter on rigid_circular (docs/envelope_noise.md).
"""
import argparse
import json
import os
from pathlib import Path
import time

from formation_control.core import parameters
from formation_control.sim import sweep
import matplotlib.pyplot as plt
import numpy as np

DOCS = Path(__file__).resolve().parents[1] / 'docs'
MISMATCH = (0.0, 0.02, 0.1)
GUST = (0.0, 0.01, 0.05)
STUDIES = (
    ('rigid_circular', 'known', 60.0),
    ('rigid_circular_flow_center', 'known', 150.0),
    ('rigid_circular_flow_center', 'estimated', 150.0),
    ('rigid_parallel_flow', 'known', 30.0),
    ('rigid_parallel_flow', 'estimated', 30.0),
    ('particle_circular_flow', 'known', 75.0),
    ('particle_circular_flow', 'estimated', 75.0),
)
GRID = [f'mismatch:={list(MISMATCH)}', f'gust_intensity:={list(GUST)}', 'gust_time:=5.0',
        'convergence:=band', 'settle_window:=10.0', 'dt_integration:=0.02']
LEVELS = (
    ('none', {}),
    ('good', {'gnss_sigma': 0.1, 'gnss_rate': 5.0, 'heading_sigma': 0.005,
              'yaw_rate_sigma': 0.005, 'velocity_sigma': 0.01, 'water_sigma': 0.01,
              'position_filter': 'kalman'}),
    ('moderate', {'gnss_sigma': 0.5, 'gnss_rate': 5.0, 'heading_sigma': 0.01,
                  'yaw_rate_sigma': 0.01, 'velocity_sigma': 0.03, 'water_sigma': 0.03,
                  'position_filter': 'kalman'}),
    ('poor', {'gnss_sigma': 1.0, 'gnss_rate': 5.0, 'heading_sigma': 0.02,
              'yaw_rate_sigma': 0.02, 'velocity_sigma': 0.05, 'water_sigma': 0.05,
              'position_filter': 'kalman'}),
)
"""The sensor levels: the parameters each sets (sigma per axis; m, rad, rad/s, m/s)."""


def study(name, source, duration, level, seeds, out, workers):
    """Run one study at one sensor level; return its table rows and the merged data."""
    base = parameters.read_params(parameters.find(name))
    base['duration'] = duration
    sensors = dict(LEVELS)[level]
    if sensors and source == 'estimated':
        sensors = dict(sensors, flow_gain_from_noise=True)
    grid = GRID + [f'flow_source:={source}']
    grid += [f'{key}:={json.dumps(value)}' for key, value in sensors.items()]
    the_plan = sweep.plan(base, grid, range(1000, 1000 + seeds), workers=workers)
    path = Path(out) / f'{name}_{source}_{level}.npz'
    data = merged(the_plan, path)
    if data is None:
        failures = sweep.execute(the_plan, path, workers)
        if failures:
            raise SystemExit(f'{name} {source} {level}: {failures}')
        data = sweep.merge(the_plan, path)
    rows = sweep.table(data)
    for r, g in zip(rows, range(len(rows))):
        r['diverged'] = int(np.count_nonzero(data['diverged'][data['grid_point'] == g]))
    return rows


def merged(the_plan, path):
    """Return the merged sweep at ``path`` if it is of this very plan, else None."""
    if not path.exists():
        return None
    data = dict(np.load(path))
    same = json.loads(str(data['params'])) == json.loads(json.dumps(the_plan.points)) and \
        sorted(set(data['seed'].tolist())) == list(the_plan.seeds)
    return data if same else None


def fractions(rows):
    """Return the fraction converged as a (mismatch, gust) array."""
    return np.array([r['fraction'] for r in rows]).reshape(len(MISMATCH), len(GUST))


def stops(rows, half=0.5):
    """Return where a law stops: the least gust (no mismatch), mismatch (no gust) below half."""
    grid = fractions(rows)
    gust = next((f'{g:g}' for g, f in zip(GUST, grid[0]) if f < half), f'> {GUST[-1]:g}')
    spread = next((f'{m:g}' for m, f in zip(MISMATCH, grid[:, 0]) if f < half),
                  f'> {MISMATCH[-1]:g}')
    return gust, spread, grid[0, 0]


def markdown(results, seeds, wall):
    """Return docs/envelope.md."""
    levels = '; '.join(f"{name}: {', '.join(f'{k} {v}' for k, v in params.items()) or 'exact'}"
                       for name, params in LEVELS)
    lines = ['# The robustness envelope (generated by bench/envelope.py)', '',
             f'{seeds} runs per grid point (seeds 1000-{999 + seeds}), sensor level x model '
             f'mismatch spread x gust intensity (gust_time 5 s), the band test over the last '
             f'10 s (bands: centre spread 0.2 m, radius error 0.05, course spread 0.05 rad, '
             f'speed error 0.05 m/s); {wall:.0f} s of wall time on a shared, loaded 2-core '
             'machine (noisy). Sensor levels (' + levels + '); estimating vehicles with '
             'sensors take the flow gain chosen from the noise (`flow_gain_from_noise`). See '
             '[robustness.md](robustness.md) for what it means.', '',
             '## Where each law stops holding its bands', '',
             'The least gust (m/s, no mismatch) and the least mismatch spread (no gust) at which '
             'fewer than half the runs converge, and the fraction converged with neither.', '',
             '| law | flow | sensors | stops at gust | stops at mismatch | converged, no gust '
             'or mismatch |', '|---|---|---|---|---|---|']
    for (name, source, _, level), rows in results:
        gust, spread, clean = stops(rows)
        lines.append(f'| {name} | {source} | {level} | {gust} | {spread} | {clean:.2f} |')
    lines.append('')
    for (name, source, duration, level), rows in results:
        lines += [f'## {name}, flow {source}, sensors {level}, {duration:g} s', '',
                  '| grid point | runs | converged | 95% Wilson | diverged | steady-state p95: '
                  'median / p95 over runs |', '|---|---|---|---|---|---|']
        for r in rows:
            steady = ', '.join(f'{k} {m:.3g} / {q:.3g}' for k, (m, q) in r['steady'].items())
            lines.append(f"| {r['label']} | {r['runs']} | {r['fraction']:.2f} | "
                         f"[{r['low']:.2f}, {r['high']:.2f}] | {r['diverged']} | {steady} |")
        lines.append('')
    return '\n'.join(lines)


def figure(results, path):
    """Draw the fraction converged over mismatch x gust: a row per sensor level, law by law."""
    studies = list(dict.fromkeys(key[:3] for key, _ in results))
    levels = list(dict.fromkeys(key[3] for key, _ in results))
    fig, axes = plt.subplots(len(levels), len(studies),
                             figsize=(2.2 * len(studies) + 0.6, 2.3 * len(levels) + 0.5),
                             squeeze=False)
    for (name, source, duration, level), rows in results:
        ax = axes[levels.index(level), studies.index((name, source, duration))]
        grid = fractions(rows)
        ax.imshow(grid.T, origin='lower', vmin=0, vmax=1, cmap='RdYlGn')
        for i in range(len(MISMATCH)):
            for j in range(len(GUST)):
                ax.text(i, j, f'{grid[i, j]:.1f}', ha='center', va='center', fontsize=8)
        ax.set_title(f'{name}\n{source}, sensors {level}', fontsize=6)
        ax.set_xticks(range(len(MISMATCH)), [f'{m:g}' for m in MISMATCH], fontsize=6)
        ax.set_yticks(range(len(GUST)), [f'{g:g}' for g in GUST], fontsize=6)
    for ax in axes[-1]:
        ax.set_xlabel('mismatch')
    for ax in axes[:, 0]:
        ax.set_ylabel('gust sigma (m/s)')
    fig.suptitle('fraction converged (band test)', fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100, bbox_inches='tight')
    plt.close(fig)


NOISE = ['gnss_sigma:=[0.0, 0.1, 0.5, 1.0]', "position_filter:=['none', 'kalman']",
         'gnss_rate:=5.0', 'velocity_sigma:=0.02', 'convergence:=band', 'settle_window:=10.0',
         'dt_integration:=0.02']


def noise_study(seeds, out, workers):
    """GNSS noise x the position filter on rigid_circular (60 s): write docs/envelope_noise.md."""
    base = parameters.read_params(parameters.find('rigid_circular'))
    base['duration'] = 60.0
    the_plan = sweep.plan(base, NOISE, range(1000, 1000 + seeds), workers=workers)
    path = Path(out) / 'rigid_circular_noise.npz'
    if sweep.execute(the_plan, path, workers):
        raise SystemExit('the noise study failed')
    rows = sweep.table(sweep.merge(the_plan, path))
    text = sweep.format_table(rows)
    print(f'\nrigid_circular, GNSS noise at 5 Hz x position filter:\n{text}', flush=True)
    lines = ['# GNSS noise and the position filter (generated by bench/envelope.py --noise)', '',
             f'rigid_circular, 60 s, {seeds} runs per grid point (seeds 1000-{999 + seeds}); '
             'fixes at 5 Hz, Doppler velocity noise 0.02 m/s, the band test over the last '
             '10 s. See [robustness.md](robustness.md).', '',
             '| grid point | runs | converged | 95% Wilson | steady-state p95: median / p95 '
             'over runs |', '|---|---|---|---|---|']
    for r in rows:
        steady = ', '.join(f'{k} {m:.3g} / {q:.3g}' for k, (m, q) in r['steady'].items())
        lines.append(f"| {r['label']} | {r['runs']} | {r['fraction']:.2f} | "
                     f"[{r['low']:.2f}, {r['high']:.2f}] | {steady} |")
    (DOCS / 'envelope_noise.md').write_text('\n'.join(lines) + '\n')


def main():
    """Run every study, print and write the tables and the figure."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[1])
    parser.add_argument('--seeds', type=int, default=8)
    parser.add_argument('--out', default='/tmp/envelope')
    parser.add_argument('--workers', type=int, default=1)
    parser.add_argument('--noise', action='store_true', help='only the GNSS-noise study')
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    print(f'load average {os.getloadavg()}', flush=True)
    if args.noise:
        noise_study(args.seeds, args.out, args.workers)
        return
    start, results = time.time(), []
    for level, _ in LEVELS:
        for name, source, duration in STUDIES:
            rows = study(name, source, duration, level, args.seeds, args.out, args.workers)
            print(f'\n{name}, flow {source}, sensors {level}:\n{sweep.format_table(rows)}',
                  flush=True)
            results.append(((name, source, duration, level), rows))
            wall = time.time() - start
            (DOCS / 'envelope.md').write_text(markdown(results, args.seeds, wall))
            figure(results, DOCS / 'envelope.png')
            Path(args.out, 'tables.json').write_text(json.dumps(
                [[list(k), rows] for k, rows in results], default=float))
    print(f'\n{wall:.0f} s; wrote {DOCS / "envelope.md"} and {DOCS / "envelope.png"}')


if __name__ == '__main__':
    main()
