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
The state layout every vehicle model shares, and the interface a model implements.

A state ``X`` is an array of shape (6, N) (or (6, ...)) with rows ``x, y, theta, omega, u, v``
(m, m, rad, rad/s, m/s, m/s) and an input ``U`` of shape (2, N): what the rows of ``U`` are is
the model's (:mod:`vehicles` lists them). ``u, v`` are the body-frame velocity relative to the
flow: the ground velocity is ``(u + i v) e^{i theta} + f`` (8.1), so the flow drops out of the
body dynamics in a uniform steady flow.

:class:`VehicleModel` is what the rest of the package asks of a model: its capabilities
(a unit-speed particle? a turn-rate input? body velocity rows and a thrust?), the scenario
parameters it reads, its dynamics (:meth:`VehicleModel.rates`), their inverse for the laws
(:meth:`VehicleModel.inverse`: the inputs that give a surge and a yaw acceleration), its fast
surge mode and the id of its compiled RK4 kernel, if any.
"""
from __future__ import annotations

from typing import Any, ClassVar, Mapping, Protocol

from formation_control.core.geometry import RealArray
import numpy as np

ROW_X, ROW_Y, ROW_THETA, ROW_OMEGA, ROW_U, ROW_V = range(6)
STATE_NAMES = ('x', 'y', 'theta', 'omega', 'u', 'v')


class Params(Protocol):
    """The physical parameters a model reads (:class:`models.Plant`): floats or arrays."""

    @property
    def m0(self) -> Any:
        """Return the mass (kg)."""

    @property
    def I0(self) -> Any:
        """Return the yaw moment of inertia (kg m^2)."""

    @property
    def l(self) -> float:  # noqa: E743 (the thesis' name)
        """Return the steering arm (m)."""

    @property
    def h(self) -> Any:
        """Return the drag coefficient (kg/m)."""

    @property
    def l1(self) -> Any:
        """Return the centre of pressure ahead of the centre of mass (m)."""

    @property
    def coeffs(self) -> Mapping[str, float]:
        """Return the model's further coefficients by parameter name."""


