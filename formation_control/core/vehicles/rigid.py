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
The thesis' rigid bodies: tail steering (6.15), moment couple (8.22), centre of pressure (A.3).

A body of mass m0 and yaw inertia I0 with a thrust T along its axis (``U[0]``, N) and a steering
force F (``U[1]``, N) at the arm l behind the centre of mass, drag ``D = h s^2`` against the
flow-relative velocity ``u + i v`` (``s = |u + i v|``)::

    u'     = (T - h s u) / m0 + v omega         (6.15), (8.9)
    v'     = (F - h s v) / m0 - u omega         (no F for the moment couple (8.22))
    omega' = -l F / I0                          (- l1 h s v / I0: centre of pressure (A.3))

Its inverse for the laws is the feedback-linearising thrust (7.1) = (8.10) and the steering force
(7.3), (8.11), (A.20).
"""
from __future__ import annotations

from typing import Any, ClassVar

from formation_control.core import _rk4  # type: ignore[attr-defined]
from formation_control.core.geometry import RealArray
from formation_control.core.vehicles.base import (Params, ROW_OMEGA, ROW_U, ROW_V,
                                                  VehicleModel)
import numpy as np


class Rigid(VehicleModel):
    """Tail steering (6.15): the steering force F acts sideways at the arm l behind the centre."""

    name = 'rigid'
    text = 'rigid (6.15)'
    params: ClassVar[tuple[str, ...]] = ('m0', 'I0', 'l', 'h')
    tail_steering = True
    kernel = _rk4.RIGID

    def body_accel(self, X: RealArray, U: RealArray,
                   p: Params) -> tuple[RealArray, RealArray, RealArray]:
        """
        Return the body accelerations, (6.15), (8.9), (8.22), (A.3).

        Parameters
        ----------
        X : array_like, shape (6, ...)
            States (rows of :mod:`vehicles.base`).
        U : array_like, shape (2, ...)
            Thrust T and steering force F (N).
        p : models.Plant
            m0, I0, l, h (and l1 for the centre of pressure).

        Returns
        -------
        du, dv, domega : ndarray, shape ``X.shape[1:]``
            ``u' = (T - h s u) / m0 + v omega``, ``v' = (F - h s v) / m0 - u omega`` (m/s^2; no
            F in v' for the moment couple (8.22)), ``omega' = -l F / I0`` (rad/s^2; minus
            ``l1 h s v / I0`` for the centre of pressure (A.3)), ``s = |u + i v|``.

        Notes
        -----
        Drag ``D = h s^2`` opposes the flow-relative velocity, so ``D cos(beta) = h s u`` and
        ``D sin(beta) = h s v``. Written in flow-relative u, v, the uniform steady flow drops out.

        """
        u, v, w = X[ROW_U], X[ROW_V], X[ROW_OMEGA]
        thrust, force = U[0], U[1]
        hs = np.sqrt(u * u + v * v) * p.h                      # h s (faster than np.hypot)
        du = (thrust - hs * u) * (1.0 / p.m0) + v * w          # (T - h s u) / m0 + v omega
        dv = self._side(force, hs * v) * (1.0 / p.m0) - u * w  # (F - h s v) / m0 - u omega
        dw = force * (-p.l / p.I0)                             # -l F / I0
        if self.drag_moment:                                   # (A.3): drag moment
            dw = dw - hs * p.l1 * v * (1.0 / p.I0)
        return du, dv, dw

    def _side(self, force: RealArray, drag: RealArray) -> RealArray:
        """Return the side force: F less the side drag (6.15)."""
        return force - drag

    def thrust(self, X: RealArray, du: RealArray, p: Params) -> RealArray:
        """
        Return the thrust that gives the surge acceleration ``du``, (7.1) = (8.10).

        ``T = h s u - m0 v omega + m0 u'`` (N), from ``u' = (T - h s u) / m0 + v omega``; with
        ``u' = K_f (u0 - u)`` this is (7.1).
        """
        u, v = X[ROW_U], X[ROW_V]
        return p.h * np.hypot(u, v) * u - p.m0 * v * X[ROW_OMEGA] + p.m0 * du

    def steering(self, X: RealArray, dw: RealArray, p: Params) -> RealArray:
        """
        Return the steering force that gives the yaw acceleration ``dw``, (7.3), (8.11), (A.20).

        ``F = -(I0/l)(omega' - h')`` (N) from ``omega' = -(l/I0) F + h'`` (6.14), (A.3), h' the
        drag moment's (:meth:`base.VehicleModel.drag_moment_accel`). (7.3) prints I0/I; (6.14)
        requires I0/l (errata).
        """
        if self.drag_moment:
            dw = dw - self.drag_moment_accel(X, p)
        return -p.I0 * dw / p.l

    def size(self, sc: Any) -> float:
        """
        Return ``2 l`` (m): the body reaches the arm l behind its centre of mass, as far ahead.

        The thesis' l = 0.5 m gives 1 m, the length of a uniform rod of its m0 = 1 kg and
        I0 = 0.1 kg m^2 to 10 % (``sqrt(12 I0 / m0)`` = 1.095 m).
        """
        return 2.0 * float(sc.l)

    def surge_mode(self, sc: Any) -> tuple[str, float] | None:
        """Return the surge drag ``2 h u0 / m0`` (1/s): the drag's slope at u0 over the mass."""
        return '2 h u0 / m0', 2.0 * sc.h * sc.u0 / sc.m0


class RigidCouple(Rigid):
    """The moment couple (8.22): F turns the body and pushes it nowhere (no RHP zero)."""

    name = 'rigid_couple'
    text = 'rigid_couple (8.22)'
    tail_steering = False
    kernel = _rk4.RIGID_COUPLE

    def _side(self, force: RealArray, drag: RealArray) -> RealArray:
        """Return the side force: the side drag alone, the couple has no net force (8.22)."""
        return -drag


class RigidCop(Rigid):
    """Tail steering with the drag at a centre of pressure l1 ahead of the centre of mass (A.3)."""

    name = 'rigid_cop'
    text = 'rigid_cop (A.3)'
    params = ('m0', 'I0', 'l', 'h', 'l1')
    drag_moment = True
    kernel = _rk4.RIGID_COP

    def drag_moment_accel(self, X: RealArray, p: Params) -> RealArray:
        """Return ``h' = -(l1/I0) D sin(beta) = -(l1/I0) h s v`` (rad/s^2), (A.3), (A.13)."""
        return -p.l1 * p.h * np.hypot(X[ROW_U], X[ROW_V]) * X[ROW_V] / p.I0
