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
Soak and chaos: a real-time fleet for a long time under scripted faults; large fleets' start-up.

``soak``: a real-time ``--scenario`` fleet (default ``rigid_circular``: a frozen or dead
vehicle leaves the circle, so each fault disturbs the formation) of ``--vehicles`` (default 8)
for ``--duration`` fleet seconds, recording a bag, with a random fault every ``--period`` s
(default 30; seeded):
a kill (its restart 10 s later), a restart, a freeze (SIGSTOP, SIGCONT 5 s later) or a cut
link (5 s). Reported: each fault applied and recovered (the process started again, continued
or the link mended), the fleet's reconvergence time after each (the first time from which the
whole fleet holds the convergence test until the next fault, from the fault's start), every
process's memory (RSS) and CPU over time (growth from warm-up to the run's end, the plant's
exit; the peak, and the RSS at the process's own exit apart), no process left after the
end, the bag complete (closed, every fault on ``/formation/faults``).

``startup``: ``--repeat`` lockstep starts of ``particle_circular`` with N vehicles,
``--per-process`` vehicle nodes per process (default 1: N + 1 processes) and no monitor, until
every vehicle has sent its first command (it has the plant's odometry, the plant its command:
up and matched), and how many starts failed. Localhost discovery reaches 32 participants
(``fleet_plan.LOCALHOST_PARTICIPANTS``), which the swarm refuses to exceed; with
``--discovery-server`` the fleet finds itself through a Fast DDS discovery server on this host
instead, so one process per vehicle goes past 32.

    .venv/bin/python bench/soak.py soak --duration 1800             # the full soak: 30 min
    .venv/bin/python bench/soak.py soak --duration 240              # a short one
    .venv/bin/python bench/soak.py startup --sizes 8 16 --repeat 3
    .venv/bin/python bench/soak.py startup --sizes 32 64 --repeat 3 --discovery-server

