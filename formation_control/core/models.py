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
The state layout, the plant's parameters and the RK4 integrator, kept apart from the models.

Every model uses the same state layout, an array ``X`` of shape (6, N) with rows
``x, y, theta, omega, u, v`` (m, m, rad, rad/s, m/s, m/s), and an input ``U`` of shape (2, N)
whose rows are the model's (:mod:`vehicles`, the table of models by name).

``u, v`` are the body-frame velocity relative to the flow ``f``; the ground velocity is
``(u + i v) e^{i theta} + f`` (8.1), with ``f = f(t, x, y)`` the :mod:`flowfields` flow at the
vehicle's own place and time (uniform and steady in the thesis). Particles keep ``u = 1, v = 0``.

:func:`deriv` is the right-hand side (the model's :meth:`vehicles.base.VehicleModel.rates` plus
the flow) and :func:`rk4_step` one classical RK4 step on it; :func:`integrate` takes the same
steps in a uniform steady flow with the model's compiled RK4 (``_rk4.c``, vehicle by vehicle)
where it has one, and agrees with :func:`rk4_step` to rounding (test_rigid.py); in a flow that
is not uniform, where every stage needs its own positions, or for a model without a kernel, it
takes :func:`rk4_step`.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from formation_control.core import _rk4  # type: ignore[attr-defined]
from formation_control.core.flowfields import Flowfield
from formation_control.core.geometry import ComplexArray, RealArray
from formation_control.core.vehicles import vehicle_model, VehicleModel
from formation_control.core.vehicles.base import (ROW_OMEGA, ROW_THETA, ROW_U, ROW_V, ROW_X,
                                                  ROW_Y, STATE_NAMES)
import numpy as np

if TYPE_CHECKING:
    from formation_control.core.parameters import Scenario

__all__ = ['body_accel', 'deriv', 'ground_velocity', 'integrate', 'Plant', 'position',
           'rk4', 'rk4_step', 'ROW_OMEGA', 'ROW_THETA', 'ROW_U', 'ROW_V', 'ROW_X', 'ROW_Y',
           'STATE_NAMES']


@dataclass(frozen=True)
class Plant:
    """
    Physical parameters of one fleet of identical vehicles (no defaults: see :meth:`Plant.of`).

    Attributes
    ----------
    model : vehicles.base.VehicleModel
        The vehicle model (:func:`vehicles.vehicle_model` of the scenario's ``model``).
    flow : flowfields.Flowfield
        The flow ``f(t, x, y) = fx + i fy`` (m/s); uniform and steady in the thesis.
    m0 : float
        Mass (kg).
    I0 : float
        Yaw moment of inertia (kg m^2).
    l : float
        Steering-force arm behind the centre of mass (m).
    h : float
        Drag coefficient, ``D = h s^2`` (kg/m), ``h = rho S C_D / 2`` (6.15).
    l1 : float
        Centre of pressure ahead of the centre of mass (m), ``rigid_cop`` only (A.1).
    coeffs : mapping of str to float
        The model's further coefficients (``VehicleModel.coefficients``), by parameter name.

    m0, I0, h and l1 may be arrays, one value per vehicle (the true vehicles of
    :class:`world.World`), broadcast against the vehicles of a state.

    """

    model: VehicleModel
    flow: Flowfield
    m0: float | RealArray
    I0: float | RealArray
    l: float
    h: float | RealArray
    l1: float | RealArray
    coeffs: Mapping[str, float] = field(default_factory=dict)

    @classmethod
    def of(cls, sc: Scenario) -> Plant:
        """
        Return the plant of a scenario.

        Parameters
        ----------
        sc : scenario.Scenario
            Any object with the scenario's attributes ``model, m0, I0, l, h, l1``, the model's
            coefficients and the flowfield's (:class:`flowfields.Flowfield`).

        Returns
        -------
        Plant

        """
        model = vehicle_model(sc.model)
        coeffs = {name: getattr(sc, name) for name in model.coefficients}
        return cls(model, Flowfield(sc), sc.m0, sc.I0, sc.l, sc.h, sc.l1, coeffs)


