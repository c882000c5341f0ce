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
``formation-control play``: a node republishing a bag, as ``ros2 bag play`` does.

Every selected topic is published with the QoS its recorded publishers offered
(:func:`playback.replay_qos`), each message as its recorded CDR bytes when its recorded time
is due (:class:`playback.Schedule`); with ``clock``, the node's ``clock`` (``/clock``, or
``/fleet_a/clock`` in the namespace ``/fleet_a``) carries the recorded time being played (the
bag's own is then not replayed: ``playback.Bag(..., skip=[CLOCK_TOPIC], namespace=...)``).
"""
import time

from formation_control.bags import playback
from formation_control.protocol import messages
from formation_control.ros.bag import msg_class
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock

TICK = 0.002
"""Wall seconds between two looks at what is due."""
ACK_TIMEOUT = Duration(seconds=2.0)
"""``wait_for_subscribers``: the longest wait for the subscribers' acknowledgements."""


def qos_profile(qos):
    """Return the rclpy QoSProfile of a :class:`playback.ReplayQos`."""
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=qos.depth,
        reliability=ReliabilityPolicy.RELIABLE if qos.reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=(DurabilityPolicy.TRANSIENT_LOCAL if qos.transient_local
                    else DurabilityPolicy.VOLATILE))


class PlayerNode(Node):
    """
    Replay ``bag`` (a :class:`playback.Bag`); ``done`` once it has played (never with ``loop``).

    ``wait_for_subscribers``: hold the start until every replayed topic has a subscriber, then
    play a reliable topic's next message only once its subscribers acknowledged the last ones
    (as ``ros2 bag play --wait-for-all-acked``): a subscriber that matches the player's writer
    a moment after the writer matched it misses nothing.
    """

    def __init__(self, bag, rate=1.0, clock=False, loop=False, wait_for_subscribers=False,
                 **kwargs):
        super().__init__('formation_player', **kwargs)
        self.bag, self.rate, self.loop = bag, rate, loop
        self.wait = wait_for_subscribers
        self.pubs = {}
        for topic in bag.topics:
            try:
                cls = msg_class(topic.msgtype)
            except ImportError as err:
                raise playback.BagError(f'{bag.path}: topic {topic.name} cannot be replayed: '
                                        f'{err} (leave it out with --topics)') from None
            self.pubs[topic.name] = self.create_publisher(cls, topic.name, qos_profile(topic.qos))
        self.reliable = {t.name for t in bag.topics if t.qos.reliable}
        self.clock = self.create_publisher(Clock, playback.CLOCK_TOPIC, 10) if clock else None
        self.done, self.error, self.count = False, None, 0
        self.schedule = self.pending = self.stream = None
        self.create_timer(TICK, self._tick)
        self.get_logger().info(f'playing {bag.path}: {len(self.pubs)} topics at rate {rate:g}')

    def _restart(self):
        self.stream = self.bag.messages()
        self.pending = next(self.stream, None)              # opens the bag: not timed
        self.schedule = playback.Schedule(self.bag.start, self.rate, time.monotonic())

    def _tick(self):
        if self.done:
            return
        if self.schedule is None:
            if self.wait and not all(p.get_subscription_count() for p in self.pubs.values()):
                return
            self._restart()
        wall = time.monotonic()
        if self.clock is not None:
            msg = Clock()
            ns = min(self.schedule.now(wall), self.bag.end)
            messages.set_time(msg.clock, ns)
            self.clock.publish(msg)
        sent = set()
        try:
            while self.pending is not None and self.schedule.due(self.pending[1]) <= wall:
                topic, _, data = self.pending
                if self.wait and topic in sent and topic in self.reliable:
                    self.pubs[topic].wait_for_all_acked(ACK_TIMEOUT)
                self.pubs[topic].publish(data)
                sent.add(topic)
                self.count += 1
                self.pending = next(self.stream, None)
        except playback.BagError as err:
            self.get_logger().error(str(err))
            self.error, self.done = err, True
            return
        if self.wait:
            for topic in sent & self.reliable:
                self.pubs[topic].wait_for_all_acked(ACK_TIMEOUT)
        if self.pending is None:
            if self.loop:
                self._restart()
                return
            if self.wait:                                    # the last ones arrive too
                for topic in self.reliable:
                    self.pubs[topic].wait_for_all_acked(ACK_TIMEOUT)
            self.done = True
