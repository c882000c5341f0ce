"""
Reliability with real processes and fixed seeds: a vehicle killed and restarted, lossy and late
links, every kind of bad message, a non-finite plant state, saturated commands, start order.
"""
import json
from pathlib import Path

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
import numpy as np
from geometry_msgs.msg import WrenchStamped
from nav_msgs.msg import Odometry
import pytest
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from formation_control import bagfile
from formation_control.core import metrics, scenario, simulator
from formation_control.core.control import Controller
from formation_control.ros import interface as itf
from rosutil import CONFIG, output

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

def _state(j, ns, values=None, frame=None, names=itf.STATE_FIELDS):
    msg = itf.state_msg(j, ns, np.array([1.0, 2.0, 0.3, 0.2, 1.0, 0.0]),
                        (complex(1.0, 2.0), 0.3, 0.2, 1.0))
    if values is not None:
        msg.position = values
    msg.name = list(names)
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
    'state_non_finite': ('state', lambda: _state(2, 0, [float('inf')] * 7), 'non_finite'),
    'state_malformed': ('state', lambda: _state(2, 0, [1.0] * 5, names=['x'] * 5), 'malformed'),
    'state_foreign_id': ('state', lambda: _state(2, 0, frame='vehicle_9/base_link'),
                         'foreign_id'),
    'state_wrong_frame': ('state', lambda: _state(2, 0, frame='map'), 'wrong_frame'),
    'state_stale': ('state', lambda: _state(2, 0), 'stale'),
}


@pytest.mark.parametrize('case', BAD_VEHICLE_INPUT)
def test_vehicle_drops_counts_and_survives_bad_input(ros, case):
    topic, make, kind = BAD_VEHICLE_INPUT[case]
    vehicle = ros.procs.start('vehicle', *_args(PARTICLE, 'num_vehicles:=2', 'vehicle_id:=1'))
    node = ros.probe.node
    pubs = {'odom': node.create_publisher(Odometry, '/vehicle_1/odom', itf.STATE_QOS),
            'state': node.create_publisher(JointState, '/vehicle_2/formation_state',
                                           itf.STATE_QOS)}
    cmds = ros.probe.collect(WrenchStamped, '/vehicle_1/cmd', itf.STATE_QOS)
    diags = ros.probe.collect(DiagnosticArray, itf.DIAGNOSTICS_TOPIC, itf.STREAM_QOS)
    assert ros.probe.spin_until(lambda: all(p.get_subscription_count() for p in pubs.values()))
    if kind == 'stale':
        pubs['state'].publish(_state(2, 400_000_000))
    pubs[topic].publish(make())
    pubs['odom'].publish(_odom(1, 400_000_000))
    pubs['state'].publish(_state(2, 400_000_000))
    name = 'formation_control/vehicle_1/links'
    assert ros.probe.spin_until(lambda: cmds and (_status(diags, name) or (0, 0, {}))[2].get(
        kind) == '1', timeout=20), (_status(diags, name), output(vehicle))
    assert itf.stamp_ns(cmds[-1].header.stamp) == 400_000_000
    counts = _status(diags, name)[2]
    others = [k for k in ('non_finite', 'malformed', 'wrong_frame', 'stale', 'foreign_id')
              if k != kind]
    assert all(counts[k] == '0' for k in others), counts
    assert vehicle.poll() is None
    assert 'dropped' in output(vehicle)


def test_plant_drops_and_counts_bad_commands(ros):
    plant = ros.procs.start('plant', *_args(PARTICLE, 'num_vehicles:=2', 'exit_when_done:=false'))
    node = ros.probe.node
    cmd = {k: node.create_publisher(WrenchStamped, itf.topic(k, 'cmd'), itf.STATE_QOS)
           for k in (1, 2)}
    diags = ros.probe.collect(DiagnosticArray, itf.DIAGNOSTICS_TOPIC, itf.STREAM_QOS)
    clock = ros.probe.collect(Clock, '/clock', itf.LATCHED_QOS)
    assert ros.probe.spin_until(lambda: clock and all(p.get_subscription_count()
                                                      for p in cmd.values()))
    bad = itf.cmd_msg(1, 0, (0.0, float('nan')), 'second_order')
    wrong = itf.cmd_msg(1, 0, (0.0, 0.1), 'second_order')
    wrong.header.frame_id = 'map'
    late = itf.cmd_msg(1, 5 * 20_000_000, (0.0, 0.1), 'second_order')
    for msg in (bad, wrong, late):
        cmd[1].publish(msg)
    for k in (1, 2):
        cmd[k].publish(itf.cmd_msg(k, 0, (0.0, 0.1), 'second_order'))
    assert ros.probe.spin_until(lambda: any(c.clock.nanosec == 20_000_000 for c in clock))

    def counted():
        s = _status(diags, 'formation_control/plant')
        return s and (s[2]['non_finite'], s[2]['wrong_frame'], s[2]['stale']) == ('1', '1', '1')
    assert ros.probe.spin_until(counted), _status(diags, 'formation_control/plant')
    assert plant.poll() is None


