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
The swarm heals a fleet that waits on a live member: it names it, restarts it, and goes on.

A member that never joins and one that stops answering while alive are made here by freezing
its process (SIGSTOP, outside the fault script, which the healer leaves alone): to the fleet
that is what a member whose TLS links never formed, or one wedged in the middleware, looks
like. The summary must name the restart and its reason, and the fleet must converge.
"""
import os
from pathlib import Path
import re
import signal
import subprocess
import tempfile
import threading
import time

from formation_control.core import scenario
from formation_control.ops import lifetime
from formation_control.protocol.fleet_plan import FleetPlan
from formation_control.sim import simulator
from formation_control.swarm import Supervisor, Swarm, SwarmOptions, wait_plant
import pytest
from rosutil import ament_prefix, BIN, CONFIG, output

LAUNCH = Path(__file__).resolve().parents[2] / 'launch' / 'fleet.launch.py'

HEAL_AFTER = 4.0


def _healed_run(ros, tmp_path, mode, freeze, when=None, duration=16.0):
    """
    Run 4 particles in ``mode``; freeze vehicle ``freeze``'s process at once or at fleet ``when``.

    Return the summary.
    """
    sc = scenario.load(CONFIG / 'particle_parallel.yaml', ['num_vehicles:=4',
                                                           f'duration:={duration}'])
    swarm = Swarm(sc, FleetPlan(4, mode), SwarmOptions(workdir=tmp_path, env=ros.env,
                                                       monitor=False, heal_after=HEAL_AFTER))
    supervisor = Supervisor(4, mode)
    try:
        with swarm:
            if when is None:
                os.kill(swarm.procs[freeze].pid, signal.SIGSTOP)
            else:
                threading.Thread(target=_freeze_at, args=(swarm, freeze, when),
                                 daemon=True).start()
            wait_plant(swarm, 240, supervisor)
    finally:
        supervisor.close()
    return swarm.result()[1]


def _freeze_at(swarm, k, when):
    end = time.monotonic() + 120
    while (swarm.t is None or swarm.t < when) and time.monotonic() < end:
        time.sleep(0.01)
    os.kill(swarm.procs[k].pid, signal.SIGSTOP)


@pytest.mark.parametrize('mode', ['lockstep', 'realtime'])
def test_a_member_that_never_joined_is_restarted_and_the_fleet_runs(ros, tmp_path, mode):
    out = _healed_run(ros, tmp_path, mode, freeze=2)
    assert [(h['process'], h['vehicles']) for h in out['healed']] == [('vehicle_2', [2])], out
    assert re.fullmatch(r'vehicles \[2\] never joined: the plant waited \d+\.\d s on them',
                        out['healed'][0]['reason'])
    assert [p['cause'] for p in out['lost']] == [f'healed: {out["healed"][0]["reason"]}']
    assert out['converged'], out


def test_a_member_that_stops_answering_is_restarted_and_the_fleet_reconverges(ros, tmp_path):
    """
    Frozen at t = 2 s, restarted past ``HEAL_AFTER`` wall seconds, the four converge again.

    In lockstep the fleet runs on without the silent vehicle at 400-1000 steps a wall second
    here: 40 s of fleet time ended about when it was healed (within the plant's 1 Hz status),
    so the run is 120 s long.
    """
    out = _healed_run(ros, tmp_path, 'lockstep', freeze=3, when=2.0, duration=120.0)
    assert [(h['process'], h['vehicles']) for h in out['healed']] == [('vehicle_3', [3])], out
    healed = out['healed'][0]
    found = re.fullmatch(r'vehicles \[3\] stopped answering: silent (\d+\.\d) s at step (\d+)',
                         healed['reason'])
    assert found and float(found[1]) > HEAL_AFTER and healed['time'] > 2.0, healed
    assert int(found[2]) == pytest.approx(healed['time'] / 0.02, abs=25)
    assert out['converged'] and out['survivors'] == [1, 2, 3, 4], out


@pytest.mark.skipif(not (BIN / 'ros2').exists(), reason='the ros2 command line is not in the '
                    'venv (make setup installs it from ../shared/ros2-tools)')
def test_a_launched_fleet_heals_a_member_that_never_joined(ros, tmp_path):
    """
    ``ros2 launch ... heal_after:=4``: the warden restarts the frozen vehicle.

    The launch starts it again (respawn), and the run ends whole and converged.
    """
    env = {**ros.env, 'AMENT_PREFIX_PATH': str(ament_prefix(tmp_path / 'prefix'))}
    log = tempfile.TemporaryFile('w+')
    launch = subprocess.Popen(
        [str(BIN / 'ros2'), 'launch', str(LAUNCH), 'scenario:=particle_parallel',
         'num_vehicles:=4', 'duration:=30', 'vehicles_per_process:=1', 'monitor:=false',
         f'heal_after:={HEAL_AFTER}', f'record_path:={tmp_path / "run.npz"}'],
        env=env, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
    launch.log = log
    ros.procs.procs.append(launch)
    end = time.monotonic() + 60
    while 'vehicle_2' not in lifetime.members(launch.pid) and time.monotonic() < end:
        time.sleep(0.05)
    os.kill(lifetime.members(launch.pid)['vehicle_2'], signal.SIGSTOP)
    launch.wait(timeout=240)
    out = output(launch)
    assert launch.returncode == 0, out[-3000:]
    healed = re.findall(r'healing (\S+): (vehicles \[2\] never joined: the plant waited '
                        r'(\d+\.\d) s on them): restarted', out)
    assert [h[0] for h in healed] == ['vehicle_2'] and float(healed[0][2]) > HEAL_AFTER, out
    run = simulator.load_run(tmp_path / 'run.npz')
    assert run.meta['complete'] and run.t[-1] == pytest.approx(30.0)
    assert simulator.summary(run)['converged']