def position(X: RealArray) -> ComplexArray:
    """
    Return the position of each vehicle as a complex number.

    Parameters
    ----------
    X : array_like, shape (6, ...)
        States (see the module docstring).

    Returns
    -------
    complex or ndarray of complex, shape ``X.shape[1:]``
        ``r = x + i y`` (m, world frame).

    """
    return X[ROW_X] + 1j * X[ROW_Y]


def ground_velocity(X: RealArray,
                    flow: complex | ComplexArray) -> ComplexArray:
    """
    Return the ground (inertial) velocity of each vehicle, (8.1).

    Parameters
    ----------
    X : array_like, shape (6, ...)
        States, rows x, y, theta, omega, u, v (m, m, rad, rad/s, m/s, m/s); any trailing
        shape, e.g. (6,) for one vehicle, (6, N) for a fleet, (6, T, N) for a run.
    flow : complex or array_like of complex, broadcast to ``X.shape[1:]``
        The flow ``f = fx + i fy`` at each vehicle (m/s, world frame).

    Returns
    -------
    complex or ndarray of complex, shape ``X.shape[1:]``
        ``(u + i v) e^{i theta} + f`` (m/s, world frame). For particles (u = 1, v = 0) this is
        ``e^{i theta} + f``, (1.4).

    """
    return (X[ROW_U] + 1j * X[ROW_V]) * np.exp(1j * X[ROW_THETA]) + flow


def body_accel(X: RealArray, U: RealArray,
               plant: Plant) -> tuple[RealArray, ...]:
    """
    Return the body-frame accelerations ``u', v', omega'`` of a model with body velocity.

    Parameters
    ----------
    X : array_like, shape (6, ...)
        States (rows x, y, theta, omega, u, v; see the module docstring).
    U : array_like, shape (2, ...)
        Inputs (thrust and steering input of ``plant.model``).
    plant : Plant
        A model with body velocity rows (``plant.model.rigid``).

    Returns
    -------
    du, dv, domega : ndarray, shape ``X.shape[1:]``
        The model's :meth:`vehicles.base.VehicleModel.body_accel`, e.g. (6.15), (8.22), (A.3).

    """
    return plant.model.body_accel(X, U, plant)


def deriv(X: RealArray, U: RealArray, plant: Plant,
          t: float = 0.0) -> RealArray:
    """
    Return the state derivative dX/dt of the model ``plant.model``.

    Parameters
    ----------
    X : array_like, shape (6, N)
        States, rows x, y, theta, omega, u, v (m, m, rad, rad/s, m/s, m/s).
    U : array_like, shape (2, N) or (2, 1)
        Inputs, as the module docstring's table gives them per model.
    plant : Plant
        The model and its physical parameters.
    t : float, optional
        Time (s), where the flow varies in time.

    Returns
    -------
    ndarray, shape (6, N)
        dX/dt: the model's rates in still water (:meth:`vehicles.base.VehicleModel.rates`:
        particles (1.1), (1.3); rigid bodies ``r' = (u + i v) e^{i theta}`` (6.7),
        ``theta' = omega`` and :func:`body_accel`) plus the flow, ``r' += f`` (1.4), (8.1).
        Rows a model does not move are zero (u, v of particles; omega of first-order ones,
        whose turn rate is the input).

    """
    X = np.asarray(X, dtype=float)
    dX = plant.model.rates(X, U, plant)
    flow = plant.flow.value if plant.flow.uniform else \
        plant.flow(t, X[ROW_X], X[ROW_Y])                    # at each vehicle's own place
    dX[ROW_X] += np.real(flow)                               # (1.4), (1.7), (8.1)
    dX[ROW_Y] += np.imag(flow)
    return dX


