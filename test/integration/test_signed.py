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
Signed control topics in a TLS fleet: a member posing as another, replays, a revoked member.

Across network namespaces as test_secure: the plant and monitor on host 0, the vehicles over
hosts 1-3, the impostor (a process holding vehicle_2's key, with a TLS profile of its own)
on host 4.
"""
import os
from pathlib import Path
import subprocess
import sys
import threading

from formation_control.ops import security, signing
from formation_control.protocol.fleet_plan import FleetPlan
from formation_control.swarm import Swarm, SwarmOptions, wait_plant
import pytest
from rosutil import domains
from test_multihost import assert_equals_simulator, dropped_lines, EXACT, load, placer
from test_secure import fleet_of, INTRUDER, made_hosts, report, started

HERE = Path(__file__).resolve().parents[1]
CLI = str(Path(sys.executable).parent / 'formation-control')
POSED = 3


@pytest.fixture
def hosts():
    yield from made_hosts(5)


@pytest.fixture
def one_host():
    yield from made_hosts(1)


def start_impostor(hosts, tmp, fleet, env, model, awaited):
    """
    Start test/impostor.py on the intruders' host with vehicle_2's key; wait for it.

    The impostor starts the run once each status in ``awaited`` has counted its envelopes.
    """
    home = tmp / 'fleet' / 'vehicle_2'
    profile = tmp / 'impostor.xml'
    profile.write_text(security.profile_xml(
        security.Member('impostor', hosts.address(INTRUDER), 7995), fleet,
        home / 'key.pem', home / 'cert.pem', home / 'ca.pem'))
    env = dict(env, FASTRTPS_DEFAULT_PROFILES_FILE=str(profile),
               OPENSSL_CONF=str(home / security.OPENSSL_CONF),
               ROS_AUTOMATIC_DISCOVERY_RANGE='SYSTEM_DEFAULT')
    proc = subprocess.Popen(hosts.prefix(INTRUDER) + [
        sys.executable, str(HERE / 'impostor.py'), str(home), str(POSED), model, *awaited],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    assert proc.stdout.readline().strip() == 'probing'
    return proc


def test_a_member_posing_as_another_is_ignored_and_counted(hosts, tmp_path):
    """
    vehicle_2's key signs vehicle 3's states and commands: every receiver drops and counts them.

    The impostor also sends envelopes that claim vehicle 3's name (bad signature), vehicle 3's
    own envelopes again half a second later (replays) and plain messages on the topics; the
    lockstep run over the TLS fleet equals the offline one. The plant holds step 0 until every
    receiver has counted the impostor's envelopes (TLS discovery takes 1-10 s here), so the
    counts do not hang on how fast the run is.
    """
    n = 4
    sc = load('rigid_parallel', f'num_vehicles:={n}', 'duration:=14.0')
    fleet = fleet_of(hosts, n)
    security.write_fleet(tmp_path / 'fleet', fleet)
    hearers = [j for j in range(1, n + 1) if POSED in sc.comm_graph.neighbours(j)]
    assert hearers, 'no vehicle hears the posed one'
    statuses = ['formation_control/plant',
                *(f'formation_control/vehicle_{j}/links' for j in hearers)]
    with domains(1) as (did,):
        base = {k: v for k, v in os.environ.items() if k != 'FASTDDS_BUILTIN_TRANSPORTS'}
        base.update(ROS_DOMAIN_ID=str(did), PYTHONUNBUFFERED='1')
        impostor = start_impostor(hosts, tmp_path, fleet, base, sc.model, statuses)
        try:
            with Swarm(sc, FleetPlan(sc.num_vehicles, secure=True, recorded=True),
                       SwarmOptions(place=placer(hosts), env=base, node_params=tuple(EXACT),
                                    secure=tmp_path / 'fleet')) as swarm:
                wait_plant(swarm, 180)
                seen = report(impostor)
        finally:
            if impostor.poll() is None:
                impostor.kill()
    run, out = swarm.result()
    assert_equals_simulator(run, sc)
    assert out['converged'], out
    sent = seen['sent']
    for name in ('formation_state', 'cmd'):
        assert min(sent[f'{name}_{how}'] for how in ('plain', 'wrong_signer', 'forged')) > 100
        assert sent[f'{name}_replayed'] > 100, sent
    for name in statuses:
        counts = seen['status'][name]
        for kind in (signing.WRONG_SIGNER, signing.BAD_SIGNATURE, signing.REPLAY):
            assert int(counts[kind]) > 50, (name, kind, counts)
    lines = dropped_lines(swarm.dir)
    assert lines and len(lines) < 40 * (len(hearers) + 1), len(lines)     # throttled: 2 s
    assert all('signed by' in line for line in lines), lines[:5]


def test_a_revoked_member_is_refused(one_host, tmp_path):
    """After ``secure revoke vehicle_2``, neither the swarm nor vehicle_2 alone starts."""
    fleet = tmp_path / 'fleet'
    made = subprocess.run([CLI, 'secure', fleet, '--vehicles', '3'], capture_output=True,
                          text=True, timeout=60)
    assert made.returncode == 0, made.stderr
    revoked = subprocess.run([CLI, 'secure', 'revoke', 'vehicle_2', fleet],
                             capture_output=True, text=True, timeout=60)
    assert revoked.returncode == 0 and 'revoked: vehicle_2' in revoked.stdout, revoked.stderr
    with domains(1) as (did,):
        env = dict(os.environ, ROS_DOMAIN_ID=str(did))
        refused = subprocess.run(one_host.prefix(0) + [
            CLI, 'swarm', 'particle_parallel', '-p', 'num_vehicles:=3', '--secure', fleet],
            capture_output=True, text=True, timeout=60, env=env)
        alone = subprocess.run(one_host.prefix(0) + [
            str(Path(sys.executable).parent / 'vehicle'), '--ros-args', '-p', 'vehicle_id:=2'],
            capture_output=True, text=True, timeout=60,
            env=security.member_env(fleet, 'vehicle_2', env))
    for done in (refused, alone):
        assert done.returncode == 2, done.stderr[-2000:]
        error = done.stderr.strip().splitlines()[-1]
        assert error.startswith('error: ') and 'member vehicle_2 is revoked' in error, error


def revoke_once_running(log, fleet, ended):
    """Revoke vehicle_2 once the plant's log says real time started (or give up at ``ended``)."""
    while not ended.wait(0.2):
        if log.is_file() and 'real time starts' in log.read_text(errors='replace').replace(
                'real time starts once', ''):
            signing.revoke(fleet, 'vehicle_2')
            return


def _revoked_run(one_host, tmp_path):
    """
    Run the 3-vehicle TLS fleet and revoke vehicle_2 once it runs; return the swarm.

    None when the fleet never started in 60 s because a member's TLS link never formed (the
    plant still waits for a vehicle that started 0.1 s after it: seen in CI, 1 run in 5).
    """
    sc = load('particle_parallel', 'num_vehicles:=3', 'duration:=8.0')
    security.write_fleet(tmp_path / 'fleet', security.roster(3))
    with domains(1) as (did,):
        env = dict(os.environ, ROS_DOMAIN_ID=str(did), PYTHONUNBUFFERED='1')
        with Swarm(sc, FleetPlan(sc.num_vehicles, 'realtime', secure=True),
                   SwarmOptions(place=lambda name: one_host.prefix(0), env=env,
                                secure=tmp_path / 'fleet')) as swarm:
            ended = threading.Event()
            revoker = threading.Thread(target=revoke_once_running, args=(
                swarm.dir / 'plant.log', tmp_path / 'fleet', ended))
            revoker.start()
            try:
                wait_plant(swarm, 60)
            except TimeoutError as err:
                if 'every vehicle is up' in str(err):
                    raise
                return None
            finally:
                ended.set()
                revoker.join()
    return swarm


def test_a_member_revoked_while_the_fleet_runs_is_dropped(one_host, tmp_path):
    """
    A real-time fleet: vehicle_2 revoked once it runs is dropped by the plant and its neighbours.

    Each reloads the list within a second and counts vehicle 2's messages as ``revoked``
    (a neighbour that has a TLS link with vehicle_2 by then); the plant holds a zero command for
    it once it is gone, the others fly on. A fleet whose TLS links never all formed says
    nothing of revocation: it is run once more, and that run must start.
    """
    swarm = started(lambda d: _revoked_run(one_host, d), tmp_path)
    logs = {p.stem: p.read_text(errors='replace') for p in swarm.dir.glob('*.log')}
    for name in ('plant', 'vehicle_1', 'vehicle_3'):
        assert "reloaded: revoked ['vehicle_2']" in logs[name], logs[name][-2000:]
    # the plant hears every vehicle before real time starts; two vehicles' TLS link may form
    # later, or not within the 8 s (seen in CI: vehicle_1 never heard vehicle_2): one neighbour
    dropped = "signed by 'vehicle_2', a revoked member (revoked;"
    assert dropped in logs['plant']
    assert dropped in logs['vehicle_1'] or dropped in logs['vehicle_3'], (
        logs['vehicle_1'][-2000:], logs['vehicle_3'][-2000:])
    run, _ = swarm.result()
    assert run.t[-1] == 8.0
