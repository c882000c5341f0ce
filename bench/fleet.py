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
Benchmark a fleet as ROS 2 processes (``formation-control swarm``).

Measured:

- ``rtf``: lockstep real-time factor (simulated s per wall s) at a 50 Hz control rate and
  500 Hz integration, for N vehicles, M vehicle nodes per process and each communication
  graph (``--graphs complete ring circulant:1,2``: degree d = N - 1, 2, 4), with the message
  deliveries a step costs, N d + 2 N;
- ``latency``: real-time mode, from the vehicles' diagnostics (median and p99): odometry handed
  to the node -> command sent (the node's latency), and, at real-time factor 1, odometry stamp
  -> command sent (adds transport, queueing and any lag of the plant behind the wall clock);
- ``startup``: from starting ``swarm`` until every vehicle has published its first command.

    .venv/bin/python bench/fleet.py rtf --sizes 5 16 32 --per-process 1 [--repeat 3]
    .venv/bin/python bench/fleet.py rtf --sizes 64 --per-process 8 --graphs complete ring
    .venv/bin/python bench/fleet.py latency --sizes 16 --per-process 4 --real-time-factor 0.25
    .venv/bin/python bench/fleet.py startup --sizes 16

Runs use ROS_DOMAIN_ID ``--domain`` (default: $ROS_DOMAIN_ID, else 88) and
ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST.
"""
import argparse
import json
import os
from pathlib import Path
import re
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

BIN = Path(sys.executable).parent
SCENARIO = 'particle_circular'


def graph_params(spec):
    """Return the ``-p`` arguments of a graph spec: ``complete``, ``ring``, ``circulant:1,2``."""
    kind, _, offsets = spec.partition(':')
    out = ['-p', f'graph:={kind}']
    if offsets:
        out += ['-p', f'graph_offsets:=[{offsets}]']
    return out


def degree(n, spec):
    """Return the degree of every vehicle on the graph ``spec`` of n vehicles."""
    from formation_control.core.scenario import resolve
    kind, _, offsets = spec.partition(':')
    params = {'num_vehicles': n, 'graph': kind}
    if offsets:
        params['graph_offsets'] = [int(d) for d in offsets.split(',')]
    return int(resolve(params).comm_graph.degrees().max())


def swarm(n, *args, domain, timeout=900):
    """Run swarm; returns (summary dict, wall seconds from start, start time.time())."""
    summary = Path(tempfile.mkdtemp(prefix='fleet_bench_')) / 'summary.json'
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    start = time.time()
    proc = subprocess.run([str(BIN / 'formation-control'), 'swarm', SCENARIO, '-p',
                           f'num_vehicles:={n}', '--summary', str(summary),
                           '--timeout', str(timeout - 30), *map(str, args)],
                          env=env, capture_output=True, text=True, timeout=timeout)
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr + proc.stdout)
    return json.loads(summary.read_text()), time.time() - start, start


def rtf(args):
    print(f'# lockstep, {SCENARIO}, dt_control 0.02 s, dt_integration 0.005 s, '
          f'{os.cpu_count()} cores, median of {args.repeat}')
    print(f"{'N':>4s} {'graph':>14s} {'d':>4s} {'per process':>11s} {'RTF':>7s} {'ms/step':>8s}"
          f" {'deliveries/step':>16s} {'us/delivery':>12s}")
    for n in args.sizes:
        for spec in args.graphs:
            d = degree(n, spec)
            for m in args.per_process:
                runs = [swarm(n, '--duration', args.duration, '--no-monitor',
                              '--vehicles-per-process', m, *graph_params(spec),
                              domain=args.domain)[0]['real_time_factor']
                        for _ in range(args.repeat)]
                factor = statistics.median(runs)
                step_ms = 20.0 / factor
                deliveries = n * d + 2 * n
                print(f'{n:4d} {spec:>14s} {d:4d} {m:11d} {factor:7.3f} {step_ms:8.2f} '
                      f'{deliveries:16d} {1e3 * step_ms / deliveries:12.1f}', flush=True)


def latency(args):
    print(f'# realtime, {SCENARIO}, real_time_factor {args.real_time_factor:g} (control at '
          f'{50 * args.real_time_factor:g} Hz of wall time), {os.cpu_count()} cores; per run: '
          f'median over the vehicles of their median and p99 (ms), and the worst p99')
    names = ['odom_to_command'] + (['stamp_to_command'] if args.real_time_factor == 1 else [])
    for n in args.sizes:
        runs = {name: [] for name in names}
        for _ in range(args.repeat):
            for name, figures in _latency_run(n, args).items():
                if name in runs:
                    runs[name].append(figures)
        for name, figures in runs.items():
            for p50, p99, worst in figures:
                print(f'N={n}, {args.graphs[0]}, {args.per_process[0]} per process, {name}: '
                      f'median {p50:.2f}, p99 {p99:.2f}, worst p99 {worst:.2f}')
            p50, p99, worst = np.median(figures, axis=0)
            print(f'N={n}, {args.graphs[0]}, {args.per_process[0]} per process, {name}, median of '
                  f'{len(figures)} runs: median {p50:.2f} ms, p99 {p99:.2f} ms, worst p99 '
                  f'{worst:.2f} ms', flush=True)


def _latency_run(n, args):
    """{latency name: (median of the vehicles' medians, median p99, worst p99)} of one run."""
    from formation_control.bags.reader import diagnostics
    bag = Path(tempfile.mkdtemp(prefix='fleet_bench_')) / 'bag'
    swarm(n, '--mode', 'realtime', '--duration', args.duration, '--bag', bag,
          '--real-time-factor', args.real_time_factor, *graph_params(args.graphs[0]),
          '--no-monitor', '--vehicles-per-process', args.per_process[0], domain=args.domain)
    last = {}
    for _, statuses in diagnostics(bag):
        for name, _, _, values in statuses:
            if 'odom_to_command_ms_p50' in values:
                last[name] = values
    assert len(last) == n, f'{len(last)} of {n} vehicles reported their latency'
    out = {}
    for name in ('odom_to_command', 'stamp_to_command'):
        p50 = [float(v[f'{name}_ms_p50']) for v in last.values()]
        p99 = [float(v[f'{name}_ms_p99']) for v in last.values()]
        out[name] = (np.median(p50), np.median(p99), max(p99))
    return out


STAMP = re.compile(r'\[(\d+\.\d+)\] \[vehicle_\d+\]: first command')


def startup(args):
    print(f'# lockstep, {SCENARIO}, {os.cpu_count()} cores, median of {args.repeat}')
    for n in args.sizes:
        times = []
        for _ in range(args.repeat):
            out, _, start = swarm(n, '--duration', 1.0, '--no-monitor', '--vehicles-per-process',
                                  args.per_process[0], domain=args.domain)
            firsts = []
            for log in Path(out['logs']).glob('vehicle*.log'):
                firsts += [float(m[1]) for m in STAMP.finditer(log.read_text())]
            assert len(firsts) == n, (len(firsts), n)
            times.append(max(firsts) - start)
        print(f'N={n}, {args.per_process[0]} per process: every vehicle commanding '
              f'{statistics.median(times):.2f} s after swarm started '
              f'(runs: {", ".join(f"{t:.2f}" for t in times)})', flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('what', choices=('rtf', 'latency', 'startup'))
    parser.add_argument('--sizes', type=int, nargs='+', default=[5, 16, 32])
    parser.add_argument('--per-process', type=int, nargs='+', default=[1])
    parser.add_argument('--graphs', nargs='+', default=['complete'],
                        help='communication graphs: complete, ring, circulant:1,2 '
                             '(latency: the first)')
    parser.add_argument('--duration', type=float, default=10.0)
    parser.add_argument('--repeat', type=int, default=3)
    parser.add_argument('--real-time-factor', type=float, default=1.0)
    parser.add_argument('--domain', type=int, default=int(os.environ.get('ROS_DOMAIN_ID', 88)))
    args = parser.parse_args()
    {'rtf': rtf, 'latency': latency, 'startup': startup}[args.what](args)


if __name__ == '__main__':
    main()
