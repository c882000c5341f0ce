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
import re
import signal
import threading
import time

from formation_control.core import scenario
from formation_control.protocol.fleet_plan import FleetPlan
from formation_control.swarm import Supervisor, Swarm, SwarmOptions, wait_plant
import pytest
from rosutil import CONFIG

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
    out = _healed_run(ros, tmp_path, 'lockstep', freeze=3, when=2.0, duration=40.0)
    assert [(h['process'], h['vehicles']) for h in out['healed']] == [('vehicle_3', [3])], out
    healed = out['healed'][0]
    found = re.fullmatch(r'vehicles \[3\] stopped answering: silent (\d+\.\d) s at step (\d+)',
                         healed['reason'])
    assert found and float(found[1]) > HEAL_AFTER and healed['time'] > 2.0, healed
    assert int(found[2]) == pytest.approx(healed['time'] / 0.02, abs=25)
    assert out['converged'] and out['survivors'] == [1, 2, 3, 4], out
