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
Reliability with fixed seeds.

A vehicle killed and restarted, lossy and late links, every kind of bad message, a non-finite
plant state, saturated commands, start order. Fleets run as real processes where the property
needs them (a process killed and started again, processes started in any order, the swarm in
real time); single nodes fed by the test, and fleets whose property is the nodes' logic, are
built in this process (the ``nodes`` fixture).
"""
import json
from pathlib import Path
import re
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from formation_control.core import scenario
from formation_control.core.control import Controller
from formation_control.protocol import links, messages, names
from formation_control.ros import interface as itf
from formation_control.ros.interface import STALL
from formation_control.sim import metrics, simulator
from formation_control_msgs.msg import FormationState, VehicleCommand
from nav_msgs.msg import Odometry
import numpy as np
import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile
from rosgraph_msgs.msg import Clock
from rosutil import CONFIG, output
from runs import assert_equal_runs, offline_run

PARTICLE = CONFIG / 'particle_parallel.yaml'
RIGID = CONFIG / 'rigid_parallel.yaml'


def _args(path, *params):
    out = ['--ros-args', '--params-file', str(path)]
    for p in params:
        out += ['-p', p]
    return out


def _status(box, name):
    """(level, message, values) of the newest status called ``name``, or None."""
    for msg in reversed(box):
        for s in msg.status:
            if s.name == name:
                return s.level, s.message, {v.key: v.value for v in s.values}
    return None


# ---- bad input: dropped, logged, counted; the node carries on --------------------------------

def _state(j, ns, values=None, frame=None, **fields):
    msg = itf.state_msg(j, ns, np.array([1.0, 2.0, 0.3, 0.2, 1.0, 0.0]),
                        (complex(1.0, 2.0), 0.3, 0.2, 1.0))
    if values is not None:
        messages.set_fields(msg, messages.STATE_FIELDS, values)
    for name, value in fields.items():
        setattr(msg, name, value)
    if frame is not None:
        msg.header.frame_id = frame
    return msg


def _odom(k, ns, x=0.5, frame='map'):
    msg = itf.odom_msg(k, ns, np.array([x, -1.0, 0.2, 0.0, 1.0, 0.0]), 0j)
    msg.header.frame_id = frame
    return msg


BAD_VEHICLE_INPUT = {
    'odom_non_finite': ('odom', lambda: _odom(1, 0, x=float('nan')), 'non_finite'),
    'odom_wrong_frame': ('odom', lambda: _odom(1, 0, frame='odom'), 'wrong_frame'),
    'odom_undecodable': ('odom', lambda: b'\x00\x01\x00\x00 not an Odometry', 'malformed'),
    'state_undecodable': ('state', lambda: b'\x00\x01\x00\x00 garbage', 'malformed'),
    'state_non_finite': ('state', lambda: _state(2, 0, [float('inf')] * 7), 'non_finite'),
    'state_malformed': ('state', lambda: _state(2, 0, neighbour_ids=[1], hears=[True]),
                        'malformed'),                 # a ring's on the complete graph
    'state_foreign_id': ('state', lambda: _state(2, 0, vehicle_id=9), 'foreign_id'),
    'state_wrong_frame': ('state', lambda: _state(2, 0, frame='vehicle_2/base_link'),
                          'wrong_frame'),
    'state_interface_version': ('state', lambda: _state(2, 0, interface_version=2),
                                'interface_version'),
    'state_stale': ('state', lambda: _state(2, 0), 'stale'),
}


@pytest.mark.parametrize('case', BAD_VEHICLE_INPUT)
def test_vehicle_drops_counts_and_survives_bad_input(nodes, case):
    topic, make, kind = BAD_VEHICLE_INPUT[case]
    vehicle = nodes.vehicle(1, PARTICLE, 'num_vehicles:=2')
    node = nodes.node
    pubs = {'odom': node.create_publisher(Odometry, '/vehicle_1/odom', itf.STATE_QOS),
            'state': node.create_publisher(FormationState, '/vehicle_2/formation_state',
                                           itf.STATE_QOS)}
    cmds = nodes.collect(VehicleCommand, '/vehicle_1/cmd', itf.STATE_QOS)
    diags = nodes.collect(DiagnosticArray, names.DIAGNOSTICS_TOPIC, itf.STREAM_QOS)
    assert nodes.spin_until(lambda: all(p.get_subscription_count() for p in pubs.values()))
    if kind == 'stale':
        pubs['state'].publish(_state(2, 400_000_000))
    pubs[topic].publish(make())
    pubs['odom'].publish(_odom(1, 400_000_000))
    pubs['state'].publish(_state(2, 400_000_000))
    name = 'formation_control/vehicle_1/links'
    assert nodes.spin_until(lambda: cmds and (_status(diags, name) or (0, 0, {}))[2].get(
        kind) == '1', timeout=20), _status(diags, name)
    assert messages.stamp_ns(cmds[-1].header.stamp) == 400_000_000
    counts = _status(diags, name)[2]
    others = [k for k in ('non_finite', 'malformed', 'wrong_frame', 'stale', 'foreign_id',
                          'interface_version') if k != kind]
    assert all(counts[k] == '0' for k in others), counts
    assert nodes.logged(vehicle, 'dropped')


def test_plant_drops_and_counts_bad_commands(nodes):
    nodes.plant(PARTICLE, 'num_vehicles:=2', 'exit_when_done:=false')
    node = nodes.node
    cmd = {k: node.create_publisher(VehicleCommand, names.topic(k, 'cmd'), itf.STATE_QOS)
           for k in (1, 2)}
    diags = nodes.collect(DiagnosticArray, names.DIAGNOSTICS_TOPIC, itf.STREAM_QOS)
    clock = nodes.collect(Clock, '/clock', itf.LATCHED_QOS)
    assert nodes.spin_until(lambda: clock and all(p.get_subscription_count()
                                                  for p in cmd.values()))
    bad = itf.cmd_msg(1, 0, (0.0, float('nan')), 'second_order')
    wrong = itf.cmd_msg(1, 0, (0.0, 0.1), 'second_order')
    wrong.header.frame_id = 'map'
    late = itf.cmd_msg(1, 5 * 20_000_000, (0.0, 0.1), 'second_order')
    kindless = VehicleCommand(vehicle_id=1, angular_acceleration=0.1)       # kind 0
    first_order = itf.cmd_msg(1, 0, (0.0, 0.1), 'first_order')
    foreign = itf.cmd_msg(2, 0, (0.0, 0.1), 'second_order')
    newer = itf.cmd_msg(1, 0, (0.0, 0.1), 'second_order')
    newer.interface_version = 2
    for msg in (bad, wrong, late, b'\x00\x01\x00\x00 not a VehicleCommand', kindless,
                first_order, foreign, newer):
        cmd[1].publish(msg)                           # bytes: published as they are
    for k in (1, 2):
        cmd[k].publish(itf.cmd_msg(k, 0, (0.0, 0.1), 'second_order'))
    assert nodes.spin_until(lambda: any(c.clock.nanosec == 20_000_000 for c in clock))

    def counted():
        s = _status(diags, 'formation_control/plant')
        return s and (s[2]['non_finite'], s[2]['wrong_frame'], s[2]['stale'],
                      s[2]['malformed'], s[2]['wrong_kind'], s[2]['foreign_id'],
                      s[2]['interface_version']) == ('1', '1', '1', '1', '2', '1', '1')
    assert nodes.spin_until(counted), _status(diags, 'formation_control/plant')


def test_plant_stops_a_vehicle_whose_state_turns_non_finite(nodes):
    plant = nodes.plant(RIGID, 'num_vehicles:=2', 'exit_when_done:=false')
    node = nodes.node
    cmd = {k: node.create_publisher(VehicleCommand, names.topic(k, 'cmd'), itf.STATE_QOS)
           for k in (1, 2)}
    odom = {k: nodes.collect(Odometry, names.topic(k, 'odom'), itf.STATE_QOS) for k in (1, 2)}
    diags = nodes.collect(DiagnosticArray, names.DIAGNOSTICS_TOPIC, itf.STREAM_QOS)
    assert nodes.spin_until(lambda: odom[1] and odom[2] and all(
        p.get_subscription_count() for p in cmd.values()))
    cmd[1].publish(itf.cmd_msg(1, 0, (5.0, 0.0), 'rigid'))
    cmd[2].publish(itf.cmd_msg(2, 0, (1e308, 0.0), 'rigid'))
    step = 20_000_000
    assert nodes.spin_until(lambda: any(messages.stamp_ns(m.header.stamp) == step
                                        for m in odom[1]))
    cmd[1].publish(itf.cmd_msg(1, step, (5.0, 0.0), 'rigid'))
    assert nodes.spin_until(lambda: any(messages.stamp_ns(m.header.stamp) == 2 * step
                                        for m in odom[1]))
    assert all(messages.stamp_ns(m.header.stamp) == 0 for m in odom[2])
    for m in odom[1]:
        assert np.isfinite(m.pose.pose.position.x) and np.isfinite(m.twist.twist.linear.x)
    assert nodes.spin_until(lambda: (_status(diags, 'formation_control/plant') or (0,))[0]
                            == DiagnosticStatus.ERROR)
    assert _status(diags, 'formation_control/plant')[2]['stopped'] == '[2]'
    assert nodes.logged(plant, 'vehicle 2: its state became non-finite')


def test_a_vehicle_answered_and_then_left_without_odometry_says_so(nodes):
    """The plant ends its run: each vehicle warns once its silence passes the stall time."""
    plant = nodes.plant(PARTICLE, 'num_vehicles:=2', 'duration:=0.1', 'exit_when_done:=false')
    for k in (1, 2):
        nodes.vehicle(k, PARTICLE, 'num_vehicles:=2', 'duration:=0.1', 'use_sim_time:=true')
    assert nodes.spin_until(lambda: plant.ended, timeout=60)

    def warned(k):
        return [m.msg for m in nodes.rosout if m.name == f'vehicle_{k}' and re.fullmatch(
            rf'no odometry for \d+\.\d s since the command for t = 0\.100 s: the plant waits '
            rf'for another vehicle or has ended, or this vehicle no longer hears it '
            rf'\(/vehicle_{k}/odom: 1 publishers matched\)', m.msg)]
    assert not warned(1) and not warned(2)
    assert nodes.spin_until(lambda: warned(1) and warned(2), timeout=30)
    assert all(float(warned(k)[0].split()[3]) > STALL for k in (1, 2))


# ---- a vehicle lost and restarted ------------------------------------------------------------

def _sub_converged(sc, X, members):
    sub = scenario.resolve({**sc.to_dict(), 'num_vehicles': int(members.sum())})
    ctrl = Controller(sub)
    snap = metrics.snapshot(ctrl, X[:, members], np.zeros((2, sub.num_vehicles)))
    return metrics.converged(sub, snap)


def _spans(t, flags):
    """Return the [start, end] times (s) of each run of True in ``flags``."""
    edges = np.flatnonzero(np.diff(np.r_[0, flags.astype(int), 0]))
    return [(round(float(t[a]), 2), round(float(t[b - 1]), 2)) for a, b in edges.reshape(-1, 2)]


def _story(run, log=''):
    """Tell each vehicle's spans of zero command and of a frozen state, for a failed check."""
    zero = np.all(run.U == 0.0, axis=1)
    frozen = np.r_[np.zeros((1, run.X.shape[2]), bool),
                   np.all(np.diff(run.X[:, :2], axis=0) == 0.0, axis=1)]
    lines = [f'vehicle {i + 1}: zero command {_spans(run.t, zero[:, i])}, frozen '
             f'{_spans(run.t, frozen[:, i])}' for i in range(run.X.shape[2])]
    return '\n'.join([f'record t {run.t[0]}..{run.t[-1]} s, {len(run.t)} samples', *lines,
                      log])


