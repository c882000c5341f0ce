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
The Foxglove live view: the scene and metrics messages, the layout, the monitor's server.

The server is read by a headless client of the Foxglove WebSocket protocol
(:mod:`foxglove_client`), which decodes what it receives as the Foxglove app does.
"""
import cmath
import contextlib
import json
import math
from pathlib import Path
import socket

from diagnostic_msgs.msg import DiagnosticArray
from formation_control import cli
from formation_control.core import scenario
from formation_control.core.errors import UsageError
from formation_control.protocol import messages, names
from formation_control.ros import interface as itf, live as live_view, markers
from formation_control.ros.monitor import MonitorNode
from formation_control.view import layout, palette, picture, scene
from formation_control_msgs.msg import FormationMetrics
from foxglove.messages import SceneUpdate
from foxglove_client import client, protobuf_class
from json_schema_rules import check
from nav_msgs.msg import Odometry
import numpy as np
import pytest
from rclpy.serialization import deserialize_message
from rosutil import CONFIG, metric_values
from std_msgs.msg import String
from visualization_msgs.msg import MarkerArray

ROOT = Path(__file__).resolve().parents[2]


def _decode(update):
    schema = SceneUpdate.get_schema()
    return protobuf_class(schema.name, schema.data).FromString(update.encode())


def _xy(v):
    return complex(v.x, v.y)


def _yaw(q):
    return 2 * math.atan2(q.z, q.w)


def test_scene_shows_each_vehicle_its_velocity_trail_links_and_centres():
    r = np.array([1 + 2j, -1 - 0.5j, 0.5j])
    theta = np.array([0.3, 2.0, -1.0])
    v = np.array([0.5 + 0.5j, -1.0 + 0j, 0j])
    trails = [[0j, 1 + 2j], [-1 - 0.5j], [1j, 0.5j]]
    centres = np.array([0.1 + 0j, 0.2j, -0.3 + 0j])
    got = _decode(scene.fleet_scene(12_500_000_001, r, theta, v, trails, [[0, 1], [1, 2]],
                                    centres, 1 - 2j))
    by_id = {e.id: e for e in got.entities}
    assert set(by_id) == {'vehicle_1', 'vehicle_2', 'vehicle_3', 'links', 'centres'}
    for e in got.entities:
        assert e.frame_id == 'map'
        assert (e.timestamp.seconds, e.timestamp.nanos) == (12, 500_000_001)
    for i in range(3):
        e = by_id[f'vehicle_{i + 1}']
        heading = e.arrows[0]
        assert _xy(heading.pose.position) == pytest.approx(r[i])
        assert _yaw(heading.pose.orientation) == pytest.approx(theta[i])
        assert heading.shaft_length + heading.head_length == pytest.approx(picture.HEADING_LENGTH)
        assert [_xy(p) for p in e.lines[0].points] == pytest.approx(trails[i])
        assert e.texts[0].text == str(i + 1)
        if v[i] == 0:
            assert len(e.arrows) == 1
            continue
        velocity = e.arrows[1]                              # the tip is at r + v
        tip = _xy(velocity.pose.position) + cmath.exp(1j * _yaw(velocity.pose.orientation)) * (
            velocity.shaft_length + velocity.head_length)
        assert tip == pytest.approx(r[i] + v[i])
    link = by_id['links'].lines[0]
    assert link.type == 2                                   # LINE_LIST: one segment per link
    assert [_xy(p) for p in link.points] == pytest.approx([r[0], r[1], r[1], r[2]])
    assert [_xy(s.pose.position) for s in by_id['centres'].spheres] == pytest.approx(centres)
    (target,) = by_id['centres'].cylinders
    assert _xy(target.pose.position) == 1 - 2j
    without = _decode(scene.fleet_scene(0, r, theta, None, trails, []))
    assert all(len(e.arrows) == 1 for e in without.entities if e.id.startswith('vehicle'))
    assert 'centres' not in {e.id for e in without.entities}
    assert not any(e.cylinders for e in without.entities if e.id.startswith('vehicle'))


def test_each_vehicle_has_a_safety_disc_coloured_by_its_nearest_neighbour():
    """Diameter d_min; ok, warn within 2 d_min of another, error within d_min (as brute force)."""
    rng = np.random.default_rng(8243)
    r = rng.uniform(-6, 6, 40) + 1j * rng.uniform(-6, 6, 40)
    d_min = 0.7
    gaps = np.abs(r[:, None] - r[None, :]) + np.diag(np.full(r.size, np.inf))
    expected = np.where(gaps.min(axis=1) < d_min, 2, np.where(gaps.min(axis=1) < 2 * d_min, 1, 0))
    assert set(expected) == {0, 1, 2}
    np.testing.assert_array_equal(picture.disc_levels(r, d_min), expected)
    got = _decode(scene.fleet_scene(0, r, np.zeros(r.size), None, [[z] for z in r], [],
                                    d_min=d_min))
    for e in (e for e in got.entities if e.id.startswith('vehicle_')):
        k = int(e.id.split('_')[1]) - 1
        (disc,) = e.cylinders
        assert _xy(disc.pose.position) == pytest.approx(r[k])
        assert (disc.size.x, disc.size.y) == (d_min, d_min)
        assert (disc.color.r, disc.color.g, disc.color.b, disc.color.a) == pytest.approx(
            palette.DISC[expected[k]])
    (ring,) = [m for m in markers.vehicle_markers(0, 'map', 1, r[0], 0.0, None, [r[0]],
                                                  (d_min, int(expected[0])))
               if m.ns == 'disc']
    assert (ring.scale.x, ring.pose.position.x) == pytest.approx((d_min, r[0].real))


def test_metrics_message_is_json_with_every_metric_by_name():
    msg = scene.metrics_message(3_000_000_007, {'order_parameter': 0.5, 'radius': math.nan})
    assert json.loads(json.dumps(msg, allow_nan=False)) == {
        'timestamp': {'sec': 3, 'nsec': 7}, 'order_parameter': 0.5}
    schema = scene.metrics_schema(messages.METRIC_DOC)
    assert set(schema['properties']) == {'timestamp', *messages.METRIC_DOC}


@pytest.mark.parametrize('namespace, frame', [('/', 'map'), ('fleet_a', 'odom')])
def test_installed_layout_is_the_generated_one_and_plots_real_metrics(
        namespace, frame, tmp_path):
    """The layout names the absolute channels of the fleet's namespace, in its world frame."""
    prefix = '/' if namespace == '/' else f'/{namespace}/'
    if namespace == '/':
        assert (ROOT / 'foxglove' / 'formation_control.json').read_text() == layout.layout_json()
    out = tmp_path / 'layout.json'
    assert cli.main(['layout', '--namespace', namespace, '--world-frame', frame,
                     '--out', str(out)]) == 0
    text = json.loads(out.read_text())
    panels = [item['content'] for item in text['content']['items'][1]['content']['items']]
    paths = [p['value'] for panel in panels if panel['panelType'] == 'Plot'
             for p in panel['config']['paths']]
    assert paths == [f'{prefix}formation/metrics.{name}' for name in
                     ('order_parameter', 'lyapunov', 'centre_spread', 'speed_error')]
    assert all(path.split('.', 1)[1] in messages.METRIC_DOC for path in paths)
    fields = FormationMetrics.get_fields_and_field_types()         # a bag's messages: the same
    assert all(fields[path.split('.', 1)[1]] == 'double' for path in paths)
    assert panels[-1]['panelType'] == 'DiagnosticsSummary'
    assert panels[-1]['config']['topicToRender'] == '/diagnostics'
    three_d = text['content']['items'][0]['content']
    assert set(three_d['config']['topics']) == {f'{prefix}formation/scene',
                                                f'{prefix}formation/markers'}
    assert three_d['config']['followTf'] == frame


