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
The fleet's frames on the ROS graph: the monitor's ``/tf`` and latched ``/tf_static``.

A lockstep fleet of three in the world frame ``odom``: each ``/tf`` message puts every vehicle's
``base_link`` in ``odom`` at the pose of its odometry of the same stamp; ``/tf_static``, sent
once, reaches a subscriber that joins later; ``ros2 topic echo --once /tf`` (when the ros2
command line is installed) prints the frames.
"""
import math
from pathlib import Path
import shutil
import subprocess
import sys

from formation_control.protocol import messages, names
from formation_control.ros import interface as itf, tf
from nav_msgs.msg import Odometry
import pytest
from rosutil import CONFIG, domains, Nodes, ros_environment
from tf2_msgs.msg import TFMessage
import yaml

BIN = Path(sys.executable).parent
ROS2 = str(BIN / 'ros2') if (BIN / 'ros2').exists() else shutil.which('ros2')
CFG = CONFIG / 'particle_circular.yaml'
PARAMS = ('num_vehicles:=3', 'world_frame:=odom')
N = 3


def _yaw(q):
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


def _angle(a):
    return math.remainder(a, 2 * math.pi)


def _keep_by_stamp(box):
    def keep(msg):
        box[messages.stamp_ns(msg.header.stamp)] = msg
    return keep


@pytest.fixture
def fleet():
    """Give a running lockstep fleet and its monitor, in process, and the domain's environment."""
    with domains() as (did,):
        nodes = Nodes(did)
        try:
            nodes.odom = {k: {} for k in range(1, N + 1)}
            for k, by_stamp in nodes.odom.items():
                nodes.node.create_subscription(Odometry, names.topic(k, 'odom'),
                                               _keep_by_stamp(by_stamp), itf.STATE_QOS)
            nodes.tf = nodes.collect(TFMessage, tf.TF_TOPIC, tf.TF_QOS)
            nodes.monitor(*PARAMS, 'markers_period:=0.05')
            nodes.plant(CFG, *PARAMS, 'duration:=1000.0')
            for k in range(1, N + 1):
                nodes.vehicle(k, CFG, *PARAMS)
            nodes.env = ros_environment(did)
            yield nodes
        finally:
            nodes.close()


def _moving(nodes, count):
    """Whether ``count`` /tf messages of different stamps came, each with its odometries."""
    stamps = {messages.stamp_ns(m.transforms[0].header.stamp) for m in nodes.tf if m.transforms}
    return len(stamps) >= count and all(
        s in by_stamp for s in stamps for by_stamp in nodes.odom.values())


def test_tf_puts_each_base_link_at_its_odometry_pose_and_tf_static_is_latched(fleet):
    assert fleet.spin_until(lambda: _moving(fleet, 3), timeout=60)
    for msg in fleet.tf:
        assert [(t.header.frame_id, t.child_frame_id) for t in msg.transforms] == [
            ('odom', f'vehicle_{k}/base_link') for k in range(1, N + 1)]
        for k, t in enumerate(msg.transforms, 1):
            ns = messages.stamp_ns(t.header.stamp)
            pose = fleet.odom[k][ns].pose.pose
            assert (t.transform.translation.x, t.transform.translation.y,
                    t.transform.translation.z) == pytest.approx(
                (pose.position.x, pose.position.y, 0.0), abs=1e-9)
            assert _angle(_yaw(t.transform.rotation) - _yaw(pose.orientation)) == pytest.approx(
                0.0, abs=1e-9)
    positions = {(t.transform.translation.x, t.transform.translation.y)
                 for msg in fleet.tf for t in msg.transforms[:1]}
    assert len(positions) > 1, 'the frames move with the fleet'
    static = fleet.collect(TFMessage, tf.TF_STATIC_TOPIC, tf.TF_STATIC_QOS)
    assert fleet.spin_until(lambda: static)
    (t,), = [m.transforms for m in static]
    assert (t.header.frame_id, t.child_frame_id) == ('map', 'odom')
    assert (t.transform.rotation.w, t.transform.translation.x) == (1.0, 0.0)


@pytest.mark.skipif(ROS2 is None, reason='the ros2 command line is not installed: neither in '
                    'the venv (make setup installs it from ../shared/ros2-tools) nor on PATH')
def test_ros2_topic_echo_prints_the_fleets_frames(fleet):
    echo = subprocess.Popen([ROS2, 'topic', 'echo', '--once', '--no-daemon', tf.TF_TOPIC,
                             'tf2_msgs/msg/TFMessage'], env=fleet.env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            stdin=subprocess.DEVNULL)
    try:
        assert fleet.spin_until(lambda: echo.poll() is not None, timeout=60)
    finally:
        if echo.poll() is None:
            echo.kill()
        out, _ = echo.communicate()
    assert echo.returncode == 0, out
    got = yaml.safe_load(out.split('\n---')[0])
    assert [(t['header']['frame_id'], t['child_frame_id']) for t in got['transforms']] == [
        ('odom', f'vehicle_{k}/base_link') for k in range(1, N + 1)]
