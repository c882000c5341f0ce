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
``formation-control doctor``: each finding on the facts of a deliberately broken fleet.

Pure checks on facts built here (the QoS ones with rclpy's own compatibility check), then the
gathering node on a real in-process fleet with a vehicle missing and one mis-configured.
"""
import copy
import json

from formation_control.core import scenario
from formation_control.ops import doctor, security
from formation_control.protocol import names
from formation_control.ros import interface as itf
from formation_control.ros.doctor import Gatherer
import pytest
from rclpy.qos import qos_check_compatible, QoSProfile, ReliabilityPolicy
from rosutil import CONFIG

ENV = {'ROS_DOMAIN_ID': '7', 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'SUBNET'}


def _scenario(**values):
    sc = scenario.load(CONFIG / 'particle_circular.yaml', [], num_vehicles=3, **values)
    return json.loads(sc.to_json())


def _state(k, prefix='/'):
    """Return vehicle k's formation_state topic as the graph names it (resolved)."""
    return prefix + names.topic(k, 'formation_state')


def _healthy(n=3, **values):
    """Facts of a fleet that works: a plant, n vehicles each hearing every other."""
    sc = _scenario(**values)
    topics = {k: _state(k) for k in range(1, n + 1)}
    endpoints = []
    for k, topic in topics.items():
        endpoints.append(doctor.Endpoint(topic, f'/vehicle_{k}', 'pub', itf.STATE_QOS))
        endpoints += [doctor.Endpoint(topic, f'/vehicle_{j}', 'sub', itf.STATE_QOS)
                      for j in topics if j != k]
    return doctor.Facts(
        namespace='/', env=dict(ENV), scenario=sc, scenario_publishers=['/plant'],
        nodes=['/plant', '/formation_monitor'] + [f'/vehicle_{k}' for k in topics],
        parameters={f'/vehicle_{k}': copy.deepcopy(sc) for k in topics}, mode='realtime',
        endpoints=endpoints, streams={t: doctor.Stream(count=50) for t in topics.values()},
        state_topics=topics, clock_lags={'plant': [0.002], 'vehicle_1': [0.003, 0.001]})


def _problems(facts):
    return [(f.level, f.subject, f.text) for f in doctor.diagnose(facts, qos_check_compatible)
            if f.level != doctor.NOTE]


def test_a_healthy_fleet_has_no_problem():
    facts = _healthy()
    findings = doctor.diagnose(facts, qos_check_compatible)
    assert _problems(facts) == [] and doctor.exit_status(findings) == 0
    assert doctor.format_report(facts, findings).endswith('no problem found\n')


def test_a_vehicle_whose_scenario_differs_from_the_plants_is_an_error():
    facts = _healthy()
    facts.parameters['/vehicle_2'].update(kappa=2.5, duration=1.0)
    facts.parameters['/vehicle_3'] = None
    findings = doctor.diagnose(facts, qos_check_compatible)
    assert _problems(facts) == [
        ('warning', '/vehicle_3', 'its parameters could not be read (no parameter service '
                                  'answered)'),
        ('error', '/vehicle_2', 'kappa = 2.5, /vehicle_1 has 5.0: the fleet runs two gains '
                                '(formation-control set kappa:=... sets every one)')]
    assert ('note', '/vehicle_2', 'duration = 1.0, the plant has 100.0') in [
        (f.level, f.subject, f.text) for f in findings]
    assert doctor.exit_status(findings) == 1


def test_gains_set_at_run_time_on_every_vehicle_are_a_note_not_a_problem():
    """``formation-control set kappa:=3 K:=0.5`` on every vehicle: the plant keeps its own."""
    facts = _healthy()
    for values in facts.parameters.values():
        values.update(kappa=3.0, K=0.5)
    findings = doctor.diagnose(facts, qos_check_compatible)
    assert _problems(facts) == [] and doctor.exit_status(findings) == 0
    notes = [(f.subject, f.text) for f in findings if f.level == doctor.NOTE]
    assert ('fleet', 'K = 0.5 on every vehicle (set at run time); the scenario of the plant '
                     'says 1.0') in notes
    assert ('fleet', 'kappa = 3.0 on every vehicle (set at run time); the scenario of the plant '
                     'says 5.0') in notes


def test_incompatible_qos_pairs_are_named_with_rclpys_reason():
    facts = _healthy()
    best_effort = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
    facts.endpoints = [e if (e.node, e.kind) != ('/vehicle_1', 'pub')
                       else doctor.Endpoint(e.topic, e.node, e.kind, best_effort)
                       for e in facts.endpoints]
    (problem, other) = _problems(facts)
    assert problem[:2] == ('error', '/vehicle_1/formation_state')
    assert problem[2].startswith('/vehicle_1 -> /vehicle_2: ') and 'reliab' in problem[2].lower()
    assert other[2].startswith('/vehicle_1 -> /vehicle_3: ')


def test_missing_duplicate_and_foreign_vehicle_ids():
    facts = _healthy()
    facts.nodes = [n for n in facts.nodes if n != '/vehicle_3'] + ['/vehicle_2', '/vehicle_9']
    del facts.parameters['/vehicle_3']
    found = _problems(facts)
    assert ('error', 'fleet', 'vehicles [3] of the 3 are missing (no node vehicle_k)') in found
    assert ('error', '/vehicle_2', '2 nodes have this name: two vehicles were started with '
                                   'vehicle_id 2') in found
    assert ('error', '/vehicle_9', 'vehicle 9 is not in the scenario (num_vehicles = 3)') in found


def test_a_silent_vehicle_and_one_that_hears_nobody():
    facts = _healthy()
    facts.streams[_state(2)].count = 0
    facts.endpoints = [e for e in facts.endpoints if e.kind == 'sub' or e.node == '/vehicle_1']
    found = _problems(facts)
    assert ('error', '/vehicle_2', 'publishes no formation_state on /vehicle_2/formation_state'
            ) in found
    assert ('error', '/vehicle_1', 'hears no neighbour: no vehicle of [2, 3] publishes its '
                                   'formation_state') in found
    assert [f[1] for f in found if 'hears no neighbour' in f[2]] == ['/vehicle_1']
    ring = _healthy(graph='ring')
    ring.streams[_state(3)].hears = {2: False, 4: False}
    assert _problems(ring) == [('error', '/vehicle_3', 'hears no neighbour: every hears flag '
                                                       'of its formation_state is false')]


def test_a_vehicle_of_another_interface_version_is_named_as_such():
    facts = _healthy()
    stream = facts.streams[_state(2)]
    stream.count, stream.refused = 0, 'a formation_state of vehicle 2 of interface version 2: ...'
    assert ('error', '/vehicle_2', 'publishes no formation_state on /vehicle_2/formation_state '
            'the doctor can read: a formation_state of vehicle 2 of interface version 2: ...'
            ) in _problems(facts)


@pytest.mark.parametrize('env, expected', [
    ({}, [('warning', 'ROS_DOMAIN_ID')]),
    ({'ROS_DOMAIN_ID': '300'}, [('error', 'ROS_DOMAIN_ID')]),
    ({'ROS_DOMAIN_ID': '150'}, [('warning', 'ROS_DOMAIN_ID')]),
    ({'ROS_DOMAIN_ID': '3', 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'OFF'},
     [('error', 'ROS_AUTOMATIC_DISCOVERY_RANGE')]),
    ({'ROS_DOMAIN_ID': '3', 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'localhost'},
     [('error', 'ROS_AUTOMATIC_DISCOVERY_RANGE')]),
    ({'ROS_DOMAIN_ID': '3', 'ROS_LOCALHOST_ONLY': '1'}, [('warning', 'ROS_LOCALHOST_ONLY')]),
])
def test_unexpected_domain_and_discovery_settings(env, expected):
    facts = _healthy()
    facts.env = env
    assert [p[:2] for p in _problems(facts)] == expected


def test_a_tls_profile_that_would_admit_anyone_is_an_error(tmp_path):
    security.write_fleet(tmp_path, security.roster(1))
    facts = _healthy()
    facts.env = dict(ENV, **security.environment(tmp_path, 'operator'))
    assert _problems(facts) == []
    facts.env.pop('OPENSSL_CONF')
    (found,) = _problems(facts)
    assert found[:2] == ('error', 'FASTRTPS_DEFAULT_PROFILES_FILE')
    assert 'the listener admits peers with no certificate' in found[2]


def test_clock_skew_between_hosts_in_real_time():
    facts = _healthy()
    facts.clock_lags['vehicle_2'] = [0.41, 0.40, 0.42]
    facts.clock_lags['plant'] = [-0.3, -0.31]
    (plant, vehicle) = _problems(facts)
    assert plant[:2] == ('warning', 'plant') and '0.300 s ahead of' in plant[2]
    assert vehicle[:2] == ('warning', 'vehicle_2') and '0.410 s behind' in vehicle[2]
    facts.mode = 'lockstep'                          # stamps are the fleet's time then
    assert _problems(facts) == []
    assert [doctor.clocked_node(name, '/fleet_a') for name in (
        'fleet_a/formation_control/vehicle_2/links', 'fleet_a/formation_control/plant',
        'formation_control/plant', 'fleet_b/formation_control/plant',
        'fleet_a/formation_control/formation')] == ['vehicle_2', 'plant', None, None, None]


def test_no_plant_on_the_domain_is_an_error_naming_the_domain():
    facts = doctor.Facts(namespace='/fleet_a', env=dict(ENV))
    ((level, subject, text),) = _problems(facts)
    assert (level, subject) == ('error', 'fleet')
    assert '/fleet_a/formation/scenario' in text and 'ROS_DOMAIN_ID=7' in text


def test_doctor_finds_the_missing_and_the_misconfigured_vehicle_of_a_real_fleet(nodes):
    """
    Lockstep fleet of 3 in /fleet_a, vehicle 3 never started, vehicle 2 with another kappa.

    A vehicle 3 of the fleet in / does not count: ``--namespace`` selects a fleet's nodes and
    topics.
    """
    from formation_control.ros.plant import PlantNode
    from formation_control.ros.vehicle import VehicleNode
    from rosutil import node_args
    cfg = CONFIG / 'particle_circular.yaml'

    def args(*params):
        return node_args(cfg, 'num_vehicles:=3', *params) + ['-r', '__ns:=/fleet_a']
    nodes.add(PlantNode(context=nodes.context, cli_args=args()))
    nodes.add(VehicleNode(1, context=nodes.context, cli_args=args('vehicle_id:=1')))
    nodes.add(VehicleNode(2, context=nodes.context, cli_args=args('vehicle_id:=2', 'kappa:=2.5')))
    nodes.vehicle(3, cfg, 'num_vehicles:=3')                     # /vehicle_3: another fleet
    gatherer = Gatherer('/fleet_a', nodes.context, nodes.executor)
    try:
        facts = gatherer.gather(listen=0.5, discover=10.0)
    finally:
        gatherer.close()
    assert facts.mode == 'lockstep' and facts.scenario['num_vehicles'] == 3
    assert facts.scenario_publishers == ['/fleet_a/plant']
    assert facts.streams[_state(1, '/fleet_a/')].count > 0
    assert facts.endpoints and all(e.topic.startswith('/fleet_a/') or e.topic == '/diagnostics'
                                   for e in facts.endpoints)
    assert '/fleet_a/clock' in {e.topic for e in facts.endpoints}
    found = _problems(facts)
    assert ('error', 'fleet', 'vehicles [3] of the 3 are missing (no node vehicle_k)') in found
    assert ('error', '/fleet_a/vehicle_2', 'kappa = 2.5, /fleet_a/vehicle_1 has 5.0: the '
            'fleet runs two gains (formation-control set kappa:=... sets every one)') in found
    assert not [f for f in found if f[1] in ('/fleet_a/vehicle_1', '/vehicle_3')], found
