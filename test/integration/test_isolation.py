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
Tests cannot hear each other: two fleets side by side, each in its test's domain.

Every fleet a test starts is on the domain ids :func:`rosutil.domains` reserved for it (DDS
ports follow the domain, and so do Fast DDS's shared-memory ports), in the same namespace and
with the same topic names here, so that any leak would show: a lockstep fleet that took one
foreign odometry or command would no longer equal its offline run, and a probe on fleet A's
domain would hear the vehicles only fleet B has.
"""
import json
from pathlib import Path
import subprocess
import sys

from formation_control.core import scenario
from formation_control.ros import interface as itf
from formation_control.sim import simulator
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from rosutil import CONFIG, domains, Probe, ros_environment
from runs import assert_equal_runs

CLI = str(Path(sys.executable).parent / 'formation-control')
DURATION = 40.0


def _swarm(tmp_path, name, did, n, duration, *args):
    out = tmp_path / name
    out.mkdir()
    with open(out / 'swarm.log', 'w') as log:
        return subprocess.Popen(
            [CLI, 'swarm', CONFIG / 'particle_parallel.yaml', '-p', f'num_vehicles:={n}',
             '--duration', str(duration), '--out', out / 'run.npz', '--summary', out / 's.json',
             *args], env=ros_environment(did), stdout=log, stderr=subprocess.STDOUT)


def test_two_noisy_fleets_side_by_side_do_not_hear_each_other(tmp_path):
    """
    Fleet A: 3 vehicles in lockstep; fleet B: 6 in lockstep, 4x the traffic, at once.

    Each runs :data:`DURATION` s: a lockstep fleet of 8 s lived about 2 s of wall time, and under
    load a probe once discovered fleet B's plant only after it was gone (it heard nothing).
    """
    with domains(2) as (a, b):
        probes = {did: Probe(did, f'probe_{did}') for did in (a, b)}
        heard = {did: {k: probes[did].collect(Odometry, f'/vehicle_{k}/odom', itf.STATE_QOS)
                       for k in (3, 4, 6)} for did in (a, b)}
        clocks = {did: probes[did].collect(Clock, '/clock', itf.LATCHED_QOS) for did in (a, b)}
        try:
            fleets = {a: _swarm(tmp_path, 'a', a, 3, DURATION),
                      b: _swarm(tmp_path, 'b', b, 6, DURATION, '--mode', 'lockstep')}
            for (did, proc), name in zip(fleets.items(), 'ab'):
                assert probes[did].spin_until(lambda: proc.poll() is not None, timeout=240)
                assert proc.returncode == 0, (tmp_path / name / 'swarm.log').read_text()
        finally:
            for probe in probes.values():
                probe.close()
    assert heard[a][3] and heard[b][3] and heard[b][4] and heard[b][6]
    assert not heard[a][4] and not heard[a][6], 'fleet A heard fleet B'
    for did in (a, b):
        t = [c.clock.sec + 1e-9 * c.clock.nanosec for c in clocks[did]]
        assert t == sorted(t) and max(t) <= DURATION
    for name, n in (('a', 3), ('b', 6)):
        sc = scenario.load(CONFIG / 'particle_parallel.yaml', [f'num_vehicles:={n}'],
                           duration=DURATION)
        assert_equal_runs(simulator.load_run(tmp_path / name / 'run.npz'), simulator.simulate(sc))
        assert json.loads((tmp_path / name / 's.json').read_text())['num_vehicles'] == n