def _assert_reconverged(record, t_kill, t_back, log=''):
    """Check the five converged without vehicle 6 (zero command), the six once it is back."""
    run = simulator.load_run(record)
    sc = run.sc
    five = np.array([True] * 5 + [False])
    back = int(np.searchsorted(run.t, t_back - 1.0))
    story = _story(run, log)
    assert not _sub_converged(sc, run.X[int(np.searchsorted(run.t, t_kill))], five), story
    assert _sub_converged(sc, run.X[back], five), story
    assert not _sub_converged(sc, run.X[back], np.ones(6, bool)), story
    assert _sub_converged(sc, run.X[-1], np.ones(6, bool)), story
    gone = (run.t > t_kill + 3.0) & (run.t < t_back - 3.0)
    assert np.all(run.U[gone, :, 5] == 0.0)


def _clock(node):
    """Return the fleet's simulated time (s), as /clock messages arrive."""
    now = []
    node.create_subscription(
        Clock, '/clock', lambda m: now.append(m.clock.sec + 1e-9 * m.clock.nanosec),
        itf.LATCHED_QOS)
    return now


KILLED = ('particle_parallel.yaml', 1.0, 15.0, 40.0)
"""Offline, with vehicle 6 out from t = 1 s: the five converge at 6.5 s; back at 12-18 s, the
six converge 6-7 s later."""
REMOVED = ('particle_circular.yaml', 5.0, 35.0, 70.0)
"""Offline, with vehicle 6 out from t = 5 s: the five converge at 22.3 s; back at 30-40 s, the
six converge 8-12 s later."""


