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

"""What every node of the package does alike: wall time, incoming bytes, dropped input, status."""
import collections
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from formation_control.protocol import intake, names
from formation_control.protocol.intake import Rejection, VERSION
from formation_control.ros import interface as itf
from formation_control.ros.fits import fits
import numpy as np
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from rosgraph_msgs.msg import Clock as ClockMsg


def wall_clock():
    """
    Return the steady wall clock of this process, for timers, and a reader in seconds.

    The reader is :func:`time.monotonic`, the clock rclpy's steady time reads (CLOCK_MONOTONIC),
    without building a Time object per call.

    Returns
    -------
    (rclpy.clock.Clock, callable)

    """
    return Clock(clock_type=ClockType.STEADY_TIME), time.monotonic


class Rejections:
    """
    Counts of dropped input by kind, each drop logged (rate-limited) with the running total.

    A message of another interface version is logged as an error, the others as warnings.

    Parameters
    ----------
    logger : rclpy logger
    kinds : iterable of str
        The kinds of rejected input that are counted.

    """

    def __init__(self, logger, kinds):
        self.logger = logger
        self.counts = dict.fromkeys(kinds, 0)

    def __call__(self, kind, what):
        """Count a dropped ``what`` (text) of ``kind`` and log it; returns None."""
        self.counts[kind] += 1
        text = f'dropped {what} ({kind}; total dropped: {self.total})'
        if kind == VERSION:
            self.logger.error(text, throttle_duration_sec=2.0)
        else:
            self.logger.warn(text, throttle_duration_sec=2.0)

    @property
    def total(self):
        return sum(self.counts.values())


class Decoder:
    """
    The rclpy side of an :class:`~formation_control.protocol.intake.Intake`.

    Calling it with a subscription's raw bytes returns their value, or None once they are
    rejected (counted and logged by ``reject``, a :class:`Rejections`).
    """

    def __init__(self, intake, msg_type, reject):
        self.intake, self.reject, self.msg_type = intake, reject, msg_type

    def deserialize(self, data):
        """Return the message of ``data``; raises ValueError on bytes no message fits."""
        if not fits(data, self.msg_type):
            raise ValueError('no message of the type fits the bytes')
        return deserialize_message(data, self.msg_type)

    def __call__(self, data):
        got = self.intake(data, self.deserialize)
        if isinstance(got, Rejection):
            return self.reject(got.kind, got.what)
        return got


def subscribe(node, msg_type, topic, rule, reject, take, signed=None):
    """
    Subscribe ``node`` to the bytes of a state ``topic``: each through ``rule``, then ``take``.

    ``rule`` is an :class:`~formation_control.protocol.intake.Intake`; ``take`` is called with
    the value of the bytes it does not reject (counted by ``reject``, a :class:`Rejections`).
    With ``signed`` (a :class:`~formation_control.ros.signed.Signed`), the bytes are the
    payloads of the topic's verified envelopes instead.
    """
    decode = Decoder(rule, msg_type, reject)

    def on_bytes(data):
        got = decode(data)
        if got is not None:
            take(got)
    return raw_subscription(node, msg_type, topic, on_bytes, signed,
                            **itf.state_qos_kwargs(reader=True))


def raw_subscription(node, msg_type, topic, on_bytes, signed=None, **qos):
    """Subscribe ``on_bytes`` to the raw bytes of ``topic``, or (``signed``) to its envelopes'."""
    if signed is None:
        return node.create_subscription(msg_type, topic, on_bytes, raw=True, **qos)
    return signed.subscription(topic, on_bytes, **qos)


def subscribe_messages(node, msg_type, topic, take, reject, signed=None, rule=intake.message,
                       **qos):
    """
    Subscribe ``node`` to the raw bytes of ``topic``, each deserialized, then ``take``-n.

    Bytes that do not deserialize are dropped and counted by ``reject`` (a
    :class:`Rejections`, kind ``malformed``) instead of the middleware's log of each; ``qos``
    are the keyword arguments of the QoS (``qos_profile=...``); ``signed``: as
    :func:`subscribe`; ``rule``: the intake of the message, given what it is (text).
    """
    decode = Decoder(rule(f'{msg_type.__name__} on {topic}'), msg_type, reject)

    def on_bytes(data):
        got = decode(data)
        if got is not None:
            take(got)
    return raw_subscription(node, msg_type, topic, on_bytes, signed, **qos)


def clock_bytes(node, reject, signed=None):
    """
    Take ``/clock`` (``use_sim_time``) as bytes too: undecodable ones counted, not logged each.

    rclpy's time source subscribes to ``/clock`` with its message type: the middleware logs a
    "Fast CDR exception" and rcutils an "error state is being overwritten" block for every
    undecodable sample. Its subscription is replaced by one of the same QoS through
    :func:`subscribe_messages` (kind ``malformed``) feeding the time source alike; with
    ``signed``, from the clock's verified envelopes.
    """
    source = node._time_source
    if source._clock_sub is None:
        return
    node.destroy_subscription(source._clock_sub)
    source._clock_sub = subscribe_messages(
        node, ClockMsg, '/clock', source.clock_callback, reject, signed, rule=intake.clock,
        qos_profile=QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT))


def status(name, level, message, values, hardware_id=''):
    """Build a DiagnosticStatus with ``values`` (dict) as its key/value pairs."""
    return DiagnosticStatus(level=level, name=name, message=message, hardware_id=hardware_id,
                            values=[KeyValue(key=k, value=str(v)) for k, v in values.items()])


def diagnostics_publisher(node):
    """Create the node's publisher on ``/diagnostics``."""
    return node.create_publisher(DiagnosticArray, names.DIAGNOSTICS_TOPIC, itf.STREAM_QOS)


def publish_diagnostics(node, publisher, statuses):
    """
    Publish ``statuses`` as one DiagnosticArray stamped with the node's clock.

    ``/diagnostics`` is shared by every fleet of the domain: in a namespace, each status name
    starts with it (``fleet_a/formation_control/vehicle_1``).
    """
    statuses = list(statuses)
    prefix = names.status_prefix(node.get_namespace())
    for s in statuses:
        s.name = prefix + s.name
    msg = DiagnosticArray(status=statuses)
    msg.header.stamp = node.get_clock().now().to_msg()
    publisher.publish(msg)
    return msg


class Latencies:
    """
    The last ``size`` samples of named latencies (ns), summarised in ms for diagnostics.

    Parameters
    ----------
    names : tuple of str
        One name per latency of a sample.

    """

    def __init__(self, names, size=1000):
        self.names = names
        self.samples = collections.deque(maxlen=size)

    def add(self, *ns):
        """One sample: a latency (ns) per name."""
        self.samples.append(ns)

    def summary(self):
        """``{name}_ms_p50`` and ``{name}_ms_p99`` of each latency; empty before a sample."""
        out = {}
        if self.samples:
            for name, ms in zip(self.names, 1e-6 * np.array(self.samples).T):
                out[f'{name}_ms_p50'] = f'{np.median(ms):.3f}'
                out[f'{name}_ms_p99'] = f'{np.percentile(ms, 99):.3f}'
        return out


def probe_node(name, context):
    """
    Return a short-lived node that leaves no trace in the graph once destroyed.

    No parameter services, no rosout, and no ``~/get_type_description`` service: rclpy
    destroys that one only when not in use, and ``ros2 service list`` kept showing it after
    the node was gone.
    """
    return Node(name, context=context, start_parameter_services=False, enable_rosout=False,
                parameter_overrides=[Parameter('start_type_description_service', value=False)])
