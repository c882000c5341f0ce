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
The fleet across hosts: the plant on one network namespace, the vehicles over three others.

Discovery over the private test subnet (``ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET``). Fast DDS
would carry data between processes of one machine through shared memory, which namespaces do
not separate; ``FASTDDS_BUILTIN_TRANSPORTS=UDPv4`` keeps every byte on the (cuttable) network,
as between real computers.
"""
import os
from pathlib import Path
import subprocess
import sys
import threading
import time

from formation_control.core import scenario
from formation_control.protocol.fleet_plan import FleetPlan
from formation_control.sim import simulator
from formation_control.swarm import run_swarm, stop, Swarm, SwarmOptions, wait_plant
from hosts import Hosts, HostsUnavailable
import numpy as np
import pytest
from rosutil import CONFIG, domains, shm_clean

VEHICLE_HOSTS = 3
DISCOVERY_PORT = 11811
# Runs that must equal the offline simulator give up no peer: a UDP sample lost between hosts
# waits for the writer's next heartbeat (3 s), beyond the default liveness timeouts.
EXACT = ('neighbor_timeout:=60.0', 'command_timeout:=120.0')


@pytest.fixture
def hosts():
    try:
        with Hosts(1 + VEHICLE_HOSTS) as made:
            yield made
    except HostsUnavailable as err:
        pytest.skip(str(err))


def fleet_env(did, **extra):
    env = dict(os.environ, ROS_DOMAIN_ID=str(did), ROS_AUTOMATIC_DISCOVERY_RANGE='SUBNET',
               FASTDDS_BUILTIN_TRANSPORTS='UDPv4', PYTHONUNBUFFERED='1', **extra)
    env.pop('RMW_IMPLEMENTATION', None)
    return env


def host_of(name):
    """Place the plant and monitor on host 0, vehicle k on host 1 + (k - 1) mod 3."""
    if name.startswith('vehicle_'):
        return 1 + (int(name.split('_')[1]) - 1) % VEHICLE_HOSTS
    assert name in ('plant', 'monitor'), name
    return 0


def placer(hosts):
    return lambda name: hosts.prefix(host_of(name))


def load(name, *overrides, seed=1):
    return scenario.load(CONFIG / f'{name}.yaml', overrides, seed=seed)


def assert_equals_simulator(run, sc):
    ref = simulator.simulate(sc)
    np.testing.assert_allclose(run.X, ref.X, rtol=0, atol=1e-9)


def dropped_lines(logs):
    return [line for path in Path(logs).glob('*.log')
            for line in path.read_text(errors='replace').splitlines() if 'dropped' in line]


def test_fleet_across_hosts_equals_the_offline_run(hosts):
    """
    Lockstep across hosts equals the offline run.

    From the first step: 4 s show it (the fleet across hosts converges in the link-cut test).
    """
    sc = load('rigid_parallel', 'num_vehicles:=6', 'duration:=4.0')
    with domains(1) as (did,):
        try:
            run, out = run_swarm(sc, SwarmOptions(place=placer(hosts), env=fleet_env(did),
                                                  node_params=tuple(EXACT)), timeout=120)
        finally:
            shm_clean(fleet_env(did))
    assert_equals_simulator(run, sc)
    assert dropped_lines(out['logs']) == []


def first_commands(swarm, n, timeout):
    logs = [swarm.dir / f'vehicle_{k}.log' for k in range(1, n + 1)]
    end = time.monotonic() + timeout
    while not all('first command' in p.read_text(errors='replace') for p in logs):
        swarm.check()
        assert time.monotonic() < end, 'not every vehicle commanded in time'
        time.sleep(0.1)


def zero_spans(t, U, k):
    """
    Return the (start, end) times of the runs of exactly zero command of vehicle ``k``.

    After its first command (before it, the real-time plant runs while discovery across hosts
    goes on: 3 s seen).
    """
    zero = np.all(U[:, :, k - 1] == 0.0, axis=1)
    assert not zero.all(), f'vehicle {k} never commanded'
    zero[:np.argmin(zero)] = False
    edges = np.flatnonzero(np.diff(np.r_[0, zero.astype(int), 0]))
    return [(t[a], t[b - 1]) for a, b in zip(edges[::2], edges[1::2])]


def test_link_cut_mid_run_and_the_formation_recovers(hosts):
    """
    Host 1 (vehicles 1 and 4) is unplugged for 5 s, in real time, before convergence.

    Seen: their commands stop from 2.2 s to 5.6 s, the six converge at 13.2 s.
    """
    sc = load('rigid_parallel', 'num_vehicles:=6', 'duration:=24.0')
    cut_host, cut_for = 1, 5.0
    with domains(1) as (did,):
        env = fleet_env(did)
        try:
            with Swarm(sc, FleetPlan(sc.num_vehicles, 'realtime'),
                       SwarmOptions(monitor=False, place=placer(hosts), env=env)) as swarm:
                first_commands(swarm, sc.num_vehicles, 60)
                hosts.link(cut_host, up=False)
                try:
                    time.sleep(cut_for)                   # the cut itself lasts cut_for
                    swarm.check()
                finally:
                    hosts.link(cut_host, up=True)
                wait_plant(swarm, 120)
        finally:
            shm_clean(env)
    run, out = swarm.result()
    cut = [k for k in range(1, 7) if host_of(f'vehicle_{k}') == cut_host]
    spans = {k: zero_spans(run.t, run.U, k) for k in range(1, 7)}
    for k in range(1, 7):
        if k in cut:
            (start, end), = spans[k]
            assert 1.5 < end - start < cut_for + 2.0, spans[k]
        else:
            assert spans[k] == [], f"vehicle {k} on the plant's side stopped commanding"
    after = run.t > end + 0.5
    assert np.all(np.any(run.U[after][:, :, [k - 1 for k in cut]] != 0.0, axis=1))
    assert out['converged'], out
    assert out['convergence_time'] > end


def test_two_fleets_on_two_domains_never_hear_each_other(hosts):
    """Same hosts, same topics, same steps, different initial states: each equals its own run."""
    fleets = [load('particle_circular', 'num_vehicles:=6', 'duration:=3.0', seed=seed)
              for seed in (1, 2)]
    assert not np.allclose(simulator.simulate(fleets[0]).X[-1],
                           simulator.simulate(fleets[1]).X[-1])
    results = [None, None]

    def fly(i, did):
        try:
            results[i] = run_swarm(fleets[i], SwarmOptions(
                monitor=False, place=placer(hosts), env=fleet_env(did),
                node_params=tuple(EXACT)), timeout=120)
        except Exception as err:
            results[i] = err

    with domains(2) as dids:
        threads = [threading.Thread(target=fly, args=(i, did)) for i, did in enumerate(dids)]
        try:
            for th in threads:
                th.start()
            for th in threads:
                th.join()
        finally:
            shm_clean(fleet_env(dids[0]))
    for result, sc in zip(results, fleets):
        assert not isinstance(result, Exception), result
        run, out = result
        assert_equals_simulator(run, sc)
        assert dropped_lines(out['logs']) == []


def discovery_server(hosts, did):
    venv = Path(sys.executable).parents[1]
    libs = [venv / 'lib', *sorted(venv.glob('lib/python3*/site-packages/ros_fastrtps.libs'))]
    env = fleet_env(did, LD_LIBRARY_PATH=os.pathsep.join(map(str, libs)))
    return subprocess.Popen(hosts.prefix(0) + [str(venv / 'bin' / 'fast-discovery-server'),
                                               '-i', '0', '-l', hosts.address(0),
                                               '-p', str(DISCOVERY_PORT)],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def unmatched_reports(swarm, k):
    """
    Count vehicle k's reports of no odometry and no publisher of it matched.

    A vehicle says so every 5 s from STALL = 3 s after it started.
    """
    text = (swarm.dir / f'vehicle_{k}.log').read_text(errors='replace')
    return text.count(f'no odometry yet on /vehicle_{k}/odom (0 publishers matched)')


def test_discovery_server_without_multicast(hosts):
    """
    Multicast off on every host: no discovery, until a Fast DDS discovery server runs.

    Every vehicle is still alone after 8 s, twice the longest discovery across hosts seen.
    """
    hosts.multicast(False)
    sc = load('rigid_parallel', 'num_vehicles:=6', 'duration:=4.0')
    with domains(1) as (did,):
        try:
            with Swarm(sc, FleetPlan(sc.num_vehicles),
                       SwarmOptions(monitor=False, place=placer(hosts),
                                    env=fleet_env(did))) as alone:
                end = time.monotonic() + 60
                while not all(unmatched_reports(alone, k) >= 2 for k in range(1, 7)):
                    alone.check()
                    assert alone.plant.poll() is None, alone.log_tail()
                    assert time.monotonic() < end, 'the vehicles did not report in time'
                    time.sleep(0.1)
                assert alone.plant.poll() is None
            server = discovery_server(hosts, did)
            try:
                env = fleet_env(did, ROS_DISCOVERY_SERVER=f'{hosts.address(0)}:{DISCOVERY_PORT}')
                run, out = run_swarm(sc, SwarmOptions(monitor=False, place=placer(hosts),
                                                      env=env, node_params=tuple(EXACT)),
                                     timeout=120)
            finally:
                stop([server])
        finally:
            shm_clean(fleet_env(did))
    assert_equals_simulator(run, sc)