WEDGED = 5.0
"""Wall seconds without a /diagnostics status from a live vehicle process: it is wedged."""


def _heard_statuses(node):
    """Return {vehicle id: wall times its links status arrived}, filled as /diagnostics comes."""
    heard = {}

    def take(msg):
        for s in msg.status:
            found = re.fullmatch(r'formation_control/vehicle_(\d+)/links', s.name)
            if found:
                heard.setdefault(int(found[1]), []).append(time.monotonic())
    node.create_subscription(DiagnosticArray, names.DIAGNOSTICS_TOPIC, take, itf.STREAM_QOS)
    return heard


def _wedged(heard, ids):
    """
    Return the ids whose status paused for more than :data:`WEDGED` s.

    From its first status to the last any vehicle sent (the fleet's end).
    """
    end = max((t for times in heard.values() for t in times), default=0.0)

    def paused(times):
        t = np.array([x for x in times if x <= end] + [end])
        return len(t) < 2 or np.diff(t).max() > WEDGED
    return [k for k in ids if paused(heard.get(k, []))]


def _run_killed(ros, tmp_path):
    """
    Run :data:`KILLED` as ``swarm`` with the kill and the restart scripted.

    Return the record, the summary, the logs and the survivors whose 1 Hz status paused (a
    process killed inside Fast DDS's shared-memory transport can leave a lock that blocks
    others' publish() with the interpreter lock held, for good: docs/reliability.md).
    """
    name, t_kill, t_back, duration = KILLED
    record, summary = tmp_path / 'run.npz', tmp_path / 'summary.json'
    heard = _heard_statuses(ros.probe.node)
    swarm = ros.procs.start('formation-control', 'swarm', CONFIG / name, '-p', 'num_vehicles:=6',
                            '--duration', str(duration), '--seed', '2', '--heal-after', '4',
                            '--fault', f'kill:6@{t_kill}', '--fault', f'restart:6@{t_back}',
                            '--no-monitor', '--out', record, '--summary', summary)
    assert ros.probe.spin_until(lambda: swarm.poll() is not None, timeout=600)
    assert swarm.returncode == 0, output(swarm)
    out = json.loads(summary.read_text())
    return record, out, output(swarm), _wedged(heard, range(1, 6))


