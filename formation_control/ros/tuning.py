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
``formation-control set NAME:=VALUE ...``: change run-time gains on every vehicle of a fleet.

A gain is a property of the fleet's law, which every vehicle computes for itself: the change
goes to every vehicle node of the namespace (``vehicle_1`` .. ``vehicle_N``, N from the plant's
``formation/scenario``), each in one atomic request, and is first checked against the
announced scenario so that an invalid value reaches none. The plant uses no gain (its scenario
parameters are read-only); the monitor follows the vehicles through ``/parameter_events``.
"""
import json
import time

from formation_control.core import parameters, scenario
from formation_control.protocol import names
from formation_control.ros import interface as itf
from formation_control.ros.common import Rejections, subscribe_messages
from formation_control.ros.parameters import EMPTY_TYPES
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from std_msgs.msg import String
import yaml


def parse(assignments):
    """
    Return the :class:`rclpy.parameter.Parameter` of each ``NAME:=VALUE``.

    Raises
    ------
    ScenarioError
        A malformed assignment, an unknown name or one that cannot change at run time.

    """
    out = []
    for text in assignments:
        name, sep, raw = text.partition(':=')
        name = name.strip()
        if not sep or not name:
            raise scenario.ScenarioError(f'{text!r}: give NAME:=VALUE (e.g. K:=0.5)')
        if name not in parameters.RUNTIME:
            raise scenario.ScenarioError(
                f'parameter {name!r} cannot change at run time; run-time parameters: '
                f"{', '.join(parameters.RUNTIME)}")
        try:
            value = yaml.safe_load(raw)
        except yaml.YAMLError:
            value = None
        if value is None or isinstance(value, dict):
            raise scenario.ScenarioError(f'parameter {name!r} = {raw.strip()!r} is invalid: '
                                         f'give a value (YAML, as ros2 param set takes it)')
        default = getattr(parameters.Scenario(), name)
        if isinstance(default, float) and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        out.append(_typed_list(name, raw, value) if isinstance(default, tuple)
                   else Parameter(name, value=value))
    return out


def _typed_list(name, raw, value):
    """Return the array parameter, typed as the nodes declare it (even when empty)."""
    kind = EMPTY_TYPES.get(name, Parameter.Type.DOUBLE_ARRAY)
    numbers = (int,) if kind == Parameter.Type.INTEGER_ARRAY else (int, float)
    if not isinstance(value, list) or not all(
            isinstance(v, numbers) and not isinstance(v, bool) for v in value):
        what = 'integers' if kind == Parameter.Type.INTEGER_ARRAY else 'numbers'
        raise scenario.ScenarioError(f'parameter {name!r} = {raw.strip()!r} is invalid: a list '
                                     f'of {what}')
    if kind == Parameter.Type.DOUBLE_ARRAY:
        value = [float(v) for v in value]
    return Parameter(name, kind, value)


class FleetTuner:
    """
    Sets parameters on the vehicle nodes of the fleet in ``namespace``, seen from ``node``.

    Parameters
    ----------
    node : rclpy.node.Node
        A node of the caller's, spun by :meth:`spin_until`.
    executor : rclpy executor
        The executor that spins ``node``.
    namespace : str
        The fleet's namespace ('/' or e.g. '/fleet_a').

    """

    def __init__(self, node, executor, namespace='/'):
        self.node, self.executor = node, executor
        self.prefix = names.namespace_prefix(namespace)
        self.announced = []
        self.reject = Rejections(node.get_logger(), ['malformed'])
        subscribe_messages(node, String, self.prefix + names.SCENARIO_TOPIC,
                           lambda msg: self.announced.append(msg.data), self.reject,
                           qos_profile=itf.LATCHED_READER_QOS)

    def spin_until(self, predicate, timeout):
        end = time.monotonic() + timeout
        while not predicate() and time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.05)
        return predicate()

    def fleet_scenario(self, timeout):
        """Return the scenario the plant announced; raise ScenarioError without one."""
        if not self.spin_until(lambda: self.announced, timeout):
            raise scenario.ScenarioError(
                f'no fleet in namespace {names.namespace_of(self.prefix)}: nothing on '
                f'{self.prefix}{names.SCENARIO_TOPIC} within {timeout:g} s (start one, or give '
                f'--namespace)')
        return scenario.resolve(json.loads(self.announced[-1]))

    def apply(self, params, timeout=10.0):
        """
        Set ``params`` on every vehicle; return {node name: None if it took them, else why}.

        The change is checked against the announced scenario first (raises ScenarioError).
        """
        sc = self.fleet_scenario(timeout)
        scenario.resolve({**sc.to_dict(), **{p.name: p.value for p in params}})
        names = [f'{self.prefix}vehicle_{k}' for k in range(1, sc.num_vehicles + 1)]
        clients = {name: AsyncParameterClient(self.node, name) for name in names}
        end = time.monotonic() + timeout
        ready = {name for name, c in clients.items()
                 if c.wait_for_services(timeout_sec=max(0.1, end - time.monotonic()))}
        futures = {name: clients[name].set_parameters_atomically(params) for name in ready}
        self.spin_until(lambda: all(f.done() for f in futures.values()),
                        max(0.1, end - time.monotonic()))
        out = {}
        for name in names:
            future = futures.get(name)
            if future is None:
                out[name] = f'not found (no parameter service within {timeout:g} s)'
            elif not future.done() or future.result() is None:
                out[name] = 'no answer'
            else:
                result = future.result().result
                out[name] = None if result.successful else result.reason
        return out


def report(params, results):
    """Return the lines ``formation-control set`` prints, and whether every vehicle took it."""
    change = ', '.join(f'{p.name} = {p.value!r}' for p in params)
    lines = [f'{name}: ' + ('set' if why is None else f'refused: {why}')
             for name, why in results.items()]
    took = sum(why is None for why in results.values())
    lines.append(f'{took}/{len(results)} vehicles took {change}; the monitor follows once all '
                 f'have; the plant uses no gain')
    return lines, took == len(results)
