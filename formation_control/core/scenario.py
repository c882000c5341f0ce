"""
Scenarios: one ROS 2 parameter file (``/**: ros__parameters: ...``) drives the offline
simulator and the ROS nodes alike. :func:`load` reads and validates it; every error names the
parameter and the values it may take, before anything runs.
"""
from dataclasses import asdict, dataclass, field, fields, replace
import json
import math
import re

import numpy as np
import yaml

from formation_control.core.models import (MODELS, PARTICLE_MODELS, RIGID_MODELS, ROW_U, ROW_V,
                                           STATE_NAMES)

FORMATIONS = ('parallel', 'circular')
CONTROLLERS = ('first_order', 'backstepping', 'proportional', 'pi')
LAW_VARIANTS = ('practical', 'full')
INIT_ARRAYS = tuple(f'init_{name}' for name in STATE_NAMES)
CHOICES = {'model': MODELS, 'formation': FORMATIONS, 'controller': CONTROLLERS,
           'law_variant': LAW_VARIANTS}


class _Loader(yaml.SafeLoader):
    """YAML 1.2 numbers, as the ROS 2 parameter parser reads them (``1e3`` is a float)."""


_Loader.add_implicit_resolver(
    'tag:yaml.org,2002:float',
    re.compile(r'^[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)[eE][-+]?[0-9]+$'),
    list('-+0123456789.'))


class ScenarioError(ValueError):
    """A scenario parameter is missing, unknown or out of its allowed range."""


@dataclass(frozen=True)
class Scenario:
    """
    Every parameter of a run (SI units, radians); the names follow the thesis.

    Chapter 1-5 (particles): num_vehicles, model, formation, controller, K, kappa, omega0,
    flow [fx, fy] (m/s), K_p. Chapter 6-8 and Appendix A (rigid bodies): u0 (m/s), K_f,
    K_P, K_I, m0 (kg), I0 (kg m^2), l (m), h (kg/m), l1 (m), c0 [x, y] (m), informed
    (vehicle ids 1..N that know c0), law_variant (practical | full), cancel_drag_moment.
    Command limits (0 = none): max_thrust, max_steering_force (N, rigid bodies),
    max_angular_accel (rad/s^2, second order), max_turn_rate (rad/s, first order).
    Run: seed, dt_control and dt_integration (s), duration (s), record_dt (s), init_box (m,
    side of the square of random positions), init_* (explicit initial states, empty = random).
    When K is not given it takes the thesis' value for the formation (-1 parallel, +1 circular).
    """

    num_vehicles: int = 16
    model: str = 'second_order'
    formation: str = 'parallel'
    controller: str = 'backstepping'
    K: float = 0.0
    kappa: float = 5.0
    omega0: float = 1.0
    flow: tuple = (0.0, 0.0)
    K_p: float = 5.0
    u0: float = 1.0
    K_f: float = 1.0
    K_P: float = 10.0
    K_I: float = 15.0
    m0: float = 1.0
    I0: float = 0.1
    l: float = 0.5
    h: float = 5.0
    l1: float = 0.0
    c0: tuple = (0.0, 0.0)
    informed: tuple = ()
    law_variant: str = 'practical'
    cancel_drag_moment: bool = True
    max_thrust: float = 0.0
    max_steering_force: float = 0.0
    max_angular_accel: float = 0.0
    max_turn_rate: float = 0.0
    seed: int = 0
    dt_control: float = 0.02
    dt_integration: float = 0.002
    duration: float = 60.0
    record_dt: float = 0.1
    init_box: float = 10.0
    init_x: tuple = ()
    init_y: tuple = ()
    init_theta: tuple = ()
    init_omega: tuple = ()
    init_u: tuple = ()
    init_v: tuple = ()
    warnings: tuple = field(default=(), compare=False)

    @property
    def flow_c(self):
        return complex(self.flow[0], self.flow[1])

    @property
    def c0_c(self):
        return complex(self.c0[0], self.c0[1])

    @property
    def informed_mask(self):
        """a_k0 of (7.17) as a float array over vehicles 1..N."""
        mask = np.zeros(self.num_vehicles)
        mask[[k - 1 for k in self.informed]] = 1.0
        return mask

    @property
    def substeps(self):
        """Integration steps in one control period, ``dt_control / dt_integration``."""
        return int(round(self.dt_control / self.dt_integration))

    @property
    def periods(self):
        """Control periods in the run, ``duration / dt_control``."""
        return int(round(self.duration / self.dt_control))

    @property
    def record_every(self):
        """Control periods between two recorded samples, ``record_dt / dt_control`` (>= 1)."""
        return max(1, int(round(self.record_dt / self.dt_control)))

    def to_dict(self):
        d = asdict(self)
        d.pop('warnings')
        return {k: list(v) if isinstance(v, tuple) else v for k, v in d.items()}

    def to_json(self):
        return json.dumps(self.to_dict(), sort_keys=True)


