"""
From vehicle state to commands: particle views, flow transforms and the rigid-body forces.

:class:`Controller` is what both the offline simulator and a vehicle node call. A vehicle
computes the view of itself (:meth:`Controller.view`), shares it, and turns the views of the
vehicles it knows into its own command (:meth:`Controller.command`).
"""
from dataclasses import replace

import numpy as np

from formation_control.core import laws
from formation_control.core.geometry import inner
from formation_control.core.models import (body_accel, ground_velocity, Plant, position,
                                           RIGID_MODELS, ROW_OMEGA, ROW_THETA, ROW_U, ROW_V)
from formation_control.core.scenario import uses_held_force


def particle_speed_terms(theta, flow):
    """
    Return ``(s, gamma, g)`` for a unit-speed particle in a uniform flow f (1.4)-(1.6).

    ``s e^{i gamma} = e^{i theta} + f`` and ``gamma' = g theta'`` with
    ``g = (1 + <f, e^{i theta}>) / s^2 = 1 - <e^{i gamma}, f> / s``, the factor of (5.1).
    """
    e = np.exp(1j * theta)
    vel = e + flow
    s2 = abs(vel) ** 2
    return np.sqrt(s2), np.angle(vel), (1.0 + inner(flow, e)) / s2


def particle_view(X, flow):
    """
    View of unit-speed particles: phase gamma, rate Omega = g omega, speed s, s' (1.8), (4.9).

    Without flow this is theta, xi, 1, 0 (1.3).
    """
    s, gamma, g = particle_speed_terms(X[ROW_THETA], flow)
    w = X[ROW_OMEGA]
    s_dot = inner(flow, 1j * np.exp(1j * X[ROW_THETA])) * w / s
    return laws.View(position(X), gamma, g * w, s, s_dot)


def body_rate_from_inertial(w, theta, flow):
    """First-order transform (5.1): body turn rate u_k = w_k / g for a uniform flow."""
    return w / particle_speed_terms(theta, flow)[2]


def body_accel_from_inertial(lam, theta, omega, flow):
    """
    Transform (5.3)/(5.4): body angular acceleration a_k from the inertial one lambda_k.

    From ``gamma' = g theta'``: ``lambda = g a + g' omega``, with
    ``g' = <f, i e^{i theta}> omega (s^2 - 2 (1 + <f, e^{i theta}>)) / s^4``.
    """
    e = np.exp(1j * theta)
    s2 = abs(e + flow) ** 2
    n = 1.0 + inner(flow, e)
    g_dot = inner(flow, 1j * e) * omega * (s2 - 2.0 * n) / s2 ** 2
    return (lam - g_dot * omega) * s2 / n


def thrust(X, u0, K_f, plant):
    """Feedback-linearising thrust (7.1) = (8.10), giving u' = K_f (u0 - u) (flow-relative u)."""
    u, v = X[ROW_U], X[ROW_V]
    return plant.h * np.hypot(u, v) * u - plant.m0 * v * X[ROW_OMEGA] + plant.m0 * K_f * (u0 - u)


def rigid_view(X, U_applied, plant, use_heading, full):
    """
    View of rigid bodies.

    ``use_heading``: phase theta with rate omega, as (7.3) with (3.7) uses it. Otherwise the
    phase is the direction of the ground velocity, psi = theta + beta (7.11) or
    gamma = theta + beta_hat (8.1), with speed s or s_hat. ``full`` computes its exact rate and
    s' from the model with the input ``U_applied`` (thrust now, steering force held);
    otherwise the thesis' practical law uses omega and s' = 0 (text after 7.12).
    """
    r = position(X)
    vel = ground_velocity(X, plant.flow)
    speed = abs(vel)
    if use_heading:
        return laws.View(r, X[ROW_THETA], X[ROW_OMEGA], speed, np.zeros_like(speed))
    if not full:
        return laws.View(r, np.angle(vel), X[ROW_OMEGA], speed, np.zeros_like(speed))
    du, dv, _ = body_accel(X, U_applied, plant)
    acc = (du + 1j * dv + 1j * X[ROW_OMEGA] * (X[ROW_U] + 1j * X[ROW_V])) * np.exp(1j * X[ROW_THETA])
    rate = inner(1j * vel, acc) / speed ** 2
    return laws.View(r, np.angle(vel), rate, speed, inner(vel, acc) / speed)


def drag_moment_accel(X, plant):
    """Yaw acceleration h' = -(l1/I0) D sin(beta) of the centre-of-pressure drag (A.3), (A.13)."""
    if plant.model != 'rigid_cop':
        return np.zeros(X.shape[1])
    return -plant.l1 * plant.h * np.hypot(X[ROW_U], X[ROW_V]) * X[ROW_V] / plant.I0


