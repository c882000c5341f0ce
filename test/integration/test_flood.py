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
A flood of malformed samples on every topic the fleet's nodes subscribe, from another process.

A lockstep fleet (plant, vehicles, monitor, recorder; built in this process, ``use_sim_time``
as the swarm runs them; estimating rigid bodies, or particles told a vortex) starts once a
flooder process (test/flooder.py) has matched every one of its subscriptions, and runs under
the flood. The samples are mutations of real serialized
messages of each topic's type (random bytes, truncations, flipped bytes, length fields of
2^31-1 and 2^32-1, a zeroed encapsulation header, trailing garbage), each checked undecodable
here, and messages with NaN or infinite doubles. Every node survives, counts each sample under
its reason, keeps its log short and free of the middleware's per-sample errors, and the fleet's
record equals the offline simulator's: nothing of the flood was taken for data.
"""
from collections import Counter
import json
import math
import os
import subprocess
import sys
import threading

from diagnostic_msgs.msg import DiagnosticArray
from formation_control.bags import reader as bagfile
from formation_control.core import scenario
from formation_control.ops import security, signing
from formation_control.protocol import names
from formation_control.protocol.intake import Rejection
from formation_control.ros import interface as itf
from formation_control.ros.bag import FleetRecorder
from formation_control.sim import simulator
from geometry_msgs.msg import TwistStamped, Vector3Stamped
from nav_msgs.msg import Odometry
import numpy as np
import pytest
from rcl_interfaces.msg import Parameter, ParameterEvent, ParameterValue
from rcl_interfaces.srv import GetParameters, SetParameters, SetParametersAtomically
from rclpy.qos import qos_profile_parameter_events
from rclpy.serialization import deserialize_message, serialize_message
from rosgraph_msgs.msg import Clock
from rosutil import CONFIG, node_args
from runs import assert_equal_runs, offline_run
from std_msgs.msg import Empty, String, UInt8MultiArray

FLEETS = {
    'estimating': (CONFIG / 'rigid_parallel.yaml',
                   ('num_vehicles:=3', 'flow_source:=estimated', 'duration:=2.0')),
    'told_the_flow': (CONFIG / 'particle_circular.yaml',
                      ('num_vehicles:=3', 'flow_model:=vortex', 'flow_circulation:=2.0',
                       'flow_radius:=2.0', 'duration:=2.0')),
    'signing': (CONFIG / 'particle_parallel.yaml', ('num_vehicles:=3', 'duration:=2.0')),
}
"""Estimating rigid bodies (the vehicles hear water_velocity, the plant formation states),
particles told a vortex (each vehicle hears its local flow with each odometry), and a signing
fleet (the vehicles and the plant hear the control topics' envelopes on ``TOPIC/signed``)."""
SIGNED = ('odom', 'cmd', 'formation_state')
"""The per-vehicle topics a signing fleet's vehicles and plant hear as envelopes (and /clock)."""
UNSIGNING = ('formation_monitor', 'formation_bag_recorder')
"""The nodes that hear the plain topics in a signing fleet too."""
NODE_PARAMS = ('use_sim_time:=true',)
EXACT = ('neighbor_timeout:=60.0', 'command_timeout:=120.0')
"""The plant's and vehicles' silences that would leave a peer out of a step's sums, lifted: a
sample lost in the flood is sent again after a second or more of wall time, and the run must
still equal the offline one."""
LOG_BOUND = 25
"""Lines each node may log over the whole run: its start-up and end, and the dropped samples'
warnings (throttled to one per 2 s per kind of line)."""
MIDDLEWARE_ERRORS = ('Fast CDR exception', 'error state is being overwritten',
                     'sequence size exceeds remaining buffer')
X = np.array([1.0, 2.0, 0.3, 0.2, 1.0, 0.0])
BAD_PARAMETERS = [Parameter(name='kappa', value=ParameterValue(type=99)),
                  Parameter(name='', value=ParameterValue(type=99)),
                  Parameter(name='kappa', value=ParameterValue(type=4, string_value='x')),
                  Parameter(name='cut_links', value=ParameterValue(type=9,
                                                                   string_array_value=['a'])),
                  Parameter(name='kappa', value=ParameterValue(type=3, double_value=math.nan)),
                  Parameter(name='x' * 10_000, value=ParameterValue(type=2, integer_value=1))]
"""Requests rclpy reads but refuses, and a parameter type that does not exist (99), which
killed every node before :func:`parameters.guard_services`."""


def _undecodable(template, msg_type, rng):
    """
    Return mutations of the serialized ``template`` that do not deserialize as ``msg_type``.

    Neither as sent nor as a reader gets them (:func:`_padded`): a cut whose lost bytes were
    zeros arrives as the whole template, a true message.
    """
    data = serialize_message(template)
    n = len(data)
    out = [rng.bytes(int(m)) for m in rng.integers(1, 2 * n, 6)]
    out += [b'\x00\x01\x00\x00' + rng.bytes(int(m)) for m in rng.integers(1, n, 6)]
    out += [data[:m] for m in sorted({1, 3, 4, 5, 8, n // 2, n - 1}) if 0 < m < n]
    for i in rng.integers(0, n, 12):
        out.append(data[:i] + bytes([data[i] ^ 0xff]) + data[i + 1:])
    for length in (b'\xff\xff\xff\x7f', b'\xff\xff\xff\xff'):
        out += [data[:i] + length + data[i + 4:] for i in range(4, n - 3, 4)]
    out.append(b'\x00\x00\x00\x00' + data[4:])
    out += [data[:m] + rng.bytes(16) for m in (n // 3, n - 2) if m > 0]
    kept = []
    for sample in out:
        if sample and sample not in kept and not _decodes(sample, msg_type) \
                and not _decodes(_padded(sample), msg_type):
            kept.append(sample)
    return kept


def _decodes(data, msg_type):
    try:
        deserialize_message(data, msg_type)
    except Exception:
        return False
    return True


def _odom(k, value):
    return itf.odom_msg(k, 20_000_000, np.array([value, 2.0, 0.3, 0.2, 1.0, 0.0]), 0j)


def _water(k, value):
    return itf.water_velocity_msg(k, 20_000_000, np.full(6, value))


def _flow(k, value):
    return itf.flow_msg(k, 20_000_000, complex(value, 0.1))


def _plan(sc, fleet=None):
    """
    Return the flooder's topics and, per node, the reason of each sample it is sent.

    With ``fleet`` (a signing fleet's directory), the vehicles and the plant hear the control
    topics' envelopes instead (``TOPIC/signed``); the monitor the plain topics still.
    """
    from formation_control.protocol.onboard import needs_second_sensor
    from formation_control_msgs.msg import FormationState, VehicleCommand
    rng = np.random.default_rng(32)
    second = needs_second_sensor(sc)
    n, graph = sc.num_vehicles, sc.comm_graph
    state_qos = {'reliability': 'RELIABLE', 'durability': 'TRANSIENT_LOCAL', 'depth': 1000}
    topics, heard = [], {'plant': [], 'formation_monitor': [], 'formation_bag_recorder': []}
    for k in range(1, n + 1):
        heard[f'vehicle_{k}'] = []

    def add(topic, msg_type, template, readers, nan=(), qos=state_qos):
        plain = [r for r in readers if fleet is None or r in UNSIGNING
                 or topic.rsplit('/', 1)[-1] not in SIGNED + ('clock',)]
        if plain:
            samples = _undecodable(template, msg_type, rng)
            _flood(topic, msg_type, samples + [serialize_message(m) for m in nan],
                   ['malformed'] * len(samples) + ['non_finite'] * len(nan), plain, qos)
        if len(plain) < len(readers):
            samples, reasons = _bad_envelopes(fleet, topic, template, rng)
            _flood(topic + signing.SUFFIX, UInt8MultiArray, samples, reasons,
                   [r for r in readers if r not in plain], qos)

    def _flood(topic, msg_type, samples, reasons, readers, qos):
        topics.append({'topic': topic, 'type': msg_type.__module__.split('.')[0] + '/msg/'
                       + msg_type.__name__, 'matches': len(readers), **qos,
                       'samples': [s.hex() for s in samples]})
        for name in readers:
            heard[name].append((topic, reasons, qos is not state_qos))

    for k in range(1, n + 1):
        vehicle = f'vehicle_{k}'
        add(names.topic(k, 'odom'), Odometry, _odom(k, 1.0), [vehicle, 'formation_monitor'],
            [_odom(k, v) for v in (math.nan, math.inf, -math.inf)])
        if second == 'water':
            add(names.topic(k, 'water_velocity'), TwistStamped, _water(k, 0.2), [vehicle],
                [_water(k, v) for v in (math.nan, math.inf)])
        if second == 'flow':
            add(names.topic(k, 'flow'), Vector3Stamped, _flow(k, 0.2), [vehicle],
                [_flow(k, v) for v in (math.nan, math.inf)])
        add(names.topic(k, 'cmd'), VehicleCommand, itf.cmd_msg(k, 0, (1.0, 0.1), sc.model),
            ['plant', 'formation_monitor'])
        listeners = [f'vehicle_{j}' for j in range(1, n + 1) if k in graph.neighbours(j)]
        estimating = ['plant'] if sc.flow_source == 'estimated' else []
        add(names.topic(k, 'formation_state'), FormationState, itf.state_msg(
            k, 0, X, (complex(1.0, 2.0), 0.3, 0.2, 1.0), graph.neighbours(k),
            [True] * len(graph.neighbours(k))), listeners + estimating + ['formation_monitor'])
    latched = {**state_qos}
    add('/' + names.SCENARIO_TOPIC, String, itf.scenario_msg(sc),
        [f'vehicle_{k}' for k in range(1, n + 1)] + ['formation_monitor'], qos=latched)
    add('/' + names.START_TOPIC, Empty, Empty(), ['plant'], qos=latched)
    events = qos_profile_parameter_events
    add('/parameter_events', ParameterEvent, ParameterEvent(
        node='/vehicle_1', changed_parameters=[Parameter(name='kappa')]), ['formation_monitor'],
        qos={'reliability': events.reliability.name, 'durability': events.durability.name,
             'depth': 1000})
    add('/clock', Clock, Clock(), ['plant', 'formation_monitor', 'formation_bag_recorder'] + [
        f'vehicle_{k}' for k in range(1, n + 1)], qos={
            'reliability': 'BEST_EFFORT', 'durability': 'VOLATILE', 'depth': 1})
    return topics, heard


def _padded(data):
    """Return ``data`` as a reader gets it: zeros up to a multiple of 4 bytes (RTPS payloads)."""
    return data + bytes(-len(data) % 4)


def _bad_envelopes(fleet, topic, template, rng):
    """
    Return envelopes for ``topic`` that no receiver may accept, and the reason of each.

    Undecodable mutations of a true envelope (no envelope: ``unsigned``), bytes without the
    envelope's mark, the message sealed by a member other than the topic's, and sealed by the
    topic's member for another topic. None is validly signed: one would be data, and its
    sequence would make the true member's next envelopes replays (a cut whose lost bytes were
    zeros is whole again once padded: left out).
    """
    topic = '/' + topic.lstrip('/')                     # as the receivers resolve it
    signer = signing.signer_for(topic)
    other = 'vehicle_1' if signer != 'vehicle_1' else 'vehicle_2'
    payload = serialize_message(template)
    true = signing.load_member(fleet / signer).signer
    samples = _undecodable(deserialize_message(true.seal(topic, payload), UInt8MultiArray),
                           UInt8MultiArray, rng)
    samples += [signing.array_message(b'no mark ' + payload),
                signing.load_member(fleet / other).signer.seal(topic, payload),
                true.seal('/vehicle_9/' + topic.rsplit('/', 1)[-1], payload)]
    judge = signing.load_member(fleet / 'plant').verifier
    verdicts = [judge.unseal(topic, _padded(data)) for data in samples]
    kept = [(data, got.kind) for data, got in zip(samples, verdicts) if isinstance(got, Rejection)]
    assert [kind for _, kind in kept[-3:]] == [signing.UNSIGNED, signing.WRONG_SIGNER,
                                               signing.WRONG_TOPIC]
    return [data for data, _ in kept], [kind for _, kind in kept]


def _ask_malformed(nodes, everyone):
    """Send every node's parameter services malformed requests; return their futures."""
    futures = []
    for node in everyone:
        for srv, name, request in (
                (SetParameters, 'set_parameters', SetParameters.Request(
                    parameters=BAD_PARAMETERS)),
                (SetParametersAtomically, 'set_parameters_atomically',
                 SetParametersAtomically.Request(parameters=BAD_PARAMETERS)),
                (GetParameters, 'get_parameters', GetParameters.Request(
                    names=['', 'x' * 10_000]))):
            client = nodes.node.create_client(srv, f'/{node.get_name()}/{name}')
            assert nodes.spin_until(client.service_is_ready)
            futures.append(client.call_async(request))
            if srv is SetParameters:
                futures += [client.call_async(SetParameters.Request(parameters=[p]))
                            for p in BAD_PARAMETERS]
    return futures


def _refused(response):
    if isinstance(response, GetParameters.Response):
        return True
    results = getattr(response, 'results', None) or [response.result]
    return not any(r.successful for r in results)


def _status(box, name):
    for msg in reversed(box):
        for s in msg.status:
            if s.name == name:
                return {v.key: v.value for v in s.values}
    return None


class Flooder:
    """The flooder process; its output lines are read as they come."""

    def __init__(self, plan_path, env):
        self.proc = subprocess.Popen(
            [sys.executable, str(CONFIG.parent / 'test' / 'flooder.py'), str(plan_path)],
            env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        self.lines = []
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self):
        for line in self.proc.stdout:
            self.lines.append(line.strip())

    def close(self):
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()
        self.reader.join(timeout=5)
        self.proc.stdout.close()


@pytest.mark.parametrize('fleet', FLEETS)
def test_a_flood_of_malformed_samples_is_counted_and_never_taken_for_data(nodes, tmp_path,
                                                                          capfd, monkeypatch,
                                                                          fleet):
    cfg, overrides = FLEETS[fleet]
    sc = scenario.load(cfg, list(overrides))
    members = None
    if fleet == 'signing':
        members = tmp_path / 'fleet'
        security.write_fleet(members, security.roster(sc.num_vehicles))
    topics, heard = _plan(sc, members)
    plan = tmp_path / 'plan.json'
    plan.write_text(json.dumps(topics))
    capfd.readouterr()                  # the checks of the samples here print, the nodes not
    record = tmp_path / 'run.npz'
    params = overrides + NODE_PARAMS + EXACT

    def member(name):
        if members is not None:
            monkeypatch.setenv('FASTRTPS_DEFAULT_PROFILES_FILE',
                               str(members / name / security.PROFILE))
    member('plant')
    plant = nodes.plant(cfg, *params, 'wait_for_start:=true', f'record_path:={record}')
    vehicles = []
    for k in range(1, sc.num_vehicles + 1):
        member(f'vehicle_{k}')
        vehicles.append(nodes.vehicle(k, cfg, *params))
    monkeypatch.delenv('FASTRTPS_DEFAULT_PROFILES_FILE', raising=False)
    assert all((node.signed is None) == (members is None) for node in [plant, *vehicles])
    monitor = nodes.monitor(*NODE_PARAMS)
    recorder = nodes.add(FleetRecorder(str(tmp_path / 'bag'), sc.num_vehicles,
                                       context=nodes.context,
                                       cli_args=node_args(None, *NODE_PARAMS)))
    diags = nodes.collect(DiagnosticArray, names.DIAGNOSTICS_TOPIC, itf.STREAM_QOS)
    start = nodes.node.create_publisher(Empty, '/' + names.START_TOPIC, itf.LATCHED_QOS)
    domain = dict(os.environ, ROS_DOMAIN_ID=str(nodes.context.get_domain_id()))
    flooder = Flooder(plan, domain)
    try:
        assert nodes.spin_until(lambda: 'matched' in flooder.lines or flooder.proc.poll()
                                is not None, timeout=60), flooder.lines
        assert 'matched' in flooder.lines, flooder.lines
        start.publish(Empty())
        asked = _ask_malformed(nodes, [plant, *vehicles, monitor, recorder])
        assert nodes.spin_until(lambda: plant.done and flooder.proc.poll() is not None,
                                timeout=120), (flooder.lines, flooder.proc.poll(), plant.done,
                                               plant.fleet.n, plant.plant.stalled(0.0),
                                               plant.plant.gate.nudges, len(diags))
        sent = json.loads(flooder.lines[-1])
        everyone = [plant, *vehicles, monitor, recorder]
        expected = {}
        for node in everyone:
            deep, shallow = expected[node.get_name()] = Counter(), Counter()
            for topic, reasons, lossy in heard[node.get_name()]:
                (shallow if lossy else deep).update(reasons[i] for i in sent[topic])

        def counted():
            return all(node.reject.counts[kind] >= count for node in everyone
                       for kind, count in expected[node.get_name()][0].items())
        nodes.spin_until(counted, timeout=10)
        assert nodes.spin_until(lambda: all(f.done() for f in asked))
        assert all(_refused(f.result()) for f in asked)
    finally:
        flooder.close()
    for node in everyone:
        deep, shallow = expected[node.get_name()]
        counts = dict(node.reject.counts)
        counts.pop('stale', None)       # a step asked again (the loaded machine) is answered twice
        assert set(deep) | set(shallow) <= set(counts), (node.get_name(), counts)
        for kind, count in counts.items():
            assert deep[kind] <= count <= deep[kind] + shallow[kind], (
                node.get_name(), kind, counts, deep, shallow)
    assert_equal_runs(simulator.load_run(record), offline_run(cfg, overrides))
    nodes.remove(recorder)
    recorder.close()
    bagged = bagfile.read_run(tmp_path / 'bag')
    read = simulator.load_run(record)
    flooded = {'/' + t: len(i) for t, i in sent.items() if t.endswith(('/odom', '/cmd'))}
    assert bagged.meta['skipped'] == flooded
    assert np.array_equal(bagged.t, read.t)
    np.testing.assert_allclose(bagged.X, read.X, rtol=0, atol=1e-9)
    published = [(name, 'malformed', node.reject.counts['malformed'])
                 for node, name in [(plant, 'formation_control/plant')] + [
                     (v, f'formation_control/vehicle_{v.k}/links') for v in vehicles]]
    published.append(('formation_control/formation', 'rejected_messages', monitor.reject.total))
    for name, key, count in published:
        assert nodes.spin_until(lambda: (_status(diags, name) or {}).get(key) == str(count),
                                timeout=5), _status(diags, name)
    for node in everyone:
        lines = [m.msg for m in nodes.rosout if m.name == node.get_name()]
        assert len(lines) <= LOG_BOUND, lines
    err = capfd.readouterr().err
    assert not [e for e in MIDDLEWARE_ERRORS if e in err], err[-2000:]
    assert len(err.splitlines()) <= LOG_BOUND * len(everyone), err[-2000:]


def test_the_doctor_and_set_count_a_flood_and_still_read_the_fleet(nodes, tmp_path, capfd):
    """
    The tools' subscriptions under a flood: the doctor's and ``formation-control set``'s.

    While the doctor listens, the flooder sends undecodable samples on the fleet's latched
    scenario and on each vehicle's formation_state; ``set``'s tuner heard the scenario's. Each
    counts every sample as ``malformed``, the doctor still reads the scenario and each
    vehicle's states, and the tuner still sets the vehicles' parameters.
    """
    from formation_control.ros.doctor import Gatherer
    from formation_control.ros.tuning import FleetTuner
    from formation_control_msgs.msg import FormationState
    from rclpy.parameter import Parameter as Param
    cfg, n = CONFIG / 'particle_circular.yaml', 2
    sc = scenario.load(cfg, [f'num_vehicles:={n}'])
    nodes.plant(cfg, f'num_vehicles:={n}', 'exit_when_done:=false')
    for k in range(1, n + 1):
        nodes.vehicle(k, cfg, f'num_vehicles:={n}')
    rng = np.random.default_rng(7)
    state_qos = {'reliability': 'RELIABLE', 'durability': 'TRANSIENT_LOCAL', 'depth': 1000}
    topics = [{'topic': '/' + names.SCENARIO_TOPIC, 'type': 'std_msgs/msg/String',
               'matches': n + 2, **state_qos,
               'samples': [s.hex() for s in _undecodable(itf.scenario_msg(sc), String, rng)]}]
    for k in range(1, n + 1):
        samples = _undecodable(itf.state_msg(k, 0, X, (complex(1.0, 2.0), 0.3, 0.2, 1.0)),
                               FormationState, rng)
        topics.append({'topic': names.topic(k, 'formation_state'),
                       'type': 'formation_control_msgs/msg/FormationState',
                       'matches': n, **state_qos, 'samples': [s.hex() for s in samples]})
    plan = tmp_path / 'plan.json'
    plan.write_text(json.dumps(topics))
    capfd.readouterr()
    tuner = FleetTuner(nodes.node, nodes.executor)
    gatherer = Gatherer('/', nodes.context, nodes.executor)
    flooder = Flooder(plan, dict(os.environ, ROS_DOMAIN_ID=str(nodes.context.get_domain_id())))
    try:
        facts = gatherer.gather(listen=4.0, discover=20.0)
        assert nodes.spin_until(lambda: flooder.proc.poll() is not None, timeout=60)
        assert flooder.proc.returncode == 0, flooder.lines
        sent = json.loads(flooder.lines[-1])
        results = tuner.apply([Param('kappa', value=3.0)])
    finally:
        gatherer.close()
        flooder.close()
    on_scenario = len(sent['/' + names.SCENARIO_TOPIC])
    assert tuner.reject.counts['malformed'] == on_scenario
    assert gatherer.reject.counts['malformed'] == sum(len(v) for v in sent.values())
    assert results == {f'/vehicle_{k}': None for k in range(1, n + 1)}
    assert facts.scenario['num_vehicles'] == n
    assert all(facts.streams['/' + names.topic(k, 'formation_state')].count > 0
               for k in range(1, n + 1)), facts.streams
    err = capfd.readouterr().err
    assert not [e for e in MIDDLEWARE_ERRORS if e in err], err[-2000:]
    assert len(err.splitlines()) <= 3 * LOG_BOUND, err[-2000:]
