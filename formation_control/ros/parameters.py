"""
Scenario parameters on a node: declared with descriptors, validated by the core's
:func:`scenario.resolve` (one source of truth), gains changeable at run time.
"""
from dataclasses import fields

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rcl_interfaces.msg import SetParametersResult
from rclpy.parameter import Parameter

from formation_control.core import links, scenario
from formation_control.core.scenario import Scenario, ScenarioError

MODES = ('lockstep', 'realtime')
"""Time modes of the plant and the vehicles."""

RUNTIME = ('K', 'kappa', 'omega0', 'K_p', 'u0', 'K_f', 'K_P', 'K_I', 'c0', 'informed',
           *scenario.LIMITS)
"""Gains and references a running node accepts; every other scenario parameter is read-only."""

DOCS = {
    'num_vehicles': 'number of vehicles N in the fleet (vehicles are numbered 1..N)',
    'model': 'vehicle model: first_order | second_order | rigid | rigid_couple | rigid_cop',
    'formation': 'parallel | circular',
    'controller': 'first_order | backstepping | proportional | pi',
    'K': 'formation gain K (1/s): < 0 for parallel (3.7), > 0 for circular (3.14)',
    'kappa': 'backstepping gain kappa (1/s), > 0',
    'omega0': 'circle curvature omega0 (rad/m), radius 1/|omega0|, != 0',
    'flow': 'uniform steady flow [fx, fy] (m/s, map frame)',
    'K_p': 'proportional gain K_p of (5.5) (1/s), > 0',
    'u0': 'commanded forward speed relative to the flow u0 (m/s), > 0',
    'K_f': 'thrust feedback-linearisation gain K_f (1/s), > 0',
    'K_P': 'PI steering proportional gain K_P (1/s), > 0',
    'K_I': 'PI steering integral gain K_I (1/s^2), >= 0',
    'm0': 'vehicle mass m0 (kg), > 0',
    'I0': 'yaw moment of inertia I0 (kg m^2), > 0',
    'l': 'steering force arm behind the centre of mass l (m), > 0',
    'h': 'drag coefficient h, D = h s^2 (kg/m), > 0',
    'l1': 'centre of pressure ahead of the centre of mass l1 (m), rigid_cop',
    'c0': 'prescribed circle centre c0 [x, y] (m, map frame)',
    'informed': 'ids (1..N) of the vehicles that know c0',
    'law_variant': 'rigid-body steering: practical (thesis) | full (s\', beta\' terms)',
    'cancel_drag_moment': 'cancel the centre-of-pressure drag moment (A.20)',
    'max_thrust': 'thrust limit |T| (N), rigid bodies; 0 = none',
    'max_steering_force': 'steering force limit |F| (N), rigid bodies; 0 = none',
    'max_angular_accel': 'angular acceleration limit (rad/s^2), second_order; 0 = none',
    'max_turn_rate': 'turn-rate command limit (rad/s), first_order; 0 = none',
    'seed': 'random seed of the initial conditions',
    'dt_control': 'control period (s), > 0',
    'dt_integration': 'integration step (s), divides dt_control',
    'duration': 'run length (s)',
    'record_dt': 'recording period (s), a multiple of dt_control',
    'init_box': 'side of the square of random initial positions (m)',
    'init_x': 'initial x of each vehicle (m); empty = random',
    'init_y': 'initial y of each vehicle (m); empty = random',
    'init_theta': 'initial heading of each vehicle (rad); empty = random',
    'init_omega': 'initial yaw rate of each vehicle (rad/s); empty = 0',
    'init_u': 'initial forward speed relative to the flow (m/s); empty = u0',
    'init_v': 'initial sideslip speed relative to the flow (m/s); empty = 0',
}
POSITIVE = ('kappa', 'K_p', 'u0', 'K_f', 'K_P', 'm0', 'I0', 'l', 'h', 'dt_control',
            'dt_integration', 'duration', 'record_dt', 'init_box')
EMPTY_TYPES = {'informed': Parameter.Type.INTEGER_ARRAY}


def _descriptor(name, read_only):
    d = ParameterDescriptor(description=DOCS[name], read_only=read_only)
    if name in POSITIVE or name in scenario.LIMITS:
        d.floating_point_range = [FloatingPointRange(from_value=0.0, to_value=1e9)]
    if name == 'num_vehicles':
        d.integer_range = [IntegerRange(from_value=1, to_value=100_000, step=1)]
    return d


def _ros_value(value):
    return list(value) if isinstance(value, tuple) else value


def declare(node, defaults=Scenario()):
    """Declare every scenario parameter on ``node`` with its descriptor and default."""
    for f in fields(Scenario):
        if f.name == 'warnings':
            continue
        value = _ros_value(getattr(defaults, f.name))
        if f.name == 'K':
            value = -1.0 if node.get_parameter('formation').value == 'parallel' else 1.0
        descriptor = _descriptor(f.name, f.name not in RUNTIME)
        if value == []:
            node.declare_parameter(f.name, EMPTY_TYPES.get(f.name, Parameter.Type.DOUBLE_ARRAY),
                                   descriptor)
        else:
            node.declare_parameter(f.name, value, descriptor)


def _values(node, changes=()):
    values = {name: node.get_parameter_or(name, Parameter(name)).value
              for name in scenario.PARAMETER_NAMES}
    values.update({p.name: p.value for p in changes if p.name in values})
    return {k: ([] if v is None else v) for k, v in values.items()}


def current(node):
    """The validated scenario the node's parameters describe (raises ScenarioError)."""
    return scenario.resolve(_values(node))


def reject_unknown(node, extra=()):
    """Refuse parameter names given to the node (YAML or -p) that it does not know."""
    known = set(scenario.PARAMETER_NAMES) | set(links.PARAMETERS) | set(extra) | {'use_sim_time'}
    unknown = sorted(n for n in node._parameter_overrides
                     if n not in known and not n.startswith('qos_overrides.'))
    if unknown:
        raise ScenarioError(f"unknown parameter(s) {', '.join(repr(u) for u in unknown)}")


def choice(node, name, allowed):
    """The value of a string parameter, refused unless it is one of ``allowed``."""
    value = node.get_parameter(name).value
    if value not in allowed:
        raise ScenarioError(f"parameter {name!r} = {value!r} is invalid: allowed values: "
                            f"{' | '.join(allowed)}")
    return value


def validator(node):
    """An on-set callback that accepts a change only if the scenario stays valid."""
    def on_set(params):
        try:
            scenario.resolve(_values(node, params))
        except ScenarioError as err:
            return SetParametersResult(successful=False, reason=str(err))
        return SetParametersResult(successful=True)
    return on_set


def declare_links(node, names, n, own=0):
    """Declare the link parameters ``names`` (:data:`links.PARAMETERS`); returns their values."""
    values = {}
    for name in names:
        default, low, high, text = links.PARAMETERS[name]
        d = ParameterDescriptor(description=text, read_only=True)
        if isinstance(default, float):
            d.floating_point_range = [FloatingPointRange(from_value=low, to_value=high)]
        elif isinstance(default, int):
            d.integer_range = [IntegerRange(from_value=low, to_value=high, step=1)]
        if default == ():
            node.declare_parameter(name, Parameter.Type.INTEGER_ARRAY, d)
            value = node.get_parameter_or(name, Parameter(name)).value
            values[name] = tuple(value or ())
        else:
            node.declare_parameter(name, default, d)
            values[name] = node.get_parameter(name).value
    return links.check(values, n, own)
