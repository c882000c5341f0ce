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
``formation-control play``: the replay QoS, the schedule, a bag of another package, bad bags.

The replay of the package's own recorded fleet into a fresh monitor is in test_monitor.py
(it shares that file's recorded run).
"""
import shutil
import subprocess

from formation_control.bags.playback import (Bag, BagError, CLOCK_TOPIC, replay_qos, ReplayQos,
                                             Schedule)
from formation_control.ros.player import PlayerNode
import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosbags.interfaces import (Qos, QosDurability, QosHistory, QosLiveliness, QosReliability,
                                QosTime)
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import get_typestore, Stores
from rosgraph_msgs.msg import Clock
from rosutil import BIN
from std_msgs.msg import String

STORE = get_typestore(Stores.ROS2_JAZZY)


def _qos(reliability, durability, depth):
    zero = QosTime(sec=0, nsec=0)
    return Qos(history=QosHistory.KEEP_LAST, depth=depth,
               reliability=QosReliability[reliability], durability=QosDurability[durability],
               deadline=zero, lifespan=zero, liveliness=QosLiveliness.AUTOMATIC,
               liveliness_lease_duration=zero, avoid_ros_namespace_conventions=False)


def test_replay_qos_is_what_every_recorded_publisher_offered():
    reliable = _qos('RELIABLE', 'TRANSIENT_LOCAL', 5)
    assert replay_qos([reliable]) == ReplayQos(True, True, 5)
    assert replay_qos([reliable, _qos('BEST_EFFORT', 'TRANSIENT_LOCAL', 20)]) == ReplayQos(
        False, True, 20)
    assert replay_qos([reliable, _qos('RELIABLE', 'VOLATILE', 1)]) == ReplayQos(True, False, 5)
    assert replay_qos([]) == ReplayQos(True, False, 10)


def test_schedule_plays_the_recorded_times_at_the_rate():
    s = Schedule(start=5_000_000_000, rate=4.0, wall0=100.0)
    assert s.due(5_000_000_000) == 100.0
    assert s.due(9_000_000_000) == pytest.approx(101.0)
    assert s.now(101.0) == 9_000_000_000


CHATTER = [(1_000_000_000 + i * 100_000_000, f'hello {i}') for i in range(6)]


@pytest.fixture
def other_bag(tmp_path):
    """Write a bag as another package does: rosbags, sqlite3, metadata version 8."""
    path = tmp_path / 'other'
    with Writer(path, version=8, storage_plugin=StoragePlugin.SQLITE3) as writer:
        chatter = writer.add_connection('/chatter', 'std_msgs/msg/String', typestore=STORE,
                                        offered_qos_profiles=[_qos('BEST_EFFORT', 'VOLATILE',
                                                                   7)])
        clock = writer.add_connection('/fleet_a/clock', 'rosgraph_msgs/msg/Clock',
                                      typestore=STORE)
        for ns, text in CHATTER:
            writer.write(chatter, ns, STORE.serialize_cdr(STORE.types['std_msgs/msg/String'](
                data=text), 'std_msgs/msg/String'))
            writer.write(clock, ns, STORE.serialize_cdr(STORE.types['rosgraph_msgs/msg/Clock'](
                clock=STORE.types['builtin_interfaces/msg/Time'](sec=0, nanosec=0)),
                'rosgraph_msgs/msg/Clock'))
    return path


def test_a_bag_of_another_package_replays_with_its_qos_and_clock(nodes, other_bag):
    """In the namespace /fleet_a: the player's clock is /fleet_a/clock, the bag's is skipped."""
    best_effort = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
    got = nodes.collect(String, '/chatter', best_effort)
    clocks = nodes.collect(Clock, '/fleet_a/clock', 10)
    bag = Bag(other_bag, skip=[CLOCK_TOPIC], namespace='/fleet_a')
    assert [(t.name, t.msgtype, t.qos) for t in bag.topics] == [
        ('/chatter', 'std_msgs/msg/String', ReplayQos(False, False, 7))]
    player = nodes.add(PlayerNode(bag, rate=5.0, clock=True, wait_for_subscribers=True,
                                  namespace='/fleet_a', context=nodes.context))
    assert nodes.spin_until(lambda: player.done, timeout=15)
    assert nodes.spin_until(lambda: len(got) == len(CHATTER), timeout=5)
    assert [m.data for m in got] == [text for _, text in CHATTER]
    (info,) = nodes.node.get_publishers_info_by_topic('/chatter')
    assert info.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT
    assert info.qos_profile.durability == DurabilityPolicy.VOLATILE
    times = [m.clock.sec * 1_000_000_000 + m.clock.nanosec for m in clocks]
    assert times == sorted(times) and len(times) > len(CHATTER)
    assert times[0] >= CHATTER[0][0] and times[-1] == CHATTER[-1][0]


def test_a_truncated_or_corrupt_bag_is_a_clear_error(tmp_path, other_bag):
    with pytest.raises(BagError, match='not a rosbag2 bag'):
        Bag(tmp_path)
    with pytest.raises(BagError, match='no topic /nothing in the bag'):
        Bag(other_bag, ['/nothing'])
    assert [t.name for t in Bag(other_bag, ['chatter']).topics] == ['/chatter']
    assert [t.name for t in Bag(other_bag, ['clock'], namespace='fleet_a/').topics] == [
        '/fleet_a/clock']
    with pytest.raises(BagError, match='no topic /fleet_a/chatter in the bag'):
        Bag(other_bag, ['chatter', '/fleet_a/clock'], namespace='/fleet_a')
    broken = tmp_path / 'broken'
    shutil.copytree(other_bag, broken)
    (db,) = broken.glob('*.db3')
    db.write_bytes(db.read_bytes()[:len(db.read_bytes()) // 2])
    with pytest.raises(BagError, match='truncated or corrupt'):
        list(Bag(broken).messages())
    (broken / 'metadata.yaml').write_text('rosbag2_bagfile_information: [1, 2\n')
    proc = subprocess.run([str(BIN / 'formation-control'), 'play', str(broken)],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert proc.stderr.startswith(f'error: {broken}: the bag is truncated or corrupt')
