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
Whole fleets as processes through ``formation-control swarm``.

Lockstep runs equal the offline simulator (from the first step, so a few seconds show it; the
lockstep swarm converging is in test_monitor), a real-time run converges, the bag holds the
run, Ctrl-C stops every process.
"""
import json
import math
import os
from pathlib import Path
import re
import signal
import socket

from diagnostic_msgs.msg import DiagnosticArray
from formation_control.bags import reader as bagfile
from formation_control.core.scenario import resolve
from formation_control.protocol import faults, messages, names
from formation_control.protocol.fleet_plan import auto_per_process, cores
from formation_control.ros.interface import STREAM_QOS
from formation_control.sim import simulator
import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosutil import CONFIG, interrupt, output
from runs import assert_equal_runs, offline_run
import yaml


def _swarm(ros, tmp_path, name, *args, timeout=300):
    summary = tmp_path / 'summary.json'
    result = ros.procs.run('formation-control', 'swarm', CONFIG / f'{name}.yaml', *args,
                           '--summary', summary, timeout=timeout)
    assert result.returncode == 0, result.stderr + result.stdout
    return json.loads(summary.read_text()), result.stdout + result.stderr


def test_lockstep_fleet_equals_the_offline_simulator(ros, tmp_path):
    overrides = ['num_vehicles:=6', 'duration:=4.0']
    args = [a for o in overrides for a in ('-p', o)]
    out, stdout = _swarm(ros, tmp_path, 'particle_circular', *args)
    assert out['real_time_factor'] > 0 and 'real_time_factor' in stdout
    fleet = simulator.load_run(Path(out['logs']) / 'run.npz')
    assert_equal_runs(fleet, offline_run(CONFIG / 'particle_circular.yaml', overrides))


def test_lockstep_rigid_fleet_in_a_flow_equals_the_offline_simulator(nodes, tmp_path):
    """The same protocol, the plant and the vehicle nodes in one process."""
    cfg, overrides = CONFIG / 'rigid_parallel_flow.yaml', ['duration:=4.0']
    assert_equal_runs(nodes.lockstep_run(cfg, tmp_path / 'run.npz', *overrides),
                      offline_run(cfg, overrides))


def test_realtime_fleet_converges(ros, tmp_path):
    """
    rigid_parallel converges at 6.1 s, offline and in real time, and holds its hold window.

    The plant integrates the steps the wall clock has reached, so 15 simulated seconds never
    take fewer than 15 wall seconds; more only by the last tick's lateness and, on an
    overloaded machine, the slips of the pacer (0.95 measured under a load of 3 on 2 cores;
    pacing at half speed would give 0.5).
    """
    out, _ = _swarm(ros, tmp_path, 'rigid_parallel', '--mode', 'realtime', '--duration', '15')
    assert out['mode'] == 'realtime'
    assert out['converged'], out
    assert 0.8 < out['real_time_factor'] <= 1.001, out


def test_bag_holds_every_vehicle_odometry_and_command(ros, tmp_path):
    bag = tmp_path / 'bag'
    out, _ = _swarm(ros, tmp_path, 'particle_parallel', '-p', 'num_vehicles:=3', '--duration',
                    '2', '--bag', bag)
    steps = int(round(2.0 / 0.02)) + 1
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert meta['storage_identifier'] == 'mcap'
    with AnyReader([bag]) as reader:
        def raw(topic):
            return [(reader.deserialize(data, c.msgtype), bytes(data)) for c, _, data
                    in reader.messages([c for c in reader.connections if c.topic == topic])]

        def read(topic):
            return [m for m, _ in raw(topic)]
        for k in (1, 2, 3):
            for name in ('odom', 'cmd', 'formation_state'):
                msgs, data = zip(*raw(f'/vehicle_{k}/{name}'))
                stamps = [messages.stamp_ns(m.header.stamp) for m in msgs]
                assert stamps == sorted(stamps)
                assert sorted(set(stamps)) == [n * 20_000_000 for n in range(steps)]
                for d, before, s, s_before in zip(data[1:], data, stamps[1:], stamps):
                    assert s != s_before or d == before     # a step asked again, sent unchanged
            assert len(read(f'/vehicle_{k}/flow')) == 1
        odom = read('/vehicle_2/odom')
    fleet = simulator.load_run(Path(out['logs']) / 'run.npz')
    last = odom[-1]
    assert last.header.stamp.sec == 2 and last.header.stamp.nanosec == 0
    assert last.pose.pose.position.x == pytest.approx(fleet.X[-1, 0, 1], abs=1e-12)
    assert last.child_frame_id == 'vehicle_2/base_link'


def test_a_bag_of_an_estimating_fleet_records_what_it_publishes_and_reads_back(ros, tmp_path):
    """
    Rigid bodies that estimate the flow publish no ``flow`` but their ``water_velocity``.

    The recorder waits for the topics the fleet publishes (it waited for ``flow`` for good),
    and the bag holds each vehicle's through-water velocity and reads back as the plant's run.
    """
    bag = tmp_path / 'bag'
    out, _ = _swarm(ros, tmp_path, 'rigid_circular_flow', '-p', 'num_vehicles:=3', '-p',
                    'flow_source:=estimated', '--duration', '2', '--bag', bag)
    with AnyReader([bag]) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
    for k in (1, 2, 3):
        assert f'/vehicle_{k}/flow' not in counts
        assert counts[f'/vehicle_{k}/water_velocity'] >= counts[f'/vehicle_{k}/odom'] > 50
    fleet = simulator.load_run(Path(out['logs']) / 'run.npz')
    np.testing.assert_allclose(bagfile.read_run(bag).X[-1], fleet.X[-1], atol=1e-9)


def test_the_package_reads_its_own_real_time_bag(ros, tmp_path):
    """
    A real-time bag: the plant samples vehicle k at step (k - 1) mod substeps of each period.

    ``report`` reads it, and each vehicle's state of a period is its own sample in it: within
    what the vehicle covers in the stagger (speed 1 m/s, 3 integration steps) of the plant's
    record at the period's start.
    """
    bag = tmp_path / 'bag'
    out, _ = _swarm(ros, tmp_path, 'particle_parallel', '-p', 'num_vehicles:=4', '--mode',
                    'realtime', '--duration', '6', '--bag', bag)
    recorded = bagfile.read_run(bag)
    fleet = simulator.load_run(Path(out['logs']) / 'run.npz')
    sc = fleet.sc
    assert recorded.X.shape[1:] == fleet.X.shape[1:] and len(recorded.t) >= len(fleet.t) - 2
    common, mine, theirs = np.intersect1d(np.round(recorded.t, 6), np.round(fleet.t, 6),
                                          return_indices=True)
    assert len(common) >= len(fleet.t) - 2
    stagger = (sc.num_vehicles - 1) * sc.dt_integration           # the last slot's lag (s)
    gap = abs((recorded.X[mine, 0] - fleet.X[theirs, 0])
              + 1j * (recorded.X[mine, 1] - fleet.X[theirs, 1]))
    assert gap[:, 0].max() < 1e-9                                 # vehicle 1: slot 0
    assert gap.max() <= 1.05 * stagger
    report = ros.procs.run('formation-control', 'report', bag, timeout=120)
    assert report.returncode == 0, report.stderr
    assert 'converged' in report.stdout


def _fleet_pids(domain_id, parent):
    """
    Return the processes ``parent`` started in this test's domain: the plant, vehicles, monitor.

    By parent, not by domain alone: a domain id is reused once a test has released it.
    """
    pids = []
    for entry in Path('/proc').iterdir():
        try:
            environ = (entry / 'environ').read_bytes().split(b'\0')
            cmdline = (entry / 'cmdline').read_bytes().split(b'\0')
            ppid = int((entry / 'stat').read_text().rpartition(')')[2].split()[1])
        except (OSError, ValueError, IndexError):
            continue
        if (ppid == parent and f'ROS_DOMAIN_ID={domain_id}'.encode() in environ
                and any(arg.endswith((b'/plant', b'/vehicle', b'/vehicles', b'/monitor'))
                        for arg in cmdline)):
            pids.append(int(entry.name))
    return pids


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM])
def test_swarm_stops_every_process_on_ctrl_c_or_sigterm(ros, sig):
    from formation_control_msgs.msg import VehicleCommand

    from formation_control.ros.interface import STATE_QOS
    swarm = ros.procs.start('formation-control', 'swarm', CONFIG / 'particle_parallel.yaml',
                            '-p', 'num_vehicles:=3', '--duration', '600')
    cmds = ros.probe.collect(VehicleCommand, '/vehicle_3/cmd', STATE_QOS)
    assert ros.probe.spin_until(lambda: len(cmds) > 5, timeout=60)
    fleet = _fleet_pids(ros.domain_id, swarm.pid)
    assert len(fleet) == 2 + math.ceil(3 / auto_per_process(3, cores()))   # plant, monitor
    swarm.send_signal(sig)
    code = swarm.wait(timeout=30)
    swarm.log.seek(0)
    assert code == 128 + sig, swarm.log.read()[-3000:]        # the shell's 130, 143
    assert not [pid for pid in fleet if Path(f'/proc/{pid}').exists()]


def test_several_vehicle_nodes_per_process_equal_the_offline_simulator(ros, tmp_path):
    overrides = ['num_vehicles:=6', 'duration:=2.0']
    out, _ = _swarm(ros, tmp_path, 'particle_circular', '-p', overrides[0], '-p', overrides[1],
                    '--vehicles-per-process', '4', '--no-monitor')
    logs = sorted(p.name for p in Path(out['logs']).glob('*.log'))
    assert logs == ['plant.log', 'vehicles_1-4.log', 'vehicles_5-6.log']
    fleet = simulator.load_run(Path(out['logs']) / 'run.npz')
    assert_equal_runs(fleet, offline_run(CONFIG / 'particle_circular.yaml', overrides))


def test_a_recorded_fleet_keeps_a_deep_history_on_its_state_writers(tmp_path):
    """A writer that matches the recorder late still resends step 0 (transient local)."""
    from formation_control.protocol.fleet_plan import RECORDED_DEPTH, write_params
    sc = resolve({'num_vehicles': 2})
    plain = yaml.safe_load(Path(write_params(sc, tmp_path / 'a.yaml')).read_text())
    recorded = yaml.safe_load(Path(write_params(sc, tmp_path / 'b.yaml', recorded=True))
                              .read_text())
    overrides = recorded['/**']['ros__parameters']['qos_overrides']
    assert 'qos_overrides' not in plain['/**']['ros__parameters'] and RECORDED_DEPTH >= 100
    assert overrides == {f'/vehicle_{k}/{name}': {'publisher': {'depth': RECORDED_DEPTH}}
                         for k in (1, 2) for name in ('odom', 'formation_state', 'cmd')}


FAULTS = ('kill:6@0.2', 'stop:2@1.5', 'cont:2@2.5', 'cut:1-3@3.5..8')


def _statuses(bag, name):
    """Return (bag time s, values) of every /diagnostics status ``name`` in the bag."""
    out = []
    with AnyReader([bag]) as reader:
        for c, t, raw in reader.messages([c for c in reader.connections
                                          if c.topic == '/diagnostics']):
            for s in reader.deserialize(raw, c.msgtype).status:
                if s.name == name:
                    out.append((t * 1e-9, {v.key: v.value for v in s.values}))
    return out


def _faults_in(bag):
    """Return the swarm's records of the bag's FaultEvents, and their (kind, vehicle ids)."""
    with AnyReader([bag]) as reader:
        conns = [c for c in reader.connections if c.topic == '/' + names.FAULTS_TOPIC]
        assert [c.msgtype for c in conns] == ['formation_control_msgs/msg/FaultEvent']
        events = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(conns)]
    return ([{'fault': e.fault, 'action': e.action, 'scheduled': e.scheduled_time,
              'applied': e.applied_time if e.applied else None} for e in events],
            [(e.kind, list(e.vehicle_ids)) for e in events])


WEDGED = 5
"""Plant statuses (1 Hz, wall clock) in a row without a vehicle process's status: wedged."""