LIMITS = ('max_thrust', 'max_steering_force', 'max_angular_accel', 'max_turn_rate')
PARAMETER_NAMES = tuple(f.name for f in fields(Scenario) if f.name != 'warnings')
_DEFAULTS = Scenario()


def _fail(name, value, allowed):
    raise ScenarioError(f"parameter '{name}' = {value!r} is invalid: {allowed}")


def _coerce(name, value):
    default = getattr(_DEFAULTS, name)
    if isinstance(default, bool):
        if not isinstance(value, bool):
            _fail(name, value, 'must be true or false')
        return value
    if isinstance(default, int):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or value != int(value):
            _fail(name, value, 'must be an integer')
        return int(value)
    if isinstance(default, float):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            _fail(name, value, 'must be a number')
        if not math.isfinite(value):
            _fail(name, value, 'must be finite (no NaN or inf)')
        return float(value)
    if isinstance(default, str):
        if not isinstance(value, str):
            _fail(name, value, f"must be one of {' | '.join(CHOICES[name])}")
        return value
    if not isinstance(value, (list, tuple)):
        _fail(name, value, 'must be a list')
    if name == 'informed':
        return tuple(_coerce_int_item(name, v) for v in value)
    out = []
    for v in value:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            _fail(name, value, 'must be a list of finite numbers')
        out.append(float(v))
    return tuple(out)


def _coerce_int_item(name, v):
    if isinstance(v, bool) or not isinstance(v, (int, float)) or v != int(v):
        _fail(name, v, 'must be a list of vehicle ids (integers)')
    return int(v)


def _choice(sc, name):
    if getattr(sc, name) not in CHOICES[name]:
        _fail(name, getattr(sc, name), f"allowed values: {' | '.join(CHOICES[name])}")


def _positive(sc, *names):
    for name in names:
        if not getattr(sc, name) > 0:
            _fail(name, getattr(sc, name), 'must be > 0')


def _check_structure(sc):
    for name in CHOICES:
        _choice(sc, name)
    if sc.num_vehicles < 1:
        _fail('num_vehicles', sc.num_vehicles, 'must be >= 1')
    if (sc.model == 'first_order') != (sc.controller == 'first_order'):
        _fail('controller', sc.controller, "model 'first_order' goes with controller "
              "'first_order' only, and controller 'first_order' with model 'first_order' only")
    for name in ('flow', 'c0'):
        if len(getattr(sc, name)) != 2:
            _fail(name, list(getattr(sc, name)), 'must be a list of 2 numbers [x, y] (m/s or m)')
    for name in INIT_ARRAYS:
        n = len(getattr(sc, name))
        if n not in (0, sc.num_vehicles):
            _fail(name, list(getattr(sc, name)),
                  f'must have num_vehicles = {sc.num_vehicles} entries (or none: random)')
    if sc.model in RIGID_MODELS and any(u <= 0 for u in sc.init_u):
        _fail('init_u', list(sc.init_u), 'rigid bodies start with forward speed u > 0 m/s')
    bad = [k for k in sc.informed if not 1 <= k <= sc.num_vehicles]
    if bad:
        _fail('informed', list(sc.informed), f'vehicle ids must lie in 1..{sc.num_vehicles}')


