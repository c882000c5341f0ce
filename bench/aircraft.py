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
  airframes   each aircraft of AIRFRAMES with its own turn_lag and kappa (identified): the
              start-up refusal, or the circle (powered: aircraft_circular, gliders:
              glider_circular) and the parallel formation per seed, saved as .npz and the
              figures recomputed from the recorded states here (not the package's metrics)

    .venv/bin/python bench/aircraft.py throughput [--n 16] [--duration 30]
    .venv/bin/python bench/aircraft.py lockstep [--n 8] [--duration 30]
    .venv/bin/python bench/aircraft.py steady [--seeds 1 2 3] [--turbulence 0 3]
    .venv/bin/python bench/aircraft.py airframes [--seeds 21 22] [--out DIR]
"""
import argparse
import json
from pathlib import Path
import subprocess
import sys
import tempfile
import time

from formation_control.core import aircraft, scenario
from formation_control.core.errors import ScenarioError
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


AIRFRAMES = (('c172x', 51.0), ('c172p', 51.0), ('c182', 55.0), ('J3Cub', 30.0), ('pa28', 45.0),
             ('sgs233', 28.0), ('sgs126', 30.0), ('SGS', 25.0), ('minisgs', 28.0))
"""Light aircraft and gliders of the jsbsim package, each at an airspeed it trims at."""
GLIDERS = ('sgs233', 'sgs126', 'SGS', 'minisgs')


def recorded(path, last):
    """Return the figures of a saved run from its states alone (the npz), over its ``last`` s."""
    d = np.load(path)
    sc = json.loads(str(d['params']))
    t, h = d['t'], d['altitude']
    late, half = t >= t[-1] - last, t >= t[-1] / 2
    ground = (d['u'] + 1j * d['v']) * np.exp(1j * d['theta']) + complex(*sc['flow'])
    speed = np.hypot(d['u'][half], d['v'][half])
    out = {'airspeed': (speed.min(), speed.max()),
           'altitude': float(np.max(abs(h[half] - sc['altitude'])))}
    if sc['formation'] == 'circular':
        radius = 1.0 / abs(sc['omega0'])
        r = d['x'][late] + 1j * d['y'][late]
        centre = r + radius * np.sign(sc['omega0']) * 1j * ground[late] / abs(ground[late])
        mean = centre.mean(axis=1, keepdims=True)
        out['spread'] = float(np.max(abs(centre - mean)))
        out['radius'] = float(np.max(abs(abs(r - mean).mean(axis=1) - radius)) / radius)
    else:
        course = np.angle(ground[late])
        mean = np.angle(np.exp(1j * course).mean(axis=1, keepdims=True))
        out['course'] = float(np.degrees(np.max(abs(np.angle(np.exp(1j * (course - mean)))))))
    return out


def airframes(seeds, out_dir):
    """Print the table of docs/aircraft.md, "Each aircraft with its own gains"."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    print('| aircraft | airspeed (m/s) | turn_lag, kappa | fitted lag (s) | formation | seed | '
          'converged | centre spread (m) | radius error | course error (deg) | '
          'airspeed held (m/s) | altitude error (m) |')
    print('|---|---|---|---|---|---|---|---|---|---|---|---|')
    for name, airspeed in AIRFRAMES:
        for formation in ('circular', 'parallel'):
            config = ('glider_circular' if name in GLIDERS else 'aircraft_circular'
                      ) if formation == 'circular' else 'aircraft_parallel'
            extra = [f'jsbsim_aircraft:={name}', f'airspeed:={airspeed}']
            if name in GLIDERS:
                extra.append('altitude:=1500.0')
            try:
                sc = scenario.load(CONFIG / f'{config}.yaml', extra)
            except ScenarioError as err:
                print(f'| {name} | {airspeed:g} | | | {formation} | | refused: {err} |||||',
                      flush=True)
                continue
            lag = aircraft.identify(sc).lag
            for seed in seeds:
                run = simulator.simulate(scenario.load(CONFIG / f'{config}.yaml',
                                                       extra + [f'seed:={seed}']))
                path = out_dir / f'{name}_{formation}_{seed}.npz'
                run.save(path)
                verdict = simulator.summary(run)
                mine = recorded(path, 100.0 if formation == 'circular' else 60.0)
                said = 'yes' if verdict['converged'] else f"no ({', '.join(verdict['unmet'])})"
                cells = ([f"{mine['spread']:.1f}", f"{mine['radius']:.2%}", '']
                         if formation == 'circular' else ['', '', f"{mine['course']:.2f}"])
                print(f'| {name} | {airspeed:g} | {sc.turn_lag:g}, {sc.kappa:.3g} | {lag:.2f} | '
                      f'{formation} | {seed} | {said} | ' + ' | '.join(cells) + ' | '
                      f"{mine['airspeed'][0]:.1f}-{mine['airspeed'][1]:.1f} | "
                      + ('glides' if name in GLIDERS else f"{mine['altitude']:.1f}") + ' |',
                      flush=True)


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
    p = sub.add_parser('airframes')
    p.add_argument('--seeds', type=int, nargs='+', default=[21, 22])
    p.add_argument('--out', default=tempfile.gettempdir())
    args = parser.parse_args()
    if args.what == 'steady':
        steady(args.seeds, args.turbulence)
    elif args.what == 'airframes':
        airframes(args.seeds, args.out)
    else:
        measure = {'throughput': throughput, 'lockstep': lockstep}[args.what]
        measure(args.n, args.duration, args.param)


if __name__ == '__main__':
    main()