def steering_force(a, X, plant, cancel_drag_moment=True):
    """
    Steering force for a yaw acceleration a: ``F = -(I0/l)(a - h')`` (7.3), (8.11), (A.20).

    (7.3) prints I0/I; omega' = -(l/I0) F (6.14) requires I0/l. ``h'`` cancels the drag
    moment of the centre-of-pressure model (A.20) when ``cancel_drag_moment``.
    """
    if cancel_drag_moment:
        a = a - drag_moment_accel(X, plant)
    return -plant.I0 * a / plant.l


def command_limits(sc):
    """(2,) bounds on |U| rows: (T, F) for rigid bodies, (-, turn input) for particles; inf = none."""
    if sc.model in RIGID_MODELS:
        limits = (sc.max_thrust, sc.max_steering_force)
    else:
        limits = (0.0, sc.max_turn_rate if sc.model == 'first_order' else sc.max_angular_accel)
    return np.array([v if v > 0 else np.inf for v in limits])


class Controller:
    """
    Decentralised formation controller of one scenario (see :mod:`scenario`).

    The same object serves the whole fleet (simulator) or one vehicle (node): ``command``
    takes the views of every vehicle known, the state of the vehicles ``idx`` it commands,
    and returns their inputs. The PI law (8.24) keeps one integrator per commanded vehicle.
    """

    def __init__(self, sc):
        self.sc = sc
        self.plant = Plant.of(sc)
        self.rigid = sc.model in RIGID_MODELS
        if sc.formation == 'parallel':
            self.formation = laws.Parallel(sc.K)
        else:
            self.formation = laws.Circular(sc.K, sc.omega0, sc.c0_c, sc.informed_mask)
        self.use_heading = sc.formation == 'parallel' and sc.flow_c == 0
        self.full = uses_held_force(sc)
        self.integral = None
        self.limits = command_limits(sc)

    def thrust(self, X):
        """Thrust (7.1)/(8.10) for rigid bodies, zero for particles."""
        if not self.rigid:
            return np.zeros(X.shape[1])
        return thrust(X, self.sc.u0, self.sc.K_f, self.plant)

    def view(self, X, F_held=None):
        """Particle view of the vehicles in ``X`` (what each vehicle shares with the others)."""
        if not self.rigid:
            return particle_view(X, self.plant.flow)
        held = np.zeros(X.shape[1]) if F_held is None else F_held
        U_applied = np.vstack([self.thrust(X), held])
        return rigid_view(X, U_applied, self.plant, self.use_heading, self.full)

    def formation_of(self, members=None):
        """The formation law over the fleet vehicles ``members`` (bool mask; None = all)."""
        f = self.formation
        if members is None or not isinstance(f, laws.Circular):
            return f
        return replace(f, informed=np.asarray(f.informed)[members])

    def phase_accel(self, view, idx, members=None):
        """Desired phase acceleration of the vehicles idx: (3.7), (3.14), (4.3), (4.8), (5.5), (8.24)."""
        sc, f = self.sc, self.formation_of(members)
        if sc.controller == 'backstepping':
            return laws.backstepping(f, view, sc.kappa, idx)
        if sc.controller == 'proportional':
            return laws.proportional(f, view, sc.K_p, idx)
        err = f.terms(view, idx).phi - view.rate[idx]
        if self.integral is None:
            self.integral = np.zeros_like(err)
        self.integral = self.integral + err * sc.dt_control
        return sc.K_P * err + sc.K_I * self.integral

    def command(self, view, X, idx=slice(None), members=None):
        """
        Inputs U (2, n) for the vehicles idx of ``view`` whose own states are ``X`` (6, n).

        ``members`` (bool mask over the fleet) names the vehicles the view holds when it is not
        the whole fleet (a vehicle that hears only its live neighbours).
        """
        sc = self.sc
        U_ = np.zeros((2, X.shape[1]))
        if sc.controller == 'first_order':
            w = laws.first_order(self.formation_of(members), view, idx)
            U_[1] = body_rate_from_inertial(w, X[ROW_THETA], self.plant.flow)
            return self.saturate(U_)
        lam = self.phase_accel(view, idx, members)
        if self.rigid:
            U_[0] = self.thrust(X)
            U_[1] = steering_force(lam, X, self.plant, sc.cancel_drag_moment)
        else:
            U_[1] = body_accel_from_inertial(lam, X[ROW_THETA], X[ROW_OMEGA], self.plant.flow)
        return self.saturate(U_)

    def saturate(self, U_):
        """Clip each input row to its limit (:func:`command_limits`)."""
        return np.clip(U_, -self.limits[:, None], self.limits[:, None])

    def saturated(self, U_):
        """(n,) bool: the vehicle's command sits on a limit."""
        return np.any(abs(np.asarray(U_)) >= self.limits[:, None] * (1 - 1e-9), axis=0)
