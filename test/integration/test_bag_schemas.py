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
A recorded bag carries its types' definitions: any MCAP reader decodes every topic.

The reader is the ``mcap`` library with ``mcap-ros2-support`` (neither the project's code nor
rosbags), decoding each message by the schema its channel names, with no ROS message package
imported. Bags of formation_control before formation_control_msgs (interface version 0:
JointState formation states, WrenchStamped commands) are refused by ``report`` and ``plot``
with the version that wrote them.
"""
import json
import math
from pathlib import Path
import subprocess
import sys

from formation_control.core import scenario
from formation_control.protocol import names
from formation_control.protocol.messages import METRIC_DOC, STATE_FIELDS
from formation_control.view import layout
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import get_typestore, Stores
from rosutil import CONFIG, domains, ros_environment, shm_clean

mcap_reader = pytest.importorskip('mcap.reader')
mcap_ros2 = pytest.importorskip('mcap_ros2.decoder')

N = 3


@pytest.fixture(scope='module')
def bag(tmp_path_factory):
    tmp = tmp_path_factory.mktemp('schemas')
    with domains() as (did,):
        env = ros_environment(did)
        try:
            proc = subprocess.run(
                [str(Path(sys.executable).parent / 'formation-control'), 'swarm',
                 str(CONFIG / 'particle_circular.yaml'), '-p', f'num_vehicles:={N}',
                 '--duration', '1.0', '--fault', 'cut:1-2@0.2..0.4', '--bag', str(tmp / 'bag'),
                 '--summary', str(tmp / 'summary.json')],
                env=env, capture_output=True, text=True, timeout=300, stdin=subprocess.DEVNULL)
        finally:
            shm_clean(env)
    assert proc.returncode == 0, proc.stderr + proc.stdout
    return tmp / 'bag'


def _decoded(bag):
    """Return {topic: (schema name, schema encoding, [decoded messages])} of the bag's MCAP."""
    out = {}
    for path in sorted(bag.glob('*.mcap')):
        with open(path, 'rb') as f:
            reader = mcap_reader.make_reader(f, decoder_factories=[mcap_ros2.DecoderFactory()])
            for schema, channel, _, msg in reader.iter_decoded_messages():
                entry = out.setdefault(channel.topic, (schema.name, schema.encoding, []))
                entry[2].append(msg)
    return out


def test_an_independent_mcap_reader_decodes_every_topic_by_its_embedded_schema(bag):
    got = _decoded(bag)
    prefix = '/'
    expected = {prefix + names.SCENARIO_TOPIC: 'std_msgs/msg/String',
                prefix + names.METRICS_TOPIC: 'formation_control_msgs/msg/FormationMetrics',
                prefix + names.FAULTS_TOPIC: 'formation_control_msgs/msg/FaultEvent',
                prefix + names.CLOCK_TOPIC: 'rosgraph_msgs/msg/Clock',
                names.DIAGNOSTICS_TOPIC: 'diagnostic_msgs/msg/DiagnosticArray',
                **{prefix + names.topic(k, 'formation_state'):
                   'formation_control_msgs/msg/FormationState' for k in range(1, N + 1)},
                **{prefix + names.topic(k, 'cmd'): 'formation_control_msgs/msg/VehicleCommand'
                   for k in range(1, N + 1)},
                **{prefix + names.topic(k, 'odom'): 'nav_msgs/msg/Odometry'
                   for k in range(1, N + 1)}}
    assert {t: got[t][0] for t in expected if t in got} == expected
    assert {encoding for _, encoding, _ in got.values()} == {'ros2msg'}
    sc = scenario.resolve(json.loads(got['/' + names.SCENARIO_TOPIC][2][0].data))
    assert sc.num_vehicles == N
    for k in range(1, N + 1):
        states = got[prefix + names.topic(k, 'formation_state')][2]
        first = states[0]
        assert (first.interface_version, first.vehicle_id, first.header.frame_id) == (1, k, 'map')
        assert list(first.neighbour_ids) == [] and not first.estimates_flow
        assert all(math.isfinite(getattr(first, name)) for name in STATE_FIELDS)
        stamp = first.header.stamp.sec * 10**9 + first.header.stamp.nanosec
        predicted = first.predicted_stamp.sec * 10**9 + first.predicted_stamp.nanosec
        assert predicted - stamp == round(sc.command_lead * 1e9)
        cmds = got[prefix + names.topic(k, 'cmd')][2]
        assert {(c.vehicle_id, c.kind, c.header.frame_id) for c in cmds} == {
            (k, 2, f'vehicle_{k}/base_link')}                        # SECOND_ORDER
        assert any(c.angular_acceleration != 0.0 for c in cmds)
    metrics = got[prefix + names.METRICS_TOPIC][2]
    assert all(0.0 <= m.order_parameter <= 1.0 for m in metrics)
    assert {name for name in METRIC_DOC if not math.isnan(getattr(metrics[-1], name))} >= {
        'order_parameter', 'centre_spread', 'min_separation', 'live_links'}
    for path in _layout_paths():                      # the Foxglove layout's plots, on a bag
        topic, field = path.split('.', 1)
        assert all(isinstance(getattr(m, field), float) for m in got[topic][2]), path
    faults = got[prefix + names.FAULTS_TOPIC][2]
    assert [(f.kind, list(f.vehicle_ids), f.fault) for f in faults] == [
        (5, [1, 2], 'cut:1-2@0.2..0.4'), (6, [1, 2], 'cut:1-2@0.2..0.4')]       # CUT, MEND


