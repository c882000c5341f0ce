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
Scenarios: one ROS 2 parameter file drives the offline simulator and the ROS nodes alike.

:func:`load` reads a scenario file and :func:`resolve` validates its values against the
parameter table (:mod:`parameters`) and the checks of each feature; every error names the
parameter and the values it may take, before anything runs. :func:`initial_state` draws the
fleet's start.
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import replace
import math
from os import PathLike
from typing import Any

from formation_control.core import formations, sensors
from formation_control.core.errors import refuse as _fail, ScenarioError
from formation_control.core.estimation import CLAMP
from formation_control.core.flowfields import Flowfield, FlowfieldError
from formation_control.core.geometry import RealArray
from formation_control.core.models import PARTICLE_MODELS, RIGID_MODELS, ROW_U, ROW_V
from formation_control.core.parameters import (check_choice, check_range, CHOICES, coerce,
                                               DEFAULTS, INIT_ARRAYS, MISMATCH_ARRAYS,
                                               PARAMETER_NAMES, PARAMETERS, parse_override,
                                               read_params, Scenario)
from formation_control.core.stability import (formation_rate, hold_fallback, steering_bandwidth,
                                              step_warnings)
from formation_control.core.steering import law
from formation_control.core.world import active
import numpy as np


def _check_structure(sc: Scenario) -> None:
    for name in CHOICES:
        check_choice(sc, name)
    check_range(sc, 'num_vehicles')
    if (sc.model == 'first_order') != (sc.controller == 'first_order'):
        _fail('controller', sc.controller, "model 'first_order' goes with controller "
              "'first_order' only, and controller 'first_order' with model 'first_order' only")
    for name in ('flow', 'c0', 'flow_center', 'geodetic_origin'):
        if len(getattr(sc, name)) != 2:
            _fail(name, list(getattr(sc, name)), 'must be a list of 2 numbers [x, y] (m/s or m)')
    for name in INIT_ARRAYS + MISMATCH_ARRAYS:
        n = len(getattr(sc, name))
        if n not in (0, sc.num_vehicles):
            _fail(name, list(getattr(sc, name)),
                  f'must have num_vehicles = {sc.num_vehicles} entries (or none: random)')
    if sc.model in RIGID_MODELS and any(u <= 0 for u in sc.init_u):
        _fail('init_u', list(sc.init_u), 'rigid bodies start with forward speed u > 0 m/s')
    bad = [k for k in sc.informed if not 1 <= k <= sc.num_vehicles]
    if bad:
        _fail('informed', list(sc.informed), f'vehicle ids must lie in 1..{sc.num_vehicles}')
    for name, kind in (('graph_edges', 'explicit'), ('graph_offsets', 'circulant')):
        if sc.graph != kind and getattr(sc, name) != getattr(DEFAULTS, name):
            _fail(name, list(getattr(sc, name)), f'applies to graph: {kind} only (graph is '
                  f'{sc.graph!r}, which would ignore it); say graph: {kind} or leave it out')
    if sc.plant_backend == 'jsbsim' and sc.model not in PARTICLE_MODELS:
        _fail('model', sc.model, 'plant_backend jsbsim flies the particle laws: model '
              'first_order or second_order')
    from formation_control.core.graphs import GraphError
    try:
        sc.comm_graph
    except GraphError as err:
        raise ScenarioError(str(err)) from None


def _check_gains(sc: Scenario) -> None:
    formations.of(sc).check(sc)
    for name, spec in PARAMETERS.items():
        if (spec.low, spec.high) != (None, None) and name != 'num_vehicles':
            check_range(sc, name)
    if sc.dt_integration > sc.dt_control or abs(
            sc.substeps * sc.dt_integration - sc.dt_control) > 1e-9 * sc.dt_control:
        _fail('dt_integration', sc.dt_integration,
              f'must divide dt_control = {sc.dt_control} into a whole number of steps')
    for name in ('duration', 'record_dt'):
        periods = getattr(sc, name) / sc.dt_control
        if periods < 1 - 1e-9 or abs(periods - round(periods)) > 1e-6:
            _fail(name, getattr(sc, name),
                  f'must be a whole number (>= 1) of control periods dt_control = {sc.dt_control}')
    _check_flow(sc)