def _wedged(bag, ids):
    """
    Return the ids whose links status was missing for :data:`WEDGED` plant statuses in a row.

    Counted from each vehicle's first status, in the bag's order (its times are the fleet's,
    which a lockstep run outpaces). A process killed or stopped inside Fast DDS's shared-memory
    transport can leave a lock that blocks other processes' publish(), with the interpreter
    lock held, for good (docs/reliability.md): a wedged process says nothing more.
    """
    since, longest = dict.fromkeys(ids), dict.fromkeys(ids, 0)
    with AnyReader([bag]) as reader:
        for c, _, raw in reader.messages([c for c in reader.connections
                                          if c.topic == '/diagnostics']):
            for s in reader.deserialize(raw, c.msgtype).status:
                found = re.fullmatch(r'formation_control/vehicle_(\d+)/links', s.name)
                if s.name == 'formation_control/plant':
                    for k in (k for k in ids if since[k] is not None):   # from its first status
                        since[k] += 1
                        longest[k] = max(longest[k], since[k])
                elif found and int(found[1]) in since:
                    since[int(found[1])] = 0
    return [k for k in ids if longest[k] >= WEDGED]


def _faulty_swarm(ros, tmp_path):
    """
    Run :data:`FAULTS` with a bag; return the summary, the output, the bag, the wedged.

    Healed after 4 s: a run of 20 fleet seconds here lasts 5-15 s of wall time.
    """
    bag = tmp_path / 'bag'
    args = ['-p', 'num_vehicles:=6', '-p', 'dt_control:=0.05', '--heal-after', '4']
    out, stderr = _swarm(ros, tmp_path, 'particle_parallel', *args, '--duration', '20',
                         '--seed', '2', '--bag', bag, *[a for f in FAULTS for a in ('--fault', f)])
    return out, stderr, bag, _wedged(bag, (1, 3, 4, 5))       # 2 is frozen by a fault