def test_fleet_reconverges_without_a_killed_vehicle_and_again_when_it_returns(ros, tmp_path):
    """
    Vehicle 6's process is killed (SIGKILL), and a new process takes its place later.

    If the kill wedged a survivor's process in the middleware (measured about 1 kill in 115 on
    a loaded machine), the swarm must have healed it (restarted, named in the summary): the
    six then converge by the end.
    """
    record, out, log, wedged = _run_killed(ros, tmp_path)
    healed = {k for h in out['healed'] for k in h['vehicles']}
    assert set(wedged) <= healed, f'vehicles {wedged} wedged, not healed:\n{log}'
    if healed:
        print(f'vehicles {sorted(healed)} healed: {out["healed"]}')
        assert out['converged'], log
        return
    _assert_reconverged(record, KILLED[1], KILLED[2], log)


def test_circular_fleet_reconverges_without_a_removed_vehicle_and_again_with_a_new_one(
        nodes, tmp_path):
    """The same with vehicle 6's node destroyed and a new node made (one process)."""
    name, t_kill, t_back, duration = REMOVED
    record = tmp_path / 'run.npz'
    common = ['num_vehicles:=6', f'duration:={duration}', 'seed:=2']
    plant = nodes.plant(CONFIG / name, *common, f'record_path:={record}')
    vehicle = {k: nodes.vehicle(k, CONFIG / name, *common, 'use_sim_time:=true')
               for k in range(1, 7)}
    now = _clock(nodes.node)
    assert nodes.spin_until(lambda: now and now[-1] >= t_kill, timeout=120)
    nodes.remove(vehicle[6])
    assert nodes.spin_until(lambda: now[-1] >= t_back, timeout=300)
    nodes.vehicle(6, CONFIG / name, *common, 'use_sim_time:=true')
    assert nodes.spin_until(lambda: plant.done, timeout=300)
    _assert_reconverged(record, t_kill, t_back)


# ---- lossy, late links; saturation; start order ------------------------------------------------

def _links(box, k):
    """(stamp ns, values) of vehicle k's newest ``links`` status."""
    name = f'formation_control/vehicle_{k}/links'
    for msg in reversed(box):
        for s in msg.status:
            if s.name == name:
                return messages.stamp_ns(msg.header.stamp), {v.key: v.value for v in s.values}
    return None


LOSSY = {'drop_probability': 0.2, 'delay': 0.05, 'delay_jitter': 0.1, 'fault_seed': 5}


@pytest.mark.parametrize('name, duration', [('rigid_parallel', 20), ('rigid_circular', 60),
                                            ('rigid_parallel_flow', 20)])
