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
Unit-speed particles: the first-order (1.1) and second-order (1.3) models of chapters 1-5.

``r' = e^{i theta}`` (1.1), (1.3) (plus the flow, (1.4)); ``U[1]`` is the turn rate theta'
(first order) or the angular acceleration omega' (second order); ``U[0]`` is unused and the
rows u, v stay at 1, 0.
"""
from __future__ import annotations

from typing import Any

from formation_control.core import _rk4  # type: ignore[attr-defined]
from formation_control.core.geometry import RealArray
from formation_control.core.vehicles.base import (Params, ROW_OMEGA, ROW_THETA, ROW_X, ROW_Y,
                                                  VehicleModel)
import numpy as np

PARTICLE_SIZE = 0.1
"""The size of a unit-speed particle (m): the thesis' particle is a point flying 1 m/s, so a
small robot a tenth of the distance it covers in a second (a 92 mm Crazyflie-class quadrotor
or a small wheeled robot); on the thesis' unit circle it leaves 0.1 of the radius."""


class Particle(VehicleModel):
    """A unit-speed particle (1.1), (1.3): ``u = 1, v = 0`` always, the input in ``U[1]``."""

    particle = True
    backends = ('native', 'jsbsim')                  # JSBSim aircraft fly the particle laws

    def size(self, sc: Any) -> float:
        """Return :data:`PARTICLE_SIZE` (m); a JSBSim aircraft's is its wingspan (separation)."""
        return PARTICLE_SIZE


class FirstOrder(Particle):
    """The first-order particle (1.1): its input is the turn rate theta' (rad/s)."""

    name = 'first_order'
    text = 'first_order (1.1)'
    first_order = True
    command_fields = ('', 'turn_rate')
    kernel = _rk4.FIRST_ORDER

    def rates(self, X: RealArray, U: RealArray, p: Params) -> RealArray:
        """Return dX/dt in still water: ``r' = e^{i theta}``, ``theta' = U[1]`` (1.1)."""
        dX = np.zeros(np.shape(X))
        dX[ROW_X], dX[ROW_Y] = np.cos(X[ROW_THETA]), np.sin(X[ROW_THETA])
        dX[ROW_THETA] = U[1]
        return dX

    def steering(self, X: RealArray, dw: RealArray, p: Params) -> RealArray:
        """Refuse: a first-order particle is steered by its turn rate, not an acceleration."""
        raise ValueError('model first_order takes a turn rate: controller first_order')


class SecondOrder(Particle):
    """The second-order particle (1.3): its input is the angular acceleration omega' (rad/s^2)."""

    name = 'second_order'
    text = 'second_order (1.3)'
    command_fields = ('', 'angular_acceleration')
    kernel = _rk4.SECOND_ORDER

    def rates(self, X: RealArray, U: RealArray, p: Params) -> RealArray:
        """Return dX/dt in still water: ``r' = e^{i theta}``, ``theta' = omega, omega' = U[1]``."""
        dX = np.zeros(np.shape(X))
        dX[ROW_X], dX[ROW_Y] = np.cos(X[ROW_THETA]), np.sin(X[ROW_THETA])
        dX[ROW_THETA] = X[ROW_OMEGA]
        dX[ROW_OMEGA] = U[1]
        return dX

    def steering(self, X: RealArray, dw: RealArray, p: Params) -> RealArray:
        """Return ``U[1] = omega'``: the input is the yaw acceleration itself (1.3)."""
        return np.asarray(dw, float)
