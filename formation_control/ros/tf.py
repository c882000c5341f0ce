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
The fleet's frames on the ROS graph (REP-105), for RViz, ``ros2 topic echo /tf`` and tf2.

The monitor publishes the Transforms of :mod:`formation_control.view.frames`:

- ``/tf_static`` (``tf2_msgs/msg/TFMessage``, transient-local, depth 1, as tf2's static
  broadcaster): ``map`` to the world frame, once, when they differ (none when the world frame is
  ``map``);
- ``/tf`` (reliable, depth 100, as tf2's broadcaster): each vehicle's base frame in the world
  frame at its pose of the monitor's last sample, stamped with that sample's fleet time, every
  ``markers_period`` wall seconds while subscribed.

Both are absolute (one tree per ROS domain, as tf2 expects): fleets that share a domain need
``base_frame`` s that differ (for example ``fleet_a/vehicle_{id}/base_link``).
"""
from formation_control.protocol import messages
from formation_control.ros import interface as itf
from formation_control.view import frames
from geometry_msgs.msg import TransformStamped
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from tf2_msgs.msg import TFMessage

TF_TOPIC = '/tf'
TF_STATIC_TOPIC = '/tf_static'
TF_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                    reliability=ReliabilityPolicy.RELIABLE,
                    durability=DurabilityPolicy.VOLATILE)
TF_STATIC_QOS = itf.LATCHED_QOS


def tf_message(ns, transforms):
    """Return the TFMessage of :class:`~formation_control.view.frames.Transform` s at ns."""
    sec, nanosec = messages.stamp_parts(ns)
    out = TFMessage()
    for tr in transforms:
        msg = TransformStamped()
        msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
        msg.header.frame_id, msg.child_frame_id = tr.parent, tr.child
        t, q = msg.transform.translation, msg.transform.rotation
        t.x, t.y, t.z = tr.translation
        q.x, q.y, q.z, q.w = tr.rotation
        out.transforms.append(msg)
    return out


class FleetFrames:
    """
    The publishers of ``/tf`` and ``/tf_static`` of a node, for the fleet's frames.

    Parameters
    ----------
    node : rclpy.node.Node
        The publishing node (the monitor).
    world : str
        The world frame.
    base : str
        The vehicles' base frames (``{id}`` pattern).

    The static transforms are stamped 0: they hold at every time.

    """

    def __init__(self, node, world, base):
        self.world, self.base = world, base
        self.pub = node.create_publisher(TFMessage, TF_TOPIC, TF_QOS)
        static = frames.static_transforms(world)
        self.static_pub = None
        if static:
            self.static_pub = node.create_publisher(TFMessage, TF_STATIC_TOPIC, TF_STATIC_QOS)
            self.static_pub.publish(tf_message(0, static))

    def wanted(self):
        return self.pub.get_subscription_count() > 0

    def publish(self, picture):
        """Publish the base frames of a :class:`~formation_control.view.picture.Picture`."""
        self.pub.publish(tf_message(picture.ns, frames.vehicle_transforms(
            picture, self.world, self.base)))