def flowfield(sc: Scenario) -> Flowfield:
    """Return the :class:`flowfields.Flowfield` of a scenario (ScenarioError if it cannot)."""
    try:
        return Flowfield(sc)
    except FlowfieldError as err:
        raise ScenarioError(str(err)) from None


def _check_flow(sc: Scenario) -> None:
    """Refuse a flowfield whose speed reaches the vehicles' (the laws need |f| < speed)."""
    speed = flowfield(sc).max_speed
    where = 'flow' if sc.flow_model == 'uniform' else 'flow_model'
    value = list(sc.flow) if where == 'flow' else sc.flow_model
    what = '|flow|' if where == 'flow' else \
        f'the {sc.flow_model} flow reaches {speed:.3g} m/s: max |f|'
    if sc.plant_backend == 'jsbsim' and speed >= sc.airspeed:
        _fail(where, value, f'aircraft need {what} < airspeed = {sc.airspeed} m/s (the wind '
              f'must not blow them backwards)')
    if sc.plant_backend == 'native' and sc.model in PARTICLE_MODELS and speed >= 1:
        _fail(where, value, f'unit-speed particles need {what} < 1 m/s (1.6)')
    if sc.model in RIGID_MODELS and speed >= sc.u0:
        _fail(where, value, f'rigid bodies need {what} < u0 = {sc.u0} m/s')
    strength = {'time_varying': 'flow_amplitude', 'shear': 'flow_shear',
                'vortex': 'flow_circulation'}.get(sc.flow_model)
    if strength and getattr(sc, strength) == 0:
        _fail(strength, 0.0, f'flow_model {sc.flow_model} needs {strength} != 0 (at 0 the flow '
              f'is the uniform flow: say flow_model: uniform)')
    own = vehicle_speed(sc)
    if sc.flow_source == 'estimated' and speed >= CLAMP * own:
        _fail(where, value, f'flow_source estimated clamps each estimate to {CLAMP:g} of the '
              f'vehicle speed {own:g} m/s, so {what} = {speed:.3g} m/s >= {CLAMP * own:.3g} '
              f'm/s would be underestimated for good (a permanent bias); lower the flow or use '
              f'flow_source: known')


def vehicle_speed(sc: Scenario) -> float:
    """Return the vehicles' speed relative to the flow (m/s): 1 particles, u0 rigid, airspeed."""
    if sc.plant_backend == 'jsbsim':
        return sc.airspeed
    return sc.u0 if sc.model in RIGID_MODELS else 1.0


SLOW_FLOW = 0.1
"""A time-varying flow is slow when it turns the course below this share of the laws' rate."""


def uses_flow_rates(sc: Scenario) -> bool:
    """
    Return whether the laws take the flow's change along each path (its rate and gradient).

    A known flow that is not uniform and steady, for every law but the rigid bodies' practical
    one, which drops every rate (beta', s') and the flow's with them (errata, "Known
    time-varying and non-uniform flows"). An estimate's derivatives are not known. Aircraft
    (``plant_backend: jsbsim``) fly the laws in their own units (:mod:`aircraft`), where the
    flow's rates are not built: they take the flow as uniform and steady.
    """
    return (sc.flow_source == 'known' and sc.flow_model != 'uniform'
            and sc.plant_backend != 'jsbsim'
            and (sc.model not in RIGID_MODELS or uses_held_force(sc)))


def _steady_view_why(sc: Scenario) -> str:
    """Return why the laws of ``sc`` take its flow as uniform and steady."""
    if sc.flow_source == 'estimated':
        return 'flow_source estimated: an estimate has no known rate or gradient'
    if sc.plant_backend == 'jsbsim':
        return "plant_backend jsbsim: the aircraft's laws take no rate of the flow"
    return 'law_variant practical drops the rates'


