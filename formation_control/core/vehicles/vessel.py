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
A marine surface vessel: 3-DOF manoeuvring dynamics with added mass, damping and Coriolis terms.

Fossen's 3-DOF manoeuvring model (T. I. Fossen, *Handbook of Marine Craft Hydrodynamics and
Motion Control*, Wiley 2011; 2nd ed. 2021: the manoeuvring model of surface vessels) in surge u,
sway v and yaw rate r = omega, relative to the current::

    M nu_r' + C(nu_r) nu_r + D(nu_r) nu_r = tau,     nu_r = nu - nu_c = (u, v, r)

with the centre of gravity at the body origin (x_g = 0) and the coupling derivatives
Y_rdot = N_vdot = Y_r = N_v = 0 (the diagonal model, for simplicity: the sway-yaw coupling of
a port-starboard and fore-aft symmetric hull), so
``M = diag(m11, m22, m33)``, ``m11 = m0 - X_udot``, ``m22 = m0 - Y_vdot``, ``m33 = I0 - N_rdot``;
``C = C_RB + C_A`` the rigid-body and added-mass Coriolis-centripetal matrices, skew-symmetric;
``D = diag(d11, d22, d33)``, ``d11 = -X_u - X_uu |u|``, ``d22 = -Y_v - Y_vv |v|``,
``d33 = -N_r - N_rr |r|`` (linear and quadratic damping; X_uu is X_|u|u)::

    m11 u' = tau_u + m22 v r - d11 u
    m22 v' =       - m11 u r - d22 v
    m33 r' = tau_r + (m11 - m22) u v - d33 r        ((m11 - m22) u v: the Munk moment)

In a uniform steady current nu_c is constant in the earth frame; written in the flow-relative
u, v (the package's state rows) it drops out of the body dynamics, as for the thesis' rigid
bodies (8.1) (Fossen's property of irrotational constant currents: the rigid-body terms in
nu and the added-mass terms in nu_r combine into the model in nu_r alone).

Actuation: a propeller's surge force tau_u (``U[0]``, N, sent as the command's ``thrust``)
and a yaw moment tau_r (``U[1]``, N m, sent as its ``steering_force``) from differential
thrust or a rudder. Sway is unactuated: a surface vessel cruising on its propellers has no
sway force but a tunnel thruster's, which loses its effect at speed, and the package's laws
steer a speed and a course, so two inputs suffice; the sway velocity follows its own damped
dynamics and shows as the crab angle the practical law reads (the course of the ground
velocity, theta + beta (7.11)).

The default coefficients are CyberShip II's, a 1:70 scale supply-ship model (length 1.255 m)
of the NTNU Marine Cybernetics Laboratory: m = 23.8 kg, I_z = 1.76 kg m^2, X_udot = -2.0 kg,
Y_vdot = -10.0 kg, N_rdot = -1.0 kg m^2, X_u = -0.7225 kg/s, X_|u|u = -1.3274 kg/m,
Y_v = -0.8612 kg/s, Y_|v|v = -36.2823 kg/m, N_r = -1.9 kg m^2/s, N_|r|r = -0.75 kg m^2
(R. Skjetne, T. I. Fossen, P. V. Kokotovic, "Adaptive maneuvering, with experiments, for a
model ship in a marine control laboratory", Automatica 41(2):289-298, 2005: the diagonal
subset of its model, as widely reused; its off-diagonal and higher-order terms left out).
"""
from __future__ import annotations

from typing import Any, ClassVar

from formation_control.core.geometry import RealArray
from formation_control.core.vehicles.base import (Params, ROW_OMEGA, ROW_U, ROW_V,
                                                  VehicleModel)

COEFFICIENTS = ('X_udot', 'Y_vdot', 'N_rdot', 'X_u', 'X_uu', 'Y_v', 'Y_vv', 'N_r', 'N_rr')
"""The vessel's hydrodynamic derivatives, scenario parameters (CyberShip II's by default)."""
LENGTH = 1.255
"""CyberShip II's length overall (m), whose coefficients are the defaults."""


