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
The rclpy side of signed control topics (:mod:`formation_control.ops.signing`).

In a process of a signing fleet, :func:`of_node` gives the node a :class:`Signed`: its
publishers of control topics also send each message's envelope on ``TOPIC/signed``, and its
subscriptions to them take only verified envelopes, whose payload then goes through the
topic's intake as before. Anywhere else it is None and the node is what it was.
"""
import copy
import os

from formation_control.core.errors import UsageError
from formation_control.ops import signing
from formation_control.ops.security import SecurityError
from formation_control.protocol.intake import Rejection
from formation_control.ros.common import wall_clock
from rclpy.serialization import serialize_message
from std_msgs.msg import UInt8MultiArray


class SignedPublisher:
    """
    A publisher of a control topic that also publishes the envelope of each message.

    The envelopes go on the resolved topic's name (remappings applied) + ``/signed``.
    """

    def __init__(self, node, member, msg_type, topic, **qos):
        self.plain = node.create_publisher(msg_type, topic, **qos)
        self.topic, self.member = node.resolve_topic_name(topic), member
        self.envelopes = node.create_publisher(UInt8MultiArray, self.topic + signing.SUFFIX,
                                               **_fresh(qos))

    def publish(self, msg):
        """Publish ``msg`` (a message or its CDR bytes) and its signed envelope."""
        data = msg if isinstance(msg, bytes) else serialize_message(msg)
        self.plain.publish(data)
        self.envelopes.publish(self.member.signer.seal(self.topic, data))


def _fresh(qos):
    """Return the QoS keyword arguments with a copy of their profile (rclpy writes into it)."""
    if 'qos_profile' in qos:
        return {**qos, 'qos_profile': copy.copy(qos['qos_profile'])}
    return qos


class Signed:
    """
    A node's signing and verifying, its drops counted by ``reject`` (a ``Rejections``).

    Every second the revocation list is reloaded if it changed (logged).
    """

    def __init__(self, node, member, reject):
        self.node, self.member, self.reject = node, member, reject
        for kind in signing.KINDS:
            reject.counts.setdefault(kind, 0)
        node.create_timer(1.0, self._refresh, clock=wall_clock()[0])

    def publisher(self, msg_type, topic, **qos):
        """Return a :class:`SignedPublisher` of ``topic``."""
        return SignedPublisher(self.node, self.member, msg_type, topic, **qos)

    def subscription(self, topic, callback, **qos):
        """Subscribe to the envelopes of ``topic``: ``callback`` gets each verified payload."""
        resolved = self.node.resolve_topic_name(topic)

        def on_envelope(data):
            got = self.member.verifier.unseal(resolved, data)
            if isinstance(got, Rejection):
                return self.reject(got.kind, got.what)
            callback(got)
        return self.node.create_subscription(UInt8MultiArray, resolved + signing.SUFFIX,
                                             on_envelope, raw=True, **qos)

    def _refresh(self):
        try:
            changed = self.member.revocations.refresh()
        except (SecurityError, OSError) as err:
            self.node.get_logger().error(f'revocation list not reloaded, the last one kept: '
                                         f'{err}', throttle_duration_sec=10.0)
            return
        if changed:
            self.node.get_logger().warn(f'revocation list {self.member.revocations.path} '
                                        f'reloaded: revoked {sorted(self.member.revocations())}')


def of_node(node, reject, member_name):
    """
    Return the node's :class:`Signed` in a signing fleet (None elsewhere).

    Raises UsageError when the process is not member ``member_name`` (what the node sends
    would be dropped by every receiver as ``wrong_signer``).
    """
    home = signing.member_home(os.environ)
    if home is None:
        return None
    member = signing.load_member(home)
    if member.name != member_name:
        raise UsageError(f'{node.get_name()} runs as member {member.name} of the signing fleet '
                         f'{home.parent}: it must run as {member_name} (. '
                         f'{home.parent / member_name / "env.sh"})')
    return Signed(node, member, reject)
