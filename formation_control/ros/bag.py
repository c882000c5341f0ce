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
Record topics of a run into a rosbag2 bag with the ``rosbags`` library.

The bag has MCAP storage and metadata version 9, what Jazzy's ``ros2 bag info`` /
``ros2 bag play`` read. Messages are written as received (CDR bytes), each topic with the QoS
its publishers offer and its type's definition (the MCAP schema; formation_control_msgs' from
its installed ``.msg`` files, :mod:`formation_control.bags.schemas`).
"""
from pathlib import Path
import sys

from ament_index_python.packages import get_package_share_directory
from formation_control.bags import schemas
from formation_control.bags.repair import finish_chunk
from formation_control.protocol import names
from formation_control.protocol.names import START_TOPIC
from formation_control.ros import interface as itf
from formation_control.ros.common import probe_node
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile
from rosbags.interfaces import (Qos, QosDurability, QosHistory, QosLiveliness, QosReliability,
                                QosTime)
from rosbags.rosbag2 import StoragePlugin, Writer

FORMATION_STATE = 'formation_control_msgs/msg/FormationState'
VEHICLE_COMMAND = 'formation_control_msgs/msg/VehicleCommand'
FORMATION_METRICS = 'formation_control_msgs/msg/FormationMetrics'
FAULT_EVENT = 'formation_control_msgs/msg/FaultEvent'


FLUSH_PERIOD = 1.0
"""Wall seconds between two finished chunks of the bag: what a kill can lose."""


VEHICLE_TOPIC_TYPES = {
    'odom': ('nav_msgs/msg/Odometry', itf.STATE_QOS),
    'flow': ('geometry_msgs/msg/Vector3Stamped', itf.LATCHED_QOS),
    'water_velocity': ('geometry_msgs/msg/TwistStamped', itf.STATE_QOS),
    'formation_state': (FORMATION_STATE, itf.STATE_QOS),
    'cmd': (VEHICLE_COMMAND, itf.STATE_QOS),
    'cmd_vel': ('geometry_msgs/msg/TwistStamped', itf.STATE_QOS),
}
"""The ROS type and QoS of each topic of
:data:`~formation_control.protocol.names.VEHICLE_TOPICS`."""


def fleet_topics(n, namespace='/', vehicle_topics=names.KNOWN_FLOW_TOPICS):
    """
    Return (topic, ROS type name, QoS) of every topic of a fleet of n in ``namespace``.

    ``vehicle_topics``: the topics of each vehicle the fleet publishes
    (:func:`~formation_control.protocol.onboard.vehicle_topics` of its scenario).
    """
    prefix = names.namespace_prefix(namespace)
    topics = [(prefix + names.CLOCK_TOPIC, 'rosgraph_msgs/msg/Clock', itf.LATCHED_QOS),
              (prefix + names.SCENARIO_TOPIC, 'std_msgs/msg/String', itf.LATCHED_QOS),
              (prefix + names.METRICS_TOPIC, FORMATION_METRICS, itf.STREAM_QOS),
              (names.DIAGNOSTICS_TOPIC, 'diagnostic_msgs/msg/DiagnosticArray', itf.STREAM_QOS),
              (prefix + names.MARKERS_TOPIC, 'visualization_msgs/msg/MarkerArray',
               itf.STREAM_QOS)]
    for k in range(1, n + 1):
        topics += [(prefix + names.topic(k, name), *VEHICLE_TOPIC_TYPES[name])
                   for name in vehicle_topics]
    return topics


def bag_qos(qos):
    """Return the rosbags form of an rclpy QoS profile (written to metadata.yaml)."""
    zero = QosTime(sec=0, nsec=0)
    return Qos(history=QosHistory.KEEP_LAST, depth=qos.depth,
               reliability=QosReliability[qos.reliability.name],
               durability=QosDurability[qos.durability.name], deadline=zero, lifespan=zero,
               liveliness=QosLiveliness.AUTOMATIC, liveliness_lease_duration=zero,
               avoid_ros_namespace_conventions=False)


def _record_qos(qos):
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                      reliability=qos.reliability, durability=qos.durability)


def msg_class(type_name):
    """Return the Python class of a ROS message type ``pkg/msg/Name`` (ImportError if none)."""
    package, _, name = type_name.split('/')
    module = __import__(f'{package}.msg', fromlist=[name])
    try:
        return getattr(module, name)
    except AttributeError:
        raise ImportError(f'no message {type_name} in the installed {package}') from None


class RecordError(RuntimeError):
    """The bag could not be created or written: what failed, and what was kept."""


def msgs_share() -> str:
    """
    Return the share directory of formation_control_msgs (its .msg files, for the bag's schemas).

    From the ament index; else this interpreter's prefix, where ``make setup`` installs it into
    a venv that has no ROS installation to set ``AMENT_PREFIX_PATH``.
    """
    try:
        return get_package_share_directory(schemas.MSGS)
    except (LookupError, OSError):                   # not indexed, or no AMENT_PREFIX_PATH
        share = Path(sys.prefix) / 'share' / schemas.MSGS
        if (share / 'msg').is_dir():
            return str(share)
    raise RecordError(f'bag: the message definitions of {schemas.MSGS} are not found: source '
                      f'the ROS 2 workspace that built it (AMENT_PREFIX_PATH)')


class BagRecorder(Node):
    """
    A node writing every message of ``topics`` ((name, type, QoS)) to a bag at ``path``.

    Every :data:`FLUSH_PERIOD` wall seconds the messages so far are written out as a finished
    chunk, so a recorder killed at any moment leaves them whole in the ``.mcap`` (without the
    summary and ``metadata.yaml`` its close writes: ``formation-control repair`` rebuilds
    those). It writes the bytes as received, undecoded; its own ``/clock`` (``use_sim_time``)
    is decoded, undecodable samples counted in :attr:`reject` (``malformed``). A write that
    fails (a full disk, an unwritable directory) stops the recording: :attr:`failure` says
    what failed and what was kept; nothing written before is lost.
    """

    def __init__(self, path, topics, **kwargs):
        self.path = path
        self.writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
        try:
            self.writer.open()
        except OSError as err:
            raise RecordError(f'bag {path}: cannot be created ({err.strerror}): give a '
                              f'directory on a writable disk') from None
        super().__init__('formation_bag_recorder', **kwargs)
        from formation_control.ros.common import clock_bytes, Rejections
        from formation_control.ros.parameters import guard_services
        self.reject = Rejections(self.get_logger(), ['malformed'])
        clock_bytes(self, self.reject)
        guard_services(self)
        typestore = schemas.typestore(schemas.msg_files(msgs_share()))
        self.count = 0
        self.failure = None
        self.done, self.exit_code = False, 0
        self.readers = {}
        for name, type_name, qos in topics:
            conn = self.writer.add_connection(name, type_name, typestore=typestore,
                                              offered_qos_profiles=[bag_qos(qos)])
            self.readers[name] = self.create_subscription(
                msg_class(type_name), name, lambda data, conn=conn: self._write(conn, data),
                _record_qos(qos), raw=True)
        from formation_control.ros.common import wall_clock
        self.flush_timer = self.create_timer(FLUSH_PERIOD, self.flush, clock=wall_clock()[0])

    def _write(self, conn, data):
        if self.failure is not None:
            return
        try:
            self.writer.write(conn, self.get_clock().now().nanoseconds, data)
        except OSError as err:
            return self._fail(err)
        self.count += 1

    def flush(self):
        """Write the pending messages out as a finished chunk (:func:`repair.finish_chunk`)."""
        if self.failure is not None:
            return
        try:
            finish_chunk(self.writer)
        except OSError as err:
            self._fail(err)

    def _fail(self, err):
        self.failure = (f'bag {self.path}: writing failed after {self.count} messages '
                        f'({err.strerror}); recording stopped. The messages before are kept: '
                        f'`formation-control repair {self.path}` (with --out DIR on a disk '
                        f'with room) makes the bag readable')
        self.get_logger().error(self.failure)
        self.done, self.exit_code = True, 1

    def close(self):
        """Close the bag: its summary and ``metadata.yaml``; a failure says so (RecordError)."""
        if self.writer.storage is None:
            return
        try:
            self.writer.close()
        except OSError as err:
            self.writer.storage = None
            if self.failure is None:
                self._fail(err)
        if self.failure is not None:
            raise RecordError(self.failure)


class FleetRecorder(BagRecorder):
    """
    ``recorder``: the fleet of its namespace into a new bag (``-p bag:=DIR``).

    The plant holds step 0 (``wait_for_start``) until each of the recorder's readers is matched
    with a publisher; then the recorder publishes ``formation/start``. The bag is closed when
    the node is destroyed (Ctrl-C, or the launch shutting down).
    """

    def __init__(self, path, n, prefix='/', monitor=True,
                 vehicle_topics=names.KNOWN_FLOW_TOPICS, **kwargs):
        from std_msgs.msg import Empty

        left_out = () if monitor else [prefix + t
                                       for t in (names.METRICS_TOPIC, names.MARKERS_TOPIC)]
        topics = [t for t in fleet_topics(n, prefix, vehicle_topics) if t[0] not in left_out]
        super().__init__(path, topics, **kwargs)
        if not self.get_parameter('use_sim_time').value:
            self.readers.pop(prefix + names.CLOCK_TOPIC)
        self.start = self.create_publisher(Empty, prefix + START_TOPIC, itf.LATCHED_QOS)
        self.start_msg = Empty()
        from formation_control.ros.common import wall_clock
        self.timer = self.create_timer(0.05, self._start_when_matched, clock=wall_clock()[0])

    def _start_when_matched(self):
        if all(r.get_publisher_count() for r in self.readers.values()):
            self.start.publish(self.start_msg)
            self.get_logger().info(f'recording {len(self.readers)} topics')
            self.destroy_timer(self.timer)

    def destroy_node(self):
        try:
            self.close()
        except RecordError:
            pass                                   # logged by _fail
        return super().destroy_node()


def main(args=None):
    """
    Record a fleet: ``recorder --ros-args -p bag:=DIR -p num_vehicles:=N``.

    ``-p vehicle_topics:="[odom, formation_state, cmd]"``: the topics of each vehicle its fleet
    publishes (:data:`~formation_control.protocol.names.KNOWN_FLOW_TOPICS`; the launch gives
    those of its scenario).
    """
    from formation_control.core.errors import UsageError
    from formation_control.protocol import names
    from formation_control.ros.runner import run

    def make(context):
        probe = probe_node('formation_bag_recorder', context)
        try:
            bag = probe.declare_parameter('bag', '').value
            n = probe.declare_parameter('num_vehicles', 0).value
            monitor = probe.declare_parameter('monitor', True).value
            topics = probe.declare_parameter('vehicle_topics',
                                             list(names.KNOWN_FLOW_TOPICS)).value
            prefix = names.namespace_prefix(probe.get_namespace())
        finally:
            probe.destroy_node()
        if not bag or n < 1:
            raise UsageError("give the bag directory and the fleet's size: -p bag:=DIR -p "
                             'num_vehicles:=N')
        if Path(bag).exists():
            raise UsageError(f'parameter {"bag"!r} = {bag!r} is invalid: it exists already')
        unknown = sorted(set(topics) - set(VEHICLE_TOPIC_TYPES))
        if unknown:
            raise UsageError(f"parameter 'vehicle_topics' = {topics!r} is invalid: each one of "
                             f"{', '.join(VEHICLE_TOPIC_TYPES)} ({unknown[0]!r} is not)")
        return FleetRecorder(bag, n, prefix, monitor, tuple(topics), context=context)
    return run(make, args)
