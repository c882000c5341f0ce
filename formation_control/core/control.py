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
From vehicle state to commands: particle views, flow transforms and the rigid-body forces.

:class:`Controller` is what both the offline simulator and a vehicle node call. A vehicle
computes the view of itself (:meth:`Controller.view`), shares it, and turns the views of the
vehicles it knows into its own command (:meth:`Controller.command`).
"""
from __future__ import annotations

from dataclasses import replace
import math
from typing import Any

from formation_control.core import aircraft, formations, laws, safety, steering
from formation_control.core.flow import uses_flow_rates, vehicle_speed
from formation_control.core.flowfields import Jet
from formation_control.core.geometry import BoolArray, ComplexArray, inner, RealArray
from formation_control.core.models import (body_accel, ground_velocity, integrate, Plant,
                                           position, ROW_OMEGA, ROW_THETA, ROW_U, ROW_V, ROW_X,
                                           ROW_Y)
from formation_control.core.parameters import Scenario
from formation_control.core.vehicles import vehicle_model
import numpy as np


def particle_speed_terms(theta: RealArray,
                         flow: complex | ComplexArray) -> tuple[RealArray, RealArray, RealArray]:
    """
    Return the inertial speed, course and course-rate factor of unit-speed particles in a flow.

    Parameters
    ----------
    theta : array_like
        Body headings theta (rad).
    flow : complex or array_like of complex
        The flow f at each vehicle (m/s), ``|f| < 1``: known or estimated.

    Returns
    -------
    s, gamma, g : ndarray, shape of ``theta``
        ``s e^{i gamma} = e^{i theta} + f`` (1.4)-(1.6): inertial speed s (m/s) and course gamma
        (rad); ``gamma' = g theta'`` with ``g = (1 + <f, e^{i theta}>) / s^2
        = 1 - <e^{i gamma}, f> / s``, the factor of (5.1).

    """
    e = np.exp(1j * theta)
    vel = e + flow
    s2 = abs(vel) ** 2
    return np.sqrt(s2), np.angle(vel), (1.0 + inner(flow, e)) / s2


def flow_course_rate(v: ComplexArray, f_dot: ComplexArray | float) -> RealArray:
    """
    Return the part of the course rate that the flow's own change makes, ``<i v, f'> / s^2``.

    ``v`` is the ground velocity (complex m/s) and ``f_dot`` the rate of the flow met along
    the path (:meth:`flowfields.Jet.rate`), 0 in a uniform steady flow.
    """
    return inner(1j * v, f_dot) / abs(v) ** 2


def particle_view(X: RealArray, flow: complex | ComplexArray,
                  jet: Jet | None = None, speed: float = 1.0) -> laws.View:
    """
    Return the particle view of particles of constant speed through the flow.

    Parameters
    ----------
    X : array_like, shape (6, N)
        States (rows of :mod:`models`); omega is the body turn rate theta'.
    flow : complex or array_like of complex, shape (N,)
        The flow f at each vehicle (m/s): known or estimated.
    jet : flowfields.Jet, optional
        The flow's derivatives at each vehicle, where it is known and not uniform and steady;
        None: taken as uniform and steady.
    speed : float, optional
        Their speed V through the flow (m/s): 1 for the thesis' particles, the airspeed of
        aircraft (:mod:`aircraft`).

    Returns
    -------
    laws.View
        Phase gamma, rate ``Omega = g omega + <i v, f'> / s^2``, speed s and
        ``s' = (<f, i e^{i theta}> omega + <v, f'>) / s`` with ``v = e^{i theta} + f`` and
        ``f' = f_t + (grad f) v`` (1.8), (4.9) with the flow's change (errata, "Known
        time-varying and non-uniform flows"); without flow theta, xi, 1, 0 (1.3). At speed V,
        ``V e^{i theta} + f = V (e^{i theta} + f / V)``: gamma and g are those of the flow
        f / V, s and the steady part of s' V times theirs, and v = V e^{i theta} + f.

    """
    w = X[ROW_OMEGA]
    if jet is None and not np.any(flow):                   # (1.3): the heading is the phase
        return laws.View(position(X), np.array(X[ROW_THETA], float), np.array(w, float),
                         np.full(np.shape(w), float(speed)), np.zeros(np.shape(w)))
    f = flow if speed == 1.0 else flow / speed
    s, gamma, g = particle_speed_terms(X[ROW_THETA], f)
    e = np.exp(1j * X[ROW_THETA])
    s_dot = inner(f, 1j * e) * w / s
    if speed != 1.0:
        s, s_dot = speed * s, speed * s_dot
    rate = g * w
    if jet is not None:
        v = speed * e + flow
        f_dot = jet.rate(v)
        rate = rate + flow_course_rate(v, f_dot)
        s_dot = s_dot + inner(v, f_dot) / s
    return laws.View(position(X), gamma, rate, s, s_dot)


def body_rate_from_inertial(w: RealArray, theta: RealArray,
                            flow: complex | ComplexArray, jet: Jet | None = None) -> RealArray:
    """
    Return the body turn rate that gives the inertial course rate ``w``, (5.1).

    Parameters
    ----------
    w : array_like
        Desired course rates gamma' (rad/s).
    theta : array_like
        Body headings (rad).
    flow : complex or array_like of complex
        The flow f at each vehicle (m/s): known or estimated.
    jet : flowfields.Jet, optional
        The known flow's derivatives at each vehicle (:func:`particle_view`).

    Returns
    -------
    ndarray
        ``u_k = (w_k - <i v, f'> / s^2) / g`` (rad/s), g of :func:`particle_speed_terms`;
        ``w_k / g`` in a uniform steady flow.

    """
    if jet is None and not np.any(flow):                   # g = 1
        return np.array(w, float)
    g = particle_speed_terms(theta, flow)[2]
    if jet is None:
        return w / g
    v = np.exp(1j * theta) + flow
    return (w - flow_course_rate(v, jet.rate(v))) / g


def body_accel_from_inertial(lam: RealArray, theta: RealArray,
                             omega: RealArray,
                             flow: complex | ComplexArray, jet: Jet | None = None) -> RealArray:
    """
    Return the body angular acceleration that gives the inertial one ``lam``, (5.3)/(5.4).

    Parameters
    ----------
    lam : array_like
        Desired course accelerations lambda_k = gamma'' (rad/s^2).
    theta, omega : array_like
        Body headings (rad) and turn rates (rad/s).
    flow : complex or array_like of complex
        The flow f at each vehicle (m/s): known or estimated.
    jet : flowfields.Jet, optional
        The known flow's derivatives at each vehicle; None: the flow is taken as steady and
        uniform.

    Returns
    -------
    ndarray
        ``a_k = (lambda_k - g' omega_k - h') / g`` (rad/s^2): from
        ``gamma' = g theta' + h``, ``h = <i v, f'> / s^2`` (:func:`particle_view`),
        ``lambda = g a + g' omega + h'`` with ``v = e^{i theta} + f``,
        ``v' = i omega e^{i theta} + f'``, ``n = 1 + <f, e^{i theta}>``, ``g = n / s^2``,
        ``g' = (<f', e^{i theta}> + <f, i e^{i theta}> omega - g (s^2)') / s^2``,
        ``h' = (<i v', f'> + <i v, f''> - h (s^2)') / s^2``, ``(s^2)' = 2 <v, v'>``. In a uniform
        steady flow (f' = 0) ``g' = <f, i e^{i theta}> omega (s^2 - 2 n) / s^4``, h = 0:
        (5.4).

    """
    if jet is None and not np.any(flow):                   # (5.4) with f = 0: a = lambda
        return np.array(lam, float)
    e = np.exp(1j * theta)
    v = e + flow
    s2 = abs(v) ** 2
    n = 1.0 + inner(flow, e)
    if jet is None:
        g_dot = inner(flow, 1j * e) * omega * (s2 - 2.0 * n) / s2 ** 2
        return (lam - g_dot * omega) * s2 / n
    f_dot = jet.rate(v)
    v_dot = 1j * omega * e + f_dot
    s2_dot = 2.0 * inner(v, v_dot)
    g = n / s2
    g_dot = (inner(f_dot, e) + inner(flow, 1j * e) * omega - g * s2_dot) / s2
    h = inner(1j * v, f_dot) / s2
    h_dot = (inner(1j * v_dot, f_dot) + inner(1j * v, jet.accel(v, v_dot)) - h * s2_dot) / s2
    return (lam - g_dot * omega - h_dot) / g


def thrust(X: RealArray, u0: float, K_f: float, plant: Plant) -> RealArray:
    """
    Return the feedback-linearising thrust of rigid bodies, (7.1) = (8.10).

    Parameters
    ----------
    X : array_like, shape (6, N)
        States (rows of :mod:`models`); u, v relative to the flow.
    u0 : float
        Commanded forward speed relative to the flow (m/s).
    K_f : float
        Speed gain (1/s).
    plant : Plant
        Physical parameters and the model, whose inverse gives the thrust
        (:meth:`vehicles.base.VehicleModel.thrust`).

    Returns
    -------
    ndarray, shape (N,)
        The thrust that gives ``u' = K_f (u0 - u)``: ``T = h s u - m0 v omega + m0 K_f (u0 - u)``
        (N) for the thesis' rigid bodies.

    """
    return plant.model.thrust(X, K_f * (u0 - X[ROW_U]), plant)


def rigid_view(X: RealArray, U_applied: RealArray, plant: Plant,
               flow: complex | ComplexArray, use_heading: bool, full: bool,
               jet: Jet | None = None) -> laws.View:
    """
    Return the particle view of rigid bodies.

    Parameters
    ----------
    X : array_like, shape (6, N)
        States (rows of :mod:`models`).
    U_applied : array_like, shape (2, N)
        Input the exact rates are computed with: thrust now, steering force held (N).
    plant : Plant
        The rigid-body model.
    flow : complex or array_like of complex, shape (N,)
        The flow at each vehicle (m/s): known or estimated.
    use_heading : bool
        Steer the heading: phase theta with rate omega, as (7.3) with (3.7) uses it.
    full : bool
        Otherwise, compute the exact course rate and s' from the model with ``U_applied``;
        the thesis' practical law (text after 7.12) uses omega and ``s' = 0``.
    jet : flowfields.Jet, optional
        The known flow's derivatives at each vehicle: the exact rates then include the
        flow's change ``f'`` in ``r''`` (the practical law drops it with the other rates).

    Returns
    -------
    laws.View
        Unless ``use_heading``, the phase is the direction of the ground velocity,
        ``psi = theta + beta`` (7.11) or ``gamma = theta + beta_hat`` (8.1); the speed is the
        ground speed s or s_hat (m/s).

    """
    r = position(X)
    rel = X[ROW_U] + 1j * X[ROW_V]
    turn = np.exp(1j * X[ROW_THETA])
    vel = rel * turn + flow                                                # (8.1)
    speed = abs(vel)
    if use_heading:
        return laws.View(r, X[ROW_THETA], X[ROW_OMEGA], speed, np.zeros_like(speed))
    if not full:
        return laws.View(r, np.angle(vel), X[ROW_OMEGA], speed, np.zeros_like(speed))
    du, dv, _ = body_accel(X, U_applied, plant)
    acc = (du + 1j * dv + 1j * X[ROW_OMEGA] * rel) * turn                   # r''
    if jet is not None:
        acc = acc + jet.rate(vel)
    rate = inner(1j * vel, acc) / speed ** 2
    return laws.View(r, np.angle(vel), rate, speed, inner(vel, acc) / speed)


def drag_moment_accel(X: RealArray, plant: Plant) -> RealArray:
    """
    Return the yaw acceleration of the centre-of-pressure drag moment, (A.3), (A.13).

    Parameters
    ----------
    X : array_like, shape (6, N)
        States (rows of :mod:`models`).
    plant : Plant
        Physical parameters.

    Returns
    -------
    ndarray, shape (N,)
        ``h' = -(l1/I0) D sin(beta) = -(l1/I0) h s v`` (rad/s^2) for ``rigid_cop``, else 0
        (:meth:`vehicles.base.VehicleModel.drag_moment_accel`).

    """
    return plant.model.drag_moment_accel(X, plant)


def steering_force(a: RealArray, X: RealArray, plant: Plant,
                   cancel_drag_moment: bool = True) -> RealArray:
    """
    Return the steering force that gives the yaw acceleration ``a``, (7.3), (8.11), (A.20).

    Parameters
    ----------
    a : array_like, shape (N,)
        Desired yaw acceleration omega' (rad/s^2).
    X : array_like, shape (6, N)
        States (rows of :mod:`models`).
    plant : Plant
        Physical parameters.
    cancel_drag_moment : bool, optional
        Subtract the drag moment h' of the centre-of-pressure model (A.20).

    Returns
    -------
    ndarray, shape (N,)
        The model's steering input for ``a`` (:meth:`vehicles.base.VehicleModel.steering`):
        ``F = -(I0/l)(a - h')`` (N) for the thesis' rigid bodies. (7.3) prints I0/I;
        ``omega' = -(l/I0) F`` (6.14) requires I0/l (errata). Without ``cancel_drag_moment``
        the law takes the body as one without a drag moment (``l1 = 0``).

    """
    if not cancel_drag_moment and plant.model.drag_moment:
        plant = replace(plant, l1=0.0)
    return plant.model.steering(X, a, plant)


def command_limits(sc: Scenario) -> RealArray:
    """
    Return the bounds on the magnitude of each input row.

    Parameters
    ----------
    sc : scenario.Scenario
        Its command limits (0 = none).

    Returns
    -------
    ndarray, shape (2,)
        (``|T|``, ``|F|``) bounds (N) for rigid bodies; (unused, turn input) for particles, rad/s^2
        (second order) or rad/s (first order); inf where there is no limit.

    """
    model = vehicle_model(sc.model)
    if model.rigid:
        limits = (sc.max_thrust, sc.max_steering_force)
    else:
        limits = (0.0, sc.max_turn_rate if model.first_order else sc.max_angular_accel)
    return np.array([v if v > 0 else np.inf for v in limits])


def law_units(sc: Scenario) -> tuple[float, float]:
    """
    Return the units of length L and time T (m, s) the particle laws are written in.

    Parameters
    ----------
    sc : scenario.Scenario
        The scenario.

    Returns
    -------
    (float, float)
        (1, 1) but for aircraft (``plant_backend: jsbsim``), whose speed V is not 1: L / T = V
        makes them unit-speed particles, and a circle of radius ``R = 1/|omega0|`` takes L = R,
        T = R / V (the thesis' unit circle, flown in R / V seconds per radian); the parallel
        law has no length, T = 1 s, L = V. Only the cross term sigma of the circular
        backstepping law depends on the choice (:class:`laws.Circular`); docs/aircraft.md.

    """
    if not aircraft.flown(sc):
        return 1.0, 1.0
    radius = formations.of(sc).radius(sc)
    if radius is not None:
        return radius, radius / sc.airspeed
    return sc.airspeed, 1.0


def pattern_law(sc: Scenario) -> laws.Moments | laws.Slots | None:
    """
    Return the phase potential of the scenario's symmetric pattern.

    Parameters
    ----------
    sc : scenario.Scenario
        Its pattern, pattern_M, pattern_gain, pattern_gain_M and pattern_form.

    Returns
    -------
    laws.Moments or laws.Slots or None
        Moments with ``K_m = pattern_gain`` (m = 1..floor(N/2) splay, m < M symmetric) and
        ``K_M = -pattern_gain_M``; or slots with gain pattern_gain and the offsets
        :attr:`parameters.Scenario.pattern_offsets`; None without a pattern.

    """
    if sc.pattern == 'none':
        return None
    if sc.pattern_slots:
        return laws.Slots(sc.pattern_gain, sc.pattern_offsets)
    return laws.Moments(sc.pattern_gains)


class Controller:
    """
    Decentralised formation controller of one scenario (see :mod:`scenario`).

    The same object serves the whole fleet (simulator) or one vehicle (node): ``command``
    takes the views of every vehicle known, the state of the vehicles ``idx`` it commands,
    and returns their inputs. The PI law (8.24) keeps one integrator per commanded vehicle.

    Parameters
    ----------
    sc : scenario.Scenario
        The validated scenario (model, formation, controller, gains, limits).

    Attributes
    ----------
    plant : models.Plant
        Physical parameters, ``Plant.of(sc)``.
    still : models.Plant
        The same without the flow: what a vehicle predicts itself with (:meth:`predict`), its
        flow added as steady.
    formation : laws.Parallel or laws.Circular
        The formation law over the whole fleet.
    limits : ndarray, shape (2,)
        :func:`command_limits`.
    law : steering.SteeringLaw
        The steering law, ``steering.law(sc)``.
    integral : ndarray or None
        The PI integrator of each commanded vehicle (rad/s s), created at the first command.
    rates : bool
        Whether the laws take the flow's change along each path into account (:meth:`jet`,
        :func:`flow.uses_flow_rates`): a known flow that is not uniform and steady.
    safety : safety.Layer or None
        The safety layer of particles (``safety: on``), between the law and the actuators.
    filtered : safety.Filtered or None
        What the layer did at the last :meth:`command`.

    """

    def __init__(self, sc: Scenario) -> None:
        self.sc = sc
        self.plant = Plant.of(sc)
        self.still = Plant.of(replace(sc, flow=(0.0, 0.0), flow_model='uniform'))
        self.rigid = self.plant.model.rigid
        self.speed = vehicle_speed(sc) if not self.rigid else 1.0
        coupling = None if sc.all_to_all else sc.comm_graph.coupling()
        cross = 1.0 / math.prod(law_units(sc)) ** 2
        self.formation = formations.of(sc).law(sc, coupling, pattern_law(sc), cross)
        self._couplings: dict[bytes, laws.Coupling] = {}
        self.use_heading = (formations.of(sc).steers_heading and sc.flow_source == 'known'
                            and self.plant.flow.uniform and self.plant.flow.value == 0)
        self.full = steering.uses_held_force(sc)
        self.rates = uses_flow_rates(sc)
        self.law = steering.law(sc)
        self.integral: RealArray | None = None
        self.limits = command_limits(sc)
        self.safety = None if self.rigid else safety.of(sc)
        self.filtered: safety.Filtered | None = None
        self.shift: RealArray | None = None

    def thrust(self, X: RealArray) -> RealArray:
        """Return the thrust of ``X`` (6, n), (7.1)/(8.10): (n,) N; 0 for particles."""
        if not self.rigid:
            return np.zeros(X.shape[1:])
        return thrust(X, self.sc.u0, self.sc.K_f, self.plant)

    def flow(self,
             flow: complex | ComplexArray | None) -> complex | ComplexArray:
        """
        Return the flow the vehicles use: ``flow`` (complex, or one per vehicle), else uniform.

        Raises
        ------
        ValueError
            ``flow`` is None and the scenario's flow is not uniform (no flow to assume).

        """
        if flow is not None:
            return flow
        if not self.plant.flow.uniform:
            raise ValueError(f'the {self.plant.flow.model} flow is not uniform: give each '
                             f"vehicle's flow")
        return self.plant.flow.value

    def jet(self, X: RealArray, flow: complex | ComplexArray | None) -> Jet | None:
        """
        Return the known flow's derivatives at the vehicles ``X`` (6, n), or None.

        ``flow`` (n,) is the flow each of them has (:meth:`flow`); None where the laws take the
        flow as uniform and steady (``rates`` false).
        """
        if not self.rates:
            return None
        return self.plant.flow.jet(X[ROW_X], X[ROW_Y], np.asarray(self.flow(flow)))

    def flow_ahead(self, X: RealArray, flow: complex | ComplexArray | None,
                   delay: float = 0.0) -> complex | ComplexArray:
        """
        Return the flow at the state :meth:`predict` gives: ``f + lead f'`` where it is known.

        Parameters
        ----------
        X : array_like, shape (6, n)
            The sampled states (not predicted).
        flow : complex or array_like of complex, shape (n,), optional
            The flow each vehicle has at its sample (:meth:`flow`).
        delay : float, optional
            As for :meth:`predict`.

        Returns
        -------
        complex or ndarray of complex
            ``flow`` itself where the laws take it as steady (``rates`` false) or nothing
            is predicted; otherwise the flow one lead later along the path, to first order
            (``f'`` of the sampled velocity, :meth:`flowfields.Jet.rate`).

        """
        flow = self.flow(flow)
        jet = self.jet(X, flow)
        if jet is None or self.sc.hold_prediction == 'none':
            return flow
        lead = delay + self.sc.command_lead
        return flow + lead * jet.rate(ground_velocity(X, flow))

    def predict(self, X: RealArray, U_held: RealArray,
                flow: complex | ComplexArray | None = None,
                delay: float = 0.0) -> RealArray:
        """
        Return the state a command is computed for: ``X`` predicted to the middle of its hold.

        Parameters
        ----------
        X : array_like, shape (6, n)
            The sampled states.
        U_held : array_like, shape (2, n)
            The inputs held until the new command acts (the previous command).
        flow : complex or array_like of complex, shape (n,), optional
            The flow each vehicle uses (:meth:`flow`), taken as steady over the prediction.
        delay : float, optional
            Seconds from the sample to the time the new command acts (real time: the delay a
            vehicle measures); 0 in lockstep and offline.

        Returns
        -------
        ndarray, shape (6, n)
            One RK4 step of the model over ``delay + sc.command_lead`` (:func:`models.integrate`;
            errata, sampled-data laws): a command held
            over ``[t, t + h]`` and computed for the state at ``t + h/2`` makes each period a
            midpoint-rule step of the continuous closed loop, whose error is of order h^2
            instead of the zero-order hold's h. ``X`` itself, whatever the delay, when
            ``hold_prediction`` is none.

        """
        if self.sc.hold_prediction == 'none':
            return np.array(X, float)
        lead = delay + self.sc.command_lead
        if self.speed != 1.0:                          # the laws' units (aircraft)
            X = np.array(X, float)
            X[ROW_X:ROW_Y + 1] /= self.speed
        X = integrate(X, U_held, lead, 1, self.still)
        if self.speed != 1.0:
            X[ROW_X:ROW_Y + 1] *= self.speed
        drift = lead * np.asarray(self.flow(flow))
        X[ROW_X] += drift.real
        X[ROW_Y] += drift.imag
        return X

    def view(self, X: RealArray, F_held: RealArray | None = None,
             flow: complex | ComplexArray | None = None,
             gust: complex | ComplexArray = 0.0) -> laws.View:
        """
        Return the particle view of the vehicles ``X``: what each vehicle shares with the others.

        Parameters
        ----------
        X : array_like, shape (6, n)
            Their states.
        F_held : array_like, shape (n,), optional
            Steering force held from the last period (N), for the exact course rate of the
            full and PI laws; zero by default.
        flow : array_like of complex, shape (n,), optional
            The flow each vehicle uses (m/s): its known local flow or its estimate; the
            scenario's uniform flow by default (:meth:`flow`).
        gust : complex or array_like of complex, optional
            A gust on top of ``flow`` (m/s, :mod:`world`), which the vehicles are not told:
            the view is then of the true motion in ``flow + gust`` (the metrics'), the
            derivatives still those of the flowfield.

        Returns
        -------
        laws.View
            :func:`particle_view` or :func:`rigid_view`, with the known flow's derivatives
            (:meth:`jet`).

        """
        flow = self.flow(flow)
        jet = self.jet(X, flow)
        flow = flow + gust
        if not self.rigid:
            return particle_view(X, flow, jet, self.speed)
        held = np.zeros(X.shape[1:]) if F_held is None else F_held
        U_applied = np.stack([self.thrust(X), held])
        return rigid_view(X, U_applied, self.plant, flow, self.use_heading, self.full, jet)

    def formation_of(self, members: BoolArray | None = None) -> laws.Formation:
        """
        Return the formation law over the fleet vehicles ``members`` (bool mask; None = all).

        The informed vehicles, the slot offsets of a slot pattern and the communication graph
        are restricted to the members (a vehicle's view holds itself and the neighbours it
        hears); the moments of a moment pattern are means over the members.
        """
        f = self.formation
        if members is None:
            return f
        members = np.asarray(members, bool)
        changes: dict[str, Any] = {}
        if isinstance(f, laws.Circular):
            changes['informed'] = np.asarray(f.informed)[members]
            if isinstance(f.pattern, laws.Slots):
                changes['pattern'] = replace(f.pattern, beta=f.pattern.beta[members])
        if f.coupling is not None:
            key = members.tobytes()
            if key not in self._couplings:
                if len(self._couplings) > 64:
                    self._couplings.clear()
                self._couplings[key] = self.sc.comm_graph.coupling(members)
            changes['coupling'] = self._couplings[key]
        return replace(f, **changes)

    def phase_accel(self, view: laws.View, idx: laws.Index,
                    members: BoolArray | None = None) -> RealArray:
        """
        Return the desired phase acceleration of the vehicles ``idx``.

        Parameters
        ----------
        view : laws.View
            Views of the vehicles known.
        idx : index
            The vehicles commanded, into the vehicles of ``view``.
        members : ndarray of bool, shape (N,), optional
            The fleet vehicles ``view`` holds; None = the whole fleet.

        Returns
        -------
        ndarray, shape (n,)
            (rad/s^2): :meth:`steering.SteeringLaw.phase_accel` of the scenario's law
            (backstepping (3.7), (3.14), (4.3), (4.8), (7.12), (7.25), proportional (5.5), or
            PI (8.24), which advances the integrator by one control period).

        """
        lam, self.integral = self.law.phase_accel(self.formation_of(members), view, idx, self.sc,
                                                  self.integral)
        return lam

    def command(self, view: laws.View, X: RealArray, idx: laws.Index = slice(None),
                members: BoolArray | None = None,
                flow: complex | ComplexArray | None = None) -> RealArray:
        """
        Return the inputs of the vehicles ``idx`` of ``view``.

        Parameters
        ----------
        view : laws.View
            Views of the vehicles known.
        X : array_like, shape (6, n)
            The commanded vehicles' own states.
        idx : index, optional
            The commanded vehicles, into the vehicles of ``view``; all by default.
        members : ndarray of bool, shape (N,), optional
            The fleet vehicles the view holds when it is not the whole fleet (a vehicle that
            hears only its live neighbours); None = the whole fleet.
        flow : array_like of complex, shape (n,), optional
            The flow each commanded vehicle uses (m/s), as in :meth:`view`.

        Returns
        -------
        ndarray, shape (2, n)
            Rigid bodies: thrust (7.1) and steering force (7.3), (8.11), (A.20) (N); particles:
            row 1 the body angular acceleration (5.4) (rad/s^2) or, first order, the turn rate
            (5.1) (rad/s). Clipped to ``limits``.

        """
        sc = self.sc
        U = np.zeros((2,) + X.shape[1:])
        if self.law.order == 1:
            w = self.law.phase_rate(self.formation_of(members), view, idx)
            flow = self.flow(flow)
            U[1] = body_rate_from_inertial(w, X[ROW_THETA], flow / self.speed,
                                           self.jet(X, flow))
            if self.safety is not None:
                U[1] = self.safe_turn_rate(U[1], view, idx, flow)
            return self.saturate(U)
        before = self.integral
        lam = self.phase_accel(view, idx, members)
        if self.rigid:
            U[0] = self.thrust(X)
            U[1] = steering_force(lam, X, self.plant, sc.cancel_drag_moment)
        else:
            flow = self.flow(flow)
            if self.safety is not None:
                lam = self.safe_phase_accel(lam, view, X, idx, members, flow)
            U[1] = body_accel_from_inertial(lam, X[ROW_THETA], X[ROW_OMEGA], flow / self.speed,
                                            self.jet(X, flow))
        out = self.saturate(U)
        if sc.anti_windup and self.law.integrates:
            self._hold_integral(before, U[1] != out[1])
        return out

    def safe_turn_rate(self, u: RealArray, view: laws.View, idx: laws.Index,
                       flow: complex | ComplexArray) -> RealArray:
        """
        Return the turn rates ``u`` (rad/s) of the vehicles ``idx`` through the safety layer.

        Each vehicle filters against every vehicle of ``view`` within the sensing range
        (:func:`safety.filter_turn_rates`), at the headings of their velocities through the
        ``flow`` (the commanded vehicles' own flow: a uniform flow is the same at both vehicles
        of a pair, and cancels from their relative motion). What it did is kept in ``filtered``.
        """
        if self.safety is None:
            return u
        ground = view.speed * view.e
        f = np.asarray(flow)
        if f.ndim and f.shape != ground.shape:             # one vehicle's flow: uniform
            f = np.mean(f, axis=-1, keepdims=True)
        heading = np.angle(ground - f)
        self.filtered = safety.filter_turn_rates(self.safety, view.r, heading, u, idx)
        return self.filtered.u

    def safe_phase_accel(self, lam: RealArray, view: laws.View, X: RealArray,
                         idx: laws.Index, members: BoolArray | None,
                         flow: complex | ComplexArray) -> RealArray:
        """
        Return the phase accelerations of second-order particles that track the filtered rate.

        The law's desired phase rate phi is turned into the body turn rate it asks for (5.1),
        filtered (:meth:`safe_turn_rate`) and turned back: ``phi_s = phi + g (u_s - u)``. The
        steering law then tracks phi_s instead of phi: ``lam + k (phi_s - phi) + (phi_s -
        phi)'``, k its gain (backstepping kappa, proportional K_p), the shift's rate the
        difference of two periods' (kept in ``shift``): its error ``z = rate - phi_s`` decays at
        the rate k (docs/separation.md, "Second order: through the backstepping chain").
        """
        phi = self.formation_of(members).terms(view, idx).phi
        f = np.asarray(np.divide(flow, self.speed), complex)
        u = body_rate_from_inertial(phi, X[ROW_THETA], f, self.jet(X, flow))
        shift = particle_speed_terms(X[ROW_THETA], f)[2] * (self.safe_turn_rate(
            u, view, idx, flow) - u)
        before = self.shift if self.shift is not None and self.shift.shape == shift.shape \
            else shift
        self.shift = shift
        gain = getattr(self.sc, self.law.gain)
        return lam + gain * shift + (shift - before) / self.sc.dt_control

    def _hold_integral(self, before: RealArray | None, clipped: BoolArray) -> None:
        """Anti-windup: undo this period's integration for the vehicles whose steering clipped."""
        if self.integral is None or not clipped.any():
            return
        kept = np.zeros_like(self.integral) if before is None else before
        self.integral = np.where(clipped, kept, self.integral)

    def saturate(self, U: RealArray) -> RealArray:
        """Return the inputs U (2, n) with each row clipped to its :func:`command_limits`."""
        limits = self.limits.reshape((2,) + (1,) * (np.ndim(U) - 1))
        return np.clip(U, -limits, limits)

    def saturated(self, U: RealArray) -> BoolArray:
        """Return (n,) bool: whether each vehicle's input U (2, n) sits on a limit."""
        return np.any(abs(np.asarray(U)) >= self.limits[:, None] * (1 - 1e-9), axis=0)