def _check_gains(sc):
    if sc.formation == 'parallel' and not sc.K < 0:
        _fail('K', sc.K, 'formation parallel needs K < 0 (1.12), (3.7)')
    if sc.formation == 'circular':
        if not sc.K > 0:
            _fail('K', sc.K, 'formation circular needs K > 0 (1.16), (3.14)')
        if sc.omega0 == 0:
            _fail('omega0', sc.omega0, 'formation circular needs omega0 != 0 (radius 1/|omega0|)')
    for name in LIMITS:
        if getattr(sc, name) < 0:
            _fail(name, getattr(sc, name), 'must be >= 0 (0 = no limit)')
    _positive(sc, 'kappa', 'K_p', 'dt_control', 'dt_integration', 'duration', 'record_dt',
              'init_box')
    if sc.dt_integration > sc.dt_control or abs(
            sc.substeps * sc.dt_integration - sc.dt_control) > 1e-9 * sc.dt_control:
        _fail('dt_integration', sc.dt_integration,
              f'must divide dt_control = {sc.dt_control} into a whole number of steps')
    for name in ('duration', 'record_dt'):
        periods = getattr(sc, name) / sc.dt_control
        if periods < 1 - 1e-9 or abs(periods - round(periods)) > 1e-6:
            _fail(name, getattr(sc, name),
                  f'must be a whole number (>= 1) of control periods dt_control = {sc.dt_control}')
    speed = abs(sc.flow_c)
    if sc.model in PARTICLE_MODELS and speed >= 1:
        _fail('flow', list(sc.flow), 'unit-speed particles need |flow| < 1 m/s (1.6)')
    if sc.model in RIGID_MODELS:
        _positive(sc, 'u0', 'K_f', 'K_P', 'm0', 'I0', 'l', 'h')
        if sc.K_I < 0:
            _fail('K_I', sc.K_I, 'must be >= 0')
        if speed >= sc.u0:
            _fail('flow', list(sc.flow), f'rigid bodies need |flow| < u0 = {sc.u0} m/s')


def rhp_zero(sc):
    """Right-half-plane zero u0 sqrt(h l / I0) (rad/s) of tail steering from F to the course."""
    return sc.u0 * math.sqrt(sc.h * sc.l / sc.I0)


def steering_bandwidth(sc):
    """The gain that sets how fast the steering loop acts (rad/s)."""
    return {'backstepping': sc.kappa, 'proportional': sc.K_p, 'pi': sc.K_P}[sc.controller]


def uses_held_force(sc):
    """Whether the steering law reads the course rate from the model with the held force F."""
    return sc.controller == 'pi' or sc.law_variant == 'full'


def held_force_loop_gain(sc):
    """
    Gain ``bandwidth * I0 / (l m0 u0)`` of the one-sample loop F -> beta' -> F of tail steering.

    With the full law, beta' (hence psi') contains F/m0 (7.7); computed from the held force it
    closes a loop through one sample that diverges when this gain nears 1.
    """
    return steering_bandwidth(sc) * sc.I0 / (sc.l * sc.m0 * sc.u0)


def _check_physics(sc):
    """Errata, 'Physical parameters': the conditions the rigid-body laws need."""
    notes = []
    if sc.model in ('rigid', 'rigid_cop'):
        zero, band = rhp_zero(sc), steering_bandwidth(sc)
        if zero < 0.5 * band:
            raise ScenarioError(
                f'tail steering has a right-half-plane zero at u0*sqrt(h*l/I0) = {zero:.3g} '
                f'rad/s, below half the steering bandwidth {band:.3g} rad/s: the law would '
                f'diverge. Raise u0, h or l, or lower I0 or the gain (parameters u0, h, l, I0)')
        if zero < band:
            notes.append(f'right-half-plane zero u0*sqrt(h*l/I0) = {zero:.3g} rad/s lies below '
                         f'the steering bandwidth {band:.3g} rad/s: expect slow, oscillating turns')
        gain = held_force_loop_gain(sc)
        if uses_held_force(sc) and gain >= 0.8:
            raise ScenarioError(
                f'the full law on tail steering closes a one-sample loop through the held force '
                f'with gain bandwidth*I0/(l*m0*u0) = {gain:.3g}, which must stay below 0.8 '
                f"(parameters law_variant, kappa or K_P, I0, l, m0, u0); use law_variant: "
                f"practical, or model: rigid_couple")
    if sc.model in RIGID_MODELS and sc.controller == 'pi':
        if not sc.h * sc.u0 / sc.m0 > sc.K_I / sc.K_P:
            raise ScenarioError(
                f'PI steering (8.24) needs h*u0/m0 = {sc.h * sc.u0 / sc.m0:.3g} > '
                f'K_I/K_P = {sc.K_I / sc.K_P:.3g} (parameters h, u0, m0, K_I, K_P)')
    return tuple(notes)


