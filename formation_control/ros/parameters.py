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
Scenario parameters on a node, declared from the core's parameter table.

Each is declared with a descriptor made from its :class:`parameters.Spec`, validated by the
core's :func:`scenario.resolve` (one source of truth); gains and references can change at run
time (:data:`parameters.RUNTIME`).
"""
import copy

from formation_control.core import formations, parameters, scenario
from formation_control.core.errors import ScenarioError
from formation_control.core.parameters import Scenario
from formation_control.protocol import links, node_parameters
from formation_control.protocol.node_parameters import MODES  # noqa: F401 (re-exported)
from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                SetParametersResult)
from rclpy.parameter import Parameter

FLOAT_BOUND = 1e9
"""Descriptor range ends of a number that the scenario leaves unbounded on that side."""
INTEGER_BOUND = 2 ** 63 - 1
EMPTY_TYPES = dict.fromkeys(('informed', 'graph_edges'), Parameter.Type.INTEGER_ARRAY)
"""The array type of a parameter whose default is empty (the others: DOUBLE_ARRAY)."""
PLANT_NOTE = ('; read-only on the plant, which does not use it: the vehicles hold the gains '
              '(formation-control set NAME:=VALUE changes them fleet-wide)')


def descriptor(name):
    """
    Return the ParameterDescriptor of scenario parameter ``name``, from its :class:`Spec`.

    Parameters
    ----------
    name : str
        A name of :data:`parameters.PARAMETERS`.

    Returns
    -------
    rcl_interfaces.msg.ParameterDescriptor
        Description with the unit, the allowed values in ``additional_constraints``, the range
        of a number (``floating_point_range`` or ``integer_range``; ROS ranges are closed, so
        '> 0' is [0, ...] here and 0 is refused by :func:`scenario.resolve`), and ``read_only``
        unless the parameter may change at run time.

    """
    spec = parameters.PARAMETERS[name]
    return _descriptor(spec, getattr(Scenario(), name), parameters.describe(name),
                       parameters.allowed(name))


def _descriptor(spec, default, description, constraints=''):
    d = ParameterDescriptor(description=description, additional_constraints=constraints,
                            read_only=not spec.runtime)
    if (spec.low, spec.high) == (None, None):
        return d
    if isinstance(default, int):
        low = -INTEGER_BOUND if spec.low is None else int(spec.low)
        high = INTEGER_BOUND if spec.high is None else int(spec.high)
        d.integer_range = [IntegerRange(from_value=low, to_value=high, step=1)]
    else:
        low = -FLOAT_BOUND if spec.low is None else float(spec.low)
        high = FLOAT_BOUND if spec.high is None else float(spec.high)
        d.floating_point_range = [FloatingPointRange(from_value=low, to_value=high)]
    return d


def _ros_value(value):
    return list(value) if isinstance(value, tuple) else value


def declare_empty(node, name, array_type, d):
    """
    Declare an array parameter whose default is empty: typed, and with the value [].

    A parameter declared without a value answers nothing to ``get_parameters``, which makes
    ``ros2 param dump`` print no parameter at all; an empty array of its type is a value.
    """
    writable = copy.deepcopy(d)
    writable.read_only = False
    node.declare_parameter(name, array_type, writable)
    if node.get_parameter_or(name, Parameter(name)).type_ == Parameter.Type.NOT_SET:
        node.set_parameters([Parameter(name, array_type, [])])
    if d.read_only:
        d.type = array_type.value
        node.set_descriptor(name, d)
    return node.get_parameter(name).value


def declare(node, defaults=Scenario(), runtime=True):
    """
    Declare every scenario parameter on ``node`` with its descriptor and default.

    ``runtime=False``: every one is read-only (the plant, which uses no gain). An integer
    given for a floating-point one (``-p kappa:=3``) is that float (:func:`as_declared`), then
    and at run time.
    """
    overrides = node._parameter_overrides
    for p in as_declared([p for name, p in overrides.items() if name in parameters.PARAMETERS]):
        overrides[p.name] = p
    for name in parameters.PARAMETER_NAMES:
        value = _ros_value(getattr(defaults, name))
        d = descriptor(name)
        if not runtime and not d.read_only:
            d.read_only = True
            d.description += PLANT_NOTE
        if name == 'K':
            value = formations.default_K(node.get_parameter('formation').value)
        if value == []:
            declare_empty(node, name, EMPTY_TYPES.get(name, Parameter.Type.DOUBLE_ARRAY), d)
        else:
            node.declare_parameter(name, value, d)
    node.add_pre_set_parameters_callback(as_declared)


def as_declared(params):
    """
    Pre-set callback: an integer set to a floating-point parameter is that float.

    ``ros2 param set /vehicle_1 kappa 3`` sends an integer, which a double parameter refuses;
    the simulator and the launch files take it (:func:`node_parameters.as_declared`). A value
    that is no number is left as it is, for the type check to refuse.
    """
    out = []
    for p in params:
        try:
            value = node_parameters.as_declared(p.name, p.value)
        except ScenarioError:
            value = p.value
        out.append(Parameter(p.name, value=value) if value is not p.value and (
            type(value) is not type(p.value) or isinstance(value, list)) else p)
    return out


def _values(node, changes=()):
    values = {name: node.get_parameter(name).value for name in parameters.PARAMETER_NAMES}
    values.update({p.name: p.value for p in changes if p.name in values})
    return values


def current(node):
    """Return the validated scenario the node's parameters describe (raises ScenarioError)."""
    return scenario.resolve(_values(node))


