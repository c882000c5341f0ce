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
JSBSim aircraft (plant_backend: jsbsim): throughput, lockstep real-time factor, steady states.

  throughput  offline, N aircraft (default 16) of config/aircraft_circular.yaml: simulated
              seconds per CPU second of this process (one core) and per wall second
  lockstep    ``formation-control swarm`` in lockstep, N aircraft (default 8): the plant's
              real-time factor (simulated / wall seconds)
  steady      the steady state of the circle (centre spread, radius error as a share of the
              radius, altitude error) and of the parallel formation (common course error),
              over the last 100 s, per seed, calm and in moderate turbulence (severity 3)

    .venv/bin/python bench/aircraft.py throughput [--n 16] [--duration 30]
    .venv/bin/python bench/aircraft.py lockstep [--n 8] [--duration 30]
    .venv/bin/python bench/aircraft.py steady [--seeds 1 2 3] [--turbulence 0 3]
"""
import argparse
import json
from pathlib import Path
import subprocess
import sys
import tempfile
import time

from formation_control.core import scenario
from formation_control.sim import simulator
import numpy as np

CONFIG = Path(__file__).resolve().parents[1] / 'config'


def throughput(n, duration, overrides=()):
    sc = scenario.load(CONFIG / 'aircraft_circular.yaml', [f'num_vehicles:={n}', *overrides])
    stepper = simulator.Stepper(sc)
    cpu, wall = time.process_time(), time.perf_counter()
    for _ in range(int(round(duration / sc.dt_control))):
        stepper.command()
        stepper.advance()
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    print(f'N = {n} aircraft, {duration:g} s simulated, JSBSim at {1 / sc.dt_integration:.0f} '
          f'Hz: {duration / cpu:.1f}x real time per CPU second (one core), '
          f'{duration / wall:.1f}x per wall second; {n * duration / cpu:.0f} aircraft-seconds '
          f'per CPU second')


def lockstep(n, duration, overrides=()):
    with tempfile.TemporaryDirectory() as tmp:
        summary = Path(tmp) / 'summary.json'
        cmd = [str(Path(sys.executable).parent / 'formation-control'), 'swarm',
               str(CONFIG / 'aircraft_circular.yaml'), '-p', f'num_vehicles:={n}',
               '--duration', str(duration), '--summary', str(summary)]
        cmd += [a for o in overrides for a in ('-p', o)]
        subprocess.run(cmd, check=True, cwd=tmp)
        out = json.loads(summary.read_text())
    print(f'lockstep ROS, N = {n} aircraft, {duration:g} s simulated: real-time factor '
          f"{out['real_time_factor']:.2f}")


def course_error(run, last):
    keep = run.t >= run.t[-1] - last
    X = run.X[keep]
    ground = (X[:, 4] + 1j * X[:, 5]) * np.exp(1j * X[:, 2]) + run.sc.flow_c
    course = np.angle(ground)
    mean = np.angle(np.exp(1j * course).mean(axis=1, keepdims=True))
    return float(np.degrees(np.max(abs(np.angle(np.exp(1j * (course - mean)))))))


def steady(seeds, turbulences, last=100.0):
    print('| formation | turbulence | seed | centre spread (m) | radius error | altitude error '
          '(m) | course error (deg) |')
    print('|---|---|---|---|---|---|---|')
    for turbulence in turbulences:
        for seed in seeds:
            extra = [f'seed:={seed}', f'turbulence:={turbulence}', f'turbulence_seed:={seed}']
            run = simulator.simulate(scenario.load(CONFIG / 'aircraft_circular.yaml', extra))
            spread, radius, altitude = simulator.aircraft_circle_errors(run, last)
            print(f'| circle of 5 | {turbulence} | {seed} | {spread:.1f} | {radius:.2%} | '
                  f'{altitude:.1f} | |', flush=True)
            run = simulator.simulate(scenario.load(CONFIG / 'aircraft_parallel.yaml', extra))
            print(f'| parallel of 4 | {turbulence} | {seed} | | | | '
                  f'{course_error(run, 60.0):.2f} |', flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    sub = parser.add_subparsers(dest='what', required=True)
    for name, n in (('throughput', 16), ('lockstep', 8)):
        p = sub.add_parser(name)
        p.add_argument('--n', type=int, default=n)
        p.add_argument('--duration', type=float, default=30.0)
        p.add_argument('-p', '--param', action='append', default=[], metavar='NAME:=VALUE')
    p = sub.add_parser('steady')
    p.add_argument('--seeds', type=int, nargs='+', default=[1, 2, 3])
    p.add_argument('--turbulence', type=int, nargs='+', default=[0, 3])
    args = parser.parse_args()
    if args.what == 'steady':
        steady(args.seeds, args.turbulence)
    else:
        measure = {'throughput': throughput, 'lockstep': lockstep}[args.what]
        measure(args.n, args.duration, args.param)


if __name__ == '__main__':
    main()