def test_rigid_scenarios_converge_with_lossy_late_links(ros, tmp_path, name, duration):
    """
    Converge in real time with lossy, late links, the faults seen to act.

    rigid_circular converges at 27 s offline and in real time; 60 s leave room under load. The
    parallel ones converge at 6-7 s, with or without the faults; 20 s leave the 6.28 s hold
    window after that with room (rigid_parallel_flow in 15 s once held only part of it, under
    load: not settled).

    Of the neighbour states that reached a vehicle (no more than were sent, nearly as many as
    reached this probe by then), its ``links`` status counts a share drop_probability as
    dropped and the others as delayed, by delay + delay_jitter / 2 on average; the jitter (0.1
    s, five control periods) delivers many of them after a newer one, so that they are refused
    as stale (a third of them in theory; none without the delays: DDS keeps the order).
    """
    sc = scenario.load(CONFIG / f'{name}.yaml', [f'duration:={float(duration)}'])
    n = sc.num_vehicles
    arrived = {k: [] for k in range(1, n + 1)}
    for k in arrived:
        ros.probe.node.create_subscription(
            FormationState, names.topic(k, 'formation_state'),
            lambda _, info, k=k: arrived[k].append(info['received_timestamp']),
            QoSProfile(depth=1000, durability=DurabilityPolicy.TRANSIENT_LOCAL), raw=True)
    diags = ros.probe.collect(DiagnosticArray, names.DIAGNOSTICS_TOPIC, itf.STREAM_QOS)
    summary = tmp_path / 'summary.json'
    swarm = ros.procs.start('formation-control', 'swarm', CONFIG / f'{name}.yaml',
                            '--mode', 'realtime', '--duration', duration, '--summary', summary,
                            *[a for key, v in LOSSY.items() for a in ('-p', f'{key}:={v}')])
    assert ros.probe.spin_until(lambda: swarm.poll() is not None, timeout=400)
    assert swarm.returncode == 0, output(swarm)
    out = json.loads(summary.read_text())
    assert out['converged'], out
    logs = Path(out['logs'])
    assert 'drop_probability' not in (logs / 'scenario.yaml').read_text()
    received, count = 0, dict.fromkeys(('dropped', 'delayed', 'stale', 'out_of_range'), 0)
    mean_delay = []
    for k in arrived:
        assert _links(diags, k) is not None, k
        stamp, values = _links(diags, k)
        received += sum(np.count_nonzero(np.array(arrived[j]) <= stamp) for j in arrived
                        if j != k)
        for key in count:
            count[key] += int(values[key])
        mean_delay.append(float(values['mean_delay']))
    heard = count['dropped'] + count['delayed']
    sent = n * (n - 1) * (sc.periods + 1)          # a state per odometry, to each neighbour
    assert 0.9 * received <= heard <= sent, (count, received, sent)
    assert count['out_of_range'] == 0
    assert count['dropped'] / heard == pytest.approx(LOSSY['drop_probability'], abs=0.02)
    assert mean_delay == pytest.approx([LOSSY['delay'] + LOSSY['delay_jitter'] / 2] * n,
                                       abs=0.01)
    assert count['stale'] > 0.1 * count['delayed'], count


def _vehicle_1_of_two(nodes, *params):
    """Start vehicle 1 of a particle pair; return its odometry, 2's state and its commands."""
    nodes.vehicle(1, PARTICLE, 'num_vehicles:=2', *params)
    node = nodes.node
    odom = node.create_publisher(Odometry, '/vehicle_1/odom', itf.STATE_QOS)
    state = node.create_publisher(FormationState, '/vehicle_2/formation_state',
                                  itf.STATE_QOS)
    cmds = nodes.collect(VehicleCommand, '/vehicle_1/cmd', itf.STATE_QOS)
    assert nodes.spin_until(lambda: odom.get_subscription_count()
                            and state.get_subscription_count())
    return odom, state, cmds


