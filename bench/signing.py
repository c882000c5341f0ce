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
What signing the control topics costs (formation_control.ops.signing).

``micro``: microseconds per sealed (signed) and per unsealed (verified) message, in this
process, for a formation state and an odometry payload (median and best of ``--repeat``
rounds of ``--count`` messages).

``fleet``: a TLS fleet made by ``formation-control secure`` with signing and one with
``--no-signing``, inside a network namespace of its own (as bench/secure_fleet.py; needs
root): the lockstep real-time factor (``--summary``) and, in real time, the vehicles'
``odom_to_command`` p50 / p99 from their ``/diagnostics`` in the swarm's bag.

    .venv/bin/python bench/signing.py micro
    sudo .venv/bin/python bench/signing.py fleet [--vehicles 4] [--duration 10] [--repeat 2]
"""
import argparse
import json
import os
from pathlib import Path
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

BIN = Path(sys.executable).parent


def micro(args):
    from formation_control.core.sensors import covariances
    from formation_control.core.scenario import resolve
    from formation_control.ops import security, signing
    from formation_control.protocol.messages import FormationState, StateWire
    from formation_control.ros.interface import odom_wire
    sc = resolve({'num_vehicles': 4})
    payloads = {
        'formation_state': ('/vehicle_1/formation_state', StateWire.of(sc, 1).encode(
            FormationState(10**9, 1.0, 2.0, 0.3, 0.1, 0.3, 0.1, 1.0))),
        'odom': ('/vehicle_1/odom', odom_wire(1, covariance=covariances(sc)).encode(
            10**9, (1.0, 2.0, 0.0, 1.0, 1.0, 0.0, 0.1)))}
    with tempfile.TemporaryDirectory() as tmp:
        security.write_fleet(Path(tmp), security.roster(1))
        vehicle, plant = (signing.load_member(Path(tmp) / m) for m in ('vehicle_1', 'plant'))
    print(f'# ECDSA P-256 / SHA-256 (cryptography), {os.cpu_count()} cores, median of '
          f'{args.repeat} x {args.count}')
    for name, (topic, payload) in payloads.items():
        signer = plant if name == 'odom' else vehicle
        seal, unseal = [], []
        for _ in range(args.repeat):
            start = time.perf_counter()
            sealed = [signer.signer.seal(topic, payload) for _ in range(args.count)]
            seal.append((time.perf_counter() - start) / args.count)
            start = time.perf_counter()
            opened = [plant.verifier.unseal(topic, data) for data in sealed]
            unseal.append((time.perf_counter() - start) / args.count)
            assert all(got == payload for got in opened)
        print(f'{name:16} payload {len(payload):4d} B, envelope {len(sealed[0]):4d} B: '
              f'seal {1e6 * statistics.median(seal):6.1f} us (best {1e6 * min(seal):6.1f}), '
              f'verify {1e6 * statistics.median(unseal):6.1f} us (best {1e6 * min(unseal):6.1f})',
              flush=True)


def swarm(ns, argv, domain):
    """Run one swarm inside namespace ``ns``; return its --summary."""
    summary = Path(tempfile.mkdtemp(prefix='signing_bench_')) / 'summary.json'
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    done = subprocess.run(['ip', 'netns', 'exec', ns, str(BIN / 'formation-control'), 'swarm',
                           *map(str, argv), '--summary', summary], env=env,
                          capture_output=True, text=True, timeout=600)
    if done.returncode:
        raise RuntimeError(f'swarm exited with {done.returncode}: {done.stderr[-2000:]}')
    return json.loads(summary.read_text())


def latencies(bag):
    """Return the median over the vehicles of their odom_to_command p50 and p99 (ms)."""
    from formation_control.bags.reader import diagnostics
    last = {}
    for _, statuses in diagnostics(bag):
        for name, _, _, values in statuses:
            if 'odom_to_command_ms_p50' in values:
                last[name] = values
    return tuple(float(np.median([float(v[f'odom_to_command_ms_{q}']) for v in last.values()]))
                 for q in ('p50', 'p99'))


def fleet_dir(tmp, extra, port, args):
    """
    Return a new fleet directory listening from ``port`` on.

    Each run has ports of its own: a TLS fleet started on the ports of one that has just
    ended is not always matched at once (docs/security.md).
    """
    directory = tmp / f'fleet_{port}'
    subprocess.run([str(BIN / 'formation-control'), 'secure', directory, '--vehicles',
                    str(args.vehicles), '--base-port', str(port), *extra],
                   check=True, capture_output=True)
    return directory


def fleet(args):
    ns = f'fcsign{os.getpid()}'
    subprocess.run(['ip', 'netns', 'add', ns], check=True)
    rows = {}
    try:
        subprocess.run(['ip', '-n', ns, 'link', 'set', 'lo', 'up'], check=True)
        with tempfile.TemporaryDirectory() as tmp:
            base = [args.scenario, '-p', f'num_vehicles:={args.vehicles}', '--duration',
                    args.duration, '--no-monitor']
            variants = {'signed': [], 'unsigned': ['--no-signing']}
            rows = {name: [] for name in variants}
            ports = iter(range(7900, 60000, 20))
            for i in range(args.repeat + 1):                # the first round is a warm-up
                for name, extra in variants.items():
                    argv = base + ['--secure', fleet_dir(Path(tmp), extra, next(ports), args)]
                    factor = swarm(ns, argv, 60 + i % 2)['real_time_factor']
                    bag = Path(tempfile.mkdtemp(prefix='signing_bench_')) / 'bag'
                    argv = base + ['--secure', fleet_dir(Path(tmp), extra, next(ports), args)]
                    swarm(ns, argv + ['--mode', 'realtime', '--bag', bag], 60 + i % 2)
                    if i:
                        rows[name].append((factor, *latencies(bag)))
                        print(name, *(f'{x:.3f}' for x in rows[name][-1]), flush=True)
    finally:
        subprocess.run(['ip', 'netns', 'del', ns])
    print(f'{args.scenario}, {args.vehicles} vehicles, {args.duration:g} s, TLS fleet, median '
          f'of {args.repeat}:')
    print(f'{"":10} {"lockstep RTF":>13} {"odom->cmd p50 ms":>17} {"p99 ms":>8}')
    for name, got in rows.items():
        factor, p50, p99 = (statistics.median(col) for col in zip(*got))
        print(f'{name:10} {factor:13.3f} {p50:17.3f} {p99:8.3f}')


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('what', choices=('micro', 'fleet'))
    parser.add_argument('--count', type=int, default=2000)
    parser.add_argument('--repeat', type=int, default=3)
    parser.add_argument('--scenario', default='rigid_parallel')
    parser.add_argument('--vehicles', type=int, default=4)
    parser.add_argument('--duration', type=float, default=10.0)
    args = parser.parse_args()
    {'micro': micro, 'fleet': fleet}[args.what](args)


if __name__ == '__main__':
    main()
