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
The monitor's Foxglove live view: a Foxglove WebSocket server (``foxglove-sdk``).

Its public port is a :class:`~formation_control.ros.relay.Relay`, so that clients of both names
of the protocol connect: ``foxglove.sdk.v1`` (the Foxglove app) and ``foxglove.websocket.v1``
(Foxglove Studio 1.x, Lichtblick).

Channels, named as the monitor resolves its topics (absolute: a fleet in ``/fleet_a`` has
``/fleet_a/formation/metrics``):

- ``<ns>/formation/scene``: ``foxglove.SceneUpdate`` (protobuf) in the monitor's
  ``world_frame``, :func:`scene.fleet_scene`;
- ``<ns>/formation/metrics``: JSON, ``timestamp`` and each metric of :data:`interface.METRIC_DOC`
  by name (plot ``/formation/metrics.order_parameter``);
- ``<ns>/formation/markers``: the RViz ``visualization_msgs/msg/MarkerArray`` as CDR, the same
  picture as the scene, so that a layout made for bags (which record the markers) works live;
- ``/diagnostics``: ``diagnostic_msgs/msg/DiagnosticArray`` as CDR (schema encoding
  ``ros2msg``, what ``foxglove_bridge`` serves), for the Diagnostics panels;
- ``/tf``: ``tf2_msgs/msg/TFMessage`` as CDR with the frames of :mod:`~formation_control.view.
  frames` (each vehicle's base frame in the world frame, ``map`` above it), at the scene's
  stamps, so that a 3D panel draws in ``map`` or follows a vehicle's base frame: the monitor's
  ``/tf`` and ``/tf_static`` of the ROS graph together (:mod:`formation_control.ros.tf`), in one
  channel (a WebSocket client joining late still gets ``map``).

``formation-control layout --namespace NS --world-frame F`` prints the layout of these names.
Each message is logged at the fleet time of the state it shows (ns).

What a client sends wrong (bytes that are no frame, frames no message of the protocol fits,
unknown channels) is answered by the servers and logged through Python's logging: those lines
are taken from :data:`SERVER_LOGGERS` into the node's ``reject`` (:class:`ServerLog`), counted
under ``live_client`` and logged throttled, so that a flood of bad frames costs a counter.
"""
import logging

from formation_control.core.errors import UsageError
from formation_control.protocol import messages, names
from formation_control.protocol.names import BASE_FRAME, WORLD_FRAME
from formation_control.ros import tf
from formation_control.ros.relay import Relay
from formation_control.view import frames, scene
import foxglove
from foxglove.channels import SceneUpdateChannel
from rclpy.serialization import serialize_message
from rosbags.typesys import get_typestore, Stores

DIAGNOSTIC_ARRAY = 'diagnostic_msgs/msg/DiagnosticArray'
MARKER_ARRAY = 'visualization_msgs/msg/MarkerArray'
SERVER_LOGGERS = ('foxglove', 'websockets', 'tungstenite')
"""The loggers of the live view's servers: foxglove-sdk (its Rust log included), the relay's."""
LIVE_CLIENT = 'live_client'
"""The kind under which the servers' warnings about a client are counted."""
TF_MESSAGE = 'tf2_msgs/msg/TFMessage'
TYPES = get_typestore(Stores.ROS2_JAZZY)


def ros2msg_schema(type_name):
    """Return the foxglove Schema of a ROS 2 message type (``ros2msg`` text, as in MCAP)."""
    text, _ = TYPES.generate_msgdef(type_name, ros_version=2)
    return foxglove.Schema(name=type_name, encoding='ros2msg', data=text.encode())


class LiveView:
    """
    A Foxglove WebSocket server on ``host:port`` with the monitor's channels.

    Parameters
    ----------
    node : rclpy.node.Node
        The monitor (names the server and resolves the channel names).
    host : str
        Address to listen on.
    port : int
        TCP port (1..65535).
    reject : callable
        ``reject(kind, text)``, the node's :class:`~formation_control.ros.common.Rejections`:
        what the servers log about a client goes there (:class:`ServerLog`).
    frame : str, optional
        The world frame of the scene (the monitor's ``world_frame``).
    base : str, optional
        The vehicles' base frames (the monitor's ``base_frame``), for ``/tf``.

    """

    def __init__(self, node, host, port, reject, frame=WORLD_FRAME, base=BASE_FRAME):
        self.frame, self.base = frame, base
        self.log = ServerLog(reject)
        self.context = foxglove.Context()
        self.server = foxglove.start_server(name=node.get_fully_qualified_name(),
                                            host='127.0.0.1', port=0, context=self.context)
        try:
            self.relay = Relay(host, port, self.server.port)
        except OSError as err:
            self.server.stop()
            self.log.remove()
            raise UsageError(f'foxglove_port {port}: cannot serve the Foxglove live view on '
                             f'{host}:{port} ({err})') from None
        self.scene = SceneUpdateChannel(node.resolve_topic_name(names.SCENE_TOPIC),
                                        context=self.context)
        self.metrics = foxglove.Channel(node.resolve_topic_name(names.METRICS_TOPIC),
                                        schema=scene.metrics_schema(messages.METRIC_DOC),
                                        context=self.context)
        self.markers = foxglove.Channel(node.resolve_topic_name(names.MARKERS_TOPIC),
                                        schema=ros2msg_schema(MARKER_ARRAY),
                                        message_encoding='cdr', context=self.context)
        self.tf = foxglove.Channel(tf.TF_TOPIC, schema=ros2msg_schema(TF_MESSAGE),
                                   message_encoding='cdr', context=self.context)
        self.diagnostics = foxglove.Channel(node.resolve_topic_name(names.DIAGNOSTICS_TOPIC),
                                            schema=ros2msg_schema(DIAGNOSTIC_ARRAY),
                                            message_encoding='cdr', context=self.context)

    @property
    def port(self):
        return self.relay.port

    def wants_scene(self):
        return self.scene.has_sinks() or self.tf.has_sinks()

    def wants_markers(self):
        return self.markers.has_sinks()

    def log_markers(self, ns, data):
        """Log a serialized MarkerArray (CDR bytes) at the stamp of its picture."""
        self.markers.log(data, log_time=int(ns))

    def log_scene(self, picture):
        """Log the scene and frames of a :class:`~formation_control.view.picture.Picture`."""
        if self.scene.has_sinks():
            self.scene.log(scene.fleet_scene(*picture, frame=self.frame),
                           log_time=int(picture.ns))
        if self.tf.has_sinks():
            message = tf.tf_message(picture.ns, frames.fleet_transforms(
                picture, self.frame, self.base))
            self.tf.log(serialize_message(message), log_time=int(picture.ns))

    def log_metrics(self, ns, values):
        if self.metrics.has_sinks():
            self.metrics.log(scene.metrics_message(ns, values), log_time=int(ns))

    def log_diagnostics(self, ns, data):
        """Log a serialized DiagnosticArray (CDR bytes)."""
        if self.diagnostics.has_sinks():
            self.diagnostics.log(data, log_time=int(ns))

    def close(self):
        self.relay.close()
        self.server.stop()
        self.log.remove()


class ServerLog(logging.Handler):
    """
    The live view servers' warnings, taken from Python's logging into a node's ``reject``.

    Each record at WARNING or above of :data:`SERVER_LOGGERS` becomes
    ``reject(LIVE_CLIENT, text)``: counted and logged throttled
    (:class:`~formation_control.ros.common.Rejections`), not printed once per bad frame.
    """

    def __init__(self, reject):
        super().__init__(logging.WARNING)
        self.reject = reject
        self.kept = []
        for name in SERVER_LOGGERS:
            logger = logging.getLogger(name)
            self.kept.append((logger, logger.propagate))
            logger.addHandler(self)
            logger.propagate = False

    def emit(self, record):
        self.reject(LIVE_CLIENT, f"a live-view client's frame ({record.name}: "
                                 f'{record.getMessage()[:200]})')

    def remove(self):
        """Give the loggers back as they were."""
        for logger, propagate in self.kept:
            logger.removeHandler(self)
            logger.propagate = propagate
