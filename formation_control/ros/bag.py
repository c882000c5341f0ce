"""
Record topics of a run into a rosbag2 bag (MCAP storage) with the ``rosbags`` library, the
format ``ros2 bag info`` / ``ros2 bag play`` read. Messages are written as received (CDR bytes).
"""
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import get_typestore, Stores

from formation_control.ros import interface as itf

def _record_qos(durability):
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, durability=durability,
                      reliability=ReliabilityPolicy.RELIABLE)


RECORD_QOS = _record_qos(DurabilityPolicy.TRANSIENT_LOCAL)
CLOCK_QOS = _record_qos(DurabilityPolicy.VOLATILE)


def fleet_topics(n):
    """(topic, ROS type name) of every topic a fleet of n vehicles uses."""
    topics = [('/clock', 'rosgraph_msgs/msg/Clock')]
    for k in range(1, n + 1):
        topics += [(itf.topic(k, 'odom'), 'nav_msgs/msg/Odometry'),
                   (itf.topic(k, 'flow'), 'geometry_msgs/msg/Vector3Stamped'),
                   (itf.topic(k, 'formation_state'), 'sensor_msgs/msg/JointState'),
                   (itf.topic(k, 'cmd'), 'geometry_msgs/msg/WrenchStamped')]
    return topics


def _msg_class(type_name):
    package, _, name = type_name.split('/')
    module = __import__(f'{package}.msg', fromlist=[name])
    return getattr(module, name)


class BagRecorder(Node):
    """Subscribes to ``topics`` and writes every message to a bag at ``path``."""

    def __init__(self, path, topics, **kwargs):
        super().__init__('formation_bag_recorder', **kwargs)
        self.writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
        self.writer.open()
        typestore = get_typestore(Stores.ROS2_JAZZY)
        self.count = 0
        for name, type_name in topics:
            conn = self.writer.add_connection(name, type_name, typestore=typestore)
            self.create_subscription(_msg_class(type_name), name,
                                     lambda data, conn=conn: self._write(conn, data),
                                     CLOCK_QOS if name == '/clock' else RECORD_QOS, raw=True)

    def _write(self, conn, data):
        self.writer.write(conn, self.get_clock().now().nanoseconds, data)
        self.count += 1

    def close(self):
        self.writer.close()
