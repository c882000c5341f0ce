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
How often a fleet starts and recovers: ``swarm --secure`` starts and survivors after kills.

``--case secure``: ``formation-control swarm particle_parallel --secure FLEET`` of
``--vehicles`` members, ``--duration`` s, ``--tries`` times, inside a network namespace of its
own (needs root, ``ip netns``). ``--case kill``: a lockstep ``particle_parallel`` fleet of 6
whose vehicle 6 is killed at a random 0.5-2.5 s and started again at 15 s (40 s run). Each
case runs with healing on (the default) or off (``--heal-after 0``). A try succeeds when the
swarm exits 0 with the fleet converged (``kill``: the six by the end) within ``--timeout`` s.
Prints successes, the tries healed, and the Wilson 95 % interval of the success rate.

    sudo .venv/bin/python bench/healing.py --case secure --vehicles 3 --tries 50 [--no-heal]
    .venv/bin/python bench/healing.py --case kill --tries 50 [--no-heal]
"""
import argparse
import json
import os
from pathlib import Path
import random
import subprocess
import sys
import tempfile

from formation_control.sim.sweep import wilson

BIN = Path(sys.executable).parent
CONFIG = Path(__file__).resolve().parents[1] / 'config'


def swarm(argv, prefix, domain, timeout, tmp):
    """Return (succeeded, healed entries) of one ``swarm`` run."""
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    summary = Path(tmp) / f'summary{domain}.json'
    summary.unlink(missing_ok=True)
    try:
        done = subprocess.run([*prefix, str(BIN / 'formation-control'), 'swarm', *argv,
                               '--summary', str(summary), '--timeout', str(timeout)], env=env,
                              capture_output=True, text=True, timeout=timeout + 60)
    except subprocess.TimeoutExpired:
        return False, []
    if done.returncode or not summary.exists():
        return False, []
    out = json.loads(summary.read_text())
    return bool(out['converged']), out.get('healed', [])


def tries(args, tmp):
    """Yield (argv, command prefix) of each try of the case."""
    rng = random.Random(args.seed)
    heal = ['--heal-after', '0'] if args.no_heal else []
    if args.case == 'secure':
        fleet = Path(tmp) / 'fleet'
        subprocess.run([str(BIN / 'formation-control'), 'secure', str(fleet), '--vehicles',
                        str(args.vehicles)], check=True, capture_output=True)
        for _ in range(args.tries):
            yield ([str(CONFIG / 'particle_parallel.yaml'), '-p',
                    f'num_vehicles:={args.vehicles}', '--duration', str(args.duration),
                    '--secure', str(fleet), '--no-monitor', *heal],
                   ['ip', 'netns', 'exec', args.netns])
        return
    for _ in range(args.tries):
        kill = round(rng.uniform(0.5, 2.5), 2)
        yield ([str(CONFIG / 'particle_parallel.yaml'), '-p', 'num_vehicles:=6', '--duration',
                '40', '--seed', '2', '--fault', f'kill:6@{kill}', '--fault', 'restart:6@15',
                '--no-monitor', *heal], [])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--case', choices=('secure', 'kill'), default='secure')
    parser.add_argument('--vehicles', type=int, default=3)
    parser.add_argument('--duration', type=float, default=3.0)
    parser.add_argument('--tries', type=int, default=50)
    parser.add_argument('--timeout', type=float, default=120.0)
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--no-heal', action='store_true')
    parser.add_argument('--domain', type=int, default=70)
    args = parser.parse_args()
    args.netns = f'fcheal{os.getpid()}'
    if args.case == 'secure':
        subprocess.run(['ip', 'netns', 'add', args.netns], check=True)
        subprocess.run(['ip', '-n', args.netns, 'link', 'set', 'lo', 'up'], check=True)
    ok = healed = 0
    try:
        with tempfile.TemporaryDirectory() as tmp:
            for i, (argv, prefix) in enumerate(tries(args, tmp)):
                good, heals = swarm(argv, prefix, args.domain, args.timeout, tmp)
                ok += good
                healed += bool(heals)
                print(f'try {i + 1}: {"ok" if good else "FAILED"}'
                      + ''.join(f'; healed {h["process"]}: {h["reason"]}' for h in heals),
                      flush=True)
    finally:
        if args.case == 'secure':
            subprocess.run(['ip', 'netns', 'del', args.netns])
    low, high = wilson(ok, args.tries)
    what = (f'swarm --secure, {args.vehicles} members' if args.case == 'secure' else
            'kill and restart, 6 vehicles')
    print(f'{what}, healing {"off" if args.no_heal else "on"}: {ok}/{args.tries} succeeded '
          f'[{low:.3f}, {high:.3f}], {healed} healed')


if __name__ == '__main__':
    main()