def test_vehicle_hears_a_neighbour_only_after_the_injected_delay(nodes):
    """Real time: until the delay has passed, the vehicle commands as if it were alone."""
    delay = 0.5
    odom, state, cmds = _vehicle_1_of_two(nodes, 'mode:=realtime', f'delay:={delay}',
                                          'hold_prediction:=none')   # of the sampled state
    sc = scenario.load(PARTICLE, ['num_vehicles:=2', 'hold_prediction:=none'])
    X = np.array([[0.5, 1.0], [-1.0, 2.0], [0.2, 0.3], [0.0, 0.2], [1.0, 1.0], [0.0, 0.0]])
    alone = Controller(scenario.resolve({**sc.to_dict(), 'num_vehicles': 1})).command(
        Controller(sc).view(X[:, [0]]), X[:, [0]])[1, 0]
    ctrl = Controller(sc)
    view = ctrl.view(X)
    together = ctrl.command(view, X[:, [0]], [0])[1, 0]
    assert abs(alone - together) > 1e-3
    step = iter(range(1_000_000))

    def command():
        """Send the next odometry; the command it is answered with."""
        before = len(cmds)
        odom.publish(itf.odom_msg(1, next(step) * 20_000_000, X[:, 0], 0j))
        assert nodes.spin_until(lambda: len(cmds) > before)
        return cmds[-1].angular_acceleration

    sent = time.monotonic()
    state.publish(itf.state_msg(2, 0, X[:, 1], (view.r[1], view.phase[1], view.rate[1],
                                                view.speed[1])))
    assert command() == pytest.approx(alone, abs=1e-9), 'heard at once: no delay'
    end = sent + 20.0
    while (u := command()) != pytest.approx(together, abs=1e-9):
        assert u == pytest.approx(alone, abs=1e-9)
        assert time.monotonic() < end, 'vehicle 2 never heard'
    assert time.monotonic() - sent >= delay