def estimate_lag(sc: Scenario) -> float:
    """
    Return a bound of the estimate's lag ``|fhat - f|`` once settled (m/s), the filter's.

    ``e' = -lambda_f e - f'`` (errata): ``A w / sqrt(lambda_f^2 + w^2)`` in the turning flow,
    ``sup |f'| / lambda_f`` with ``|f'| <= |grad f| (speed + max |f|)`` along any path in a
    flow that varies in space.
    """
    flow = flowfield(sc)
    if sc.flow_model == 'time_varying':
        return sc.flow_amplitude * flow.rate / float(np.hypot(sc.flow_gain, flow.rate))
    return flow.max_gradient() * (vehicle_speed(sc) + flow.max_speed) / sc.flow_gain


def _slow_flow_note(sc: Scenario) -> str | None:
    """Return the warning of a time-varying flow too fast for a law's steady view, or None."""
    if sc.flow_model != 'time_varying' or uses_flow_rates(sc):
        return None
    flow = flowfield(sc)
    s_min = vehicle_speed(sc) - flow.max_speed
    turn = flow.max_rate() / s_min
    rate, what = formations.of(sc).law_rate(sc, s_min)
    if turn <= SLOW_FLOW * rate:
        return None
    period = 2.0 * np.pi * sc.flow_amplitude / (SLOW_FLOW * rate * s_min)
    return (f'flow_period = {sc.flow_period:g} s: the laws treat the flow as steady (no df/dt; '
            f'{_steady_view_why(sc)}), '
            f'and |df/dt| = 2 pi A / T = {flow.max_rate():.3g} m/s^2 turns the course by up to '
            f'|df/dt| / (s - |f|) = {turn:.3g} rad/s, more than {SLOW_FLOW:g} of {what} = '
            f'{rate:.3g} rad/s: expect the formation to lag the flow. Use flow_period >= '
            f'{period:.3g} s or a smaller flow_amplitude')


def _uniform_view_note(sc: Scenario) -> str | None:
    """
    Return the warning of a flow varying in space that a law takes as uniform, or None.

    Refuses (ScenarioError) an estimating filter whose lag bound reaches half the speed
    margin ``s - max |f|``: the believed course is then within no angle of the true one.
    """
    if sc.flow_model in ('uniform', 'time_varying') or uses_flow_rates(sc):
        return None
    flow, own = flowfield(sc), vehicle_speed(sc)
    margin = own - flow.max_speed
    text = (f'flow_model {sc.flow_model} (|grad f| up to {flow.max_gradient():.3g} 1/s): the '
            f'laws take the flow at each vehicle as uniform and steady '
            f'({_steady_view_why(sc)})')
    if sc.flow_source == 'known':
        return (f'{text}: the circle is kept only approximately (docs/laws.md, "Flowfields"); '
                f'use law_variant: full or controller: pi for the laws with grad f')
    lag = estimate_lag(sc)
    if sc.flow_estimator == 'filter' and lag >= 0.5 * margin:
        _fail('flow_model', sc.flow_model,
              f'{text}, and the estimate lags the flow met along the path by up to '
              f'|grad f| (speed + max |f|) / lambda_f = {lag:.3g} m/s, at least half the speed '
              f'margin speed - max |f| = {margin:.3g} m/s: no course bound holds. Raise '
              f'flow_gain, lower the gradient, or use flow_source: known')
    return (f'{text}: the true circle is kept only to within the lag of the estimate, '
            f'|fhat - f| <= |grad f| (speed + max |f|) / lambda_f = {lag:.3g} m/s; use '
            f'flow_source: known for the laws with grad f')


KINKS = {'shear': ('the edges |y| = flow_shear_width of the layer', 1.0),
         'vortex': ('the rim of the core (flow_radius)', 2.0),
         'grid': ('the edges of the grid cells', 2.0)}
"""Where each flow's gradient jumps, and the largest jump in units of ``max |grad f|``."""