def _layout_paths():
    text = json.loads(layout.layout_json())
    panels = [item['content'] for item in text['content']['items'][1]['content']['items']]
    return [p['value'] for panel in panels if panel['panelType'] == 'Plot'
            for p in panel['config']['paths']]


def _legacy_bag(path):
    """Write a bag as formation_control did before formation_control_msgs (interface 0)."""
    store = get_typestore(Stores.ROS2_JAZZY)
    String = store.types['std_msgs/msg/String']
    Header = store.types['std_msgs/msg/Header']
    Time = store.types['builtin_interfaces/msg/Time']
    Wrench = store.types['geometry_msgs/msg/Wrench']
    Vector3 = store.types['geometry_msgs/msg/Vector3']
    WrenchStamped = store.types['geometry_msgs/msg/WrenchStamped']
    sc = scenario.load(CONFIG / 'particle_parallel.yaml', ['num_vehicles:=1'])
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conns = {t: writer.add_connection(t, kind, typestore=store) for t, kind in (
            ('/formation/scenario', 'std_msgs/msg/String'),
            ('/vehicle_1/cmd', 'geometry_msgs/msg/WrenchStamped'))}
        writer.write(conns['/formation/scenario'], 1, store.serialize_cdr(
            String(data=sc.to_json()), 'std_msgs/msg/String'))
        zero = Vector3(x=0.0, y=0.0, z=0.0)
        cmd = WrenchStamped(header=Header(stamp=Time(sec=0, nanosec=0), frame_id='x'),
                            wrench=Wrench(force=zero, torque=zero))
        writer.write(conns['/vehicle_1/cmd'], 2, store.serialize_cdr(
            cmd, 'geometry_msgs/msg/WrenchStamped'))


@pytest.mark.parametrize('command', ['report', 'plot'])
def test_a_bag_of_interface_version_0_is_refused_naming_it(ros, tmp_path, command):
    _legacy_bag(tmp_path / 'old')
    out = ['--out', tmp_path / 'p.png'] if command == 'plot' else []
    args = [command, tmp_path / 'old', *out]
    result = ros.procs.run('formation-control', *args)
    assert result.returncode == 2, result.stdout + result.stderr
    assert ('written by formation_control of interface version 0 (/vehicle_1/cmd: its type '
            'geometry_msgs/msg/WrenchStamped); this formation_control reads '
            'formation_control_msgs interface version 1') in result.stderr
