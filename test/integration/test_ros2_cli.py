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
A fleet as a ROS 2 user runs it: ``ros2 launch``, ``ros2 run``, ``ros2 topic|node|param``.

The real Jazzy command line: the ``ros2`` of the venv (``make setup`` installs it from
../shared/ros2-tools) or one on PATH (a Jazzy installation), on the package as ``colcon build``
installs it (the session's workspace). Each ``ros2`` call costs 1-2 s of start-up, so the
checks against one running fleet run in parallel batches.
"""
import contextlib
import math
import os
from pathlib import Path
import shutil
import signal
import subprocess
import sys
import time

from diagnostic_msgs.msg import DiagnosticArray
from formation_control.bags import reader as bagfile
from formation_control.core import parameters, scenario
from formation_control.protocol import messages, node_parameters
from formation_control.protocol.fleet_plan import auto_per_process, cores
from formation_control.ros import interface as itf
from formation_control.ros.monitor import MonitorNode
from formation_control.ros.plant import PlantNode
from formation_control.ros.vehicle import VehicleNode
from formation_control.sim import simulator
from formation_control_msgs.msg import FormationMetrics, FormationState, VehicleCommand
import numpy as np
import pytest
from rclpy.qos import QoSProfile
from rosutil import CONFIG, domains, Probe, ros_environment, shm_clean
import yaml

BIN = Path(sys.executable).parent
ROS2 = str(BIN / 'ros2') if (BIN / 'ros2').exists() else shutil.which('ros2')
pytestmark = pytest.mark.skipif(
    ROS2 is None, reason='the ros2 command line is not installed: neither in the venv (make '
    'setup installs it from ../shared/ros2-tools) nor on PATH (a ROS 2 Jazzy installation)')


def _default_sigint():
    signal.signal(signal.SIGINT, signal.SIG_DFL)          # a launcher that ignored it


def _interrupt(proc, sig=signal.SIGINT):
    """
    Send ``sig`` to ``proc``'s process group, as a terminal's Ctrl-C does.

    ``ros2 run`` forwards no signal: it leaves its node to the terminal's signal to the group,
    so a SIGINT to ``ros2 run`` alone would leave the node running in the domain.
    """
    with contextlib.suppress(ProcessLookupError):
        os.killpg(proc.pid, sig)


class Cli:
    """``ros2`` commands in a private domain, on the colcon-installed package."""

    def __init__(self, install, domain_id):
        site = next((install / 'lib').glob('python3*/site-packages'))
        env = ros_environment(domain_id)
        env['AMENT_PREFIX_PATH'] = os.pathsep.join(
            p for p in (str(install), env.get('AMENT_PREFIX_PATH', '')) if p)
        env['PYTHONPATH'] = os.pathsep.join(p for p in (str(site), env.get('PYTHONPATH', '')) if p)
        env['PATH'] = f'{BIN}{os.pathsep}{env["PATH"]}'
        self.env, self.procs = env, []

    def start(self, *args, log=None):
        proc = subprocess.Popen([ROS2, *map(str, args)], env=self.env, text=True,
                                stdout=log or subprocess.PIPE, stderr=subprocess.STDOUT,
                                stdin=subprocess.DEVNULL, preexec_fn=_default_sigint,
                                process_group=0)
        self.procs.append(proc)
        return proc

    def launch(self, log, *args):
        return self.start('launch', 'formation_control', 'fleet.launch.py', *args, log=log)

    def many(self, *commands, timeout=60.0):
        """
        Run ``ros2`` commands at once; return their (exit code, output).

        A command given as (seconds, args) runs until interrupted after ``seconds``.
        """
        started = []
        for cmd in commands:
            stop_after, args = cmd if isinstance(cmd[0], (int, float)) else (None, cmd)
            started.append((stop_after, self.start(*args)))
        t0, out = time.monotonic(), []
        for stop_after, proc in started:
            if stop_after is not None:
                time.sleep(max(0.0, t0 + stop_after - time.monotonic()))
                _interrupt(proc)
            text, _ = proc.communicate(timeout=timeout)
            out.append((proc.returncode, text))
        return out

    def stop_all(self):
        for proc in self.procs:
            if proc.poll() is None:
                _interrupt(proc)
        for proc in self.procs:
            try:
                proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                _interrupt(proc, signal.SIGKILL)
                proc.wait()


@pytest.fixture
def cli(colcon_install):
    with domains() as (did,):
        made = Cli(colcon_install, did)
        made.probe = Probe(did)
        subprocess.run([ROS2, 'daemon', 'start'], env=made.env, capture_output=True, timeout=30)
        try:
            yield made
        finally:
            made.probe.close()
            made.stop_all()
            subprocess.run([ROS2, 'daemon', 'stop'], env=made.env, capture_output=True,
                           timeout=30)
            shm_clean(made.env)


def _message(text):
    """Return the first message ``ros2 topic echo`` printed (YAML before ``---``)."""
    lines = [line for line in text.split('\n---')[0].splitlines()
             if not line.startswith(('\t', 'A message was lost'))]          # QoS event notes
    return yaml.safe_load('\n'.join(lines))


def _children(pid):
    path = Path(f'/proc/{pid}/task/{pid}/children')
    return [int(c) for c in path.read_text().split()] if path.exists() else []


def _dump(text):
    (node, body), = yaml.safe_load(text).items()
    return node, body['ros__parameters']


def _flat(params, prefix=''):
    out = {}
    for key, value in params.items():
        if isinstance(value, dict):
            out.update(_flat(value, f'{prefix}{key}.'))
        else:
            out[prefix + key] = value
    return out


def _fresh_values(node_cls, dump_path, *args):
    """Load a ``ros2 param dump`` into a fresh node (--params-file) and return its values."""
    with domains() as (did,):
        fresh = Probe(did)
        try:
            node = node_cls(*args, context=fresh.context, cli_args=[
                '--ros-args', '-r', '__ns:=/fleet_a', '--params-file', str(dump_path)])
            values = {name: p.value for name, p in node._parameters.items()}
            node.destroy_node()
            return values
        finally:
            fresh.close()


def _launch(cli, path, *args):
    with open(path, 'w') as log:
        return cli.launch(log, *args)


def _check_lockstep_fleet(launch, tmp_path, sc):
    """fleet_b ran in fleet_a's domain and equals its offline run: it heard no other fleet."""
    assert launch.wait(timeout=180) == 0, (tmp_path / 'fleet_b.log').read_text()
    run = simulator.load_run(tmp_path / 'fleet_b.npz')
    np.testing.assert_allclose(run.X, simulator.simulate(sc).X, atol=1e-6)
    summary = simulator.summary(run)
    assert summary['converged'] and summary['convergence_time'] < sc.duration, summary
    recorded = bagfile.read_run(tmp_path / 'bag_b')          # the launch's record:=DIR
    assert recorded.sc == run.sc and simulator.summary(recorded)['converged']
    np.testing.assert_allclose(recorded.X[-1], run.X[-1], atol=1e-9)


def _check_dump(tmp_path, rc, text):
    """Every parameter is in the dump, and the dump loaded into a fresh node gives the same."""
    tables = {'/fleet_a/plant': (PlantNode, (), node_parameters.PLANT),
              '/fleet_a/vehicle_2': (VehicleNode, (2,), node_parameters.VEHICLE),
              '/fleet_a/formation_monitor': (MonitorNode, (), node_parameters.MONITOR)}
    assert rc == 0, text
    name, params = _dump(text)
    node_cls, args, table = tables[name]
    values = _flat(params)
    expected = set(table) - {'vehicle_ids'} | {'use_sim_time'}
    if node_cls is not MonitorNode:
        expected |= set(parameters.PARAMETER_NAMES)
    assert expected <= set(values), expected - set(values)
    if node_cls is VehicleNode:
        assert (values['kappa'], values['K_f']) == (3.0, 2.0)           # formation-control set
    path = tmp_path / f'{name.split("/")[-1]}.yaml'
    path.write_text(text)
    fresh = _fresh_values(node_cls, path, *args)
    compared = [k for k in values if node_cls is not MonitorNode               # the monitor's
                or not k.startswith('qos_overrides.')]              # come with the scenario
    assert {k: fresh[k] for k in compared} == {k: values[k] for k in compared}, name


def test_two_launched_fleets_inspected_and_tuned_with_the_ros2_cli(cli, tmp_path):
    """
    Two fleets in one domain, launched: fleet_a in real time, fleet_b in lockstep.

    fleet_a is inspected and tuned with the CLI while both run, then stopped with SIGINT.
    """
    fleet_b = scenario.load(CONFIG / 'particle_parallel.yaml', ['num_vehicles:=3'],
                            duration=13.0)
    patient = tmp_path / 'patient.yaml'          # the CLI batch below loads the CPUs: no vehicle
    patient.write_text(yaml.safe_dump({'/**': {'ros__parameters': {     # leaves while starved
        'neighbor_timeout': 30.0, 'command_timeout': 60.0}}}))
    launch_b = _launch(cli, tmp_path / 'fleet_b.log', 'scenario:=particle_parallel',
                       'namespace:=fleet_b', 'num_vehicles:=3', 'duration:=13.0',
                       f'params_file:={patient}', f'record_path:={tmp_path / "fleet_b.npz"}',
                       f'record:={tmp_path / "bag_b"}')
    launch = _launch(cli, tmp_path / 'launch.log', 'scenario:=rigid_parallel',
                     'namespace:=fleet_a', 'num_vehicles:=4', 'mode:=realtime', 'duration:=600.0')
    diagnostics = cli.probe.collect(DiagnosticArray, '/diagnostics', itf.STREAM_QOS)
    metrics = cli.probe.collect(FormationMetrics, '/fleet_a/formation/metrics', itf.STREAM_QOS)
    assert cli.probe.spin_until(lambda: metrics, 60), (tmp_path / 'launch.log').read_text()
    states = []                          # when vehicle 1's states arrived here (epoch ns)
    cli.probe.node.create_subscription(
        FormationState, '/fleet_a/vehicle_1/formation_state',
        lambda _, info: states.append(info['received_timestamp']), QoSProfile(depth=1000),
        raw=True)
    set_ = subprocess.run([str(BIN / 'formation-control'), 'set', 'kappa:=3', 'K_f:=2',
                           '--namespace', 'fleet_a'], env=cli.env, capture_output=True,
                          text=True, timeout=60)
    assert set_.returncode == 0, set_.stdout + set_.stderr
    assert '4/4 vehicles took kappa = 3.0, K_f = 2.0' in set_.stdout
    v = '/fleet_a/vehicle_1'
    out = cli.many(
        ['node', 'list'],
        ['topic', 'echo', '--once', '/fleet_a/vehicle_2/odom'],
        ['topic', 'echo', '--once', '/fleet_a/vehicle_2/formation_state'],
        ['topic', 'echo', '--once', '/fleet_a/vehicle_3/cmd'],
        ['topic', 'echo', '--once', '/fleet_a/formation/metrics'],
        ['topic', 'info', '-v', '/fleet_a/vehicle_4/odom'],
        ['topic', 'type', '/fleet_a/vehicle_2/formation_state'],
        ['param', 'dump', '/fleet_a/plant'],
        ['param', 'dump', '/fleet_a/vehicle_2'],
        ['param', 'dump', '/fleet_a/formation_monitor'],
        ['param', 'set', '/fleet_a/plant', 'K', '5.0'],
        ['param', 'set', v, 'K', '1.0'],
        ['param', 'set', v, 'kappa', 'fast'],
        ['param', 'set', v, 'kappa', '-2.0'],
        ['run', 'formation_control', 'vehicle', '--ros-args', '--params-file',
         CONFIG / 'rigid_parallel.yaml', '-p', 'vehicle_id:=9'],
        ['launch', 'formation_control', 'vehicle.launch.py', 'scenario:=rigid_parralel'],
        ['launch', 'formation_control', 'fleet.launch.py', 'scenario:=particle_circular',
         'num_vehicles:=40', 'vehicles_per_process:=1', 'namespace:=fleet_c'],
        ['launch', 'formation_control', 'fleet.launch.py', 'mode:=fast', 'namespace:=fleet_c'],
        ['launch', 'formation_control', 'fleet.launch.py', f'record:={tmp_path}',
         'namespace:=fleet_c'],
    )
    assert launch_b.wait(timeout=180) == 0, (tmp_path / 'fleet_b.log').read_text()
    window = time.time_ns()
    hz, = cli.many((8.0, ['topic', 'hz', '/fleet_a/vehicle_1/formation_state']))  # alone: the
    window = (window, time.time_ns())                                  # batch loads the CPUs
    assert cli.probe.spin_until(lambda: states and states[-1] > window[1], 60)  # all taken
    (_, nodes), odom, state, cmd, metric, info, kind, *dumps = out
    dumps, refusals, (run_rc, run_out), bad_launch, too_many, bad_mode, old_bag = (
        dumps[:3], dumps[3:7], *dumps[7:])
    fleet = {'/fleet_a/plant', '/fleet_a/formation_monitor',
             *(f'/fleet_a/vehicle_{k}' for k in range(1, 5))}
    for _ in range(3):                  # the daemon's graph may lag behind under a load
        if set(nodes.split()) >= fleet:
            break
        nodes = cli.many(['node', 'list'])[0][1]
    assert set(nodes.split()) >= fleet, nodes
    msg = _message(odom[1])
    assert (msg['header']['frame_id'], msg['child_frame_id']) == ('map', 'vehicle_2/base_link')
    msg = _message(state[1])                                       # named fields
    assert (msg['interface_version'], msg['vehicle_id'], msg['header']['frame_id']) == (
        1, 2, 'map')
    assert set(messages.STATE_FIELDS) <= set(msg) and isinstance(msg['phase_rate'], float)
    assert (msg['neighbour_ids'], msg['hears'], msg['estimates_flow']) == ([], [], False)
    assert set(msg['predicted_stamp']) == {'sec', 'nanosec'}
    assert kind[1].split() == ['formation_control_msgs/msg/FormationState']
    msg = _message(cmd[1])
    assert (msg['header']['frame_id'], msg['vehicle_id']) == ('vehicle_3/base_link', 3)
    assert msg['kind'] == VehicleCommand.RIGID_BODY and isinstance(msg['thrust'], float)
    msg = _message(metric[1])
    assert 0.0 <= msg['order_parameter'] <= 1.0 and isinstance(msg['converged'], bool)
    rates = [float(line.split()[-1]) for line in hz[1].splitlines()
             if line.startswith('average rate')]
    # 1 / dt_control, or less on a loaded machine, where the real-time plant slips: what the
    # probe heard over the same seconds
    heard = np.count_nonzero((np.array(states) > window[0]) & (np.array(states) < window[1]))
    rate = heard / (1e-9 * (window[1] - window[0]))
    assert 10.0 < rate < 55.0 and rates and abs(rates[-1] - rate) < 0.2 * rate, (rate, hz[1])
    assert 'Node name: plant' in info[1] and 'Node namespace: /fleet_a' in info[1]
    assert 'TRANSIENT_LOCAL' in info[1]
    reasons = [text for _, text in refusals]
    assert all('Setting parameter failed' in text for text in reasons), reasons
    assert 'read-only' in reasons[0]
    assert 'formation parallel needs K < 0' in reasons[1]
    assert 'Wrong parameter type' in reasons[2]
    assert 'kappa' in reasons[3]
    assert run_rc == 2 and "parameter 'vehicle_id' = 9 is invalid" in run_out, run_out
    assert bad_launch[0] != 0 and "scenario 'rigid_parralel' not found" in bad_launch[1]
    assert too_many[0] != 0 and ('vehicles_per_process 1 makes 44 DDS participants on this '
                                 'host' in too_many[1]), too_many[1]
    assert bad_mode[0] != 0 and "mode 'fast' is invalid: lockstep or realtime" in bad_mode[1]
    assert old_bag[0] != 0 and (f"record '{tmp_path}' exists already: give a new bag "
                                'directory' in old_bag[1]), old_bag[1]
    for rc, text in dumps:
        _check_dump(tmp_path, rc, text)
    _check_lockstep_fleet(launch_b, tmp_path, fleet_b)
    formation = 'fleet_a/formation_control/formation'                  # namespaced status
    assert cli.probe.spin_until(lambda: any(
        s.name == formation and s.message.startswith('converged in')
        for m in diagnostics for s in m.status), 30)
    assert launch.poll() is None
    children = _children(launch.pid)
    vehicles = math.ceil(4 / auto_per_process(4, cores()))
    assert len(children) == 3 + vehicles                     # the plant, monitor and warden
    launch.send_signal(signal.SIGINT)
    assert launch.wait(timeout=30) == 0
    assert not [c for c in children if Path(f'/proc/{c}').exists()]
    log = (tmp_path / 'launch.log').read_text()
    assert 'every vehicle took' in log, '\n'.join(line for line in log.splitlines()
                                                  if 'monitor' in line or 'WARN' in line)


def test_a_formation_state_of_another_interface_version_is_dropped_and_counted(cli, tmp_path):
    """``ros2 topic pub`` of a FormationState of interface version 2: vehicle 1 refuses it."""
    with open(tmp_path / 'vehicle.log', 'w') as log:
        _refused_by_a_vehicle(cli, log)
        cli.stop_all()
    logged = (tmp_path / 'vehicle.log').read_text()
    assert ('[ERROR]' in logged and 'dropped a formation_state of vehicle 2 of interface '
            'version 2: this node speaks formation_control_msgs version 1' in logged), logged


def _refused_by_a_vehicle(cli, log):
    from diagnostic_msgs.msg import DiagnosticArray
    cli.start('run', 'formation_control', 'vehicle', '--ros-args', '--params-file',
              CONFIG / 'particle_parallel.yaml', '-p', 'num_vehicles:=2', '-p', 'vehicle_id:=1',
              log=log)
    diagnostics = cli.probe.collect(DiagnosticArray, '/diagnostics', itf.STREAM_QOS)
    name = 'formation_control/vehicle_1/links'

    def count():
        for m in reversed(diagnostics):
            for s in m.status:
                if s.name == name:
                    return {v.key: v.value for v in s.values}['interface_version']
        return None
    assert cli.probe.spin_until(lambda: count() == '0', 60)
    (rc, text), = cli.many(['topic', 'pub', '--once', '-w', '1', '--qos-reliability',
                            'reliable', '--qos-durability', 'transient_local',
                            '/vehicle_2/formation_state',
                            'formation_control_msgs/msg/FormationState',
                            '{interface_version: 2, vehicle_id: 2, speed: 1.0}'])
    assert rc == 0, text
    assert cli.probe.spin_until(lambda: count() == '1', 30), count()


def _env_of(node):
    """Return a launch Node's additional environment as {name: value} (text substitutions)."""
    def text(subs):
        return ''.join(s.text for s in subs)
    return {text(name): text(value) for name, value in node.additional_env}


def test_launched_nodes_get_the_fleets_fast_dds_profile_unless_one_is_named(monkeypatch):
    """
    ``fleet.launch.py`` and ``vehicle.launch.py`` give each node the fleet's Fast DDS profile.

    It is written beside the launch's parameter file (ops/dds_profile.py); a profile the user
    names in either variable is left alone (a TLS member's own profile carries the same writer
    section: test_dds_profile.py).
    """
    if ROS2 is None:
        pytest.skip('the ros2 command line (and launch) is not installed')
    from formation_control.ops import dds_profile
    from formation_control.ros import launching
    for name in dds_profile.PROFILE_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    args = {'scenario': 'particle_parallel', 'num_vehicles': '3', 'duration': '',
            'namespace': '', 'params_file': '', 'secure': ''}
    _, files = launching._scenario(args)
    env = _env_of(launching._node('vehicle', args, files, 'vehicle_1'))
    profile = Path(files[0]).parent / dds_profile.FILE
    assert env['FASTRTPS_DEFAULT_PROFILES_FILE'] == str(profile)
    assert profile.read_text() == dds_profile.profile_xml()
    monkeypatch.setenv('FASTDDS_DEFAULT_PROFILES_FILE', '/etc/fleet/mine.xml')
    _, files = launching._scenario(args)
    assert 'FASTRTPS_DEFAULT_PROFILES_FILE' not in _env_of(
        launching._node('vehicle', args, files, 'vehicle_1'))


@pytest.mark.skipif(not (BIN / 'ros2').exists(), reason='the ros2 command line is not in the '
                    'venv (make setup installs it from ../shared/ros2-tools)')
def test_the_venvs_ros2_finds_the_package_as_the_readme_uses_it(tmp_path):
    """``make setup`` registers the package in the venv: ``.venv/bin/ros2 launch|run`` find it."""
    env = {k: v for k, v in ros_environment(0).items() if k != 'AMENT_PREFIX_PATH'}
    prefix = subprocess.run([str(BIN / 'ros2'), 'pkg', 'prefix', 'formation_control'], env=env,
                            capture_output=True, text=True, timeout=60, cwd=tmp_path)
    assert prefix.stdout.strip() == str(Path(sys.prefix)), prefix.stderr
    found = subprocess.run([str(BIN / 'ros2'), 'pkg', 'executables', 'formation_control'],
                           env=env, capture_output=True, text=True, timeout=60, cwd=tmp_path)
    assert {'plant', 'vehicle', 'vehicles', 'monitor', 'recorder', 'warden'} <= {
        line.split()[-1] for line in found.stdout.splitlines()}, found.stderr
    shown = subprocess.run([str(BIN / 'ros2'), 'launch', 'formation_control', 'fleet.launch.py',
                            '--show-args'], env=env, capture_output=True, text=True, timeout=60,
                           cwd=tmp_path)
    assert shown.returncode == 0 and "'heal_after':" in shown.stdout, shown.stderr