def test_swarm_survives_scripted_faults(ros, tmp_path):
    """
    Vehicle 6 killed before convergence, 2 frozen and resumed, the link 1-3 cut for 4.5 s.

    The five converge without 6 (at about 7 s; not the six) and the swarm exits 0; vehicle 2
    is commanded again within 3 s of fleet time once continued; each fault is in the summary
    and the bag at its fleet time. If the kill or the freeze wedged another vehicle's process
    in the middleware (docs/reliability.md), the swarm must have healed it: restarted it, named
    in the summary.
    """
    out, stderr, bag, wedged = _faulty_swarm(ros, tmp_path)
    healed = {k for h in out['healed'] for k in h['vehicles']}
    assert set(wedged) <= healed, f'vehicles {wedged} wedged, not healed: {out["healed"]}'
    assert re.search(r'swarm: t = \d+\.\d\d s: kill vehicle 6 \(kill:6@0\.2\)', stderr)
    assert re.search(r'swarm: t = \d+\.\d\d s: vehicle_6 exited with -9 \(SIGKILL\) \(fault '
                     r'kill:6@0\.2\); the others carry on', stderr)
    assert [f['fault'] for f in out['faults']] == [*FAULTS, FAULTS[3]]
    applied = [f['applied'] for f in out['faults']]
    # at the first fleet step the swarm sees at or after the time: later on a loaded machine
    assert all(0 <= f['applied'] - f['scheduled'] < 2.0 for f in out['faults']), out['faults']
    records, kinds = _faults_in(bag)
    assert records == out['faults']
    assert kinds == [(1, [6]), (3, [2]), (4, [2]), (5, [1, 3]), (6, [1, 3])]  # KILL .. MEND
    (lost,) = [p for p in out['lost'] if not p['cause'].startswith('healed: ')]
    assert (lost['process'], lost['exit'], lost['cause']) == ('vehicle_6', -9, 'fault kill:6@0.2')
    assert 0.2 <= lost['time'] < 2.0                    # its death is seen a few steps later
    assert out['survivors'] == [1, 2, 3, 4, 5]
    assert out['survivors_converged'] and not out['converged']
    assert 2.0 < out['survivors_convergence_time'] < 20.0         # after the kill at 0.2 s
    run = simulator.load_run(Path(out['logs']) / 'run.npz')
    commanded = np.any(run.U != 0.0, axis=1)                       # (T, N)
    assert not commanded[run.t > lost['time'] + 0.1, 5].any()
    frozen = (run.t > applied[1] + 0.2) & (run.t < applied[2])
    assert not commanded[frozen, 1].any()
    # resumed, it hears the plant again at once: a sample it missed while stopped is asked for
    # at the writer's next heartbeat, 0.1 s with the fleet's profile (3 s without: 1-10 s here)
    back = run.t[(run.t > applied[2]) & commanded[:, 1]]
    assert back.size and back[0] < applied[2] + 3.0, back[:1]
    for k, other in ((1, 3), (3, 1)):
        log = (Path(out['logs']) / f'vehicle_{k}.log').read_text()
        assert log.index(f'links cut: [{other}]') < log.index('links cut: []'), log
        last = _statuses(bag, f'formation_control/vehicle_{k}/links')[-1][1]
        assert int(last['dropped']) > 0 and str(other) not in last['gone_neighbours'], last


