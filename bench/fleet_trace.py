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

r"""
Break a fleet's step down, hop by hop, from the nodes' traces (``formation_control.ros.tracing``).

Run a fleet with ``FORMATION_CONTROL_TRACE=DIR`` in its environment, then read DIR:

    FORMATION_CONTROL_TRACE=/tmp/tr .venv/bin/formation-control swarm particle_circular \\
        -p num_vehicles:=16 -p graph:=ring --vehicles-per-process 1 --duration 4 --no-monitor
    .venv/bin/python bench/fleet_trace.py /tmp/tr [--skip 1.0]

Per message (median, p90, p99, mean in ms; CLOCK_MONOTONIC is one clock for every process of
a host): the plant's publish call; hop 1, the plant's publish of an odometry -> the vehicle's
callback entry (DDS delivery, the wake-up of the vehicle's threads and its executor, the take);
the vehicle's own parts (callback entry -> its law begins, the law, encoding and publishing the
command); hop 2, a state sent -> the neighbour's callback (decoded); hop 3, a command sent -> the
plant's callback (decoded). Lockstep: the step period and its critical path. Then the CPU time
and context switches per step (or per control period in real time) of the plant and the
vehicles between each node's first and last traced event.
"""
import argparse
import collections
from pathlib import Path

import numpy as np


def load(directory):
    """{node name: (event rows, npz)} of a trace directory."""
    out = {}
    for path in sorted(Path(directory).glob('*.npz')):
        z = np.load(path)
        out[path.stem.rsplit('_', 1)[0]] = (z['rows'], z)
    return out


def stat(name, xs):
    xs = 1e-6 * np.asarray(xs, float)
    if not len(xs):
        return print(f'{name:48s} (none)')
    print(f'{name:48s} n={len(xs):6d}  median {np.median(xs):7.3f}  p90 '
          f'{np.percentile(xs, 90):7.3f}  p99 {np.percentile(xs, 99):7.3f}  '
          f'mean {xs.mean():7.3f} ms')


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('directory')
    parser.add_argument('--skip', type=float, default=1.0,
                        help='simulated seconds left out at the start')
    args = parser.parse_args()
    nodes = load(args.directory)
    events = list(next(iter(nodes.values()))[1]['events'])
    code = {name: i for i, name in enumerate(events)}
    plant, plant_npz = nodes.pop('plant')

    def table(rows, event):
        return {(int(v), int(ns)): int(t) for _, v, ns, t in rows[rows[:, 0] == code[event]]}

    odom_pub, odom_sent = table(plant, 'odom_pub'), table(plant, 'odom_sent')
    cmd_in = table(plant, 'cmd_in')
    vehicles = {int(name.split('_')[1]): rows for name, (rows, _) in nodes.items()}
    first = min(ns for _, ns in odom_pub)
    since = first + int(args.skip * 1e9)
    sent_states = {k: table(rows, 'state_sent') for k, rows in vehicles.items()}
    parts = collections.defaultdict(list)
    for k, rows in vehicles.items():
        odom_in, law_start = table(rows, 'odom_in'), table(rows, 'law_start')
        law_end, cmd_sent = table(rows, 'law_end'), table(rows, 'cmd_sent')
        for key, t in odom_in.items():
            if key[1] < since or key not in odom_pub:
                continue
            parts['plant: publish() call'].append(odom_sent[key] - odom_pub[key])
            parts['hop 1: odometry published -> vehicle callback'].append(t - odom_pub[key])
            if key in law_start:
                parts['vehicle: callback -> law begins'].append(law_start[key] - t)
                parts['vehicle: law'].append(law_end[key] - law_start[key])
                parts['vehicle: command encoded and published'].append(
                    cmd_sent[key] - law_end[key])
                parts['vehicle: callback -> command sent'].append(cmd_sent[key] - t)
                parts['odometry published -> command sent'].append(cmd_sent[key] - odom_pub[key])
                if key in cmd_in:
                    parts['hop 3: command sent -> plant callback'].append(
                        cmd_in[key] - cmd_sent[key])
        for _, j, ns, t in rows[rows[:, 0] == code['state_in']]:
            sent = sent_states[int(j)].get((int(j), int(ns)))
            if ns >= since and sent is not None:
                parts['hop 2: state sent -> neighbour callback'].append(t - sent)
    for name, xs in parts.items():
        stat(name, xs)
    steps = plant[(plant[:, 0] == code['step']) & (plant[:, 2] >= since)]
    n = len(vehicles)
    if len(steps) > 1:
        stat('lockstep: step period (wall)', np.diff(steps[:, 3]))
        path = collections.defaultdict(list)
        for _, _, ns, t in steps[:-1]:
            pubs = [odom_sent.get((k, ns)) for k in range(1, n + 1)]
            ins = [cmd_in.get((k, ns)) for k in range(1, n + 1)]
            if None not in pubs and None not in ins:
                path['step sent -> last odometry published'].append(max(pubs) - t)
                path['step sent -> first command at the plant'].append(min(ins) - t)
                path['step sent -> last command at the plant'].append(max(ins) - t)
        for name, xs in path.items():
            stat(name, xs)
    traced = {name: npz['traced'] for name, (_, npz) in nodes.items()}
    fleet = np.sum(list(traced.values()), axis=0)
    p = plant_npz['traced']
    all_steps = int(np.count_nonzero(plant[:, 0] == code['step']))
    if all_steps:
        per, unit = all_steps, 'step'
    else:
        per, unit = 50 * p[3], 'control period (50 Hz)'
    print(f'per {unit} ({per:.0f} in {p[3]:.1f} s): CPU plant {1e3 * p[0] / per:.2f} ms, '
          f'{n} vehicles {1e3 * fleet[0] / per:.2f} ms; voluntary context switches plant '
          f'{p[1] / per:.1f}, vehicles {fleet[1] / per:.1f}; involuntary plant {p[2] / per:.1f}, '
          f'vehicles {fleet[2] / per:.1f}')


if __name__ == '__main__':
    main()