class Vessel(VehicleModel):
    """A surface vessel in surge, sway and yaw (Fossen 2011), thrust and yaw-moment actuated."""

    name = 'vessel'
    text = 'vessel (Fossen 3-DOF)'
    params: ClassVar[tuple[str, ...]] = ('m0', 'I0', *COEFFICIENTS)
    coefficients: ClassVar[tuple[str, ...]] = COEFFICIENTS

    @staticmethod
    def masses(p: Params) -> tuple[Any, Any, Any]:
        """Return ``m11, m22, m33``: rigid-body mass and inertia plus added mass (kg, kg m^2)."""
        c = p.coeffs
        return p.m0 - c['X_udot'], p.m0 - c['Y_vdot'], p.I0 - c['N_rdot']

    @staticmethod
    def damping(X: RealArray, p: Params) -> tuple[RealArray, RealArray, RealArray]:
        """Return the damping forces ``d11 u, d22 v, d33 r`` (N, N, N m) of ``D(nu_r) nu_r``."""
        c, u, v, r = p.coeffs, X[ROW_U], X[ROW_V], X[ROW_OMEGA]
        return (-(c['X_u'] + c['X_uu'] * abs(u)) * u, -(c['Y_v'] + c['Y_vv'] * abs(v)) * v,
                -(c['N_r'] + c['N_rr'] * abs(r)) * r)

    def body_accel(self, X: RealArray, U: RealArray,
                   p: Params) -> tuple[RealArray, RealArray, RealArray]:
        """
        Return ``u', v', r'`` from ``M nu' + C(nu) nu + D(nu) nu = tau`` (the module docstring).

        Parameters
        ----------
        X : array_like, shape (6, ...)
            States; u, v relative to the current, omega = r.
        U : array_like, shape (2, ...)
            Surge force tau_u (N) and yaw moment tau_r (N m).
        p : models.Plant
            m0, I0 and the hydrodynamic derivatives (``p.coeffs``).

        Returns
        -------
        du, dv, dr : ndarray, shape ``X.shape[1:]``
            (m/s^2, m/s^2, rad/s^2).

        """
        u, v, r = X[ROW_U], X[ROW_V], X[ROW_OMEGA]
        m11, m22, m33 = self.masses(p)
        du_drag, dv_drag, dr_drag = self.damping(X, p)
        return ((U[0] + m22 * v * r - du_drag) / m11, (-m11 * u * r - dv_drag) / m22,
                (U[1] + (m11 - m22) * u * v - dr_drag) / m33)

    def thrust(self, X: RealArray, du: RealArray, p: Params) -> RealArray:
        """Return ``tau_u = m11 u' - m22 v r + d11 u`` (N): the surge force for ``u' = du``."""
        m11, m22, _ = self.masses(p)
        return m11 * du - m22 * X[ROW_V] * X[ROW_OMEGA] + self.damping(X, p)[0]

    def steering(self, X: RealArray, dw: RealArray, p: Params) -> RealArray:
        """Return ``tau_r = m33 r' - (m11 - m22) u v + d33 r`` (N m), the moment for r' = dw."""
        m11, m22, m33 = self.masses(p)
        return m33 * dw - (m11 - m22) * X[ROW_U] * X[ROW_V] + self.damping(X, p)[2]

    def size(self, sc: Any) -> float:
        """Return :data:`LENGTH` (m), CyberShip II's length overall (its beam is 0.29 m)."""
        return LENGTH

    def surge_mode(self, sc: Any) -> tuple[str, float] | None:
        """Return the surge damping's slope at u0 over the surge mass (1/s)."""
        rate = -(sc.X_u + 2.0 * sc.X_uu * sc.u0) / (sc.m0 - sc.X_udot)
        return '-(X_u + 2 X_uu u0) / (m0 - X_udot)', rate