def test_swarm_notes_dead_processes_restarts_them_and_applies_process_faults(tmp_path):
    """The bookkeeping of :class:`Swarm` on stand-in processes (no ROS): fleet time is set."""
    import sys

    from formation_control.protocol.fleet_plan import FleetPlan
    from formation_control.swarm import Swarm, SwarmOptions
    sc = resolve({'num_vehicles': 3})
    swarm = Swarm(sc, FleetPlan(3), SwarmOptions(workdir=tmp_path, monitor=False,
                                                 restart_dead=0.5))
    sleeper = [sys.executable, '-c', 'import time; time.sleep(60)']
    swarm.commands = [sleeper, [sys.executable, '-c', 'import sys; sys.exit(3)'], sleeper,
                      sleeper]
    with swarm:
        swarm.t = 1.0
        swarm.procs[1].wait(timeout=30)
        swarm.check()
        assert swarm.lost == [{'process': 'vehicle_1', 'vehicles': [1], 'time': 1.0, 'exit': 3,
                               'cause': 'not scripted', 'restarted': None}]
        swarm.t = 1.4
        swarm.check()
        assert swarm.lost[0]['restarted'] is None
        swarm.commands[1] = sleeper                         # started again, it stays up
        swarm.t = 1.5
        swarm.check()
        assert swarm.lost[0]['restarted'] == 1.5 and len(swarm.lost) == 1
        for text in ('stop:2@1.5', 'kill:3@1.5'):
            swarm.apply(faults.parse(text)[0])
        swarm.procs[3].wait(timeout=30)
        swarm.check()
        assert swarm.lost[-1]['cause'] == 'fault kill:3@1.5' and swarm.lost[-1]['exit'] == -9
        assert swarm.lost[-1]['restarted'] is None and not swarm.restarts   # scripted: no restart
        assert 2 not in swarm.running_vehicles()
        stopped = swarm.procs[2]
    assert stopped.returncode is not None                  # a frozen process is stopped too
    assert [f['fault'] for f in swarm.faults] == ['stop:2@1.5', 'kill:3@1.5']