def rk4(rates: Callable[[RealArray, float], RealArray], X: RealArray, dt: float,
        t: float = 0.0) -> RealArray:
    """
    Return the state after one classical Runge-Kutta (RK4) step of ``X' = rates(X, t)``.

    Parameters
    ----------
    rates : callable
        ``rates(X, t)``: dX/dt, shape of ``X`` (the inputs held inside it).
    X : array_like, shape (6, ...)
        State at the start of the step.
    dt : float
        Step (s); negative steps integrate backwards.
    t : float, optional
        Time at the start of the step (s); the stages are at t, t + dt/2, t + dt/2, t + dt.

    Returns
    -------
    ndarray, shape of ``X``
        ``X + (dt/6)(k1 + 2 k2 + 2 k3 + k4)``.

    """
    k1 = rates(X, t)
    k2 = rates(X + 0.5 * dt * k1, t + 0.5 * dt)
    k3 = rates(X + 0.5 * dt * k2, t + 0.5 * dt)
    k4 = rates(X + dt * k3, t + dt)
    return X + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def rk4_step(X: RealArray, U: RealArray, dt: float, plant: Plant,
             t: float = 0.0) -> RealArray:
    """
    Return the state after one classical Runge-Kutta (RK4) step with the input held.

    Parameters
    ----------
    X : array_like, shape (6, N)
        State at the start of the step (see :func:`deriv`).
    U : array_like, shape (2, N) or (2, 1)
        Input, held over the step.
    dt : float
        Step (s); negative steps integrate backwards.
    plant : Plant
        The model and its physical parameters.
    t : float, optional
        Time at the start of the step (s); the stages are at t, t + dt/2, t + dt/2, t + dt.

    Returns
    -------
    ndarray, shape (6, N)
        :func:`rk4` with the stages ``k_i`` of :func:`deriv`.

    """
    return rk4(lambda X, t: deriv(X, U, plant, t), X, dt, t)


def integrate(X: RealArray, U: RealArray, dt: float, steps: int, plant: Plant,
              t: float = 0.0) -> RealArray:
    """
    Return the state after ``steps`` RK4 steps with the input held (one sampled-data period).

    Parameters
    ----------
    X : array_like, shape (6, ...)
        State at the start of the period (see :func:`deriv`): (6, N) a fleet, (6, B, N) a
        batch of fleets; not modified.
    U : array_like, shape (2, ...)
        Input, held over the period (zero-order hold), broadcast to the vehicles of ``X``;
        not modified.
    dt : float
        Integration step (s).
    steps : int
        Number of steps, ``dt_control / dt_integration`` for one control period.
    plant : Plant
        The model and its physical parameters.
    t : float, optional
        Time at the start of the period (s), where the flow varies in time.

    Returns
    -------
    ndarray, shape of ``X``
        The state ``steps * dt`` later, equal to ``steps`` calls of :func:`rk4_step` to
        rounding (test_rigid.py).

    Notes
    -----
    In a uniform steady flow this is the model's compiled RK4 (``_rk4.c``, the kernel
    ``plant.model.kernel``), vehicle by vehicle: a vehicle's numbers do not depend on the
    others, so a fleet integrated alone, in a batch or as one vehicle of a node are the same
    bit for bit. cos and sin of each stage's heading are
    those of the step's turned by the stage's increment (a Taylor series below 0.05 rad);
    omega' held, the last stage's heading is the next step's. A flow that is not uniform, or a
    model without a kernel, takes :func:`rk4_step`, which evaluates the flow at every stage.

    """
    if not plant.flow.uniform or plant.model.kernel is None:
        for step in range(steps):
            X = rk4_step(X, U, dt, plant, t + step * dt)
        return X
    shape = np.shape(X)
    X = np.array(X, dtype=float, order='C')
    U = np.ascontiguousarray(np.broadcast_to(np.asarray(U, dtype=float), (2,) + shape[1:]))
    params = [np.asarray(p, dtype=float) for p in (plant.m0, plant.I0, plant.h, plant.l1)]
    if any(p.ndim for p in params):
        params = [np.broadcast_to(p, shape[1:]) for p in params]
    flow = complex(plant.flow.value)
    _rk4.integrate(X, U, np.ascontiguousarray(params), plant.model.kernel, dt, steps,
                   plant.l, flow.real, flow.imag)
    return X