def test_plant_stops_a_vehicle_whose_state_turns_non_finite(ros):
    plant = ros.procs.start('plant', *_args(RIGID, 'num_vehicles:=2', 'exit_when_done:=false'))
    node = ros.probe.node
    cmd = {k: node.create_publisher(WrenchStamped, itf.topic(k, 'cmd'), itf.STATE_QOS)
           for k in (1, 2)}
    odom = {k: ros.probe.collect(Odometry, itf.topic(k, 'odom'), itf.STATE_QOS) for k in (1, 2)}
    diags = ros.probe.collect(DiagnosticArray, itf.DIAGNOSTICS_TOPIC, itf.STREAM_QOS)
    assert ros.probe.spin_until(lambda: odom[1] and odom[2] and all(
        p.get_subscription_count() for p in cmd.values()))
    cmd[1].publish(itf.cmd_msg(1, 0, (5.0, 0.0), 'rigid'))
    cmd[2].publish(itf.cmd_msg(2, 0, (1e308, 0.0), 'rigid'))
    step = 20_000_000
    assert ros.probe.spin_until(lambda: any(itf.stamp_ns(m.header.stamp) == step
                                            for m in odom[1]))
    cmd[1].publish(itf.cmd_msg(1, step, (5.0, 0.0), 'rigid'))
    assert ros.probe.spin_until(lambda: any(itf.stamp_ns(m.header.stamp) == 2 * step
                                            for m in odom[1]))
    assert all(itf.stamp_ns(m.header.stamp) == 0 for m in odom[2])
    for m in odom[1]:
        assert np.isfinite(m.pose.pose.position.x) and np.isfinite(m.twist.twist.linear.x)
    assert ros.probe.spin_until(lambda: (_status(diags, 'formation_control/plant') or (0,))[0]
                                == DiagnosticStatus.ERROR)
    assert _status(diags, 'formation_control/plant')[2]['stopped'] == '[2]'
    assert 'vehicle 2: its state became non-finite' in output(plant)
    assert plant.poll() is None


# ---- a vehicle lost and restarted ------------------------------------------------------------

def _sub_converged(sc, X, members):
    sub = scenario.resolve({**sc.to_dict(), 'num_vehicles': int(members.sum())})
    ctrl = Controller(sub)
    snap = metrics.snapshot(ctrl, X[:, members], np.zeros((2, sub.num_vehicles)))
    return metrics.converged(sub, snap)


FLEETS = {
    'circular': ('particle_circular.yaml', 5.0, 60.0, 150.0),
    'parallel': ('particle_parallel.yaml', 1.0, 25.0, 50.0),
}


@pytest.mark.parametrize('formation', FLEETS)
def test_fleet_reconverges_without_a_killed_vehicle_and_again_when_it_returns(ros, tmp_path,
                                                                           formation):
    name, t_kill, t_back, duration = FLEETS[formation]
    record = tmp_path / 'run.npz'
    common = ['num_vehicles:=6', f'duration:={duration}', 'seed:=2']
    plant = ros.procs.start('plant', *_args(CONFIG / name, *common, f'record_path:={record}'))
    vehicle = {k: ros.procs.start('vehicle', *_args(CONFIG / name, *common, f'vehicle_id:={k}',
                                                    'use_sim_time:=true'))
               for k in range(1, 7)}
    now = []
    ros.probe.node.create_subscription(
        Clock, '/clock', lambda m: now.append(m.clock.sec + 1e-9 * m.clock.nanosec),
        itf.LATCHED_QOS)
    assert ros.probe.spin_until(lambda: now and now[-1] >= t_kill, timeout=120)
    vehicle[6].kill()
    vehicle[6].wait(timeout=10)
    assert ros.probe.spin_until(lambda: now[-1] >= t_back, timeout=300), output(plant)
    ros.procs.start('vehicle', *_args(CONFIG / name, *common, 'vehicle_id:=6',
                                      'use_sim_time:=true'))
    plant.wait(timeout=600)
    assert plant.returncode == 0, output(plant)
    run = simulator.load_run(record)
    sc = run.sc
    five = np.array([True] * 5 + [False])
    back = int(np.searchsorted(run.t, t_back - 1.0))
    assert not _sub_converged(sc, run.X[int(np.searchsorted(run.t, t_kill))], five)
    assert _sub_converged(sc, run.X[back], five)
    assert not _sub_converged(sc, run.X[back], np.ones(6, bool))
    assert _sub_converged(sc, run.X[-1], np.ones(6, bool))
    gone = (run.t > t_kill + 3.0) & (run.t < t_back - 3.0)
    assert np.all(run.U[gone, :, 5] == 0.0)


