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
What the TLS fleet costs: one lockstep swarm with ``--secure`` and with the default transports.

Runs ``formation-control swarm SCENARIO -p num_vehicles:=N --duration D`` in turn with and
without ``--secure`` (a fleet made by ``formation-control secure`` in a temporary directory),
inside a network namespace of its own, so that the TLS fleet's discovery range
(``SYSTEM_DEFAULT``: TCP to the listed peers) stays inside it. Needs root (``ip netns``).
Prints, per variant, the median wall and CPU seconds of the whole run (the swarm and its
children) and of the plant's stepping (its log: "D s simulated in W s of wall time").

    sudo .venv/bin/python bench/secure_fleet.py [--vehicles 4] [--duration 8] [--repeat 3]
"""
import argparse
import os
from pathlib import Path
import re
import statistics
import subprocess
import sys
import tempfile
import time

BIN = Path(sys.executable).parent
STEPPING = re.compile(r'simulated in ([0-9.]+) s of wall time')


def run(ns, args, domain):
    """Return (wall s, CPU s of the process tree, the plant's stepping s) of one swarm run."""
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    start = time.monotonic()
    before = os.times()
    done = subprocess.run(['ip', 'netns', 'exec', ns, str(BIN / 'formation-control'), 'swarm',
                           *args], env=env, capture_output=True, text=True, timeout=600)
    after = os.times()
    wall = time.monotonic() - start
    if done.returncode:
        raise RuntimeError(f'swarm exited with {done.returncode}: {done.stderr[-2000:]}')
    logs = re.search(r'^\s*logs\s+(\S+)', done.stdout, re.M)[1]
    stepping = float(STEPPING.search((Path(logs) / 'plant.log').read_text())[1])
    cpu = (after.children_user - before.children_user) + (after.children_system
                                                          - before.children_system)
    return wall, cpu, stepping


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--scenario', default='rigid_parallel')
    parser.add_argument('--vehicles', type=int, default=4)
    parser.add_argument('--duration', type=float, default=8.0)
    parser.add_argument('--repeat', type=int, default=3)
    args = parser.parse_args()
    ns = f'fcbench{os.getpid()}'
    subprocess.run(['ip', 'netns', 'add', ns], check=True)
    try:
        subprocess.run(['ip', '-n', ns, 'link', 'set', 'lo', 'up'], check=True)
        with tempfile.TemporaryDirectory() as tmp:
            fleet = Path(tmp) / 'fleet'
            subprocess.run([str(BIN / 'formation-control'), 'secure', str(fleet), '--vehicles',
                            str(args.vehicles)], check=True, capture_output=True)
            base = [args.scenario, '-p', f'num_vehicles:={args.vehicles}', '--duration',
                    str(args.duration)]
            variants = {'TLS fleet': base + ['--secure', str(fleet)], 'default transports': base}
            times = {name: [] for name in variants}
            for i in range(args.repeat + 1):               # the first round is a warm-up
                for name, argv in variants.items():
                    got = run(ns, argv, 60 + i % 2)
                    if i:
                        times[name].append(got)
    finally:
        subprocess.run(['ip', 'netns', 'del', ns])
    print(f'{args.scenario}, {args.vehicles} vehicles, lockstep {args.duration:g} s, '
          f'median of {args.repeat}:')
    print(f'{"":20} {"wall s":>8} {"CPU s":>8} {"stepping s":>11}')
    for name, rows in times.items():
        wall, cpu, stepping = (statistics.median(col) for col in zip(*rows))
        print(f'{name:20} {wall:8.2f} {cpu:8.2f} {stepping:11.2f}')


if __name__ == '__main__':
    main()