Runs use ROS_DOMAIN_ID ``--domain`` (default: $ROS_DOMAIN_ID, else 89; keep it at most 101:
above, the DDS ports of a domain fall in Linux's ephemeral port range, 32768-60999) and
ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST; bench/ is not in CI's suite.
"""
import argparse
import itertools
import json
import math
import os
from pathlib import Path
import random
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
import psutil

BIN = Path(sys.executable).parent
RESTART_AFTER, CONT_AFTER, CUT_FOR = 10.0, 5.0, 5.0
SAMPLE_PERIOD = 5.0
"""Wall seconds between two samples of every process's memory and CPU."""
WARM_UP = 0.2
"""The fraction of each process's life (its longest-lived pid) before its memory growth counts."""
SERIES_POINTS = 40
"""Samples of each process's RSS kept in the report (its curve over the run)."""
ORPHAN_DEADLINE = 20.0


def _env(domain):
    return dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')


def fault_script(n, duration, period, rng):
    """Return the ``--fault`` texts and the faults' (time, kind, text) list."""
    script, episodes = [], []
    for t in np.arange(period, duration - period + 1e-9, period):
        kind = rng.choice(('kill', 'restart', 'stop', 'cut'))
        k = rng.randint(1, n)
        if kind == 'kill':
            texts = [f'kill:{k}@{t:g}', f'restart:{k}@{t + RESTART_AFTER:g}']
        elif kind == 'restart':
            texts = [f'restart:{k}@{t:g}']
        elif kind == 'stop':
            texts = [f'stop:{k}@{t:g}', f'cont:{k}@{t + CONT_AFTER:g}']
        else:
            j = k % n + 1
            texts = [f'cut:{min(j, k)}-{max(j, k)}@{t:g}..{t + CUT_FOR:g}']
        script += texts
        episodes.append((float(t), kind, ' + '.join(texts)))
    return script, episodes


def _name(proc):
    """Return a fleet process's name: plant, vehicle_K, monitor (or its executable)."""
    try:
        cmd = proc.cmdline()
    except psutil.Error:
        return None
    exe = Path(cmd[1] if len(cmd) > 1 and cmd[0].endswith('python') else cmd[0]).name
    ids = [a.split(':=')[1] for a in cmd if a.startswith('vehicle_id:=')]
    return f'vehicle_{ids[0]}' if exe == 'vehicle' and ids else exe


class Sampler:
    """Every process of a swarm (by parent), its RSS (MB) and CPU (%) every SAMPLE_PERIOD s."""

    def __init__(self, swarm):
        self.swarm = psutil.Process(swarm.pid)
        self.rows = []                           # (t, name, pid, rss MB, cpu %)
        self.procs, self.start = {}, time.monotonic()
        self.pids = set()

    def sample(self):
        t = time.monotonic() - self.start
        try:
            found = [self.swarm, *self.swarm.children()]
        except psutil.Error:
            return
        for proc in found:
            if proc.pid not in self.procs:
                self.procs[proc.pid] = proc
                proc.cpu_percent()
            proc = self.procs[proc.pid]
            self.pids.add(proc.pid)
            try:
                with proc.oneshot():
                    name = 'swarm' if proc is self.swarm else _name(proc)
                    self.rows.append((t, name, proc.pid, proc.memory_info().rss / 2**20,
                                      proc.cpu_percent()))
            except psutil.Error:
                continue

    def lives(self):
        """Per process name, the samples of its longest-lived pid."""
        out = {}
        for name in sorted({r[1] for r in self.rows if r[1]}):
            rows = [r for r in self.rows if r[1] == name]
            pid = max({r[2] for r in rows}, key=lambda p: sum(r[2] == p for r in rows))
            out[name] = (rows, [r for r in rows if r[2] == pid])
        return out

    def table(self):
        """
        Per process name: RSS after warm-up and at the run's end, growth %, mean CPU %.

        The run ends when the plant exits; what a process does after (the swarm closing the
        bag, reading the record for its summary) is its exit: ``rss_exit_MB``, apart.
        """
        lives = self.lives()
        run_end = lives['plant'][1][-1][0] if 'plant' in lives else math.inf
        out = {}
        for name, (rows, life) in lives.items():
            born, died = life[0][0], min(life[-1][0], run_end)
            running = [r for r in life if r[0] <= died] or life
            warm = [r for r in running if r[0] >= born + WARM_UP * (died - born)] or running
            rss0, rss1 = warm[0][3], warm[-1][3]
            out[name] = {'rss_warm_MB': round(rss0, 1), 'rss_end_MB': round(rss1, 1),
                         'growth_pct': round(100 * (rss1 - rss0) / rss0, 1),
                         'rss_peak_MB': round(max(r[3] for r in warm), 1),
                         'rss_exit_MB': round(life[-1][3], 1),
                         'cpu_mean_pct': round(statistics.mean(r[4] for r in life[1:] or life), 1),
                         'pids': len({r[2] for r in rows}), 'samples': len(life),
                         'rss_MB': _series(life)}
        return out


def _series(life, points=SERIES_POINTS):
    """Return (t s, RSS MB) of a process's life at about ``points`` evenly spaced samples."""
    step = max(1, len(life) // points)
    return [(round(r[0]), round(r[3], 1)) for r in life[::step] + life[-1:]]


def reconvergence(run, episodes, duration):
    """Return, per fault, seconds from its start until the whole fleet holds convergence."""
    from formation_control.protocol.faults import survivors_converged
    from formation_control.sim.simulator import Run
    members = list(range(1, run.sc.num_vehicles + 1))
    ends = [t for t, _, _ in episodes[1:]] + [duration]
    out = []
    for (t, kind, text), end in zip(episodes, ends):
        rows = (run.t >= t) & (run.t < end)
        window = Run(run.sc, run.t[rows], run.X[rows], run.U[rows])
        converged, since = survivors_converged(window, members)
        out.append({'time': t, 'fault': text,
                    'reconverged_after': None if not converged else round(since - t, 2)})
    return out


def _gone(pids, deadline=ORPHAN_DEADLINE):
    end = time.monotonic() + deadline
    while True:
        left = [p for p in pids if psutil.pid_exists(p)
                and psutil.Process(p).status() != psutil.STATUS_ZOMBIE]
        if not left or time.monotonic() > end:
            return left
        time.sleep(0.2)


def soak(args):
    from formation_control.bags.playback import Bag
    from formation_control.sim.simulator import load_run
    rng = random.Random(args.seed)
    script, episodes = fault_script(args.vehicles, args.duration, args.period, rng)
    work = Path(tempfile.mkdtemp(prefix='soak_'))
    bag, summary = work / 'bag', work / 'summary.json'
    cmd = [str(BIN / 'formation-control'), 'swarm', args.scenario, '--mode', 'realtime',
           '-p', f'num_vehicles:={args.vehicles}', '--duration', str(args.duration),
           '--bag', str(bag), '--summary', str(summary),
           *(a for f in script for a in ('--fault', f))]
    env = _env(args.domain)
    print(f'# soak: {" ".join(cmd[1:])}', flush=True)
    with open(work / 'swarm.log', 'w') as log:
        swarm = subprocess.Popen(cmd, env=env, stdout=log, stderr=subprocess.STDOUT,
                                 stdin=subprocess.DEVNULL)
        sampler, start = Sampler(swarm), time.monotonic()
        while swarm.poll() is None:
            sampler.sample()
            time.sleep(SAMPLE_PERIOD)
    wall = time.monotonic() - start
    left = _gone(sampler.pids - {swarm.pid})
    out = json.loads(summary.read_text()) if summary.exists() else {}
    run = load_run(Path(out['logs']) / 'run.npz') if out else None
    faults_topic = sum(1 for _ in Bag(bag, ['/formation/faults']).messages())
    report = {
        'command': ' '.join(cmd[1:]), 'exit': swarm.returncode, 'wall_s': round(wall, 1),
        'real_time_factor': out.get('real_time_factor'),
        'faults': len(out.get('faults', [])),
        'faults_applied': sum(f['applied'] is not None for f in out.get('faults', [])),
        'lost': [(p['process'], p['cause'], p['restarted']) for p in out.get('lost', [])],
        'unrecovered': [p['process'] for p in out.get('lost', []) if p['restarted'] is None],
        'survivors': out.get('survivors'), 'converged_at_end': out.get('survivors_converged'),
        'reconvergence': reconvergence(run, episodes, args.duration) if run else None,
        'processes': sampler.table(), 'left_running': left,
        'bag': {'closed': (bag / 'metadata.yaml').exists(),
                'messages': sum(1 for _ in Bag(bag).messages()),
                'faults_recorded': faults_topic},
        'logs': str(work)}
    print(json.dumps(report, indent=1))
    if args.out:
        Path(args.out).write_text(json.dumps(report, indent=1))


STARTED = 'first command'


DISCOVERY_PORTS = itertools.count(11888)
"""A port of its own for each start's discovery server."""


def _discovery_server(env):
    """Start a Fast DDS discovery server on this host; return it and the fleet's environment."""
    port = next(DISCOVERY_PORTS)
    venv = BIN.parent
    libs = [venv / 'lib', *sorted(venv.glob('lib/python3*/site-packages/ros_fastrtps.libs'))]
    server = subprocess.Popen([str(BIN / 'fast-discovery-server'), '-i', '0', '-l', '127.0.0.1',
                               '-p', str(port)],
                              env={**env, 'LD_LIBRARY_PATH': os.pathsep.join(map(str, libs))},
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return server, {**env, 'ROS_DISCOVERY_SERVER': f'127.0.0.1:{port}'}


def _start_once(n, args):
    """Return seconds until every vehicle commanded, or the reason the start failed."""
    work = Path(tempfile.mkdtemp(prefix='soak_start_'))
    env, server = _env(args.domain), None
    if args.discovery_server:
        server, env = _discovery_server(env)
    start = time.time()
    try:
        proc = subprocess.run(
            [str(BIN / 'formation-control'), 'swarm', 'particle_circular', '-p',
             f'num_vehicles:={n}', '--duration', '1', '--no-monitor', '--vehicles-per-process',
             str(args.per_process), '--timeout', str(args.timeout),
             '--summary', str(work / 's.json')],
            env=env, capture_output=True, text=True, timeout=args.timeout + 60)
    except subprocess.TimeoutExpired:
        return f'the swarm had not ended {args.timeout + 60:.0f} s after its start'
    finally:
        if server is not None:
            server.terminate()
            server.wait()
    if proc.returncode != 0:
        return (proc.stderr.strip().splitlines() or ['exit %d' % proc.returncode])[-1]
    logs = Path(json.loads((work / 's.json').read_text())['logs'])
    firsts = []
    for log in logs.glob('vehicle*.log'):
        seen = set()
        for line in log.read_text().splitlines():
            node = line.split('[')[3].split(']')[0] if line.count('[') >= 4 else ''
            if STARTED in line and node not in seen:
                seen.add(node)
                firsts.append(float(line.split('[')[2].split(']')[0]))
    if len(firsts) != n:
        return f'{len(firsts)} of {n} vehicles commanded'
    return max(firsts) - start


def startup(args):
    found = 'a discovery server' if args.discovery_server else 'localhost discovery'
    print(f'# startup: lockstep particle_circular, {args.per_process} vehicle(s) per process, '
          f'no monitor, {found}, {os.cpu_count()} cores, {args.repeat} starts each')
    for n in args.sizes:
        got = [_start_once(n, args) for _ in range(args.repeat)]
        times = [g for g in got if isinstance(g, float)]
        failures = [g for g in got if not isinstance(g, float)]
        median = f'{statistics.median(times):.1f} s' if times else '-'
        processes = -(-n // args.per_process) + 1
        print(f'N={n} ({processes} processes): up and matched in {median} (runs: '
              f'{", ".join(f"{t:.1f}" for t in times)}); failed {len(failures)} of '
              f'{len(got)}{": " + "; ".join(failures) if failures else ""}', flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('what', choices=('soak', 'startup'))
    parser.add_argument('--scenario', default='rigid_circular')
    parser.add_argument('--vehicles', type=int, default=8)
    parser.add_argument('--duration', type=float, default=1800.0, help='fleet seconds')
    parser.add_argument('--period', type=float, default=30.0, help='fleet seconds per fault')
    parser.add_argument('--seed', type=int, default=2)
    parser.add_argument('--out', help='write the soak report (JSON) here')
    parser.add_argument('--sizes', type=int, nargs='+', default=[8, 16, 32, 64])
    parser.add_argument('--repeat', type=int, default=3)
    parser.add_argument('--timeout', type=float, default=600.0, help='seconds per start')
    parser.add_argument('--per-process', type=int, default=1, help='vehicle nodes per process')
    parser.add_argument('--discovery-server', action='store_true',
                        help='discover through a Fast DDS discovery server on this host')
    parser.add_argument('--domain', type=int, default=int(os.environ.get('ROS_DOMAIN_ID', 89)))
    args = parser.parse_args()
    {'soak': soak, 'startup': startup}[args.what](args)


if __name__ == '__main__':
    main()