def _kink_note(sc: Scenario) -> str | None:
    """
    Return the warning of a known flow whose gradient jumps by more than the laws can ignore.

    Where ``grad f`` jumps by D the true course rate jumps by up to D (``<i v, D v> / s^2``) and
    the law's V_c with it (errata, (E28.2)); warned above SLOW_FLOW of the laws' rate.
    """
    if sc.flow_model not in KINKS or not uses_flow_rates(sc):
        return None
    flow = flowfield(sc)
    where, share = KINKS[sc.flow_model]
    jump = share * flow.max_gradient()
    s_min = vehicle_speed(sc) - flow.max_speed
    rate, _ = formations.of(sc).law_rate(sc, s_min)
    if jump <= SLOW_FLOW * rate:
        return None
    return (f'flow_model {sc.flow_model}: the gradient of the flow jumps at {where}, so a vehicle '
            f'crossing it has its course rate kicked by up to {jump:.3g} rad/s, more than '
            f'{SLOW_FLOW:g} of the rate of the laws, {rate:.3g} rad/s: the laws (with grad f) '
            f'hold between crossings only; expect the formation to be kept approximately there')


def _check_pattern(sc: Scenario) -> None:
    """Refuse a symmetric pattern that cannot exist or that the laws do not reach."""
    if sc.pattern == 'none':
        return
    if not formations.of(sc).patterns:
        _fail('pattern', sc.pattern, 'a symmetric pattern places vehicles on the circle: it '
              'needs formation circular')
    if sc.flow_c != 0 or sc.flow_model != 'uniform':
        flow = (f'flow = {list(sc.flow)} m/s' if sc.flow_model == 'uniform' else
                f'flow_model = {sc.flow_model!r} (flow = {list(sc.flow)} m/s)')
        _fail('pattern', sc.pattern, f'{flow} is not a zero flow: in a flow no '
              f'fixed phase pattern exists on a circle (the course rate omega0 s_k varies '
              f'with the course, so the vehicles move along the circle relative to each '
              f'other); use flow: [0.0, 0.0] or pattern: none')
    n, m = sc.num_vehicles, sc.pattern_M
    if sc.pattern == 'symmetric' and not (2 <= m < n and n % m == 0):
        _fail('pattern_M', m, f'symmetric needs 2 <= M < num_vehicles = {n} with M dividing '
              f'num_vehicles (M clusters of N/M); M = N is pattern: splay')
    if sc.pattern_form == 'moments' and not sc.all_to_all:
        _fail('pattern_form', sc.pattern_form, 'the moments are fleet means (all-to-all): on a '
              'limited graph their Laplacian form converges only locally; use slots (or auto)')
    if sc.pattern_slots and not sc.comm_graph.complete:
        _check_slot_traps(sc)


def _check_slot_traps(sc: Scenario) -> None:
    """Refuse slots on a graph whose phase potential has stable states other than synchrony."""
    from formation_control.core import graphs
    n = sc.num_vehicles
    if sc.graph in ('ring', 'circulant'):
        offsets = (1,) if sc.graph == 'ring' else sc.graph_offsets
        twisted = graphs.twisted_states(n, offsets)
        if not twisted:
            return
        where = (f'a ring of {n}' if sc.graph == 'ring' else
                 f'the circulant graph {list(offsets)} on {n}')
        rule = ' (|q| < N/4)' if sc.graph == 'ring' else ''
        found = (f'{where} has stable twisted states for slots: psi_k = 2 pi q k / N with '
                 f"q = {', '.join(map(str, twisted))}{rule}")
    else:
        share = graphs.slot_traps(sc.comm_graph)
        if share == 0:
            return
        found = (f'the {sc.graph} graph on {n} has stable slot states other than synchrony: '
                 f'{share:.0%} of {graphs.TRAP_STARTS} random phase starts end in one')
    dense = math.ceil(0.75 * (n - 1))
    _fail('graph', sc.graph, f'{found}, where a slot pattern stops with its slots wrongly filled '
          f'(a splay in coincident pairs, clusters in the wrong number or order). Use graph: '
          f'complete (the moment form), a tree (graph: explicit without cycles), or a denser '
          f'graph (every degree >= {dense} = 3 (N - 1) / 4 synchronises from almost every start)')