def test_a_process_fault_with_several_vehicles_per_process_is_refused_before_any_start(ros):
    result = ros.procs.run('formation-control', 'swarm', CONFIG / 'particle_parallel.yaml',
                           '-p', 'num_vehicles:=8', '--vehicles-per-process', '4',
                           '--fault', 'kill:2@1')
    assert result.returncode == 2
    assert result.stderr.strip().splitlines()[-1] == (
        'error: --vehicles-per-process 4 with a process fault (kill, restart, stop, cont): a '
        'fault acts on the process of one vehicle, 1 only')
    assert 'started' not in result.stdout + result.stderr


def test_a_fleet_beyond_localhost_discovery_is_refused_before_any_start(ros):
    """40 vehicle processes, the plant, the monitor and the swarm: 43 participants, over 32."""
    result = ros.procs.run('formation-control', 'swarm', 'particle_circular',
                           '-p', 'num_vehicles:=40', '--vehicles-per-process', '1')
    assert result.returncode == 2
    assert result.stderr.strip().splitlines()[-1] == (
        'error: --vehicles-per-process 1 makes 43 DDS participants on this host, but with '
        'ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST rmw_fastrtps discovers at most 32 (the rest '
        'would never match each other): use --vehicles-per-process 2 or more (or auto), or a '
        'discovery server (ROS_DISCOVERY_SERVER)')
    assert 'started' not in result.stdout + result.stderr


def test_a_live_view_on_a_busy_port_is_refused_before_any_start(ros):
    with socket.socket() as busy:
        busy.bind(('127.0.0.1', 0))
        busy.listen()
        port = busy.getsockname()[1]
        result = ros.procs.run('formation-control', 'swarm', CONFIG / 'particle_parallel.yaml',
                               '--foxglove', str(port))
    assert result.returncode == 2
    assert result.stderr.strip().splitlines()[-1] == (
        f'error: --foxglove {port}: cannot serve the Foxglove live view on 127.0.0.1:{port} '
        f'(Address already in use): give a free port')
    assert 'started' not in result.stdout + result.stderr


