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
Seeing a run: the monitor's metrics, diagnostics and markers, a bag, plots and reports.

A recorded bag (its metadata as Jazzy's rosbag2 reads it), and plot / report from the bag and
from the plant's .npz.
"""
import itertools
import json
import math
from pathlib import Path
import re
import socket
import subprocess
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from formation_control.bags import reader as bagfile
from formation_control.cli import load_source
from formation_control.core import scenario
from formation_control.core.control import Controller
from formation_control.protocol import messages, names
from formation_control.ros import interface as itf
from formation_control.sim import metrics, report
from formation_control_msgs.msg import FormationMetrics
from nav_msgs.msg import Odometry
import numpy as np
import pytest
from rosutil import (BIN, CONFIG, domains, interrupt, metric_values, ros_environment,
                     shm_clean)
from std_msgs.msg import String
from visualization_msgs.msg import Marker, MarkerArray
import yaml

SCENARIO = 'rigid_parallel_flow'
DURATION = 14.0                # converged from t = 7 s, held past the 6.28 s hold window
"""Lockstep equals the offline run, which converges at t = 7 s."""


@pytest.fixture(scope='module')
def recorded(tmp_path_factory):
    """One lockstep fleet, its monitor serving the Foxglove live view, recorded to a bag."""
    tmp = tmp_path_factory.mktemp('recorded')
    with socket.socket() as free:
        free.bind(('127.0.0.1', 0))
        port = free.getsockname()[1]
    with domains() as (did,):
        env = ros_environment(did)
        try:
            proc = subprocess.run(
                [str(BIN / 'formation-control'), 'swarm', str(CONFIG / f'{SCENARIO}.yaml'),
                 '--duration', str(DURATION), '--bag', str(tmp / 'bag'),
                 '--out', str(tmp / 'run.npz'), '--summary', str(tmp / 'summary.json'),
                 '--foxglove', str(port)],
                env=env, capture_output=True, text=True, timeout=300,
                stdin=subprocess.DEVNULL)
        finally:
            shm_clean(env)
    assert proc.returncode == 0, proc.stderr + proc.stdout
    assert f'Foxglove live view: open ws://127.0.0.1:{port}' in proc.stderr
    out = json.loads((tmp / 'summary.json').read_text())
    monitor_log = (Path(out['logs']) / 'monitor.log').read_text()
    assert f'Foxglove live view on ws://127.0.0.1:{port}' in monitor_log, monitor_log
    return tmp, proc.stdout, out


def test_swarm_converges_and_ends_with_the_report(recorded):
    _, stdout, out = recorded
    assert out['converged']
    assert 'quantity' in stdout and 'predicted' in stdout
    assert re.search(r'converged\s+yes, from t = ', stdout)
    row = re.search(r'crab_angle_inertial\s+(\S+)\s+(\S+)\s+\(8\.17\)', stdout)
    assert row and float(row[1]) == pytest.approx(float(row[2]), abs=1e-4)


def test_metrics_topic_agrees_with_the_core_on_the_recorded_run(recorded):
    tmp = recorded[0]
    run = bagfile.read_run(tmp / 'bag')
    t, values = bagfile.metrics(tmp / 'bag')
    assert len(t) >= 0.9 * len(run.t)
    assert set(values) <= set(messages.METRIC_DOC)
    ctrl = Controller(run.sc)
    matched = 0
    for i, ti in enumerate(t):
        j = np.flatnonzero(abs(run.t - ti) < 1e-9)
        if j.size == 0:
            continue
        expected = metrics.snapshot(ctrl, run.X[j[0]], run.U[j[0]]).values()
        assert set(expected) | {'live_links', 'algebraic_connectivity'} == set(values)
        for name, value in expected.items():
            assert values[name][i] == pytest.approx(value, abs=1e-9), (name, ti)
        matched += 1
    assert matched >= 0.9 * len(run.t)
    assert values['order_parameter'][-1] > metrics.ORDER_TOL
    n = run.sc.num_vehicles                               # the complete graph, every link live
    assert values['live_links'][-1] == n * (n - 1) / 2
    assert values['algebraic_connectivity'][-1] == pytest.approx(n)


def test_formation_status_turns_converged_with_the_time_it_took(recorded):
    tmp, _, out = recorded
    arrays = bagfile.diagnostics(tmp / 'bag')
    formation = [(s, stats) for s, stats in arrays
                 if stats[0][0] == 'formation_control/formation']
    messages = [stats[0][2] for _, stats in formation]
    assert any(m == 'converging' for m in messages)
    done = [stats for _, stats in formation if stats[0][2].startswith('converged in')]
    assert done, messages
    first = done[0]
    took = float(first[0][3]['convergence_time'])
    assert took == pytest.approx(out['convergence_time'], abs=0.1)
    assert first[0][1] == 0
    assert first[1][0] == 'formation_control/separation'
    vehicles = first[2:]
    assert [name for name, *_ in vehicles] == [
        f'formation_control/vehicle_{k}' for k in range(1, out['num_vehicles'] + 1)]
    assert all(level == 0 and msg == 'ok' for _, level, msg, _ in vehicles), vehicles


def test_plots_of_the_bag_and_the_npz_draw_the_same_data(recorded):
    tmp = recorded[0]
    for source in ('bag', 'run.npz'):
        png = tmp / f'{source}.png'
        proc = subprocess.run([str(BIN / 'formation-control'), 'plot', str(tmp / source),
                               '--out', str(png)], capture_output=True, text=True, timeout=120)
        assert proc.returncode == 0, proc.stderr
        data = png.read_bytes()
        assert data.startswith(b'\x89PNG\r\n\x1a\n') and len(data) > 20_000
    from_bag = report.series(load_source(tmp / 'bag'))
    from_npz = report.series(load_source(tmp / 'run.npz'))
    assert from_bag['x'].shape == from_npz['x'].shape
    for key in ('t', 'x', 'y', 'omega', 'u', 'speed', 'beta', 'beta_hat', 'lyapunov', 'order'):
        np.testing.assert_allclose(from_bag[key], from_npz[key], rtol=0, atol=1e-9,
                                   err_msg=key)
    wrapped = np.angle(np.exp(1j * (from_bag['theta'] - from_npz['theta'])))
    assert np.max(abs(wrapped)) < 1e-9


def test_report_of_the_bag_matches_the_swarm_summary(recorded):
    tmp, _, out = recorded
    proc = subprocess.run([str(BIN / 'formation-control'), 'report', str(tmp / 'bag'),
                           '--summary', str(tmp / 'bag.json')],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    again = json.loads((tmp / 'bag.json').read_text())
    assert again['converged'] and again['convergence_time'] == out['convergence_time']
    for name, value in out['final'].items():
        assert again['final'][name] == pytest.approx(value, abs=1e-9), name
    assert again['predicted'] == pytest.approx(out['predicted'])


QOS_KEYS = {'history', 'depth', 'reliability', 'durability', 'deadline', 'lifespan',
            'liveliness', 'liveliness_lease_duration', 'avoid_ros_namespace_conventions'}


def test_bag_metadata_is_what_jazzy_ros2_bag_info_reads(recorded):
    """The keys rosbag2_storage (Jazzy, metadata version 9) requires, with their types."""
    bag = recorded[0] / 'bag'
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['version'] == 9 and info['storage_identifier'] == 'mcap'
    for key in ('compression_format', 'compression_mode', 'ros_distro'):
        assert isinstance(info[key], str)
    assert 'custom_data' in info
    files = info['relative_file_paths']
    assert len(files) == 1 and (bag / files[0]).is_file()
    assert info['files'][0]['path'] == files[0]
    assert isinstance(info['duration']['nanoseconds'], int)
    assert isinstance(info['starting_time']['nanoseconds_since_epoch'], int)
    topics = info['topics_with_message_count']
    assert info['message_count'] == sum(t['message_count'] for t in topics)
    by_name = {t['topic_metadata']['name']: t for t in topics}
    assert {'/formation/metrics', '/diagnostics', '/formation/scenario'} <= set(by_name)
    assert by_name['/formation/metrics']['message_count'] > 0
    for entry in topics:
        meta = entry['topic_metadata']
        assert re.fullmatch(r'\w+/msg/\w+', meta['type'])
        assert meta['serialization_format'] == 'cdr'
        assert re.fullmatch(r'RIHS01_[0-9a-f]{64}', meta['type_description_hash'])
        (qos,) = meta['offered_qos_profiles']
        assert set(qos) == QOS_KEYS
        assert qos['reliability'] == 'reliable' and qos['history'] == 'keep_last'
        assert qos['durability'] in ('volatile', 'transient_local')
        assert isinstance(qos['depth'], int) and qos['depth'] >= 1
    odom = by_name['/vehicle_1/odom']['topic_metadata']['offered_qos_profiles'][0]
    assert (odom['durability'], odom['depth']) == ('transient_local', itf.STATE_QOS.depth)


# ---- the monitor on its own, fed by a test publisher (in this process but for one test) ----

def _scenario(**values):
    return scenario.load(CONFIG / 'particle_circular.yaml', [], **values)


def _odom(k, ns, x, y, theta, frame='map'):
    X = np.array([x, y, theta, 1.0, 1.0, 0.0])
    msg = itf.odom_msg(k, ns, X, 0j)
    msg.header.frame_id = frame
    return msg


MONITOR_PARAMS = ('stale_timeout:=2.0', 'diagnostics_period:=0.1', 'markers_period:=0.1',
                  'period:=0.0')


def _feed(probe, sc):
    """Announce ``sc`` and wait until the monitor hears every vehicle's odometry topic."""
    node = probe.node
    announce = node.create_publisher(String, names.SCENARIO_TOPIC, itf.LATCHED_QOS)
    announce.publish(itf.scenario_msg(sc))
    odom = {k: node.create_publisher(Odometry, names.topic(k, 'odom'), itf.STATE_QOS)
            for k in range(1, sc.num_vehicles + 1)}
    assert probe.spin_until(lambda: all(p.get_subscription_count() for p in odom.values())
                            and node.count_publishers(names.METRICS_TOPIC))
    return odom


def _start_monitor(nodes, sc):
    nodes.monitor(*MONITOR_PARAMS)
    return _feed(nodes, sc)


def _latest(box, name):
    for msg in reversed(box):
        for status in msg.status:
            if status.name == 'formation_control/' + name:
                return status
    return None


def test_vehicle_whose_odom_stops_goes_stale(nodes):
    sc = _scenario(num_vehicles=2)
    diags = nodes.collect(DiagnosticArray, names.DIAGNOSTICS_TOPIC, itf.STREAM_QOS)
    odom = _start_monitor(nodes, sc)

    def feed(ks, ns):
        for k in ks:
            odom[k].publish(_odom(k, ns, k, 0.0, 0.5))

    feed((1, 2), 0)
    step, fed = itertools.count(1), [time.monotonic()]

    def stale_2():
        if time.monotonic() - fed[0] >= 0.02:          # vehicle 1 goes on at 50 Hz
            feed((1,), next(step) * 20_000_000)
            fed[0] = time.monotonic()
        status = _latest(diags, 'vehicle_2')
        return status is not None and 'stale odom' in status.message
    assert nodes.spin_until(stale_2, timeout=15)
    assert _latest(diags, 'vehicle_2').level == DiagnosticStatus.ERROR
    first = _latest(diags, 'vehicle_1')
    assert 'stale odom' not in first.message
    assert 'stale cmd' in first.message


def test_markers_show_each_vehicle_its_circle_centre_and_the_target(ros):
    """The ``monitor`` executable: markers, then exit 0 on SIGINT."""
    sc = _scenario(num_vehicles=2, c0=[1.0, -2.0], informed=[1])
    markers = ros.probe.collect(MarkerArray, names.MARKERS_TOPIC, itf.STREAM_QOS)
    monitor = ros.procs.start('monitor', '--ros-args',
                              *[a for p in MONITOR_PARAMS for a in ('-p', p)])
    odom = _feed(ros.probe, sc)
    poses = {1: (0.5, 1.0, 0.3), 2: (-1.0, 2.0, 2.0)}
    for k, (x, y, theta) in poses.items():
        odom[k].publish(_odom(k, 0, x, y, theta))
    assert ros.probe.spin_until(lambda: markers)
    by_key = {(m.ns, m.id): m for m in markers[-1].markers}
    for k, (x, y, theta) in poses.items():
        arrow = by_key[('heading', k)]
        assert arrow.type == Marker.ARROW and arrow.header.frame_id == 'map'
        assert (arrow.pose.position.x, arrow.pose.position.y) == pytest.approx((x, y))
        q = arrow.pose.orientation
        assert 2 * math.atan2(q.z, q.w) == pytest.approx(theta)
        assert [(p.x, p.y) for p in by_key[('trail', k)].points] == [(x, y)]
    assert ('velocity', 1) not in by_key
    centres = [complex(p.x, p.y) for p in by_key[('centres', 0)].points]
    expected = [complex(x, y) + 1j * np.exp(1j * theta) / sc.omega0
                for x, y, theta in poses.values()]
    np.testing.assert_allclose(centres, expected, atol=1e-12)
    target = by_key[('target_centre', 0)]
    assert (target.pose.position.x, target.pose.position.y) == (1.0, -2.0)
    assert interrupt(monitor) == 0


def test_monitor_drops_and_counts_bad_odometry(nodes):
    sc = _scenario(num_vehicles=2)
    diags = nodes.collect(DiagnosticArray, names.DIAGNOSTICS_TOPIC, itf.STREAM_QOS)
    metrics_box = nodes.collect(FormationMetrics, names.METRICS_TOPIC, itf.STREAM_QOS)
    odom = _start_monitor(nodes, sc)
    odom[1].publish(_odom(1, 0, math.nan, 0.0, 0.0))
    odom[2].publish(_odom(2, 0, 0.0, 0.0, 0.0, frame='odom'))
    odom[1].publish(_odom(1, 0, 0.0, 1.0, 0.0))
    odom[2].publish(_odom(2, 0, 1.0, 0.0, 1.0))

    def counted():
        status = _latest(diags, 'formation')
        return status is not None and {v.key: v.value for v in status.values}.get(
            'rejected_messages') == '2' and metrics_box
    assert nodes.spin_until(counted)
    X = np.array([[0.0, 1.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 1.0], [0.0, 0.0]])
    expected = metrics.snapshot(Controller(sc), X, np.zeros((2, 2))).values()
    expected.update(live_links=0.0, algebraic_connectivity=0.0)     # no formation state heard
    got = metric_values(metrics_box[0])
    assert got == pytest.approx(expected)


def test_bag_holds_the_markers_of_the_sampled_poses(recorded):
    """``swarm --bag`` records ``/formation/markers``: each shows the odometry of its stamp."""
    bag, n = recorded[0] / 'bag', recorded[2]['num_vehicles']
    prefix = bagfile.fleet_prefix(bag)                   # a bag holds the resolved names
    assert prefix == '/'
    odom, arrays = {}, []
    odom_topics = [names.topic(k, 'odom') for k in range(1, n + 1)]
    topics = [prefix + t for t in [names.MARKERS_TOPIC] + odom_topics]
    for topic, msg in bagfile.messages(bag, topics):
        if topic == prefix + names.MARKERS_TOPIC:
            arrays.append(msg)
        else:
            odom[(topic, messages.stamp_ns(msg.header.stamp))] = msg.pose.pose
    assert len(arrays) >= 3
    t, values = bagfile.metrics(bag)
    sample = {int(round(ti * 1e9)): i for i, ti in enumerate(t)}
    for array in arrays:
        text, = [m for m in array.markers if m.ns == 'metrics']
        i = sample.get(messages.stamp_ns(text.header.stamp))
        if i is not None:                    # the bag may lack the first metrics samples
            assert f"|p| = {values['order_parameter'][i]:.4f}" in text.text.splitlines()
            assert f"speed error (m/s) = {values['speed_error'][i]:.4f}" in text.text
        headings = [m for m in array.markers if m.ns == 'heading']
        assert [m.id for m in headings] == list(range(1, n + 1))
        for m in headings:
            pose = odom[(prefix + names.topic(m.id, 'odom'), messages.stamp_ns(m.header.stamp))]
            assert (m.pose.position.x, m.pose.position.y) == (pose.position.x, pose.position.y)
            assert (m.pose.orientation.z, m.pose.orientation.w) == pytest.approx(
                (pose.orientation.z, pose.orientation.w), abs=1e-12)


def test_replaying_the_bag_into_a_fresh_monitor_gives_its_metrics_and_report(recorded, nodes):
    """
    ``play``: the recorded fleet's topics, republished, give a new monitor the same metrics.

    At the recorded rate (14 s): the monitor samples a step once it holds every vehicle's
    odometry of it, which a replay much faster than recorded on a loaded machine interleaves
    with the next steps' (a 10 x replay of 9 s lost up to 70 of its 91 samples).
    """
    from formation_control.bags.playback import Bag
    from formation_control.ros.player import PlayerNode
    tmp, _, out = recorded
    bag, n = tmp / 'bag', out['num_vehicles']
    box = nodes.collect(FormationMetrics, names.METRICS_TOPIC, itf.STREAM_QOS)
    fleet = [names.topic(k, name) for k in range(1, n + 1)
             for name in ('odom', 'cmd', 'formation_state')]
    # Deep readers (overrides name the resolved topic): a moment's stall of this loaded
    # machine loses no sample of the replay.
    monitor = nodes.monitor(*[f'qos_overrides./{t}.subscription.depth:=1000' for t in fleet])
    # The names relative to the fleet's namespace (/) select the bag's resolved ones.
    nodes.add(PlayerNode(Bag(bag, [names.SCENARIO_TOPIC]), wait_for_subscribers=True,
                         context=nodes.context))
    assert nodes.spin_until(lambda: monitor.sc is not None)
    player = nodes.add(PlayerNode(Bag(bag, fleet), rate=1.0, wait_for_subscribers=True,
                                  context=nodes.context))
    assert nodes.spin_until(lambda: player.done, timeout=60)
    t, values = bagfile.metrics(bag)
    stamps = np.rint(t * 1e9).astype(np.int64)
    assert nodes.spin_until(lambda: box and messages.stamp_ns(box[-1].header.stamp) >= stamps[-1])
    replayed = {messages.stamp_ns(m.header.stamp): metric_values(m) for m in box}
    # Every sample from t = 0; the bag may lack the recorded monitor's first ones (published
    # before the recorder's reader matched its writer).
    period = int(round(monitor.get_parameter('period').value * 1e9))
    assert sorted(replayed) == list(range(0, stamps[-1] + 1, period))
    assert set(stamps) <= set(replayed)
    # The live graph counts the states heard within stale_timeout of wall time: a property of
    # the links when they ran, which a replay on a busy machine need not repeat.
    live = ('live_links', 'algebraic_connectivity')
    for i, ns in enumerate(stamps):
        same = {k: v for k, v in replayed[ns].items() if k not in live}
        assert same == pytest.approx({k: v[i] for k, v in values.items() if k not in live},
                                     abs=1e-9)
    run = bagfile.read_run(bag)
    _, rows = report.report(run)
    assert stamps[-1] * 1e-9 == pytest.approx(run.t[-1])                  # the final step
    last = replayed[stamps[-1]]
    assert {name: last[name] for name, *_ in rows} == pytest.approx(
        {name: value for name, value, *_ in rows}, abs=1e-9)