def reject_unknown(node, extra=()):
    """Refuse parameter names given to the node (YAML or -p) that it does not know."""
    known = (set(parameters.PARAMETER_NAMES) | set(links.PARAMETERS) | set(extra)
             | {'use_sim_time', 'start_type_description_service'})
    unknown = sorted(n for n in node._parameter_overrides
                     if n not in known and not n.startswith('qos_overrides.'))
    if unknown:
        raise ScenarioError(parameters.unknown(unknown, known))


def choice(node, name, allowed):
    """Return the value of a string parameter, refused unless it is one of ``allowed``."""
    value = node.get_parameter(name).value
    if value not in allowed:
        raise ScenarioError(f'parameter {name!r} = {value!r} is invalid: allowed values: '
                            f"{' | '.join(allowed)}")
    return value


def validator(node, check=None):
    """
    Return an on-set callback that accepts a change only if the scenario stays valid.

    ``check``, given, is called with the parameters too, and refuses them by raising
    ScenarioError.
    """
    def on_set(params):
        try:
            scenario.resolve(_values(node, params))
            if check is not None:
                check(params)
        except ScenarioError as err:
            return SetParametersResult(successful=False, reason=str(err))
        return SetParametersResult(successful=True)
    return on_set


def guard_services(node):
    """
    Answer a parameter request rclpy cannot read with a refusal, instead of dying of it.

    rclpy's parameter services raise out of the executor, and so end the node, on a request
    naming a parameter type that does not exist (``value.type`` 99: "99 is not a valid
    Parameter.Type"). Each is wrapped: such a request gets its empty response (for a set, every
    result unsuccessful with the reason), a throttled warning and nothing else.
    """
    for service in node.services:
        if getattr(service.callback, 'guarded', False):
            continue
        service.callback = _guarded(node, service.callback, service.srv_type.Response)


def _guarded(node, callback, response_type):
    def answer(request, response):
        try:
            return callback(request, response)
        except (ValueError, TypeError) as err:
            node.get_logger().warn(f'refused a malformed parameter request ({err})',
                                   throttle_duration_sec=2.0)
            return _refusal(request, response_type(), f'malformed request: {err}')
    answer.guarded = True
    return answer


def _refusal(request, response, reason):
    if hasattr(response, 'results'):
        response.results = [SetParametersResult(successful=False, reason=reason)
                            for _ in request.parameters]
    elif hasattr(response, 'result'):
        response.result = SetParametersResult(successful=False, reason=reason)
    return response


def declare_node(node, table, names=None):
    """
    Declare node parameters from a table of :mod:`node_parameters` and return their values.

    Parameters
    ----------
    node : rclpy.node.Node
        The node to declare them on.
    table : dict
        ``name -> (default, parameters.Spec)``.
    names : iterable of str, optional
        The entries to declare (default: all).

    Returns
    -------
    dict
        name -> value (an array gives a tuple).

    """
    guard_services(node)
    values = {}
    for name in table if names is None else names:
        default, spec = table[name]
        text = f'{spec.text} [{spec.unit}]' if spec.unit else spec.text
        d = _descriptor(spec, default, text, ' | '.join(spec.choices) or spec.rule)
        if default == ():
            values[name] = tuple(declare_empty(node, name, Parameter.Type.INTEGER_ARRAY, d))
        else:
            node.declare_parameter(name, default, d)
            values[name] = node.get_parameter(name).value
    return values


def declare_links(node, names, n, own=0):
    """Declare the link parameters ``names`` (:data:`links.PARAMETERS`); returns their values."""
    return links.check(declare_node(node, links.PARAMETERS, names), n, own)