NATIVE_WORLD = ('mismatch', *MISMATCH_ARRAYS, 'actuator_lag', 'max_thrust_rate',
                'max_steering_rate', 'gust_intensity', 'gnss_sigma', 'gnss_rate', 'heading_sigma',
                'heading_bias', 'yaw_rate_sigma', 'velocity_sigma', 'water_sigma', 'water_bias',
                'sensor_latency', 'position_filter')
"""The world of the native plant (issue 30), refused with ``plant_backend: jsbsim``."""

JSBSIM_OWNS = ('u0', 'K_f', 'K_P', 'K_I', 'm0', 'I0', 'l', 'h', 'l1', 'max_thrust',
               'max_steering_force')
"""The rigid-body parameters, which a JSBSim aircraft's own model (mass, drag, ...) replaces."""


def _check_aircraft(sc: Scenario) -> None:
    """Refuse a jsbsim scenario the aircraft cannot fly (docs/aircraft.md, "Bad input")."""
    native = [name for name in NATIVE_WORLD if getattr(sc, name) != getattr(DEFAULTS, name)]
    if native:
        _fail(native[0], getattr(sc, native[0]), "with plant_backend jsbsim: the native plant's "
              'model mismatch, actuators, gusts and sensors are not applied to JSBSim aircraft '
              '(JSBSim has its own turbulence: turbulence_severity): leave it out')
    owned = [name for name in JSBSIM_OWNS if getattr(sc, name) != getattr(DEFAULTS, name)]
    if owned:
        _fail(owned[0], getattr(sc, owned[0]), f'with plant_backend jsbsim the aircraft model '
              f'{sc.jsbsim_aircraft!r} owns its mass, inertia, drag and thrust: leave out '
              f"{', '.join(owned)}")
    if not -80.0 <= sc.geodetic_origin[0] <= 80.0:
        _fail('geodetic_origin', list(sc.geodetic_origin), 'the latitude must lie within '
              '+-80 deg (the map frame is a tangent plane)')
    for name, ok in (('min_airspeed', sc.min_airspeed <= sc.airspeed),
                     ('max_airspeed', not sc.max_airspeed or sc.max_airspeed >= sc.airspeed)):
        if not ok:
            _fail(name, getattr(sc, name), f'the limit must admit airspeed = {sc.airspeed} m/s')
    from formation_control.core import aircraft
    radius = formations.of(sc).radius(sc)
    if radius is not None:
        bank = aircraft.required_bank(sc)
        if bank >= sc.bank_limit:
            _fail('omega0', sc.omega0, f'a circle of radius {radius:.4g} m at airspeed '
                  f'{sc.airspeed} m/s in the wind {list(sc.flow)} m/s needs a bank of '
                  f'{math.degrees(bank):.3g} deg (tan(bank) = V^2 / (g R) in still air), '
                  f'beyond bank_limit = {sc.bank_limit} rad = {math.degrees(sc.bank_limit):.3g} '
                  f'deg: use a larger radius (smaller |omega0|) or a larger bank_limit')
    try:
        aircraft.check(sc)
    except aircraft.AircraftError as err:
        raise ScenarioError(str(err)) from None


def rhp_zero(sc: Scenario) -> float:
    """
    Return the right-half-plane zero of tail steering, from the force F to the course.

    Parameters
    ----------
    sc : Scenario
        A rigid-body scenario (u0, h, l, I0).

    Returns
    -------
    float
        ``u0 sqrt(h l / I0)`` (rad/s): the side force at the tail first pushes the velocity
        the wrong way (errata, "Physical parameters").

    """
    return sc.u0 * math.sqrt(sc.h * sc.l / sc.I0)


def uses_held_force(sc: Scenario) -> bool:
    """
    Return whether the steering law reads the course rate from the model with the held force.

    The full law (``law_variant: full``) and the PI law (8.24) do (the exact rate and s' of
    :func:`control.rigid_view`); the practical law uses omega.
    """
    return law(sc).held_force or sc.law_variant == 'full'


