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
A vehicle's estimate of its own position between and across position fixes.

With ``position_filter: kalman`` each vehicle (the vehicle node's :class:`onboard.Onboard`, and
the simulator for the whole fleet) keeps an estimate ``rhat`` of its position. Every control
step it predicts it with its own model and the command it holds: one RK4 step of the nominal
model over ``dt_control`` from its estimate with the heading, yaw rate and velocities it has
just measured (those come every step), plus the flow it uses. At a new fix ``z`` (the steps
:func:`sensors.fix_every` apart, after the latency) it corrects ``rhat <- rhat + k (z - rhat)``
with the steady-state Kalman gain of a random walk observed in noise:

- the fix noise ``R = gnss_sigma^2`` per axis;
- the dead-reckoning error over one fix interval T, ``Q = s^2 dt T + (drift T)^2``: the
  velocity noise s (``velocity_sigma`` told the flow, ``water_sigma`` estimating) integrated
  over the interval's steps, and a velocity the model does not know (``filter_drift``: a gust,
  a mismatch) held over it;
- ``P- = (Q + sqrt(Q^2 + 4 Q R)) / 2``, ``k = P- / (P- + R)``; the error variance just after a
  fix is ``P = k R`` and grows by Q until the next (:func:`position_gain`).

The first fix initialises the estimate. Without the filter (``none``) a vehicle uses its
latest fix as its position (the raw fixes).
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING

from formation_control.core.geometry import ComplexArray, RealArray
from formation_control.core.models import integrate, Plant, ROW_X, ROW_Y
from formation_control.core.sensors import fix_every
import numpy as np

if TYPE_CHECKING:
    from formation_control.core.scenario import Scenario


def position_gain(sc: Scenario) -> tuple[float, float, float]:
    """
    Return the filter's fix gain k, and its error variances P (after a fix) and Q (m^2).

    See the module docstring; k = 1 (take every fix) when the fixes have no noise.
    """
    T = fix_every(sc) * sc.dt_control
    s = sc.velocity_sigma if sc.flow_source == 'known' else sc.water_sigma
    R = sc.gnss_sigma ** 2
    Q = s * s * sc.dt_control * T + (sc.filter_drift * T) ** 2
    if R == 0:
        return 1.0, 0.0, Q
    prior = 0.5 * (Q + math.sqrt(Q * Q + 4.0 * Q * R))
    k = prior / (prior + R)
    return k, k * R, Q


def raw_error(sc: Scenario, speed: float) -> float:
    """
    Return the rms position error per axis of the raw fixes (m) at a ground speed (m/s).

    The fix noise and, along the motion, the staleness of a fix held over the n steps of a
    fix interval: ``sqrt(sigma^2 + (speed dt)^2 (n - 1)(2 n - 1) / 12)`` (the mean square of
    ``speed dt j``, j = 0..n-1, shared by two axes).
    """
    n = fix_every(sc)
    stale = (speed * sc.dt_control) ** 2 * (n - 1) * (2 * n - 1) / 6.0
    return math.sqrt(sc.gnss_sigma ** 2 + 0.5 * stale)


def filtered_error(sc: Scenario) -> float:
    """Return the rms position error per axis of the filter (m): ``sqrt(P + Q / 2)``."""
    _, P, Q = position_gain(sc)
    return math.sqrt(P + 0.5 * Q)


class PositionFilter:
    """
    The position estimates of the vehicles of scenario ``sc`` (any fleet shape).

    Parameters
    ----------
    sc : scenario.Scenario
    still : models.Plant
        The vehicles' own model without the flow (``Controller.still``).

    Attributes
    ----------
    X : ndarray, shape (6, ...), or None
        The last estimate (the measured state with the estimated position), None before the
        first sample.

    """

    def __init__(self, sc: Scenario, still: Plant) -> None:
        self.sc, self.still = sc, still
        self.k = position_gain(sc)[0]
        self.X: RealArray | None = None
        self.z: ComplexArray | None = None

    def update(self, seen: RealArray, U_held: RealArray,
               flow: complex | ComplexArray) -> RealArray:
        """
        Return the state (6, ...) to command from: ``seen`` with the estimated position.

        A fix is new where it differs from the last one (a held fix repeats bit for bit), so
        the vehicle needs no clock to tell fixes apart.

        Parameters
        ----------
        seen : ndarray, shape (6, ...)
            What the vehicles measured (their latest fixes in x, y).
        U_held : ndarray, shape (2, ...)
            The commands they held over the last period.
        flow : complex or ndarray of complex
            The flow they use (m/s).

        """
        X = np.array(seen, float)
        z = X[ROW_X] + 1j * X[ROW_Y]
        if self.X is None or self.z is None:
            rhat = z
        else:
            dt = self.sc.dt_control
            ahead = integrate(self.X, U_held, dt, 1, self.still)
            prior = ahead[ROW_X] + 1j * ahead[ROW_Y] + dt * np.asarray(flow)
            rhat = np.where(z != self.z, prior + self.k * (z - prior), prior)
        self.z = z
        X[ROW_X], X[ROW_Y] = rhat.real, rhat.imag
        self.X = X
        return X.copy()


def predicted_gain(sc: Scenario) -> float:
    """
    Return the factor by which the filter lowers the formation's steady-state errors.

    An approximation (docs/errata.md, "The world a real fleet meets"): the formation loop passes
    the position error below its rate ``w = formation_rate`` (core/stability.py) and little
    above. The raw fixes' error is white, held over each fix interval T: per axis its
    one-sided spectrum is ``2 sigma^2 T``, of which ``sigma^2 T w / pi`` passes. The filter's
    error lies below its own bandwidth ``k / T``, far below w, and passes whole
    (:func:`filtered_error`). The factor is the ratio of the two standard deviations.
    """
    from formation_control.core.stability import formation_rate
    T = fix_every(sc) * sc.dt_control
    passed = sc.gnss_sigma * math.sqrt(T * formation_rate(sc) / math.pi)
    return passed / filtered_error(sc)