def resolve(params):
    """Build a validated :class:`Scenario` from a dict of parameter values."""
    unknown = sorted(set(params) - set(PARAMETER_NAMES))
    if unknown:
        raise ScenarioError(f"unknown parameter(s) {', '.join(repr(u) for u in unknown)}; "
                            f"allowed: {', '.join(PARAMETER_NAMES)}")
    values = {k: _coerce(k, v) for k, v in params.items()}
    sc = replace(_DEFAULTS, **values)
    if 'K' not in values:
        sc = replace(sc, K=-1.0 if sc.formation == 'parallel' else 1.0)
    _check_structure(sc)
    _check_gains(sc)
    return replace(sc, warnings=_check_physics(sc))


def parse_override(text):
    """Parse ``name:=value`` (value in YAML syntax, as ``ros2 run -p`` takes it)."""
    if ':=' not in text:
        raise ScenarioError(f"override {text!r} must read name:=value")
    name, value = text.split(':=', 1)
    try:
        return name.strip(), yaml.load(value, Loader=_Loader)
    except yaml.YAMLError as err:
        raise ScenarioError(f'override {text!r}: value is not valid YAML ({err})') from None


def read_params(path):
    """Return the ``/**: ros__parameters`` mapping of a ROS 2 parameter file."""
    try:
        with open(path, encoding='utf-8') as f:
            doc = yaml.load(f, Loader=_Loader)
    except (OSError, yaml.YAMLError) as err:
        raise ScenarioError(f'{path}: cannot read the scenario ({err})') from None
    try:
        params = doc['/**']['ros__parameters'] or {}
    except (TypeError, KeyError):
        params = None
    if not isinstance(params, dict):
        raise ScenarioError(f"{path}: a scenario is a ROS 2 parameter file with a "
                            f"'/**: ros__parameters:' section mapping parameter names to values")
    return params


def load(path, overrides=(), **values):
    """Read, override (``name:=value`` strings, then keyword values) and validate a scenario."""
    params = read_params(path)
    params.update(parse_override(o) for o in overrides)
    params.update({k: v for k, v in values.items() if v is not None})
    return resolve(params)


def initial_state(sc):
    """
    Initial state (6, N): explicit ``init_*`` arrays where given, else the thesis' random draw.

    Positions uniform in the init_box square centred on the origin, headings uniform on the
    circle, turning rates zero, u = u0 (rigid) or 1 (particles), v = 0; seeded by ``seed``.
    """
    n = sc.num_vehicles
    rng = np.random.default_rng(sc.seed)
    half = 0.5 * sc.init_box
    speed = sc.u0 if sc.model in RIGID_MODELS else 1.0
    drawn = (rng.uniform(-half, half, n), rng.uniform(-half, half, n),
             rng.uniform(-np.pi, np.pi, n), np.zeros(n), np.full(n, speed), np.zeros(n))
    X = np.array(drawn)
    for row, name in enumerate(INIT_ARRAYS):
        if getattr(sc, name):
            X[row] = getattr(sc, name)
    if sc.model in PARTICLE_MODELS:
        X[ROW_U], X[ROW_V] = 1.0, 0.0
    return X