def test_two_fleets_in_one_domain_and_namespace_do_not_fly_on_together_in_silence(ros):
    """
    A second swarm on the first one's topics: one of them at least stops, exit 1, saying why.

    Whichever hears the other's plant first stops its fleet; the other stops too if it heard
    the first before it went, else it flies on alone (then stopped here: 130).
    """
    diagnostics = ros.probe.collect(DiagnosticArray, '/diagnostics', STREAM_QOS)
    swarms = [ros.procs.start('formation-control', 'swarm', 'particle_parallel', '--mode',
                              'realtime', '--duration', '120', '--no-monitor')]
    assert ros.probe.spin_until(lambda: any(
        s.name == 'formation_control/plant' for m in diagnostics for s in m.status),
        timeout=60), output(swarms[0])
    swarms.append(ros.procs.start('formation-control', 'swarm', 'particle_parallel', '--mode',
                                  'realtime', '--duration', '120', '--no-monitor'))
    assert ros.probe.spin_until(lambda: any(p.poll() is not None for p in swarms), timeout=60)
    ros.probe.spin_until(lambda: all(p.poll() is not None for p in swarms), timeout=5)
    codes = [p.poll() if p.poll() is not None else interrupt(p, timeout=30) for p in swarms]
    line = re.compile(rf'error: another fleet runs in ROS_DOMAIN_ID {ros.domain_id}, '
                      r'namespace / \(plants \w{8}, \w{8} both speak\): both fleets publish '
                      r'the same topics; give one another ROS_DOMAIN_ID or --namespace\n')
    said = [bool(line.search(output(p))) for p in swarms]
    assert any(said) and all(c == 1 for c, s in zip(codes, said) if s), (codes, said)
    assert all(c in (1, 130) for c in codes), [output(p) for p in swarms]


def test_a_swarm_that_lost_a_vehicle_it_did_not_script_exits_1_naming_it(ros):
    diagnostics = ros.probe.collect(DiagnosticArray, '/diagnostics', STREAM_QOS)
    swarm = ros.procs.start('formation-control', 'swarm', 'particle_parallel', '-p',
                            'num_vehicles:=3', '--mode', 'realtime', '--duration', '8',
                            '--vehicles-per-process', '1', '--no-monitor')
    assert ros.probe.spin_until(lambda: any(
        s.name == 'formation_control/plant' for m in diagnostics for s in m.status),
        timeout=60), output(swarm)
    vehicle = next(pid for pid in map(int, filter(str.isdigit, os.listdir('/proc')))
                   if ' vehicle_id:=2 ' in _cmdline(pid) + ' ' and _parent(pid) == swarm.pid)
    os.kill(vehicle, signal.SIGKILL)
    assert ros.probe.spin_until(lambda: swarm.poll() is not None, timeout=120), output(swarm)
    assert swarm.returncode == 1
    assert re.search(r'error: vehicle_2 exited \(not scripted\) and did not come back: the run '
                     r'failed; their logs are in \S+\n*$', output(swarm)), output(swarm)


def _cmdline(pid):
    try:
        return Path(f'/proc/{pid}/cmdline').read_bytes().replace(b'\0', b' ').decode().strip()
    except OSError:
        return ''


def _parent(pid):
    try:
        return int(Path(f'/proc/{pid}/stat').read_text().rsplit(') ', 1)[1].split()[1])
    except (OSError, IndexError, ValueError):
        return None


def test_the_default_swarm_groups_vehicle_nodes_by_the_cores(ros, tmp_path):
    overrides = ['num_vehicles:=9', 'duration:=1.0']
    out, _ = _swarm(ros, tmp_path, 'particle_circular', '-p', overrides[0], '-p', overrides[1],
                    '--no-monitor')
    m = auto_per_process(9, cores())
    expected = ['plant.log'] + ([f'vehicle_{k}.log' for k in range(1, 10)] if m == 1 else
                                [f'vehicles_{k}-{min(k + m - 1, 9)}.log' for k in range(1, 10, m)])
    assert sorted(p.name for p in Path(out['logs']).glob('*.log')) == sorted(expected)
    fleet = simulator.load_run(Path(out['logs']) / 'run.npz')
    assert_equal_runs(fleet, offline_run(CONFIG / 'particle_circular.yaml', overrides))
