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
The flow a scenario's vehicles meet, as the laws see it, and its checks.

The flowfield of a scenario (:mod:`flowfields`), the vehicles' speed through it, whether the
laws take its change along each path (df/dt, grad f), and :func:`check`: a flow faster than
the vehicles is refused (the laws need ``|f| < speed`` (1.6)); a flow that varies faster than a
law taking it as uniform and steady can follow, or whose gradient jumps, is warned about
(docs/errata.md, "Known time-varying and non-uniform flows").
"""
from __future__ import annotations

from formation_control.core import aircraft, formations
from formation_control.core.errors import refuse as _fail, ScenarioError
from formation_control.core.estimation import CLAMP
from formation_control.core.flowfields import Flowfield, FlowfieldError
from formation_control.core.parameters import Scenario
from formation_control.core.steering import uses_held_force
from formation_control.core.vehicles import vehicle_model
import numpy as np


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
    if aircraft.flown(sc) and speed >= sc.airspeed:
        _fail(where, value, f'aircraft need {what} < airspeed = {sc.airspeed} m/s (the wind '
              f'must not blow them backwards)')
    model = vehicle_model(sc.model)
    if not aircraft.flown(sc) and model.particle and speed >= 1:
        _fail(where, value, f'unit-speed particles need {what} < 1 m/s (1.6)')
    if model.rigid and speed >= sc.u0:
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
    if aircraft.flown(sc):
        return sc.airspeed
    return vehicle_model(sc.model).speed(sc.u0)


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
            and not aircraft.flown(sc)
            and (not vehicle_model(sc.model).rigid or uses_held_force(sc)))


def _steady_view_why(sc: Scenario) -> str:
    """Return why the laws of ``sc`` take its flow as uniform and steady."""
    if sc.flow_source == 'estimated':
        return 'flow_source estimated: an estimate has no known rate or gradient'
    if aircraft.flown(sc):
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


def check(sc: Scenario) -> tuple[str, ...]:
    """
    Refuse a flow the vehicles cannot fly in; warn of one the laws see approximately.

    Also warned about: a gust (``gust_intensity``, :mod:`world`) whose three sigma carry the
    flow past the vehicles' speed.
    """
    _check_flow(sc)
    notes = [note for note in (_slow_flow_note(sc), _uniform_view_note(sc), _kink_note(sc))
             if note]
    if sc.gust_intensity:
        speed, top = vehicle_speed(sc), flowfield(sc).max_speed + 3.0 * sc.gust_intensity
        if top >= speed:
            notes.append(f'gust_intensity = {sc.gust_intensity:g} m/s: the flow plus three '
                         f'sigma of gust reaches {top:.3g} m/s, beyond the vehicle speed '
                         f'{speed:g} m/s, where the laws need |f| < speed')
    return tuple(notes)
