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
``formation-control doctor``: the facts of a running fleet, gathered by one node.

The node joins the domain in the fleet's namespace and resolves the fleet's relative names
there, as the fleet's nodes do (``formation/scenario`` in ``/fleet_a``:
``/fleet_a/formation/scenario``): it reads the plant's latched scenario, the ROS graph (the
nodes and every endpoint's QoS of the topics in the namespace, and ``/diagnostics``), each
vehicle's scenario parameters (its parameter services) and listens to the formation states for
a while; :mod:`formation_control.ops.doctor` checks what it gathered.
"""
import json
import os
import time

from diagnostic_msgs.msg import DiagnosticArray
from formation_control.core.errors import ScenarioError
from formation_control.core.parameters import PARAMETER_NAMES
from formation_control.core.scenario import resolve
from formation_control.ops import doctor
from formation_control.protocol import intake, messages, names
from formation_control.ros import interface as itf
from formation_control.ros.common import Rejections, subscribe, subscribe_messages
from formation_control_msgs.msg import FormationState
from rcl_interfaces.srv import GetParameters
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import parameter_value_to_python
from rclpy.qos import qos_check_compatible
from std_msgs.msg import String

ENVIRONMENT = ('ROS_DOMAIN_ID', 'ROS_AUTOMATIC_DISCOVERY_RANGE', 'ROS_LOCALHOST_ONLY',
               'FASTRTPS_DEFAULT_PROFILES_FILE', 'OPENSSL_CONF')
NAME = 'formation_doctor'


def _fq(name, namespace):
    return names.resolve(namespace, name)


def _python(value):
    v = parameter_value_to_python(value)
    if v is None:
        return []
    return v if isinstance(v, (str, bool, int, float)) else list(v)


STATE_REFUSALS = (intake.MALFORMED, intake.FOREIGN_ID, intake.WRONG_FRAME, intake.VERSION)
"""What the doctor counts of what it refuses (:func:`intake.formation_state`, the scenario)."""


class Gatherer:
    """The doctor's node in ``namespace`` on ``context``, spun by ``executor`` (None: its own)."""

    def __init__(self, namespace='/', context=None, executor=None):
        self.node = rclpy.create_node(NAME, namespace=namespace or '/', context=context,
                                      start_parameter_services=False)
        self.own = executor is None
        self.executor = SingleThreadedExecutor(context=context) if self.own else executor
        self.executor.add_node(self.node)
        self.me = self.node.get_fully_qualified_name()
        self.reject = Rejections(self.node.get_logger(), STATE_REFUSALS)

    def spin_until(self, predicate, timeout):
        end = time.monotonic() + timeout
        while not predicate() and time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.05)
        return predicate()

    def _call(self, client, names, timeout):
        future = client.call_async(GetParameters.Request(names=list(names)))
        if not self.spin_until(future.done, timeout) or future.result() is None:
            raise TimeoutError(client.srv_name)
        return future.result().values

    def _parameters(self, name, names, timeout):
        """
        Return {name: value} of parameters of node ``name``; None if it does not answer.

        A node answers nothing to a request that names a parameter declared without a value
        (an empty list here, as :func:`parameters.declare` declares them): each is asked alone.
        """
        client = self.node.create_client(GetParameters, f'{name}/get_parameters')
        try:
            if not client.wait_for_service(timeout_sec=timeout):
                return None
            values = self._call(client, names, timeout)
            if len(values) == len(names):
                return {k: _python(v) for k, v in zip(names, values)}
            out = {}
            for k in names:
                one = self._call(client, [k], timeout)
                out[k] = _python(one[0]) if one else []
            return out
        except TimeoutError:
            return None
        finally:
            self.node.destroy_client(client)

    def _endpoints(self):
        """Return the endpoints of the fleet's topics: those in its namespace, /diagnostics."""
        ns = names.namespace_prefix(self.node.get_namespace())
        out = []
        for topic, _ in self.node.get_topic_names_and_types():
            if not (topic.startswith(ns) or topic == names.DIAGNOSTICS_TOPIC):
                continue
            for kind, infos in (('pub', self.node.get_publishers_info_by_topic(topic)),
                                ('sub', self.node.get_subscriptions_info_by_topic(topic))):
                out += [doctor.Endpoint(topic, _fq(i.node_name, i.node_namespace), kind,
                                        i.qos_profile) for i in infos
                        if _fq(i.node_name, i.node_namespace) != self.me]
        return out

    def _listen(self, facts, sc, seconds):
        for k, topic in facts.state_topics.items():
            stream = facts.streams[topic] = doctor.Stream()
            subscribe(self.node, FormationState, topic,
                      intake.formation_state(messages.StateWire.of(sc, k)),
                      lambda kind, what, s=stream: self._refused(s, kind, what),
                      lambda got, s=stream: self._heard(s, got))
        subscribe_messages(self.node, DiagnosticArray, self.node.resolve_topic_name(
            names.DIAGNOSTICS_TOPIC), lambda msg: self._clocked(facts, msg), self.reject,
            qos_profile=itf.STREAM_QOS)
        end = time.monotonic() + seconds                # a span: what arrives in it is counted
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.05)

    @staticmethod
    def _clocked(facts, msg):
        lag = (time.time_ns() - messages.stamp_ns(msg.header.stamp)) * 1e-9
        for status in msg.status:
            who = doctor.clocked_node(status.name, facts.namespace)
            if who is not None:
                facts.clock_lags.setdefault(who, []).append(lag)

    def _refused(self, stream, kind, what):
        stream.refused = what
        self.reject(kind, what)

    @staticmethod
    def _heard(stream, got):
        stream.count += 1
        stream.hears = dict(got.hears)

    def _graph(self, facts, scenario_topic):
        node = self.node
        facts.nodes = [_fq(n, ns) for n, ns in node.get_node_names_and_namespaces()
                       if _fq(n, ns) != self.me]
        facts.scenario_publishers = [_fq(i.node_name, i.node_namespace)
                                     for i in node.get_publishers_info_by_topic(scenario_topic)]

    def _fleet_seen(self, facts, topic, n):
        """Take the graph into ``facts``; return whether it shows every vehicle node 1..n."""
        self._graph(facts, topic)
        return set(range(1, n + 1)) <= set(doctor.vehicle_ids(facts))

    def gather(self, listen=2.0, discover=5.0):
        """
        Return the :class:`doctor.Facts` of the fleet.

        It waits up to ``discover`` s for the plant's scenario, then as long for the graph to
        show every vehicle node (discovery takes 1-3 s: a node not seen yet is not missing).
        """
        node = self.node
        facts = doctor.Facts(namespace=node.get_namespace(),
                             env={k: os.environ[k] for k in ENVIRONMENT if k in os.environ})
        topic = node.resolve_topic_name(names.SCENARIO_TOPIC)
        box = []
        subscribe_messages(node, String, topic, box.append, self.reject,
                           qos_profile=itf.LATCHED_READER_QOS)
        self.spin_until(lambda: box, discover)
        if not box:
            self._graph(facts, topic)
            return facts
        try:
            facts.scenario = json.loads(box[0].data)
            sc = resolve(facts.scenario)
        except (ValueError, KeyError, TypeError, ScenarioError):
            facts.scenario = None
            return facts
        facts.state_topics = {k: node.resolve_topic_name(names.topic(k, 'formation_state'))
                              for k in range(1, sc.num_vehicles + 1)}
        self._listen(facts, sc, listen)
        self.spin_until(lambda: self._fleet_seen(facts, topic, sc.num_vehicles), discover)
        for ids in doctor.vehicle_ids(facts).values():
            for name in set(ids):
                facts.parameters[name] = self._parameters(name, PARAMETER_NAMES, 2.0)
        for plant in set(facts.scenario_publishers):
            mode = self._parameters(plant, ['mode'], 2.0)
            facts.mode = mode and mode['mode']
        facts.endpoints = self._endpoints()
        return facts

    def close(self):
        self.executor.remove_node(self.node)
        if self.own:
            self.executor.shutdown()
        self.node.destroy_node()


def run(namespace='/', listen=2.0, discover=5.0):
    """Gather the facts of the fleet in ``namespace``; return (facts, findings)."""
    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=rclpy.SignalHandlerOptions.NO)
    try:
        gatherer = Gatherer(namespace, context)
        try:
            facts = gatherer.gather(listen, discover)
        finally:
            gatherer.close()
    finally:
        context.try_shutdown()
    return facts, doctor.diagnose(facts, qos_check_compatible)