def _layout_topics(node):
    """Return the topics a layout (the Foxglove format) names."""
    if node['type'] == 'split':
        return {t for item in node['items'] for t in _layout_topics(item['content'])}
    config = node['config']
    named = {'ThreeDee': lambda: set(config['topics']),
             'Plot': lambda: {p['value'].split('.', 1)[0] for p in config['paths']},
             'DiagnosticsSummary': lambda: {config['topicToRender']}}
    return named[node['panelType']]()


def _free_port():
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


POSES = {1: (0.5, 1.0, 0.3), 2: (-1.0, 2.0, 2.0), 3: (0.0, -1.5, -2.5)}


@pytest.mark.parametrize('subprotocol', ['foxglove.sdk.v1', 'foxglove.websocket.v1'])
def test_foxglove_client_sees_the_monitors_metrics_poses_and_diagnostics(nodes, subprotocol):
    """
    A monitor with ``foxglove_port``: what a Foxglove client receives equals its topics.

    The monitor is in the namespace ``/fleet_a`` with the world frame ``odom``: the channels
    are its resolved names, the scene is in its frame. A client of either name of the protocol
    (the Foxglove app's, Foxglove Studio's and Lichtblick's) is served alike.
    """
    sc = scenario.load(CONFIG / 'particle_circular.yaml', [], num_vehicles=3, c0=[1.0, -2.0],
                       informed=[1])
    port = _free_port()
    nodes.add(MonitorNode(context=nodes.context, cli_args=[
        '--ros-args', '-r', '__ns:=/fleet_a', '-p', 'period:=0.0', '-p', 'markers_period:=0.05',
        '-p', 'diagnostics_period:=0.1', '-p', 'world_frame:=odom', '-p',
        f'foxglove_port:={port}']))
    scene_topic, metrics_topic = '/fleet_a/formation/scene', '/fleet_a/formation/metrics'
    markers_topic = '/fleet_a/formation/markers'
    ros_metrics = nodes.collect(FormationMetrics, metrics_topic, itf.STREAM_QOS)
    with client(port, subprotocols=[subprotocol]) as fox:
        topics = (scene_topic, metrics_topic, markers_topic, names.DIAGNOSTICS_TOPIC, '/tf')
        fox.wait_advertised(topics, lambda: nodes.spin_until(lambda: True))
        assert fox.channels[scene_topic]['schemaName'] == 'foxglove.SceneUpdate'
        assert fox.channels[names.DIAGNOSTICS_TOPIC]['schemaEncoding'] == 'ros2msg'
        named = _layout_topics(json.loads(layout.layout_json('fleet_a', 'odom'))['content'])
        assert named <= set(fox.channels), f'named, not served: {named - set(fox.channels)}'
        for channel in fox.channels.values():
            if channel['encoding'] == 'json':
                check(json.loads(channel['schema']), channel['topic'])
        fox.subscribe(topics)
        node = nodes.node
        node.create_publisher(String, '/fleet_a/formation/scenario', itf.LATCHED_QOS).publish(
            itf.scenario_msg(sc))
        odom = {k: node.create_publisher(Odometry, f'/fleet_a/vehicle_{k}/odom', itf.STATE_QOS)
                for k in POSES}
        assert nodes.spin_until(lambda: all(p.get_subscription_count() for p in odom.values()))
        stamp = 4_200_000_000
        frames = names.Frames('odom')
        for k, (x, y, theta) in POSES.items():
            odom[k].publish(itf.odom_msg(k, stamp, np.array([x, y, theta, 1.0, 1.0, 0.0]), 0j,
                                         frames))
        got = {}

        def heard_all():
            nodes.spin_until(lambda: True, timeout=0)
            frame = fox.poll(timeout=0.02)
            if frame is not None:
                got.setdefault(frame[0]['topic'], []).append(frame[1:])
            return ros_metrics and all(got.get(t) for t in topics)
        assert nodes.spin_until(heard_all, timeout=20)
    (log_time, live), = got[metrics_topic]
    assert log_time == stamp == messages.stamp_ns(ros_metrics[0].header.stamp)
    assert live.pop('timestamp') == {'sec': 4, 'nsec': 200_000_000}
    assert live == metric_values(ros_metrics[0])
    log_time, update = got[scene_topic][-1]
    assert log_time == stamp
    assert {e.frame_id for e in update.entities} == {'odom'}
    by_id = {e.id: e for e in update.entities}
    for k, (x, y, theta) in POSES.items():
        heading = by_id[f'vehicle_{k}'].arrows[0]
        assert _xy(heading.pose.position) == pytest.approx(complex(x, y))
        assert _yaw(heading.pose.orientation) == pytest.approx(theta)
    expected = [complex(x, y) + 1j * np.exp(1j * theta) / sc.omega0 for x, y, theta in
                POSES.values()]
    assert [_xy(s.pose.position) for s in by_id['centres'].spheres] == pytest.approx(expected)
    assert _xy(by_id['centres'].cylinders[0].pose.position) == 1 - 2j
    marker_array = deserialize_message(got[markers_topic][-1][1], MarkerArray)
    assert {m.header.frame_id for m in marker_array.markers} == {'odom'}
    assert got[markers_topic][-1][0] == stamp
    log_time, data = got['/tf'][-1]
    tf = live_view.TYPES.deserialize_cdr(data, live_view.TF_MESSAGE)
    assert log_time == stamp
    assert [(t.header.frame_id, t.child_frame_id) for t in tf.transforms] == [
        ('map', 'odom')] + [('odom', f'vehicle_{k}/base_link') for k in POSES]
    for t, (x, y, theta) in zip(tf.transforms[1:], POSES.values()):
        assert (t.transform.translation.x, t.transform.translation.y) == pytest.approx((x, y))
        assert _yaw(t.transform.rotation) == pytest.approx(theta)
        assert messages.stamp_ns(t.header.stamp) == stamp
    statuses = {s.name for _, data in got[names.DIAGNOSTICS_TOPIC]
                for s in deserialize_message(data, DiagnosticArray).status}
    assert 'fleet_a/formation_control/formation' in statuses         # /diagnostics: shared