def held_force_loop_gain(sc: Scenario) -> float:
    """
    Return the gain of the one-sample loop F -> beta' -> F of tail steering with the full law.

    Parameters
    ----------
    sc : Scenario
        A rigid-body scenario.

    Returns
    -------
    float
        ``bandwidth I0 / (l m0 u0)`` (:func:`steering_bandwidth`). With the full law, beta'
        (hence psi') contains F/m0 (7.7); computed from the held force it closes a loop
        through one sample that diverges when this gain nears 1.

    """
    return steering_bandwidth(sc) * sc.I0 / (sc.l * sc.m0 * sc.u0)


def _check_physics(sc: Scenario) -> tuple[str, ...]:
    """Check the conditions the rigid-body laws need (errata); return the warnings."""
    notes = [note for note in (_slow_flow_note(sc), _uniform_view_note(sc), _kink_note(sc))
             if note]
    if sc.model in ('rigid', 'rigid_cop'):
        zero, band = rhp_zero(sc), steering_bandwidth(sc)
        if zero < 0.5 * band:
            raise ScenarioError(
                f'tail steering has a right-half-plane zero at u0*sqrt(h*l/I0) = {zero:.3g} '
                f'rad/s, below half the steering bandwidth {band:.3g} rad/s: the law would '
                f'diverge. Raise u0, h or l, or lower I0 or the gain (parameters u0, h, l, I0)')
        if zero < band:
            notes.append(f'right-half-plane zero u0*sqrt(h*l/I0) = {zero:.3g} rad/s lies '
                         f'below the steering bandwidth {band:.3g} rad/s: expect slow, '
                         f'oscillating turns')
        gain = held_force_loop_gain(sc)
        if uses_held_force(sc) and gain >= 0.8:
            raise ScenarioError(
                f'the full law on tail steering closes a one-sample loop through the held force '
                f'with gain bandwidth*I0/(l*m0*u0) = {gain:.3g}, which must stay below 0.8 '
                f'(parameters law_variant, kappa or K_P, I0, l, m0, u0); use law_variant: '
                f'practical, or model: rigid_couple')
    if sc.model in RIGID_MODELS and sc.controller == 'pi':
        if not sc.h * sc.u0 / sc.m0 > sc.K_I / sc.K_P:
            raise ScenarioError(
                f'PI steering (8.24) needs h*u0/m0 = {sc.h * sc.u0 / sc.m0:.3g} > '
                f'K_I/K_P = {sc.K_I / sc.K_P:.3g} (parameters h, u0, m0, K_I, K_P)')
    return tuple(notes)


def practical(sc: Scenario) -> bool:
    """Return whether the convergence test is the band test (band, or auto with the world on)."""
    return sc.convergence == 'band' or (sc.convergence == 'auto' and (
        active(sc) or sensors.active(sc)))


def _check_world(sc: Scenario) -> tuple[str, ...]:
    """Refuse a world no vehicle could have or the loop could bear; return the warnings."""
    if sc.mismatch >= 1:
        _fail('mismatch', sc.mismatch, 'must be < 1: a factor 1 - mismatch <= 0 makes a mass, '
              'inertia or drag non-positive')
    for name in MISMATCH_ARRAYS:
        if name != 'mismatch_l1' and any(v <= 0 for v in getattr(sc, name)):
            _fail(name, list(getattr(sc, name)), 'every factor must be > 0 (a non-positive '
                  'mass, inertia, drag or effectiveness)')
    rates = sensors.check_rates(sc)
    if rates:
        name, why = rates.split(': ', 1)
        _fail(name, getattr(sc, name), why)
    notes = []
    steer = law(sc)
    if sc.actuator_lag:
        limit = steer.lag_limit(steer.bandwidth(sc), formation_rate(sc), sc.K_I)
        gain = steer.gain
        text = (f'actuator_lag = {sc.actuator_lag:g} s against the steering loop ({gain}, '
                f'formation rate {formation_rate(sc):.3g} 1/s), stable only for a lag below '
                f'{limit:.3g} s (docs/errata.md, "Actuator lag")')
        if sc.actuator_lag >= limit:
            _fail('actuator_lag', sc.actuator_lag, f'{text}: the loop would diverge; lower the '
                  f'lag or the gains')
        if sc.actuator_lag > 0.5 * limit:
            notes.append(f'{text}: past half of it, expect slow, oscillating turns')
    if sc.gust_intensity:
        speed, top = vehicle_speed(sc), flowfield(sc).max_speed + 3.0 * sc.gust_intensity
        if top >= speed:
            notes.append(f'gust_intensity = {sc.gust_intensity:g} m/s: the flow plus three '
                         f'sigma of gust reaches {top:.3g} m/s, beyond the vehicle speed '
                         f'{speed:g} m/s, where the laws need |f| < speed')
    return tuple(notes)