class VehicleModel:
    """
    One vehicle model: capabilities, parameters, dynamics and their inverse.

    Attributes
    ----------
    name : str
        The value of the scenario parameter ``model``.
    text : str
        What it is, with its equation, for the parameter table.
    particle : bool
        A unit-speed particle (1.1), (1.3): ``u = 1, v = 0`` always, the input in ``U[1]``.
    first_order : bool
        ``U[1]`` is the turn rate theta' itself (1.1); the steering law is then first_order.
    params : tuple of str
        The scenario parameters of the vehicle it reads (``m0``, ``I0``, ...).
    coefficients : tuple of str
        Those of them :meth:`models.Plant.of` carries in ``Plant.coeffs`` (beyond m0, I0, l, h,
        l1).
    tail_steering : bool
        A side force behind the centre of mass steers it: a right-half-plane zero (errata).
    drag_moment : bool
        Drag acts at a centre of pressure ahead of the centre of mass (A.3).
    command_fields : tuple of str
        The VehicleCommand fields that carry ``U[0]`` and ``U[1]`` ('' for none).
    kernel : int or None
        The id of its compiled RK4 (``_rk4.RIGID``, ...); None integrates with numpy RK4.
    backends : tuple of str
        The plant backends (``plant_backend``) that can be the plant of its laws.

    """

    name: ClassVar[str]
    text: ClassVar[str]
    particle: ClassVar[bool] = False
    first_order: ClassVar[bool] = False
    params: ClassVar[tuple[str, ...]] = ()
    coefficients: ClassVar[tuple[str, ...]] = ()
    tail_steering: ClassVar[bool] = False
    drag_moment: ClassVar[bool] = False
    command_fields: ClassVar[tuple[str, str]] = ('thrust', 'steering_force')
    kernel: ClassVar[int | None] = None
    backends: ClassVar[tuple[str, ...]] = ('native',)

    @property
    def rigid(self) -> bool:
        """Return whether it has body velocity rows u, v and a thrust input ``U[0]``."""
        return not self.particle

    def __repr__(self) -> str:
        """Return its name, as the scenario spells it."""
        return f'<vehicle model {self.name}>'

    def speed(self, u0: float) -> float:
        """Return its cruising speed relative to the flow (m/s): u0, or 1 for particles."""
        return 1.0 if self.particle else u0

    def rates(self, X: RealArray, U: RealArray, p: Params) -> RealArray:
        """
        Return dX/dt in still water: kinematics (6.7) and :meth:`body_accel`.

        Parameters
        ----------
        X : array_like, shape (6, ...)
            States (rows of the module docstring).
        U : array_like, shape (2, ...)
            Inputs.
        p : models.Plant
            Physical parameters.

        Returns
        -------
        ndarray, shape of ``X``
            ``r' = (u + i v) e^{i theta}`` (6.7), ``theta' = omega`` and the body accelerations;
            the flow is added by :func:`models.deriv`.

        """
        dX = np.zeros(np.shape(X))
        c, s = np.cos(X[ROW_THETA]), np.sin(X[ROW_THETA])
        u, v = X[ROW_U], X[ROW_V]
        dX[ROW_X], dX[ROW_Y] = u * c - v * s, u * s + v * c
        dX[ROW_THETA] = X[ROW_OMEGA]
        dX[ROW_U], dX[ROW_V], dX[ROW_OMEGA] = self.body_accel(X, U, p)
        return dX

    def body_accel(self, X: RealArray, U: RealArray,
                   p: Params) -> tuple[RealArray, RealArray, RealArray]:
        """Return the body accelerations ``u', v', omega'`` (m/s^2, m/s^2, rad/s^2)."""
        raise NotImplementedError(f'{self.name} has no body velocity')

    def thrust(self, X: RealArray, du: RealArray, p: Params) -> RealArray:
        """
        Return ``U[0]`` that gives the surge acceleration ``du`` (m/s^2) in the state ``X``.

        Particles have no thrust: 0.
        """
        return np.zeros(np.shape(X)[1:])

    def steering(self, X: RealArray, dw: RealArray, p: Params) -> RealArray:
        """Return ``U[1]`` that gives the yaw acceleration ``dw`` (rad/s^2) in the state ``X``."""
        raise NotImplementedError

    def inverse(self, X: RealArray, du: RealArray, dw: RealArray, p: Params) -> RealArray:
        """
        Return the inputs U (2, ...) that give the accelerations ``u' = du``, ``omega' = dw``.

        The laws ask for a surge acceleration ``K_f (u0 - u)`` (7.1) and a yaw acceleration
        (the steering law's); sway is left to its own dynamics.
        """
        return np.stack([self.thrust(X, du, p), self.steering(X, dw, p)])

    def drag_moment_accel(self, X: RealArray, p: Params) -> RealArray:
        """Return the yaw acceleration of a drag moment, h' (A.13) (rad/s^2); 0 without one."""
        return np.zeros(np.shape(X)[1:])

    def size(self, sc: Any) -> float:
        """
        Return the vehicle's size: the diameter of the disc that holds it from above (m).

        Two vehicles of this size may touch once their centres are closer than it; the
        separation distance ``d_min`` is derived from it (:func:`separation.limits`). ``sc``
        is the scenario (a model's size may depend on its parameters).
        """
        raise NotImplementedError

    def surge_mode(self, sc: Any) -> tuple[str, float] | None:
        """
        Return the formula and rate (1/s) of its open-loop surge mode at the speed ``sc.u0``.

        The linearised drag, the fast mode RK4 must resolve (:func:`stability.modes`); None
        for particles, which have no surge dynamics. ``sc`` is the scenario.
        """
        return None
