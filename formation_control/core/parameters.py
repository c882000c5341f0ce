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
The scenario parameter table: every parameter of a run, its default, unit and allowed values.

A scenario file is ``/**: ros__parameters: ...`` (:func:`read_params`, :func:`parse_override`,
:func:`find`); :func:`scenario.resolve` validates it, every error naming the parameter and the
values it may take, before anything runs. The parameters, their defaults, units, ranges and
the configurations that read them (:data:`READERS`) are one table, the fields of
:class:`Scenario`: a value set where the run does not read it is refused (:func:`check_read`).
This module imports no physics module: each feature checks its own parameters, and imports
the table, never the reverse.
"""
from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field, fields, replace
import difflib
from functools import cached_property
import json
import math
from os import PathLike
from pathlib import Path
import re
from typing import Any, TYPE_CHECKING

from formation_control.core.errors import refuse as _fail, ScenarioError, UsageError
from formation_control.core.geometry import RealArray
from formation_control.core.vehicles import (MODEL_NAMES, reading, rigid_names, vehicle_model,
                                             VEHICLE_MODELS)
from formation_control.core.vehicles.base import STATE_NAMES
import numpy as np
import yaml

if TYPE_CHECKING:
    from formation_control.core.graphs import Graph

FLOW_MODELS = ('uniform', 'time_varying', 'shear', 'vortex', 'grid')
"""The flowfields (:mod:`flowfields`)."""
MISMATCH_NAMES = ('m0', 'I0', 'h', 'l1', 'thrust', 'steering')
"""The plant-only factors of model mismatch, in the order they are drawn (:mod:`world`)."""
FORMATIONS = ('parallel', 'circular')
"""The formations (:data:`formations.FORMATIONS`)."""
CONTROLLERS = ('first_order', 'backstepping', 'proportional', 'pi')
"""The steering laws (:data:`steering.LAWS`)."""
LAW_VARIANTS = ('practical', 'full')
PATTERNS = ('none', 'splay', 'symmetric')
HOLD_PREDICTIONS = ('midpoint', 'none')
PLANT_BACKENDS = ('native', 'jsbsim')
PATTERN_GAIN = 0.5
"""Default K_m (rad/s) of the symmetric patterns (docs/laws.md, "Symmetric patterns")."""
PATTERN_GAIN_M = 0.1
"""Default ``|K_M|`` (rad/s): K_M = -0.1 gives (3, 12) from seeds 1-3 (-0.05 too, more slowly),
-0.2 leaves unequal clusters from seed 2."""
FLOW_SOURCES = ('known', 'estimated')
FLOW_ESTIMATORS = ('filter', 'observer')
INIT_ARRAYS = tuple(f'init_{name}' for name in STATE_NAMES)
MISMATCH_ARRAYS = tuple(f'mismatch_{name}' for name in MISMATCH_NAMES)


class _Loader(yaml.SafeLoader):
    """YAML 1.2 numbers, as the ROS 2 parameter parser reads them (``1e3`` is a float)."""


_Loader.add_implicit_resolver(
    'tag:yaml.org,2002:float',
    re.compile(r'^[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)[eE][-+]?[0-9]+$'),
    list('-+0123456789.'))


@dataclass(frozen=True)
class Reader:
    """
    A configuration that reads a parameter: the values of one deciding parameter, its axis.

    Attributes
    ----------
    text : str
        The configuration in words, as messages and docs/parameters.md name it.
    axis : str
        The parameter whose value decides it (``plant_backend``, ``model``, ...).
    values : tuple
        The values of ``axis`` that read the parameter.
    shared : str
        Why a shared parameter file often sets the parameter where it is not read: a value is
        then warned about, not refused ('' = refused).
    hint : str
        What the refusal adds.

    """

    text: str
    axis: str
    values: tuple[Any, ...]
    shared: str = ''
    hint: str = ''

    def holds(self, sc: Any) -> bool:
        """Return whether scenario ``sc`` is this configuration (its axis takes one value)."""
        return getattr(sc, self.axis) in self.values


def _models(text: str, test: Callable[[Any], bool]) -> Reader:
    """Return the :class:`Reader` of the vehicle models (the registry's) that pass ``test``."""
    names = tuple(m.name for m in VEHICLE_MODELS.values() if test(m))
    return Reader(text or f"model {' or '.join(names)}", 'model', names)


def model_reader(param: str) -> str:
    """Return the name in :data:`READERS` of the models that read vehicle parameter ``param``."""
    return f"model {' or '.join(reading(param))}"


_GAINS = 'a fleet file often carries the gains of every steering law (-p controller:=...)'
_FORMATION = 'a fleet file is often flown in both formations (-p formation:=...)'
READERS = {r.text: r for r in (
    Reader('plant_backend native', 'plant_backend', ('native',), hint='JSBSim aircraft meet '
           "no mismatch, actuators, gusts or sensors of the native plant's world; their own "
           "turbulence is 'turbulence'"),
    Reader('plant_backend jsbsim', 'plant_backend', ('jsbsim',)),
    _models('rigid bodies', lambda m: m.rigid),
    replace(_models('rigid bodies (their through-water sensor)', lambda m: m.rigid),
            shared="a fleet's sensor suite is often given to particles and rigid bodies alike"),
    _models('', lambda m: m.first_order),
    _models('', lambda m: m.particle and not m.first_order),
    _models('', lambda m: m.particle),
    *(Reader(model_reader(p), 'model', reading(p))
      for p in dict.fromkeys(p for m in VEHICLE_MODELS.values() for p in m.params)),
    Reader('formation circular', 'formation', ('circular',), _FORMATION),
    Reader('controller backstepping', 'controller', ('backstepping',), _GAINS),
    Reader('controller proportional', 'controller', ('proportional',), _GAINS),
    Reader('controller pi', 'controller', ('pi',), _GAINS),
    Reader('flow_source estimated', 'flow_source', ('estimated',)),
    Reader('flow_estimator filter', 'flow_estimator', ('filter',)),
    Reader('flow_estimator observer', 'flow_estimator', ('observer',)),
    *(Reader(f'flow_model {m}', 'flow_model', (m,)) for m in FLOW_MODELS[1:]),
    Reader('position_filter kalman', 'position_filter', ('kalman',)),
    Reader('pattern splay or symmetric', 'pattern', PATTERNS[1:]),
    Reader('pattern symmetric', 'pattern', ('symmetric',)),
    *(Reader(f'graph {g}', 'graph', (g,)) for g in ('circulant', 'random', 'explicit')),
    Reader('safety on', 'safety', ('on',)))}
"""The configurations that read parameters, by their words (:attr:`Spec.reads`): each a set of
values of one axis, its models from the vehicle registry."""


@dataclass(frozen=True)
class Spec:
    """
    What one scenario parameter means and which values it may take.

    Attributes
    ----------
    unit : str
        SI unit of the value ('' for none).
    text : str
        What it is, with the thesis' symbol and equation.
    low, high : float or None
        Range of a number, ``low <= value <= high`` (None: unbounded on that side); checked by
        :func:`scenario.resolve`, and the range of the ROS parameter descriptor.
    above : bool
        The lower end is excluded: ``value > low``.
    zero : str
        What the value 0 means, when it means something special ('no limit').
    models : tuple of str
        The models whose scenarios are checked against the range (the others ignore it).
    choices : tuple of str
        The allowed values of a string.
    rule : str
        Further conditions, in words (checked by :func:`scenario.resolve` in code).
    reads : tuple of str
        The configurations (:data:`READERS`) that read it, all of them; () = every run. A value
        other than the default elsewhere is refused (or warned about) by :func:`check_read`.
    runtime : bool
        A running node accepts a new value (validated with the whole scenario); otherwise the
        parameter is read-only.
    shown_default : str
        The default as the docs show it, when the field's default is a placeholder.

    """

    unit: str
    text: str
    low: float | None = None
    high: float | None = None
    above: bool = False
    zero: str = ''
    models: tuple[str, ...] = MODEL_NAMES
    choices: tuple[str, ...] = ()
    rule: str = ''
    reads: tuple[str, ...] = ()
    runtime: bool = False
    shown_default: str = ''


def _param(default: object, unit: str, text: str, **spec: Any) -> Any:
    """Declare a :class:`Scenario` field with its default and its :class:`Spec`."""
    return field(default=default, metadata={'spec': Spec(unit, text, **spec)})


_POSITIVE = {'low': 0.0, 'above': True}
_RIGID = {'models': rigid_names(), 'reads': ('rigid bodies',)}
_RIGID_POSITIVE = dict(_POSITIVE, **_RIGID)
_MODELS_TEXT = '; '.join(
    f"{kind} {', '.join(m.text for m in VEHICLE_MODELS.values() if m.particle == particle)}"
    for kind, particle in (('particles', True), ('rigid bodies', False)))


def _read_by(name: str) -> dict[str, Any]:
    """Return the Spec keywords of a vehicle parameter > 0 for the models that read it."""
    return dict(_POSITIVE, models=reading(name), reads=(model_reader(name),))


def _derivative(name: str) -> dict[str, Any]:
    """Return the Spec keywords of a hydrodynamic derivative (<= 0) for the models reading it."""
    return {'high': 0.0, 'models': reading(name), 'reads': (model_reader(name),)}


_NATIVE = ('plant_backend native',)
_JSBSIM = ('plant_backend jsbsim',)
_WATER = _NATIVE + ('rigid bodies (their through-water sensor)',)
_CIRCULAR = ('formation circular',)
_PARTICLES = 'model first_order or second_order'
SWITCH = ('off', 'on')
"""The choices of a switch; YAML 1.1 reads a bare ``on`` as true (:func:`coerce`)."""
_ESTIMATED = ('flow_source estimated',)
_FILTER = _ESTIMATED + ('flow_estimator filter',)
_OBSERVER = _ESTIMATED + ('flow_estimator observer',)
_LIMIT = {'low': 0.0, 'zero': 'no limit', 'runtime': True}
_ENTRIES = 'num_vehicles entries, or none'


@dataclass(frozen=True)
class Scenario:
    """
    Every parameter of a run (SI units, radians); the names follow the thesis.

    Each field is declared with its default and its :class:`Spec` (unit, meaning, allowed
    values, whether a running node accepts a change): this is the one parameter table, which
    :data:`PARAMETERS` collects. It drives the validation of :func:`check`, the ROS parameter
    descriptors (``ros/parameters.py``) and ``docs/parameters.md`` (:func:`markdown`,
    ``formation-control params``).
    """

    # Chapters 1-5: the fleet and the particle laws
    num_vehicles: int = _param(16, '', 'number of vehicles N, numbered 1..N', low=1)
    model: str = _param('second_order', '', f'vehicle model: {_MODELS_TEXT}',
                        choices=MODEL_NAMES)
    formation: str = _param('parallel', '', 'formation: parallel (1.12) or circular (1.16)',
                            choices=FORMATIONS)
    controller: str = _param(
        'backstepping', '', 'steering law: first_order (1.12), (1.16); backstepping (3.7), '
        '(3.14), (7.12); proportional (5.5); pi (8.24)', choices=CONTROLLERS,
        rule='first_order goes with model first_order, and only with it')
    K: float = _param(0.0, '1/s', 'formation gain K',
                      shown_default='-1.0 parallel, 1.0 circular',
                      rule='K < 0 for parallel (1.12), (3.7); K > 0 for circular (1.16), (3.14)',
                      runtime=True)
    kappa: float = _param(5.0, '1/s', 'backstepping gain kappa (3.7), (3.14)', runtime=True,
                          **_POSITIVE, reads=('controller backstepping',))
    omega0: float = _param(1.0, 'rad/m', 'circle curvature omega0: radius 1/|omega0|',
                           rule='!= 0 for circular', runtime=True, reads=_CIRCULAR)
    flow: tuple = _param((0.0, 0.0), 'm/s', 'uniform steady flow [fx, fy], map frame (1.4); '
                         'the background of the other flow models',
                         rule='max |f| < 1 for particles (1.6), < u0 for rigid bodies')
    flow_model: str = _param('uniform', '', 'flowfield: uniform (the thesis), time_varying '
                             '(flow plus a rotating part), shear (layer along x), vortex '
                             '(Rankine) or grid (file, bilinear); see core/flowfields.py',
                             choices=FLOW_MODELS)
    flow_amplitude: float = _param(0.0, 'm/s', 'time_varying: amplitude A of the flow part '
                                   'that turns once per flow_period', low=0.0,
                                   reads=('flow_model time_varying',))
    flow_period: float = _param(600.0, 's', 'time_varying: period T of that turn', **_POSITIVE,
                                reads=('flow_model time_varying',))
    flow_shear: float = _param(0.0, '1/s', 'shear: gradient G, fx = flow_x + G clip(y, -w, w)',
                               reads=('flow_model shear',))
    flow_shear_width: float = _param(5.0, 'm', 'shear: half-width w of the shear layer',
                                     **_POSITIVE, reads=('flow_model shear',))
    flow_center: tuple = _param((0.0, 0.0), 'm', 'vortex: centre [x, y], map frame',
                                reads=('flow_model vortex',))
    flow_radius: float = _param(2.0, 'm', 'vortex: core radius R', **_POSITIVE,
                                reads=('flow_model vortex',))
    flow_circulation: float = _param(0.0, 'm^2/s', 'vortex: circulation Gamma (> 0 counter-'
                                     'clockwise); peak speed Gamma / (2 pi R) at r = R',
                                     reads=('flow_model vortex',))
    flow_grid_file: str = _param('', '', 'grid: .npz (x, y, fx, fy) or .csv (x,y,fx,fy) file of '
                                 'the flow', rule='an existing file with finite values',
                                 reads=('flow_model grid',))
    flow_source: str = _param('known', '', 'where a vehicle gets the flow: known (the flow '
                              'topic: the local flow) or estimated (from its own ground and '
                              'through-water velocities, no flow topic)', choices=FLOW_SOURCES)
    flow_estimator: str = _param('filter', '', "estimated: filter fhat' = lambda_f (v_ground - "
                                 "v_rel - fhat), or observer from the position only (rhat' = "
                                 "v_rel + fhat + l1 (r - rhat), fhat' = l2 (r - rhat))",
                                 choices=FLOW_ESTIMATORS, reads=_ESTIMATED)
    flow_gain: float = _param(1.0, '1/s', 'filter: estimator bandwidth lambda_f', runtime=True,
                              **_POSITIVE, reads=_FILTER)
    flow_gain_from_noise: bool = _param(False, '', 'filter: take the bandwidth that minimises the '
                                        'error in the gust with the sensor noise instead of '
                                        'flow_gain (estimation.best_gain; with position_filter: '
                                        'kalman, navigation.best_flow_gain)', reads=_FILTER)
    flow_observer_l1: float = _param(2.0, '1/s', 'observer: position gain l1', runtime=True,
                                     **_POSITIVE, reads=_OBSERVER)
    flow_observer_l2: float = _param(1.0, '1/s^2', 'observer: flow gain l2', runtime=True,
                                     **_POSITIVE, reads=_OBSERVER)
    flow_consensus: float = _param(0.0, '1/s', 'estimated: gain of the consensus term that pulls '
                                   "each estimate toward its neighbours' (uniform flows)",
                                   low=0.0, zero='none', runtime=True, reads=_ESTIMATED)
    K_p: float = _param(5.0, '1/s', 'proportional steering gain K_p (5.5)', runtime=True,
                        **_POSITIVE, reads=('controller proportional',))
    # Chapters 6-8 and Appendix A: rigid bodies
    u0: float = _param(1.0, 'm/s', 'forward speed u0 relative to the flow that the thrust holds '
                       '(7.1)', runtime=True, **_RIGID_POSITIVE)
    K_f: float = _param(1.0, '1/s', "thrust gain K_f: u' = K_f (u0 - u) (7.1), (8.10)",
                        runtime=True, **_RIGID_POSITIVE)
    K_P: float = _param(10.0, '1/s', 'PI steering proportional gain K_P (8.24)', runtime=True,
                        models=rigid_names(), **_POSITIVE, reads=('rigid bodies', 'controller pi'))
    K_I: float = _param(15.0, '1/s^2', 'PI steering integral gain K_I (8.24)', runtime=True,
                        low=0.0, models=rigid_names(), reads=('rigid bodies', 'controller pi'))
    m0: float = _param(1.0, 'kg', 'mass m0 (6.15)', **_read_by('m0'))
    I0: float = _param(0.1, 'kg m^2', 'yaw moment of inertia I0 (6.15)', **_read_by('I0'))
    l: float = _param(0.5, 'm', 'arm l of the steering force behind the centre of mass (6.14)',
                      **_read_by('l'))
    h: float = _param(5.0, 'kg/m', 'drag coefficient h: drag D = h s^2 (6.15)', **_read_by('h'))
    l1: float = _param(0.0, 'm', 'centre of pressure l1 ahead of the centre of mass, rigid_cop '
                       '(A.1)', reads=(model_reader('l1'),))
    # A marine surface vessel (core/vehicles/vessel.py): CyberShip II (Skjetne et al. 2005)
    X_udot: float = _param(-2.0, 'kg', 'vessel: surge added mass X_udot',
                           **_derivative('X_udot'))
    Y_vdot: float = _param(-10.0, 'kg', 'vessel: sway added mass Y_vdot',
                           **_derivative('Y_vdot'))
    N_rdot: float = _param(-1.0, 'kg m^2', 'vessel: yaw added inertia N_rdot',
                           **_derivative('N_rdot'))
    X_u: float = _param(-0.7225, 'kg/s', 'vessel: linear surge damping X_u',
                        **_derivative('X_u'))
    X_uu: float = _param(-1.3274, 'kg/m', 'vessel: quadratic surge damping X_|u|u',
                         **_derivative('X_uu'))
    Y_v: float = _param(-0.8612, 'kg/s', 'vessel: linear sway damping Y_v',
                        **_derivative('Y_v'))
    Y_vv: float = _param(-36.2823, 'kg/m', 'vessel: quadratic sway damping Y_|v|v',
                         **_derivative('Y_vv'))
    N_r: float = _param(-1.9, 'kg m^2/s', 'vessel: linear yaw damping N_r',
                        **_derivative('N_r'))
    N_rr: float = _param(-0.75, 'kg m^2', 'vessel: quadratic yaw damping N_|r|r',
                         **_derivative('N_rr'))
    # Real flight dynamics: JSBSim aircraft (core/aircraft.py, docs/aircraft.md)
    plant_backend: str = _param('native', '', 'what integrates the vehicles: native (the '
                                "model's equations, core/models.py) or jsbsim (each vehicle a "
                                'JSBSim aircraft flying the particle laws at its airspeed)',
                                choices=PLANT_BACKENDS, rule='jsbsim: model first_order or '
                                'second_order; the rigid-body parameters are left out')
    jsbsim_aircraft: str = _param('c172x', '', 'jsbsim: the aircraft model (gliders: sgs233, '
                                  'sgs126, minisgs descend)', rule='an aircraft of the jsbsim '
                                  'package that trims at altitude and airspeed', reads=_JSBSIM)
    altitude: float = _param(900.0, 'm', 'jsbsim: initial altitude above the ground (held by '
                             'powered aircraft)', **_POSITIVE, reads=_JSBSIM)
    airspeed: float = _param(51.0, 'm/s', 'jsbsim: true airspeed V held; the particle laws '
                             'fly with it as the vehicle speed', rule='> max |f|', **_POSITIVE,
                             reads=_JSBSIM)
    min_airspeed: float = _param(0.0, 'm/s', 'jsbsim: lowest airspeed demand the autopilot '
                                 'takes', low=0.0, zero='no limit', rule='<= airspeed',
                                 reads=_JSBSIM)
    max_airspeed: float = _param(0.0, 'm/s', 'jsbsim: highest airspeed demand the autopilot '
                                 'takes', low=0.0, zero='no limit', rule='>= airspeed',
                                 reads=_JSBSIM)
    bank_limit: float = _param(0.5236, 'rad', 'jsbsim: bank limit of the autopilot (bank from '
                               'tan(phi) = V omega / g)', rule='above the bank the circle '
                               'needs, tan(phi) = V^2 / (g R) in still air', high=1.2,
                               **_POSITIVE, reads=_JSBSIM)
    roll_rate_limit: float = _param(0.5, 'rad/s', 'jsbsim: roll-rate limit of the autopilot',
                                    **_POSITIVE, reads=_JSBSIM)
    turn_lag: float = _param(0.0, 's', 'jsbsim: time constant of the bank hold; the '
                             'second-order turn-rate demand is omega + turn_lag a', low=0.0,
                             zero="the aircraft's own, identified from its turn response "
                             '(kappa at its default then 1/turn_lag)', reads=_JSBSIM)
    turbulence: int = _param(0, '', 'jsbsim: MIL-F-8785C turbulence severity (1-2 light, 3-4 '
                             'moderate, 5-7 severe)', low=0, high=7, zero='none', reads=_JSBSIM)
    turbulence_seed: int = _param(0, '', 'jsbsim: seed of the turbulence (per aircraft: seed '
                                  '65537 + index)', low=0, reads=_JSBSIM)
    geodetic_origin: tuple = _param((38.99, -76.94), 'deg', 'jsbsim: latitude, longitude of the '
                                    'map origin (the map frame is the tangent plane there)',
                                    rule='latitude within +-80', reads=_JSBSIM)
    c0: tuple = _param((0.0, 0.0), 'm', 'prescribed circle centre c0 [x, y], map frame (7.17)',
                       runtime=True, reads=_CIRCULAR)
    informed: tuple = _param((), '', 'ids of the vehicles that know c0 (a_k0 = 1 in (7.17)); '
                             'empty = none', rule='ids in 1..num_vehicles', runtime=True,
                             reads=_CIRCULAR)
    law_variant: str = _param(
        'practical', '', "rigid-body steering (7.12): practical (the thesis' simulations) or "
        "full (adds s' and beta' computed from the model)", choices=LAW_VARIANTS,
        reads=('rigid bodies',))
    cancel_drag_moment: bool = _param(True, '', 'cancel the drag moment of the centre of '
                                      'pressure, rigid_cop (A.20)', reads=(model_reader('l1'),))
    # Symmetric circular patterns (Sepulchre, Paley and Leonard 2007), flow-free
    pattern: str = _param('none', '', 'places on the circle: none (free), splay (evenly '
                          'spaced) or symmetric (pattern_M clusters of N/M evenly spaced)',
                          choices=PATTERNS, rule='formation circular and no flow', reads=_CIRCULAR)
    pattern_M: int = _param(2, '', 'symmetric: the number of clusters M',
                            rule='2 <= M < num_vehicles and M divides num_vehicles',
                            reads=('pattern symmetric',))
    pattern_gain: float = _param(PATTERN_GAIN, 'rad/s', 'gain K_m > 0 of the phase potential '
                                 '(m = 1..floor(N/2) splay, m < M symmetric); the slot gain',
                                 **_POSITIVE, reads=('pattern splay or symmetric',))
    pattern_gain_M: float = _param(PATTERN_GAIN_M, 'rad/s', 'symmetric moments: |K_M| of the '
                                   'clustering term, K_M = -pattern_gain_M (too large: unequal '
                                   'clusters)', **_POSITIVE, reads=('pattern symmetric',))
    pattern_form: str = _param('auto', '', 'moments (fleet means of e^{i m phase}) or slots '
                               '(synchronise phase_k - beta_k over the graph, beta_k from the '
                               'id k); auto = moments on the complete graph, slots otherwise',
                               choices=('auto', 'moments', 'slots'),
                               rule='moments only on the complete graph with default graph_nu',
                               reads=('pattern splay or symmetric',))
    # Communication graph (Sepulchre, Paley and Leonard 2008: limited communication)
    graph: str = _param('complete', '', 'who hears whom: complete (all-to-all, the thesis), '
                        'ring, circulant, random (connected) or explicit',
                        choices=('complete', 'ring', 'circulant', 'random', 'explicit'),
                        rule='undirected and connected')
    graph_offsets: tuple = _param((1,), '', 'circulant: vehicle k hears k +- d for each offset d',
                                  rule='distinct integers 1 <= d < num_vehicles/2',
                                  reads=('graph circulant',))
    graph_degree: float = _param(4.0, '', 'random: the mean number of neighbours',
                                 rule='2 <= degree <= num_vehicles - 1', reads=('graph random',))
    graph_seed: int = _param(0, '', 'random: the seed of the graph', low=0,
                             reads=('graph random',))
    graph_edges: tuple = _param((), '', 'explicit: undirected edges as a flat list of 1-based id '
                                'pairs [i1, j1, i2, j2, ...]', rule='ids in 1..num_vehicles, no '
                                'self or repeated edges', reads=('graph explicit',))
    graph_nu: float = _param(0.0, '', 'the constant nu of the Laplacian laws (sums over '
                             'neighbours divided by nu)', low=0.0,
                             zero='max degree + 1 (num_vehicles on the complete graph: the '
                             'all-to-all laws)')
    # Command limits
    max_thrust: float = _param(0.0, 'N', 'thrust limit |T|, rigid bodies', **_LIMIT,
                               reads=('rigid bodies',))
    max_steering_force: float = _param(0.0, 'N', 'steering-force limit |F|, rigid bodies',
                                       **_LIMIT, reads=('rigid bodies',))
    max_angular_accel: float = _param(0.0, 'rad/s^2', 'angular-acceleration command limit, '
                                      'second_order', **_LIMIT, reads=('model second_order',))
    max_turn_rate: float = _param(0.0, 'rad/s', 'turn-rate command limit, first_order',
                                  **_LIMIT, reads=('model first_order',))
    # Separation (core/separation.py, docs/separation.md)
    d_min: float = _param(0.0, 'm', 'separation distance: two vehicles closer than this '
                          'horizontally are too close (aircraft: and closer than '
                          'd_min_vertical in altitude)', low=0.0,
                          zero="derived: the vehicle's size (its length; an aircraft's "
                          'wingspan)', rule='a splay must space its vehicles at least this far '
                          '(chord 2 sin(pi/N) / |omega0|)')
    d_min_vertical: float = _param(0.0, 'm', 'jsbsim: vertical separation, the half-height of '
                                   "the protected volume (TCAS' ALIM)", low=0.0, zero='d_min',
                                   reads=_JSBSIM)
    sensing_range: float = _param(0.0, 'm', 'range within which a vehicle hears every other '
                                  'vehicle (the safety layer)', low=0.0,
                                  zero='derived: d_min + twice the top ground speed over one '
                                  'time constant of the formation law', rule='>= d_min')
    # The safety layer (core/safety.py, docs/separation.md)
    safety: str = _param('off', '', 'decentralized safety layer between the law and the '
                         'actuators: each vehicle filters its turn rate against every vehicle '
                         'within sensing_range (turning-circle barrier, closed form)',
                         choices=SWITCH, rule='not for aircraft, a flow that is not '
                         'uniform or the pi law', reads=(_PARTICLES,))
    safety_turn_rate: float = _param(0.0, 'rad/s', 'u_max of the safety layer: the filtered '
                                     'turn rate lies in [-u_max, u_max], the backup circle has '
                                     'radius V / u_max', low=0.0,
                                     zero="derived: first_order's max_turn_rate where set, "
                                     'else V / d_min', rule='> V |omega0| (circular); <= '
                                     'max_turn_rate (first_order)', reads=('safety on',))
    safety_gain: float = _param(0.0, '1/s', "alpha of the safety layer's barrier condition "
                                "h' >= -alpha h", low=0.0, zero='derived: 2 u_max',
                                reads=('safety on',))
    # The run
    seed: int = _param(0, '', 'random seed of the initial state', low=0)
    dt_control: float = _param(0.02, 's', 'control period: each command is held this long',
                               **_POSITIVE)
    dt_integration: float = _param(0.005, 's', 'RK4 integration step', rule='divides '
                                   'dt_control into a whole number of steps', **_POSITIVE)
    hold_prediction: str = _param(
        'midpoint', '', 'the state each held command is computed for: midpoint (predicted to '
        'the middle of its hold, errors of order dt_control^2) or none (the sampled state, the '
        "thesis' zero-order hold, errors of order dt_control)", choices=HOLD_PREDICTIONS)
    duration: float = _param(60.0, 's', 'length of the run',
                             rule='a whole number of dt_control', **_POSITIVE)
    record_dt: float = _param(0.1, 's', 'recording period (simulator, plant and bags)',
                              rule='a whole number of dt_control', **_POSITIVE)
    init_box: float = _param(10.0, 'm', 'side of the square, centred on the origin, of the '
                             'random initial positions', **_POSITIVE)
    init_x: tuple = _param((), 'm', 'initial x of each vehicle; empty = random', rule=_ENTRIES)
    init_y: tuple = _param((), 'm', 'initial y of each vehicle; empty = random', rule=_ENTRIES)
    init_theta: tuple = _param((), 'rad', 'initial heading theta of each vehicle; empty = '
                               'random', rule=_ENTRIES)
    init_omega: tuple = _param((), 'rad/s', 'initial yaw rate of each vehicle; empty = 0',
                               rule=_ENTRIES)
    init_u: tuple = _param((), 'm/s', 'initial forward speed relative to the flow; empty = u0 '
                           '(particles: always 1)', rule=f'> 0 for rigid bodies; {_ENTRIES}')
    init_v: tuple = _param((), 'm/s', 'initial sideslip speed relative to the flow; empty = 0 '
                           '(particles: always 0)', rule=_ENTRIES)
    # The world a real fleet meets (core/world.py): off by default, the plant's only
    world_seed: int = _param(0, '', "seed of the world's random draws (mismatch, gusts), with the "
                             "run's seed and each vehicle's id", low=0)
    mismatch: float = _param(0.0, '', "spread of the model mismatch: each vehicle's true m0, I0, "
                             'h, l1, thrust and steering effectiveness are the nominal times a '
                             'factor drawn uniform in [1 - mismatch, 1 + mismatch]; the '
                             'controllers keep the nominal', low=0.0, zero='none',
                             rule='< 1 (a factor 1 - mismatch <= 0 would make a mass, inertia '
                             'or drag non-positive)', reads=_NATIVE)
    mismatch_m0: tuple = _param((), '', "true-to-nominal factor of each vehicle's mass m0 (wins "
                                'over mismatch); empty = drawn', rule=f'> 0; {_ENTRIES}',
                                reads=_NATIVE + (model_reader('m0'),))
    mismatch_I0: tuple = _param((), '', "factor of each vehicle's inertia I0; empty = drawn",
                                rule=f'> 0; {_ENTRIES}', reads=_NATIVE + (model_reader('I0'),))
    mismatch_h: tuple = _param((), '', "factor of each vehicle's drag h; empty = drawn",
                               rule=f'> 0; {_ENTRIES}', reads=_NATIVE + (model_reader('h'),))
    mismatch_l1: tuple = _param((), '', "factor of each vehicle's drag-moment lever l1 "
                                '(rigid_cop); empty = drawn', rule=_ENTRIES,
                                reads=_NATIVE + (model_reader('l1'),))
    mismatch_thrust: tuple = _param((), '', "factor of each vehicle's thrust effectiveness "
                                    '(applied T = factor * command); empty = drawn',
                                    rule=f'> 0; {_ENTRIES}', reads=_NATIVE + ('rigid bodies',))
    mismatch_steering: tuple = _param((), '', "factor of each vehicle's steering effectiveness "
                                      "(force F, or a particle's turn input); empty = drawn",
                                      rule=f'> 0; {_ENTRIES}', reads=_NATIVE)
    actuator_lag: float = _param(0.0, 's', 'time constant tau of the first-order lag from each '
                                 'command to the applied input', low=0.0, zero='none',
                                 rule="below the formation's limit: the steering loop's, on "
                                 "a circle also the centre loop's (refused from it, warned "
                                 'from half of it)', reads=_NATIVE)
    max_thrust_rate: float = _param(0.0, 'N/s', 'rate limit of the applied thrust, rigid bodies',
                                    low=0.0, zero='no limit', models=rigid_names(),
                                    reads=_NATIVE + ('rigid bodies',))
    max_steering_rate: float = _param(0.0, 'N/s', 'rate limit of the applied steering input: N/s '
                                      'rigid bodies, rad/s^3 second_order, rad/s^2 first_order',
                                      low=0.0, zero='no limit', reads=_NATIVE)
    anti_windup: bool = _param(False, '', 'pi: hold the integrator of a vehicle whose steering '
                               'command sits on its limit (conditional integration)',
                               reads=('controller pi',))
    gust_intensity: float = _param(0.0, 'm/s', 'standard deviation sigma of the gust per axis: a '
                                   'Gauss-Markov flow component of each vehicle, on top of the '
                                   'flowfield, unknown to the vehicles', low=0.0, zero='none',
                                   reads=_NATIVE)
    gust_time: float = _param(10.0, 's', 'correlation time T of the gust (a correlation length L '
                              'met at speed V: T = L / V)', **_POSITIVE, reads=_NATIVE)
    gnss_sigma: float = _param(0.0, 'm', 'sensors: position-fix noise sigma per axis (GNSS)',
                               low=0.0, zero='none', reads=_NATIVE)
    gnss_rate: float = _param(0.0, 'Hz', 'sensors: position fixes per second, the last held '
                              'between fixes', low=0.0, zero='every control step',
                              rule='at most 1 / dt_control, a whole number of periods apart',
                              reads=_NATIVE)
    heading_sigma: float = _param(0.0, 'rad', 'sensors: heading noise sigma (compass)', low=0.0,
                                  zero='none', reads=_NATIVE)
    heading_bias: float = _param(0.0, 'rad', 'sensors: heading bias (compass), every vehicle',
                                 reads=_NATIVE)
    yaw_rate_sigma: float = _param(0.0, 'rad/s', 'sensors: yaw-rate noise sigma (gyro)',
                                   low=0.0, zero='none', reads=_NATIVE)
    velocity_sigma: float = _param(0.0, 'm/s', 'sensors: ground-velocity noise sigma per axis '
                                   '(GNSS Doppler), map frame', low=0.0, zero='none',
                                   reads=_NATIVE)
    water_sigma: float = _param(0.0, 'm/s', 'sensors: through-water velocity noise sigma per '
                                'body axis (DVL, pitot), rigid bodies', low=0.0, zero='none',
                                reads=_WATER)
    water_bias: float = _param(0.0, 'm/s', 'sensors: through-water speed bias along body x, '
                               'rigid bodies', reads=_WATER)
    sensor_latency: float = _param(0.0, 's', 'sensors: how late every measurement arrives',
                                   low=0.0, zero='none', rule='a whole number of dt_control',
                                   reads=_NATIVE)
    position_filter: str = _param('none', '', "a vehicle's position between and across fixes: "
                                  'none (its latest fix) or kalman (predicted by its own model '
                                  'and held command, corrected at each fix with the steady-state '
                                  'gain of the noise; its filtered ground and through-water '
                                  'velocities feed the flow estimator; core/navigation.py)',
                                  choices=('none', 'kalman'), reads=_NATIVE)
    filter_drift: float = _param(0.05, 'm/s', 'kalman: the velocity error the filter allows its '
                                 'dead reckoning over a fix interval (gusts, mismatch), and its '
                                 'velocities over gust_time',
                                 **_POSITIVE, reads=('position_filter kalman',))
    convergence: str = _param('auto', '', "the convergence test: exact (the thesis' "
                              'tolerances), band (every steady-state error within its band) or '
                              'auto (band when mismatch, actuators, gusts or sensors are on); '
                              'either holds at every sample of the last hold_window',
                              choices=('auto', 'exact', 'band'))
    settle_window: float = _param(10.0, 's', 'band: the last window the steady-state errors are '
                                  'taken over (the whole run if it is shorter); the shortest '
                                  'hold_window', **_POSITIVE)
    band_spread: float = _param(0.2, 'm', 'band: the centre spread max |c_k - mean c|, circular',
                                **_POSITIVE)
    band_radius: float = _param(0.05, '', 'band: the relative radius error, circular',
                                **_POSITIVE)
    band_course: float = _param(0.05, 'rad', 'band: the course spread max |phase_k - arg p|, '
                                'parallel', **_POSITIVE)
    band_speed: float = _param(0.05, 'm/s', 'band: the speed error mean |u - u0|, rigid bodies',
                               **_POSITIVE)
    hold_window: float = _param(0.0, 's', "converged 'yes': how long every condition must "
                                'have held, at every recorded sample, to the end of the run '
                                '(the band test: at least its settle_window)', low=0.0,
                                zero='derived: one cycle of the formation law and of the '
                                'steering loop, at least 10 recorded samples (docs/laws.md)')
    warnings: tuple[str, ...] = field(default=(), compare=False)

    @property
    def flow_c(self) -> complex:
        """Return the flow as a complex number ``fx + i fy`` (m/s)."""
        return complex(self.flow[0], self.flow[1])

    @property
    def c0_c(self) -> complex:
        """Return the prescribed centre as a complex number (m)."""
        return complex(self.c0[0], self.c0[1])

    @cached_property
    def comm_graph(self) -> Graph:
        """Return the communication graph (:func:`graphs.build`; validated by :func:`check`)."""
        from formation_control.core import graphs
        return graphs.build(self.num_vehicles, self.graph, self.graph_offsets, self.graph_degree,
                            self.graph_seed, self.graph_edges, self.graph_nu)

    @property
    def all_to_all(self) -> bool:
        """Return whether the laws take their all-to-all form (complete graph, default nu)."""
        return self.graph == 'complete' and self.graph_nu == 0

    @property
    def pattern_slots(self) -> bool:
        """Return whether the pattern takes its slot form (pattern_form, or auto on a graph)."""
        return self.pattern_form == 'slots' or (self.pattern_form == 'auto'
                                                and not self.all_to_all)

    @property
    def pattern_offsets(self) -> RealArray:
        """
        Return the slot offsets beta_k (rad), (N,) over vehicles 1..N.

        Splay ``2 pi (k - 1) / N``, symmetric ``2 pi ((k - 1) mod M) / M``: fixed by the id and
        the fleet size, so a vehicle that drops out leaves its slot empty.
        """
        k = np.arange(self.num_vehicles)
        if self.pattern == 'symmetric':
            return 2.0 * np.pi * (k % self.pattern_M) / self.pattern_M
        return 2.0 * np.pi * k / self.num_vehicles

    @property
    def pattern_gains(self) -> tuple[float, ...]:
        """Return the moment gains (K_1, K_2, ...) (rad/s) of the pattern; () for none."""
        if self.pattern == 'splay':
            return (self.pattern_gain,) * (self.num_vehicles // 2)
        if self.pattern == 'symmetric':
            return (self.pattern_gain,) * (self.pattern_M - 1) + (-self.pattern_gain_M,)
        return ()

    @property
    def informed_mask(self) -> RealArray:
        """Return a_k0 of (7.17), (N,) floats over vehicles 1..N: 1 for the informed ones."""
        mask = np.zeros(self.num_vehicles)
        mask[[k - 1 for k in self.informed]] = 1.0
        return mask

    @property
    def substeps(self) -> int:
        """Integration steps in one control period, ``dt_control / dt_integration``."""
        return int(round(self.dt_control / self.dt_integration))

    @property
    def command_lead(self) -> float:
        """How far ahead of its sample a command's state is predicted (s): half a period or 0."""
        return 0.5 * self.dt_control if self.hold_prediction == 'midpoint' else 0.0

    @property
    def periods(self) -> int:
        """Control periods in the run, ``duration / dt_control``."""
        return int(round(self.duration / self.dt_control))

    @property
    def record_every(self) -> int:
        """Control periods between two recorded samples, ``record_dt / dt_control`` (>= 1)."""
        return max(1, int(round(self.record_dt / self.dt_control)))

    def to_dict(self) -> dict[str, Any]:
        """Return the parameters as a dict of plain values (lists for the tuples)."""
        d = asdict(self)
        d.pop('warnings')
        return {k: list(v) if isinstance(v, tuple) else v for k, v in d.items()}

    def to_json(self) -> str:
        """Return :meth:`to_dict` as JSON (``/formation/scenario``, the ``.npz`` params)."""
        return json.dumps(self.to_dict(), sort_keys=True)


PARAMETERS = {f.name: f.metadata['spec'] for f in fields(Scenario) if 'spec' in f.metadata}
"""The parameter table, name -> :class:`Spec`, in the order of :class:`Scenario`."""
PARAMETER_NAMES = tuple(PARAMETERS)
CHOICES = {name: spec.choices for name, spec in PARAMETERS.items() if spec.choices}
RUNTIME = tuple(name for name, spec in PARAMETERS.items() if spec.runtime)
"""The parameters a running node accepts changes of; every other one is read-only."""
DEFAULTS = Scenario()


def unknown(names: Iterable[str], known: Iterable[str] = PARAMETERS) -> str:
    """
    Return the refusal of parameter ``names`` that are not ``known``, each with its near miss.

    One short line: ``unknown parameter 'kapa' (did you mean 'kappa'?); every parameter:
    formation-control params (docs/parameters.md)``.
    """
    known = list(known)
    shown = []
    for name in sorted(names):
        near = (difflib.get_close_matches(name, known, n=1, cutoff=0.6)
                or difflib.get_close_matches(name.lower(), [k.lower() for k in known], n=1,
                                             cutoff=0.6))
        match = next((k for k in known if near and k.lower() == near[0].lower()), None)
        shown.append(f'{name!r}' + (f' (did you mean {match!r}?)' if match else ''))
    return (f"unknown parameter{'s' if len(shown) > 1 else ''} {', '.join(shown)}; every "
            'parameter: formation-control params (docs/parameters.md)')


def coerce(name: str, value: Any) -> Any:
    """Return ``value`` as the type of parameter ``name``'s default, or refuse it naming both."""
    default = getattr(DEFAULTS, name)
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
        if isinstance(value, bool) and CHOICES.get(name) == SWITCH:
            return SWITCH[value]                 # YAML 1.1 reads a bare on / off as a bool
        if not isinstance(value, str):
            _fail(name, value, f"must be one of {' | '.join(CHOICES[name])}" if name in CHOICES
                  else 'must be a string')
        return value
    if not isinstance(value, (list, tuple)):
        _fail(name, value, 'must be a list')
    if name in ('informed', 'graph_offsets', 'graph_edges'):
        return tuple(_coerce_int_item(name, v, value) for v in value)
    out = []
    for v in value:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            _fail(name, value, 'must be a list of finite numbers')
        out.append(float(v))
    return tuple(out)


def _coerce_int_item(name: str, v: Any, value: Any) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or v != int(v):
        flat = ' (a flat list [i1, j1, i2, j2, ...], not pairs)' if isinstance(
            v, (list, tuple)) else ''
        _fail(name, list(value), f'must be a list of vehicle ids (integers){flat}'
              if name != 'graph_offsets' else 'must be a list of integers')
    return int(v)


def check_choice(sc: Scenario, name: str) -> None:
    """Refuse a value of parameter ``name`` outside its choices, listing them."""
    if getattr(sc, name) not in CHOICES[name]:
        _fail(name, getattr(sc, name), f"allowed values: {' | '.join(CHOICES[name])}")


def _bounds(spec: Spec) -> str:
    """Return the range of a :class:`Spec` in words: '> 0', '>= 0 (0 = no limit)' or ''."""
    parts = []
    if spec.low is not None:
        parts.append(f"{'>' if spec.above else '>='} {spec.low:g}")
    if spec.high is not None:
        parts.append(f'<= {spec.high:g}')
    text = ' and '.join(parts)
    return f'{text} (0 = {spec.zero})' if text and spec.zero else text


def describe(name: str) -> str:
    """Return what parameter ``name`` is, with its unit: 'backstepping gain kappa ... [1/s]'."""
    spec = PARAMETERS[name]
    return f'{spec.text} [{spec.unit}]' if spec.unit else spec.text


def allowed(name: str) -> str:
    """Return the values parameter ``name`` may take, in words ('' when any value goes)."""
    spec = PARAMETERS[name]
    parts = [' | '.join(spec.choices)] if spec.choices else []
    bounds = _bounds(spec)
    if bounds:
        where = 'rigid bodies' if spec.models == rigid_names() else ', '.join(spec.models)
        parts.append(bounds if spec.models == MODEL_NAMES else f'{bounds} for {where}')
    if spec.rule:
        parts.append(spec.rule)
    return '; '.join(parts)


def read_by(name: str) -> str:
    """Return the configurations that read parameter ``name`` in words ('every run' for all)."""
    readers = [READERS[r] for r in PARAMETERS[name].reads]
    return ' and '.join(f"{r.text}{' (else warned)' if r.shared else ''}"
                        for r in readers) or 'every run'


def _shown(name: str) -> str:
    """Return the default of parameter ``name`` as the docs show it."""
    spec, value = PARAMETERS[name], getattr(DEFAULTS, name)
    if spec.shown_default:
        return spec.shown_default
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, str):
        return f'`{value}`'
    return str(list(value)) if isinstance(value, tuple) else str(value)


MARKDOWN_HEAD = """\
# Scenario parameters

<!-- Generated from the table in formation_control/core/parameters.py by
     `formation-control params > docs/parameters.md`; do not edit by hand:
     test/unit/test_scenario.py checks that this file equals the generated text. -->

A scenario is a ROS 2 parameter file (`/**: ros__parameters: ...`). The same names configure
the offline simulator (`formation-control sim FILE -p name:=value`), the plant and every
vehicle node, which declare each one with a descriptor made from this table (the description
with the unit, the range, read-only unless marked *run time*). Units are SI, angles in radians;
equation numbers are those of R. Mellish, *Backstepping control design for the coordinated
motion of vehicles in a flowfield*, M.S. thesis, University of Maryland, 2011.

A value outside *allowed* is refused before anything runs, with a message naming the
parameter. A *run time* parameter can be changed on a running node (`ros2 param set
/vehicle_1 kappa 3.0`); a change that would make the scenario invalid is refused with the
reason.

"""

MARKDOWN_TAIL = """
A parameter is read by the runs its *read by* column names (all of them): a value other than
its default in any other run is refused, naming the parameter and what would read it (`'turbulence'
= 3 is invalid: not read by this run: it applies to plant_backend jsbsim only (plant_backend is
'native'); leave it out`). Three kinds are warned about instead (*else warned*), as one fleet
file often carries them for runs that do not all read them: the gains of one steering law or
formation (`kappa`, `K_p`, `K_P`, `K_I`, `anti_windup`; `omega0`, `c0`, `informed`, `pattern`),
flown with `-p controller:=...` or `-p formation:=...`, and the through-water sensor of rigid
bodies (`water_sigma`, `water_bias`) in a sensor suite given to particles too; the run goes on
and ignores them (a `pattern` on a parallel formation is still refused by the formation's own
check).

Checks across parameters, for rigid bodies (see [errata.md](errata.md), "Rigid-body practice"):

- tail steering (`rigid`, `rigid_cop`) has a right-half-plane zero at u0 sqrt(h l / I0): it is
  refused below half the steering bandwidth (kappa, K_p or K_P, by controller) and warned
  about below the bandwidth;
- the full law on tail steering (`law_variant: full`, and always the `pi` controller) closes a
  one-sample loop of gain bandwidth I0 / (l m0 u0), refused from 0.8;
- PI steering (8.24) needs h u0 / m0 > K_I / K_P.

Checks across parameters, for every model (errata.md, issue 28):

- `graph_nu`, when given, must be at least the largest degree (every d_k / nu <= 1);
- `flow_model` `time_varying`, `shear` or `vortex` needs a non-zero strength (`flow_amplitude`,
  `flow_shear`, `flow_circulation`); `flow_source: estimated` needs max |f| below 0.95 of the
  vehicle speed (the estimate's clamp). Known flows that vary are taken into the laws (df/dt,
  grad f; errata); where a law takes the flow as uniform and steady (`flow_source: estimated`,
  or the rigid bodies' `law_variant: practical`), a `time_varying` flow that turns the course
  faster than 0.1 of the laws' rate (|omega0| (s - |f|) circular, |K| parallel) and every
  flow that varies in space are warned about, and an estimating filter whose lag bound
  |grad f| (speed + max |f|) / lambda_f reaches half the speed margin speed - max |f| is
  refused; a known shear, vortex or grid whose gradient jumps (layer edges, core rim, cell
  edges) by more than 0.1 of the laws' rate is warned about (the laws hold between crossings);
- a slot pattern is refused on a graph whose phase potential has stable states other than
  synchrony (a ring or circulant graph with a stable twisted state, or one found by a census
  of 64 random phase starts);
- a held loop whose gain times `dt_control` passes half its limit is warned about (with
  `hold_prediction: midpoint` the limit of a single loop is 1, not 2, and the second-order
  laws' cascade with the formation loop lowers it further); where only the plain hold is
  stable, the run falls back to `hold_prediction: none` and says so.
"""


def markdown() -> str:
    """
    Return docs/parameters.md: the parameter table of :data:`PARAMETERS` in Markdown.

    Returns
    -------
    str
        The whole page, as ``formation-control params`` prints it.

    """
    rows = [(f'`{name}`', _shown(name), spec.unit, allowed(name), read_by(name),
             'yes' if spec.runtime else '', spec.text) for name, spec in PARAMETERS.items()]
    table = markdown_table(('parameter', 'default', 'unit', 'allowed', 'read by', 'run time',
                            'meaning'), rows)
    return MARKDOWN_HEAD + '\n'.join(table) + '\n' + MARKDOWN_TAIL


def markdown_table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> list[str]:
    """
    Return the lines of a Markdown table.

    Parameters
    ----------
    header : sequence of str
        The column titles.
    rows : iterable of sequence of str
        The cells of each row, as many as titles; a ``|`` in a cell is escaped.

    Returns
    -------
    list of str
        The title line, the rule and one line per row.

    """
    def line(cells: Iterable[str]) -> str:
        return '| ' + ' | '.join(c.replace('|', '\\|') for c in cells) + ' |'

    return [line(header), '|' + '---|' * len(header)] + [line(r) for r in rows]


def check_range(sc: Scenario, name: str) -> None:
    """Refuse a value outside the range of its :class:`Spec` (for the models it applies to)."""
    spec, value = PARAMETERS[name], getattr(sc, name)
    if sc.model not in spec.models:
        return
    if spec.low is not None and not (value > spec.low if spec.above else value >= spec.low):
        _fail(name, value, f'must be {_bounds(replace(spec, high=None))}')
    if spec.high is not None and not value <= spec.high:
        _fail(name, value, f'must be {_bounds(replace(spec, low=None))}')


def unread(sc: Scenario) -> list[tuple[str, Reader]]:
    """
    Return the parameters set away from their defaults in a run that does not read them.

    Returns
    -------
    list of tuple
        ``(name, reader)`` in table order: a configuration of the parameter's
        :attr:`Spec.reads` that ``sc`` is not, a refusing one before a warning one.

    """
    out = []
    for name, spec in PARAMETERS.items():
        missing = [r for r in map(READERS.__getitem__, spec.reads) if not r.holds(sc)]
        if missing and getattr(sc, name) != getattr(DEFAULTS, name):
            out.append((name, min(missing, key=lambda r: bool(r.shared))))
    return out


def check_read(sc: Scenario) -> tuple[str, ...]:
    """
    Refuse a value other than the default where the run will not read it; warn where shared.

    Returns
    -------
    tuple of str
        A warning for each such value whose configuration is :attr:`Reader.shared` (a shared
        file often sets it).

    Raises
    ------
    ScenarioError
        Naming the parameter and what would read it.

    """
    notes = []
    for name, reader in unread(sc):
        value = getattr(sc, name)
        value = list(value) if isinstance(value, tuple) else value
        why = (f'not read by this run: it applies to {reader.text} only ({reader.axis} is '
               f'{getattr(sc, reader.axis)!r})')
        if not reader.shared:
            _fail(name, value, f"{why}{'; ' + reader.hint if reader.hint else ''}; leave it out")
        notes.append(f"parameter '{name}' = {value!r} is {why}: ignored (warned, not refused: "
                     f'{reader.shared})')
    return tuple(notes)


def check(sc: Scenario) -> tuple[str, ...]:
    """
    Refuse values the table does not allow: choices, unread values, ranges, lengths, ids, steps.

    Returns
    -------
    tuple of str
        The notes of :func:`check_read`: values set where a shared file often sets them and
        the run does not read them.

    Raises
    ------
    ScenarioError
        Naming the parameter and the values it may take; a communication graph that cannot
        be built (:func:`graphs.build`).

    """
    for name in CHOICES:
        check_choice(sc, name)
    for name, spec in PARAMETERS.items():
        if (spec.low, spec.high) != (None, None):
            check_range(sc, name)
    for name in ('flow', 'c0', 'flow_center', 'geodetic_origin'):
        if len(getattr(sc, name)) != 2:
            _fail(name, list(getattr(sc, name)), 'must be a list of 2 numbers [x, y] (m/s or m)')
    for name in INIT_ARRAYS + MISMATCH_ARRAYS:
        n = len(getattr(sc, name))
        if n not in (0, sc.num_vehicles):
            _fail(name, list(getattr(sc, name)),
                  f'must have num_vehicles = {sc.num_vehicles} entries (or none: random)')
    notes = check_read(sc)
    if sc.plant_backend not in vehicle_model(sc.model).backends:
        takes = [m.name for m in VEHICLE_MODELS.values() if sc.plant_backend in m.backends]
        _fail('model', sc.model, f'plant_backend {sc.plant_backend} flies the laws of model '
              f"{' or '.join(takes)} only")
    if vehicle_model(sc.model).rigid and any(u <= 0 for u in sc.init_u):
        _fail('init_u', list(sc.init_u), 'rigid bodies start with forward speed u > 0 m/s')
    bad = [k for k in sc.informed if not 1 <= k <= sc.num_vehicles]
    if bad:
        _fail('informed', list(sc.informed), f'vehicle ids must lie in 1..{sc.num_vehicles}')
    from formation_control.core.graphs import GraphError
    try:
        sc.comm_graph
    except GraphError as err:
        raise ScenarioError(str(err)) from None
    if sc.dt_integration > sc.dt_control or abs(
            sc.substeps * sc.dt_integration - sc.dt_control) > 1e-9 * sc.dt_control:
        _fail('dt_integration', sc.dt_integration,
              f'must divide dt_control = {sc.dt_control} into a whole number of steps')
    for name in ('duration', 'record_dt'):
        periods = getattr(sc, name) / sc.dt_control
        if periods < 1 - 1e-9 or abs(periods - round(periods)) > 1e-6:
            _fail(name, getattr(sc, name),
                  f'must be a whole number (>= 1) of control periods dt_control = {sc.dt_control}')
    return notes


def parse_override(text: str) -> tuple[str, Any]:
    """Parse ``name:=value`` (value in YAML syntax, as ``ros2 run -p`` takes it)."""
    if ':=' not in text:
        raise ScenarioError(f'override {text!r} must read name:=value')
    name, value = text.split(':=', 1)
    try:
        return name.strip(), yaml.load(value, Loader=_Loader)
    except yaml.YAMLError as err:
        raise ScenarioError(f'override {text!r}: value is not valid YAML ({err})') from None


def read_params(path: str | PathLike[str]) -> dict[str, Any]:
    """Return the ``/**: ros__parameters`` mapping of a ROS 2 parameter file."""
    try:
        with open(path, encoding='utf-8') as f:
            doc = yaml.load(f, Loader=_Loader)
    except (OSError, yaml.YAMLError) as err:
        raise UsageError(f'{path}: cannot read the scenario ({err})') from None
    try:
        params = doc['/**']['ros__parameters'] or {}
    except (TypeError, KeyError):
        params = None
    if not isinstance(params, dict):
        raise UsageError(f'{path}: a scenario is a ROS 2 parameter file with a '
                         f"'/**: ros__parameters:' section mapping parameter names to values")
    return params


PLANT_ONLY = ('seed', 'duration', 'record_dt', 'dt_integration', 'init_box') + INIT_ARRAYS + (
    'world_seed', 'mismatch', 'actuator_lag', 'max_thrust_rate', 'max_steering_rate',
    'gust_intensity', 'gust_time', 'gnss_sigma', 'gnss_rate', 'heading_sigma', 'heading_bias',
    'yaw_rate_sigma', 'velocity_sigma', 'water_sigma', 'water_bias', 'sensor_latency'
) + MISMATCH_ARRAYS
"""Parameters only the plant uses (the initial state, the integration, the run's length and
record): a vehicle may differ there (``formation-control doctor`` notes it)."""


def differences(mine: Scenario, theirs: Scenario) -> list[tuple[str, Any, Any]]:
    """
    Return the parameters on which a vehicle's scenario differs from the plant's.

    Parameters
    ----------
    mine, theirs : Scenario
        The vehicle's scenario and the plant's (its latched ``/formation/scenario``).

    Returns
    -------
    list of tuple
        ``(name, mine, theirs)`` for each parameter outside :data:`PLANT_ONLY` that differs, in
        table order: a vehicle with any of them would fly another law or fleet.

    """
    return [(name, getattr(mine, name), getattr(theirs, name)) for name in PARAMETER_NAMES
            if name not in PLANT_ONLY and getattr(mine, name) != getattr(theirs, name)]


def find(name: str | PathLike[str]) -> Path:
    """Return the path of a scenario: a path, or the name of a file in the package's config/."""
    path = Path(name)
    if path.exists():
        return path
    stem = path.name if path.suffix else path.name + '.yaml'
    source_tree = Path(__file__).resolve().parents[2] / 'config' / stem
    if source_tree.exists():
        return source_tree
    try:
        from ament_index_python.packages import get_package_share_directory
        candidate = Path(get_package_share_directory('formation_control')) / 'config' / stem
    except (ImportError, LookupError, OSError):
        candidate = None
    if candidate is not None and candidate.exists():
        return candidate
    raise UsageError(f'scenario {name!r} not found (a path, or one of config/*.yaml)')