def resolve(params: Mapping[str, Any]) -> Scenario:
    """
    Build a validated scenario from parameter values.

    Parameters
    ----------
    params : dict
        Parameter name -> value, as a parameter file or ROS gives them (lists for pairs and
        arrays); names left out take the defaults of :data:`PARAMETERS`, K that of the
        formation (-1 parallel, 1 circular).

    Returns
    -------
    Scenario
        With ``warnings``: the notes of the physical checks that do not refuse.

    Raises
    ------
    ScenarioError
        An unknown name, a value of the wrong type or outside its allowed values, or
        parameters that do not fit together; the message names the parameter.

    """
    unknown = sorted(set(params) - set(PARAMETER_NAMES))
    if unknown:
        raise ScenarioError(f"unknown parameter(s) {', '.join(repr(u) for u in unknown)}; "
                            f"allowed: {', '.join(PARAMETER_NAMES)}")
    values = {k: coerce(k, v) for k, v in params.items()}
    sc = replace(DEFAULTS, **values)
    if 'K' not in values:
        sc = replace(sc, K=formations.default_K(sc.formation))
    _check_structure(sc)
    _check_gains(sc)
    _check_pattern(sc)
    notes = _check_physics(sc) + _check_world(sc)
    if sc.plant_backend == 'jsbsim':
        _check_aircraft(sc)
    hold, fallback = hold_fallback(sc)
    if fallback:
        sc, notes = replace(sc, hold_prediction=hold), notes + (fallback,)
    return replace(sc, warnings=notes + tuple(step_warnings(sc)))


def load(path: str | PathLike[str], overrides: Iterable[str] = (), **values: Any) -> Scenario:
    """
    Read, override and validate a scenario.

    Parameters
    ----------
    path : str or path-like
        A ROS 2 parameter file (``/**: ros__parameters: ...``).
    overrides : iterable of str, optional
        ``name:=value`` strings (YAML values, as ``ros2 run -p`` takes them), applied in order.
    **values
        Parameter values applied last; None values are ignored (unset options).

    Returns
    -------
    Scenario
        :func:`resolve` of the result.

    Raises
    ------
    UsageError
        The file cannot be read or is not a parameter file.
    ScenarioError
        :func:`resolve` refuses it.

    """
    params = read_params(path)
    params.update(parse_override(o) for o in overrides)
    params.update({k: v for k, v in values.items() if v is not None})
    return resolve(params)


def initial_state(sc: Scenario) -> RealArray:
    """
    Return the initial state of the fleet.

    Parameters
    ----------
    sc : Scenario
        The scenario (num_vehicles, seed, init_box, init_* arrays, model, u0).

    Returns
    -------
    ndarray, shape (6, N)
        Rows of :mod:`models`: the explicit ``init_*`` arrays where given, else the thesis'
        random draw, seeded by ``seed``: positions uniform in the init_box square centred on
        the origin (m), headings uniform on the circle (rad), turning rates zero, u = u0 (rigid
        bodies), v = 0. Particles always have u = 1, v = 0.

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