def test_foxglove_port_in_use_is_a_clear_error(nodes):
    with socket.socket() as busy:
        busy.bind(('127.0.0.1', 0))
        busy.listen()
        port = busy.getsockname()[1]
        with pytest.raises(UsageError, match=f'foxglove_port {port}'):
            nodes.monitor(f'foxglove_port:={port}')


BAD_FRAMES = [b'>' + bytes(range(40)), 'not json', json.dumps({'op': 'nope'}),
              json.dumps({'op': 'subscribe', 'subscriptions': [{'id': 2**40, 'channelId': 9}]}),
              json.dumps({'op': 'subscribe', 'subscriptions': 'x'}),
              json.dumps({'op': 'unsubscribe', 'subscriptionIds': [5, -1]}),
              json.dumps({'op': 'advertise', 'channels': [{'id': 1}]}),
              b'\x01\x07\x00\x00\x00' + bytes(12), b'\x02\x00', '{' * 100_000,
              json.dumps({'op': 'getParameters', 'parameterNames': [1]})]
"""Frames no message of the protocol fits: binary of an unknown opcode, text that is no JSON or
no op, ids out of range, a message for a channel never advertised, a short binary frame."""
NOT_WEBSOCKET = [bytes(range(256)) * 2, b'GET / HTTP/1.1\r\nHost: x\r\n\r\n',
                 b'\x16\x03\x01\x02\x00' + bytes(200),
                 b'GET / HTTP/1.1\r\nX: ' + b'a' * 100_000 + b'\r\n\r\n']