# ---- lossy, late links; saturation; start order ------------------------------------------------

def _swarm(ros, tmp_path, name, *args, timeout=400):
    summary = tmp_path / 'summary.json'
    result = ros.procs.run('formation-control', 'swarm', CONFIG / f'{name}.yaml', *args,
                           '--summary', summary, timeout=timeout)
    assert result.returncode == 0, result.stderr + result.stdout
    return json.loads(summary.read_text())


@pytest.mark.parametrize('name, duration', [('rigid_parallel', 20), ('rigid_circular', 60),
                                            ('rigid_parallel_flow', 20)])
def test_rigid_scenarios_converge_with_lossy_late_links(ros, tmp_path, name, duration):
    """rigid_circular converges at 27 s offline and in real time; 60 s leave room under load."""
    out = _swarm(ros, tmp_path, name, '--mode', 'realtime', '--duration', str(duration),
                 '-p', 'drop_probability:=0.2', '-p', 'delay:=0.05', '-p', 'delay_jitter:=0.1',
                 '-p', 'fault_seed:=5')
    assert out['converged'], out
    logs = Path(out['logs'])
    assert 'drop_probability' not in (logs / 'scenario.yaml').read_text()


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


def test_diagnostics_show_saturation(ros, tmp_path):
    bag = tmp_path / 'bag'
    out = _swarm(ros, tmp_path, 'rigid_circular', '--duration', '3', '--bag', str(bag),
                 *[a for p in _limits('rigid_circular') for a in ('-p', p)])
    reasons = {msg for _, statuses in bagfile.diagnostics(bag)
               for name, level, msg, _ in statuses if name.startswith('formation_control/vehicle')}
    assert any('command saturated' in r for r in reasons), reasons
    assert out['num_vehicles'] == 5


def test_vehicles_first_plant_last(ros, tmp_path):
    record = tmp_path / 'run.npz'
    common = ['num_vehicles:=4', 'duration:=20.0']
    for k in range(1, 5):
        ros.procs.start('vehicle', *_args(CONFIG / 'particle_circular.yaml', *common,
                                          f'vehicle_id:={k}', 'use_sim_time:=true'))
    states = ros.probe.collect(JointState, '/vehicle_4/formation_state', itf.STATE_QOS)
    assert ros.probe.spin_until(lambda: ros.probe.node.count_publishers('/vehicle_4/cmd') > 0)
    assert not states
    plant = ros.procs.start('plant', *_args(CONFIG / 'particle_circular.yaml', *common,
                                            f'record_path:={record}'))
    plant.wait(timeout=120)
    assert plant.returncode == 0, output(plant)
    fleet = simulator.load_run(record)
    offline = simulator.simulate(scenario.load(CONFIG / 'particle_circular.yaml', common))
    np.testing.assert_allclose(fleet.X, offline.X, rtol=0, atol=1e-6, err_msg=output(plant))


def test_vehicles_that_answered_are_not_gone_while_a_slow_one_is_awaited(ros, tmp_path):
    """Step 0: vehicle 3 hears its neighbours 2.5 s late (beyond command_timeout); the plant
    waits for it (never heard before) and keeps the commands the others sent long before."""
    record = tmp_path / 'run.npz'
    common = ['num_vehicles:=3', 'duration:=0.02', 'record_dt:=0.02']
    cfg = CONFIG / 'particle_circular.yaml'
    plant = ros.procs.start('plant', *_args(cfg, *common, f'record_path:={record}'))
    for k in (1, 2):
        ros.procs.start('vehicle', *_args(cfg, *common, f'vehicle_id:={k}'))
    ros.procs.start('vehicle', *_args(cfg, *common, 'vehicle_id:=3', 'delay:=2.5',
                                      'neighbor_timeout:=10.0'))
    plant.wait(timeout=60)
    assert plant.returncode == 0, output(plant)
    fleet = simulator.load_run(record)
    offline = simulator.simulate(scenario.load(cfg, common))
    np.testing.assert_allclose(fleet.U[0], offline.U[0], rtol=0, atol=1e-12)
    assert np.all(fleet.U[0, 1] != 0)


