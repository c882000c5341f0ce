"""
Vehicle models as state-derivative functions, and the RK4 integrator kept apart from them.

Every model uses the same state layout, an array ``X`` of shape (6, N) with rows
``x, y, theta, omega, u, v`` (m, m, rad, rad/s, m/s, m/s), and an input ``U`` of shape (2, N):

========================  =====================================  ================================
model                     ``U[0]``                               ``U[1]``
========================  =====================================  ================================
``first_order``  (1.1)    unused                                 turn rate theta' (rad/s)
``second_order`` (1.3)    unused                                 angular acceleration a (rad/s^2)
``rigid``        (6.15)   thrust T along body x (N)              steering force F at the tail (N)
``rigid_couple`` (8.22)   thrust T (N)                           moment-couple force F (N)
``rigid_cop``    (A.3)    thrust T (N)                           steering force F at the tail (N)
========================  =====================================  ================================

``u, v`` are the body-frame velocity relative to the (uniform, steady) flow ``f``; the
ground velocity is ``(u + i v) e^{i theta} + f`` (8.1). Particles keep ``u = 1, v = 0``.
"""
from dataclasses import dataclass

import numpy as np

X, Y, THETA, OMEGA, U, V = range(6)
STATE_NAMES = ('x', 'y', 'theta', 'omega', 'u', 'v')
PARTICLE_MODELS = ('first_order', 'second_order')
RIGID_MODELS = ('rigid', 'rigid_couple', 'rigid_cop')
MODELS = PARTICLE_MODELS + RIGID_MODELS


@dataclass(frozen=True)
class Plant:
    """
    Physical parameters of one fleet of identical vehicles.

    Parameters
    ----------
    model : one of MODELS
    flow : uniform steady flow f = fx + i fy (m/s)
    m0 : mass (kg); I0 : yaw moment of inertia (kg m^2)
    l : steering-force arm behind the centre of mass (m)
    h : drag coefficient, D = h s^2 (kg/m), h = rho S C_D / 2 (6.15)
    l1 : centre of pressure ahead of the centre of mass (m), ``rigid_cop`` only (A.1)
    """

    model: str = 'second_order'
    flow: complex = 0j
    m0: float = 1.0
    I0: float = 0.1
    l: float = 0.5
    h: float = 5.0
    l1: float = 0.0


def body_accel(X_, U_, plant):
    """
    Return (u', v', omega') of the rigid-body models, (6.15), (8.9), (8.22), (A.3).

    Drag ``D = h s^2`` opposes the flow-relative velocity, so ``D cos(beta) = h s u`` and
    ``D sin(beta) = h s v``. Written in flow-relative u, v, the uniform steady flow drops out.
    """
    u, v, w = X_[U], X_[V], X_[OMEGA]
    thrust, force = U_[0], U_[1]
    hs = plant.h * np.hypot(u, v)
    side = 0.0 if plant.model == 'rigid_couple' else force
    du = (thrust - hs * u) / plant.m0 + v * w
    dv = (side - hs * v) / plant.m0 - u * w
    dw = -plant.l * force / plant.I0
    if plant.model == 'rigid_cop':
        dw = dw - plant.l1 * hs * v / plant.I0
    return du, dv, dw


def deriv(X_, U_, plant):
    """Return dX/dt for the model ``plant.model``; see the module docstring for the layout."""
    dX = np.empty_like(X_)
    c, s = np.cos(X_[THETA]), np.sin(X_[THETA])
    if plant.model in PARTICLE_MODELS:
        dX[X], dX[Y] = c, s                                  # (1.1), (1.3)
        dX[U:] = 0.0
        if plant.model == 'first_order':
            dX[THETA], dX[OMEGA] = U_[1], 0.0
        else:
            dX[THETA], dX[OMEGA] = X_[OMEGA], U_[1]
    else:
        u, v = X_[U], X_[V]
        dX[X], dX[Y] = u * c - v * s, u * s + v * c          # (6.7)
        dX[THETA] = X_[OMEGA]
        dX[U], dX[V], dX[OMEGA] = body_accel(X_, U_, plant)
    if plant.flow:
        dX[X] += plant.flow.real                             # (1.4), (1.7), (8.1)
        dX[Y] += plant.flow.imag
    return dX


def rk4_step(X_, U_, dt, plant):
    """Advance ``X`` by one classical Runge-Kutta step of ``dt`` seconds with ``U`` held."""
    k1 = deriv(X_, U_, plant)
    k2 = deriv(X_ + 0.5 * dt * k1, U_, plant)
    k3 = deriv(X_ + 0.5 * dt * k2, U_, plant)
    k4 = deriv(X_ + dt * k3, U_, plant)
    return X_ + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def integrate(X_, U_, dt, steps, plant):
    """Apply ``steps`` RK4 steps of ``dt`` with ``U`` held (one sampled-data period)."""
    for _ in range(steps):
        X_ = rk4_step(X_, U_, dt, plant)
    return X_