"""Bytes to the live port that open no WebSocket: noise, HTTP without upgrade, a TLS hello,
a header too large."""
FLOOD_ROUNDS = 30


def _statuses(fox, timeout):
    """Read the status messages the server sends until none comes for ``timeout`` s."""
    got = []
    while True:
        try:
            frame = fox.ws.recv(timeout=timeout)
        except TimeoutError:
            return got
        if isinstance(frame, str) and json.loads(frame)['op'] == 'status':
            got.append(json.loads(frame))


@pytest.mark.parametrize('subprotocol', ['foxglove.sdk.v1', 'foxglove.websocket.v1'])
def test_a_flood_of_bad_frames_is_answered_counted_and_the_live_view_serves_on(
        nodes, capfd, subprotocol):
    """
    What a client sends wrong is answered (a status), counted and logged throttled.

    foxglove-sdk logs each bad frame through Python's logging: before :class:`live.ServerLog`
    took those lines, every frame printed one on stderr.
    """
    port = _free_port()
    monitor = nodes.add(MonitorNode(context=nodes.context, cli_args=[
        '--ros-args', '-p', 'period:=0.0', '-p', f'foxglove_port:={port}']))
    for data in NOT_WEBSOCKET:
        with socket.create_connection(('127.0.0.1', port), timeout=5) as raw:
            raw.sendall(data)
            with contextlib.suppress(OSError):
                raw.recv(200)
    with client(port, subprotocols=[subprotocol]) as fox:
        for _ in range(FLOOD_ROUNDS):
            for frame in BAD_FRAMES:
                fox.ws.send(frame)
        statuses = _statuses(fox, 1.0)
    assert len(statuses) == FLOOD_ROUNDS * len(BAD_FRAMES), statuses[:12]
    assert all(s['level'] == 2 for s in statuses)
    invalid = sum(s['message'].startswith(('Invalid message', 'Unknown channel'))
                  for s in statuses)
    assert nodes.spin_until(lambda: monitor.reject.counts[live_view.LIVE_CLIENT] >= invalid)
    assert monitor.reject.counts[live_view.LIVE_CLIENT] == invalid
    with client(port) as fox:
        fox.wait_advertised(['/' + names.METRICS_TOPIC],
                            lambda: nodes.spin_until(lambda: True, timeout=0))
    nodes.spin_until(lambda: False, timeout=1.0)                # the log lines arrive
    lines = [m.msg for m in nodes.rosout if m.name == monitor.get_name()]
    assert len(lines) <= 5, lines
    err = capfd.readouterr().err.splitlines()
    assert len([e for e in err if 'Invalid message' in e]) <= 3, err[-20:]