def test_vehicle_drops_the_seeded_share_of_what_it_hears(nodes):
    """The drops are the seeded draws of :class:`links.Faults`, counted in ``links``."""
    faults = {'drop_probability': 0.3, 'fault_seed': 11}
    nodes.vehicle(1, PARTICLE, 'num_vehicles:=3', 'mode:=realtime',
                  *[f'{k}:={v}' for k, v in faults.items()])
    node = nodes.node
    pubs = {j: node.create_publisher(FormationState, names.topic(j, 'formation_state'),
                                     itf.STATE_QOS) for j in (2, 3)}
    diags = nodes.collect(DiagnosticArray, names.DIAGNOSTICS_TOPIC, itf.STREAM_QOS)
    assert nodes.spin_until(lambda: all(p.get_subscription_count() for p in pubs.values()))
    odom = node.create_publisher(Odometry, '/vehicle_1/odom', itf.STATE_QOS)
    cmds = nodes.collect(VehicleCommand, '/vehicle_1/cmd', itf.STATE_QOS)
    sent = 200
    for n in range(sent // 2):
        for j, pub in pubs.items():
            pub.publish(_state(j, n * 20_000_000))
        if n % 4 == 3:                   # the events executor handles them in order: once the
            before = len(cmds)           # odometry is answered, every state was handled
            odom.publish(_odom(1, n * 20_000_000))
            assert nodes.spin_until(lambda: len(cmds) > before)
    model = links.Faults(**faults, vehicle_id=1)
    expected = sum(model.admit(2) is None for _ in range(sent))
    assert expected == pytest.approx(0.3 * sent, abs=15)

    def counted():
        got = _links(diags, 1)
        return got is not None and got[1]['dropped'] == str(expected)
    assert nodes.spin_until(counted, timeout=20), _links(diags, 1)


SATURATED = ['rigid_parallel', 'rigid_circular', 'rigid_parallel_flow']


def _limits(name):
    """Thrust limit at twice the steady need h s u0 - m0 v omega; steering force 0.1 N."""
    sc = scenario.load(CONFIG / f'{name}.yaml')
    v0, s0, _, yaw = metrics.steady_turn(sc) if sc.formation == 'circular' else (0, sc.u0, 0, 0)
    need = sc.h * s0 * sc.u0 - sc.m0 * v0 * yaw
    return [f'max_thrust:={2 * need}', 'max_steering_force:=0.1']


@pytest.mark.parametrize('name', SATURATED)
def test_rigid_scenarios_converge_with_commands_limited_to_twice_the_need(name):
    sc = scenario.load(CONFIG / f'{name}.yaml', _limits(name))
    run = simulator.simulate(sc)
    ctrl = Controller(sc)
    saturated = np.array([ctrl.saturated(U) for U in run.U])
    assert saturated.any()
    assert np.all(abs(run.U[:, 0]) <= sc.max_thrust + 1e-12)
    assert np.all(abs(run.U[:, 1]) <= sc.max_steering_force + 1e-12)
    assert simulator.summary(run)['converged']


def test_diagnostics_show_saturation(nodes):
    cfg, limits = CONFIG / 'rigid_circular.yaml', _limits('rigid_circular')
    diags = nodes.collect(DiagnosticArray, names.DIAGNOSTICS_TOPIC, itf.STREAM_QOS)
    nodes.monitor('use_sim_time:=true', 'diagnostics_period:=0.2')
    plant = nodes.plant(cfg, 'duration:=3.0', *limits)
    for k in range(1, 6):
        nodes.vehicle(k, cfg, 'duration:=3.0', *limits)

    def reasons():
        return {(s.name, s.message) for msg in diags for s in msg.status
                if s.name.startswith('formation_control/vehicle')}
    assert nodes.spin_until(lambda: any('command saturated' in m for _, m in reasons()),
                            timeout=60), reasons()
    assert plant.sc.num_vehicles == 5
    named = {name for name, _ in reasons()}
    assert named >= {f'formation_control/vehicle_{k}' for k in range(1, 6)}


def test_vehicles_first_plant_last(ros, tmp_path):
    """Lockstep equals the offline run from the first step: 2 s show it."""
    record = tmp_path / 'run.npz'
    common = ['num_vehicles:=4', 'duration:=2.0']
    for k in range(1, 5):
        ros.procs.start('vehicle', *_args(CONFIG / 'particle_circular.yaml', *common,
                                          f'vehicle_id:={k}', 'use_sim_time:=true'))
    states = ros.probe.collect(FormationState, '/vehicle_4/formation_state', itf.STATE_QOS)
    assert ros.probe.spin_until(lambda: ros.probe.node.count_publishers('/vehicle_4/cmd') > 0)
    assert not states
    plant = ros.procs.start('plant', *_args(CONFIG / 'particle_circular.yaml', *common,
                                            f'record_path:={record}'))
    plant.wait(timeout=120)
    assert plant.returncode == 0, output(plant)
    fleet = simulator.load_run(record)
    offline = simulator.simulate(scenario.load(CONFIG / 'particle_circular.yaml', common))
    np.testing.assert_allclose(fleet.X, offline.X, rtol=0, atol=1e-6, err_msg=output(plant))


def test_vehicles_that_answered_are_not_gone_while_a_slow_one_is_awaited(nodes, tmp_path):
    """
    Step 0: vehicle 3 hears its neighbours 2.5 s late (beyond command_timeout).

    The plant waits for it (never heard before) and keeps the commands the others sent long
    before.
    """
    record = tmp_path / 'run.npz'
    common = ['num_vehicles:=3', 'duration:=0.02', 'record_dt:=0.02']
    cfg = CONFIG / 'particle_circular.yaml'
    plant = nodes.plant(cfg, *common, f'record_path:={record}')
    for k in (1, 2):
        nodes.vehicle(k, cfg, *common)
    nodes.vehicle(3, cfg, *common, 'delay:=2.5', 'neighbor_timeout:=10.0')
    assert nodes.spin_until(lambda: plant.done, timeout=60)
    fleet = simulator.load_run(record)
    offline = simulator.simulate(scenario.load(cfg, common))
    np.testing.assert_allclose(fleet.U[0], offline.U[0], rtol=0, atol=1e-12)
    assert np.all(fleet.U[0, 1] != 0)


def test_a_neighbour_heard_before_the_first_odometry_is_still_waited_for(nodes):
    """Lockstep: silence counts only once a step has begun for this vehicle."""
    timeout = 1.0
    odom, state, cmds = _vehicle_1_of_two(nodes, f'neighbor_timeout:={timeout}')
    state.publish(_state(2, 0))
    nodes.spin_for(1.5 * timeout)                             # silent beyond neighbor_timeout
    odom.publish(_odom(1, 0))
    assert nodes.spin_until(lambda: cmds)
    odom.publish(_odom(1, 20_000_000))
    assert not nodes.spin_until(lambda: len(cmds) > 1, timeout=0.5 * timeout), \
        'commanded step 1 without waiting for vehicle 2'
    state.publish(_state(2, 20_000_000))
    assert nodes.spin_until(lambda: len(cmds) > 1)
    assert messages.stamp_ns(cmds[1].header.stamp) == 20_000_000


def test_formation_states_best_effort_through_qos_overrides(ros, tmp_path):
    """
    ROS 2's qos_overrides parameters make the neighbour links best effort (depth 1).

    The fleet converges at 6.4 s, as offline, and holds past its 6.28 s hold window.
    """
    from rclpy.qos import ReliabilityPolicy

    from formation_control.protocol.fleet_plan import FleetPlan
    from formation_control.swarm import Swarm, SwarmOptions, wait_plant
    sc = scenario.load(RIGID, ['num_vehicles:=4', 'duration:=14.0'])
    overrides = [f'qos_overrides./vehicle_{k}/formation_state.{end}.{policy}:={value}'
                 for k in range(1, 5) for end in ('publisher', 'subscription')
                 for policy, value in (('reliability', 'best_effort'), ('depth', 1))]
    with Swarm(sc, FleetPlan(sc.num_vehicles, 'realtime'),
               SwarmOptions(workdir=tmp_path, monitor=False,
                            node_params=tuple(overrides))) as swarm:
        def offered():
            return ros.probe.node.get_publishers_info_by_topic('/vehicle_3/formation_state')
        assert ros.probe.spin_until(lambda: offered(), timeout=30)
        assert offered()[0].qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT
        wait_plant(swarm, 120)
    run, out = swarm.result()
    assert out['converged'], out


# ---- a step asked again ------------------------------------------------------------------------

def test_plant_asks_again_a_vehicle_that_has_not_answered(nodes):
    """A vehicle that never got (or never handled) its odometry is sent the step again."""
    odom = nodes.collect(Odometry, '/vehicle_1/odom', itf.STATE_QOS)
    nodes.plant(PARTICLE, 'num_vehicles:=1', 'duration:=1.0')
    cmd = nodes.node.create_publisher(VehicleCommand, '/vehicle_1/cmd', itf.STATE_QOS)
    assert nodes.spin_until(lambda: odom and cmd.get_subscription_count())
    assert nodes.spin_until(lambda: len(odom) > 1, timeout=5.0)
    assert [messages.stamp_ns(m.header.stamp) for m in odom[:2]] == [0, 0]
    assert odom[0].pose == odom[1].pose
    cmd.publish(itf.cmd_msg(1, 0, np.zeros(2), 'second_order'))
    assert nodes.spin_until(
        lambda: any(messages.stamp_ns(m.header.stamp) == 20_000_000 for m in odom))


def test_a_neighbour_state_lost_is_sent_again_and_the_fleet_equals_its_offline_run(nodes,
                                                                                   tmp_path):
    """
    Vehicle 1 loses vehicle 2's first state (a reader's history overrun by a flood).

    It has its odometry and waits for that state; vehicle 2 has answered. The plant asks both
    again, vehicle 2's answer carries its state again, and the run goes on unchanged.
    """
    overrides = ('num_vehicles:=2', 'duration:=0.2')
    record = tmp_path / 'run.npz'
    plant = nodes.plant(PARTICLE, *overrides, f'record_path:={record}')
    first = nodes.vehicle(1, PARTICLE, *overrides)
    heard, lost = first.me.heard, []

    def losing(j, state):
        if j == 2 and not lost:
            lost.append(state.stamp)
            return False
        return heard(j, state)
    first.me.heard = losing
    nodes.vehicle(2, PARTICLE, *overrides)
    assert nodes.spin_until(lambda: plant.done, timeout=60)
    assert lost == [0] and plant.plant.gate.nudges >= 1
    assert_equal_runs(simulator.load_run(record), offline_run(PARTICLE, list(overrides)))


def test_vehicle_answers_a_repeated_step_with_the_same_state_and_command(nodes):
    nodes.vehicle(1, PARTICLE, 'num_vehicles:=1')
    odom = nodes.node.create_publisher(Odometry, '/vehicle_1/odom', itf.STATE_QOS)
    states = nodes.collect(FormationState, '/vehicle_1/formation_state', itf.STATE_QOS)
    cmds = nodes.collect(VehicleCommand, '/vehicle_1/cmd', itf.STATE_QOS)
    assert nodes.spin_until(lambda: odom.get_subscription_count())
    odom.publish(_odom(1, 0))
    assert nodes.spin_until(lambda: cmds and states)
    odom.publish(_odom(1, 0, x=7.0))                 # the same step: answered as before
    assert nodes.spin_until(lambda: len(cmds) > 1 and len(states) > 1)
    assert states[1] == states[0] and cmds[1] == cmds[0]


def test_vehicle_refuses_a_scenario_other_than_the_plants(nodes):
    """Another fleet size and gain than the plant's latched scenario: refused, naming both."""
    nodes.plant(PARTICLE, 'num_vehicles:=3')
    same = nodes.vehicle(1, PARTICLE, 'num_vehicles:=3', 'seed:=9', 'duration:=5.0')
    other = nodes.vehicle(2, PARTICLE, 'num_vehicles:=4', 'kappa:=2.0')
    assert nodes.spin_until(lambda: other.done, timeout=20)
    assert other.exit_code == 2 and not same.done
    assert nodes.spin_until(lambda: nodes.logged(
        other, "refused: this vehicle's scenario differs from the plant's (/formation/scenario): "
               'num_vehicles = 4 here, 3 at the plant; kappa = 2.0 here, 5.0 at the plant'))