def test_a_neighbour_heard_before_the_first_odometry_is_still_waited_for(ros):
    """Lockstep: silence counts only once a step has begun for this vehicle."""
    ros.procs.start('vehicle', *_args(PARTICLE, 'num_vehicles:=2', 'vehicle_id:=1',
                                      'neighbor_timeout:=3.0'))
    node = ros.probe.node
    odom = node.create_publisher(Odometry, '/vehicle_1/odom', itf.STATE_QOS)
    state = node.create_publisher(JointState, '/vehicle_2/formation_state', itf.STATE_QOS)
    cmds = ros.probe.collect(WrenchStamped, '/vehicle_1/cmd', itf.STATE_QOS)
    assert ros.probe.spin_until(lambda: odom.get_subscription_count()
                                and state.get_subscription_count())
    state.publish(_state(2, 0))
    ros.probe.spin_until(lambda: False, timeout=4.0)          # beyond neighbor_timeout
    odom.publish(_odom(1, 0))
    assert ros.probe.spin_until(lambda: cmds)
    odom.publish(_odom(1, 20_000_000))
    ros.probe.spin_until(lambda: len(cmds) > 1, timeout=1.0)
    assert len(cmds) == 1, 'commanded step 1 without waiting for vehicle 2'
    state.publish(_state(2, 20_000_000))
    assert ros.probe.spin_until(lambda: len(cmds) > 1)
    assert itf.stamp_ns(cmds[1].header.stamp) == 20_000_000


def test_formation_states_best_effort_through_qos_overrides(ros, tmp_path):
    """ROS 2's qos_overrides parameters make the neighbour links best effort (depth 1)."""
    from rclpy.qos import ReliabilityPolicy

    from formation_control.swarm import Swarm, wait_plant
    sc = scenario.load(RIGID, ['num_vehicles:=4', 'duration:=15.0'])
    overrides = [f'qos_overrides./vehicle_{k}/formation_state.{end}.{policy}:={value}'
                 for k in range(1, 5) for end in ('publisher', 'subscription')
                 for policy, value in (('reliability', 'best_effort'), ('depth', 1))]
    with Swarm(sc, 'realtime', workdir=tmp_path, monitor=False, node_params=overrides) as swarm:
        def offered():
            return ros.probe.node.get_publishers_info_by_topic('/vehicle_3/formation_state')
        assert ros.probe.spin_until(lambda: offered(), timeout=30)
        assert offered()[0].qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT
        wait_plant(swarm, 120)
    run, out = swarm.result()
    assert out['converged'], out


# ---- a step asked again ------------------------------------------------------------------------

def test_plant_asks_again_a_vehicle_that_has_not_answered(ros):
    """A vehicle that never got (or never handled) its odometry is sent the step again."""
    ros.procs.start('plant', *_args(PARTICLE, 'num_vehicles:=1', 'duration:=1.0'))
    node = ros.probe.node
    odom = ros.probe.collect(Odometry, '/vehicle_1/odom', itf.STATE_QOS)
    cmd = node.create_publisher(WrenchStamped, '/vehicle_1/cmd', itf.STATE_QOS)
    assert ros.probe.spin_until(lambda: odom and cmd.get_subscription_count())
    assert ros.probe.spin_until(lambda: len(odom) > 1, timeout=5.0)
    assert [itf.stamp_ns(m.header.stamp) for m in odom[:2]] == [0, 0]
    assert odom[0].pose == odom[1].pose
    cmd.publish(itf.cmd_msg(1, 0, np.zeros(2), 'second_order'))
    assert ros.probe.spin_until(
        lambda: any(itf.stamp_ns(m.header.stamp) == 20_000_000 for m in odom))


def test_vehicle_answers_a_repeated_step_with_the_same_state_and_command(ros):
    ros.procs.start('vehicle', *_args(PARTICLE, 'num_vehicles:=1', 'vehicle_id:=1'))
    node = ros.probe.node
    odom = node.create_publisher(Odometry, '/vehicle_1/odom', itf.STATE_QOS)
    states = ros.probe.collect(JointState, '/vehicle_1/formation_state', itf.STATE_QOS)
    cmds = ros.probe.collect(WrenchStamped, '/vehicle_1/cmd', itf.STATE_QOS)
    assert ros.probe.spin_until(lambda: odom.get_subscription_count())
    odom.publish(_odom(1, 0))
    assert ros.probe.spin_until(lambda: cmds and states)
    odom.publish(_odom(1, 0, x=7.0))                 # the same step: answered as before
    assert ros.probe.spin_until(lambda: len(cmds) > 1 and len(states) > 1)
    assert states[1] == states[0] and cmds[1] == cmds[0]
