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
Onboard flow estimation: what a vehicle that is not told the flow uses instead.

With ``flow_source: estimated``, a vehicle measures its ground velocity (odometry) and its
velocity through the water or air (a DVL or airspeed sensor; a unit-speed particle knows its
own: ``e^{i theta}``). Their difference is the flow at the vehicle, ``m = v_ground - v_rel``
(8.1). The estimators, one state per vehicle, sampled every control period ``dt``:

- ``filter``: ``fhat' = lambda_f (m - fhat)``, discretised exactly for the measurement held over
  the period: ``fhat <- m + (fhat - m) e^{-lambda_f dt}``;
- ``observer``, from the position only: ``rhat' = v_rel + fhat + l1 (r - rhat)``,
  ``fhat' = l2 (r - rhat)``, discretised as a predictor-corrector whose error matrix has the
  poles ``e^{s dt}`` of the continuous error ``s^2 + l1 s + l2``;
- a consensus term, gain ``flow_consensus``: ``fhat_k <- fhat_k + (1 - e^{-k_c dt})
  (mean_{j in N_k} fhat_j - fhat_k)`` over the neighbours' estimates (a uniform flow).

In a flow that is uniform and steady the estimation error ``e = fhat - f`` obeys a linear
equation that does not depend on the control (``e' = -lambda_f e``): the cascade argument of
docs/errata.md, "Flow estimation". Every estimate is clamped to ``|fhat| <= CLAMP * speed``
(1 for particles, u0 for rigid bodies), so that the transforms (5.1)-(5.4) stay defined.
"""
from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

from formation_control.core.geometry import ComplexArray, RealArray
from formation_control.core.models import position, ROW_THETA, ROW_U, ROW_V
from formation_control.core.vehicles import vehicle_model
import numpy as np

if TYPE_CHECKING:
    from formation_control.core.graphs import Graph
    from formation_control.core.parameters import Scenario

CLAMP = 0.95
"""Largest ``|fhat|`` as a fraction of the vehicle's speed through the water."""


def relative_velocity(X: RealArray) -> ComplexArray:
    """
    Return the velocity through the flow of each vehicle, world frame.

    Parameters
    ----------
    X : array_like, shape (6, n)
        States (rows of :mod:`models`); particles have u = 1, v = 0.

    Returns
    -------
    ndarray of complex, shape (n,)
        ``v_rel = (u + i v) e^{i theta}`` (m/s): what a DVL or airspeed sensor measures, in the
        map frame.

    """
    return (X[ROW_U] + 1j * X[ROW_V]) * np.exp(1j * X[ROW_THETA])


def observer_gains(l1: float, l2: float, dt: float) -> tuple[float, float]:
    """
    Return the corrector gains of the discrete position-only observer.

    Parameters
    ----------
    l1, l2 : float
        Continuous gains (1/s, 1/s^2): error poles the roots of ``s^2 + l1 s + l2``.
    dt : float
        Sample period (s).

    Returns
    -------
    k1, k2 : float
        ``rhat <- rhat_pred + k1 (r - rhat_pred)``, ``fhat <- fhat + k2 (r - rhat_pred)``: the
        error matrix ``[[1 - k1, (1 - k1) dt], [-k2, 1 - k2 dt]]`` has determinant
        ``1 - k1 = e^{-l1 dt}`` and trace ``2 - k1 - k2 dt = e^{s1 dt} + e^{s2 dt}``.

    """
    root = np.sqrt(complex(0.25 * l1 * l1 - l2))
    trace = float((2.0 * np.exp(-0.5 * l1 * dt) * np.cosh(root * dt)).real)
    k1 = 1.0 - np.exp(-l1 * dt)
    return k1, (2.0 - k1 - trace) / dt


class FlowEstimator:
    """
    The flow estimates of ``n`` vehicles of scenario ``sc`` (its flow_* gains).

    Attributes
    ----------
    fhat : ndarray of complex, shape (n,)
        The estimates (m/s, map frame), 0 before the first measurement.
    rhat : ndarray of complex, shape (n,) or None
        The observer's position estimates (m), None before the first measurement.

    """

    def __init__(self, sc: Scenario, n: int | tuple[int, ...]) -> None:
        self.sc = sc
        self.fhat = np.zeros(n, complex)
        self.rhat: ComplexArray | None = None
        self.v_rel = np.zeros(n, complex)
        self.limit = CLAMP * vehicle_model(sc.model).speed(sc.u0)

    def update(self, X: RealArray, v_ground: ComplexArray,
               neighbours: ComplexArray | None = None,
               v_rel: ComplexArray | None = None) -> ComplexArray:
        """
        Take one period's measurements; return the estimates (n,) complex.

        Parameters
        ----------
        X : array_like, shape (6, n)
            The vehicles' states as they measure them (position, heading, u, v).
        v_ground : array_like of complex, shape (n,)
            Their ground velocities (m/s, map frame), the odometry twist.
        neighbours : array_like of complex, shape (n,), optional
            The mean of each vehicle's neighbours' estimates, for the consensus term.
        v_rel : array_like of complex, shape (n,), optional
            Their velocities through the water (m/s, map frame); :func:`relative_velocity` of
            X by default (the position filter gives its own, :func:`navigation.flow_input`).

        """
        sc, dt = self.sc, self.sc.dt_control
        v_rel = relative_velocity(X) if v_rel is None else np.asarray(v_rel, complex)
        if sc.flow_estimator == 'filter':
            m = np.asarray(v_ground) - v_rel
            self.fhat = m + (self.fhat - m) * np.exp(-bandwidth(sc) * dt)
        else:
            self._observe(position(X), v_rel, dt)
        if neighbours is not None and sc.flow_consensus > 0:
            self.fhat = self.fhat + (1.0 - np.exp(-sc.flow_consensus * dt)) * (
                np.asarray(neighbours) - self.fhat)
        return self.clamp()

    def _observe(self, r: ComplexArray, v_rel: ComplexArray,
                 dt: float) -> None:
        """Advance the position-only observer to the position samples r."""
        if self.rhat is None:
            self.rhat, self.v_rel = r.copy(), v_rel
            return
        k1, k2 = observer_gains(self.sc.flow_observer_l1, self.sc.flow_observer_l2, dt)
        predicted = self.rhat + dt * (0.5 * (self.v_rel + v_rel) + self.fhat)
        innovation = r - predicted
        self.rhat = predicted + k1 * innovation
        self.fhat = self.fhat + k2 * innovation
        self.v_rel = v_rel

    def clamp(self) -> ComplexArray:
        """Clamp the estimates to ``|fhat| <= limit``; return them."""
        size = abs(self.fhat)
        over = size > self.limit
        self.fhat[over] *= self.limit / size[over]
        return self.fhat

    def retune(self, sc: Scenario) -> None:
        """Take the gains of ``sc`` (changed at run time); the estimates carry on."""
        self.sc = sc


def neighbour_mean(graph: Graph, fhat: ComplexArray) -> ComplexArray:
    """
    Return the mean of each vehicle's neighbours' estimates over a communication graph.

    Parameters
    ----------
    graph : graphs.Graph
        Who hears whom (connected: every vehicle has a neighbour when n > 1).
    fhat : ndarray of complex, shape (n,)
        The estimates.

    Returns
    -------
    ndarray of complex, shape (n,)
        ``mean_{j in N_k} fhat_j``; ``fhat`` itself for a single vehicle.

    """
    n = fhat.size
    if n < 2:
        return fhat.copy()
    if graph.complete:
        return (fhat.sum() - fhat) / (n - 1)
    src, dst = graph.arcs
    total = (np.bincount(dst, fhat.real[src], n) + 1j * np.bincount(dst, fhat.imag[src], n))
    return np.asarray(total / graph.degrees(), complex)


def filter_noise(sc: Scenario) -> float:
    """
    Return the steady standard deviation (m/s, per axis) of the filter's flow estimate from noise.

    The measurement ``m = v_ground - v_rel`` of vehicles with sensors (:mod:`sensors`) is the
    flow plus white noise of variance ``s^2 = velocity_sigma^2 + water_sigma^2`` per map axis
    (the DVL's body-frame noise is isotropic); the sampled filter ``e <- a e + (1 - a) w``,
    ``a = e^{-lambda_f dt}``, leaves ``var e = s^2 (1 - a) / (1 + a)``, about
    ``s^2 lambda_f dt / 2``: the bandwidth trades this noise against the lag
    ``sup |f'| / lambda_f`` of a varying flow (docs/errata.md, "The world a real fleet meets").
    Particles know their own velocity through the water (water_sigma does not apply).
    """
    a = np.exp(-bandwidth(sc) * sc.dt_control)
    water = sc.water_sigma if vehicle_model(sc.model).rigid else 0.0
    return float(np.sqrt((sc.velocity_sigma ** 2 + water ** 2) * (1 - a) / (1 + a)))


def tracking_error(sc: Scenario, gain: float | None = None) -> float:
    """
    Return the steady rms error (m/s, per axis) of the filter's estimate of a gusty flow.

    The gust (:mod:`world`) is a Gauss-Markov process of variance ``sigma_g^2`` and rate
    ``b = 1 / gust_time``; the measurement adds white noise of spectral density
    ``N = s^2 dt`` (:func:`filter_noise`). The continuous filter ``fhat' = lambda (f + n -
    fhat)`` then has ``var e = sigma_g^2 b / (lambda + b) + N lambda / 2`` per axis: the lag
    behind the gust falls with the bandwidth, the noise grows with it. The noise term is taken
    in its sampled form, ``s^2 (1 - a) / (1 + a)``.
    """
    lam = bandwidth(sc) if gain is None else gain
    b = 1.0 / sc.gust_time
    noise = filter_noise(replace(sc, flow_gain=lam, flow_gain_from_noise=False)) ** 2
    return float(np.sqrt(sc.gust_intensity ** 2 * b / (lam + b) + noise))


def best_gain(sc: Scenario) -> float:
    """
    Return the bandwidth lambda_f (1/s) that minimises :func:`tracking_error`.

    Setting the derivative of ``sigma_g^2 b / (lambda + b) + N lambda / 2`` to zero:
    ``lambda* = sigma_g sqrt(2 b / N) - b`` (``N = s^2 dt``); the fastest the sampled filter
    takes, ``1 / dt``, without noise; a slow ``b`` where the gust is nil.
    """
    water = sc.water_sigma if vehicle_model(sc.model).rigid else 0.0
    N = (sc.velocity_sigma ** 2 + water ** 2) * sc.dt_control
    b = 1.0 / sc.gust_time
    if N == 0:
        return 1.0 / sc.dt_control
    return float(max(b, sc.gust_intensity * np.sqrt(2.0 * b / N) - b))


def bandwidth(sc: Scenario) -> float:
    """
    Return the filter's bandwidth lambda_f (1/s): flow_gain, or the one chosen from the noise.

    With ``flow_gain_from_noise``: :func:`best_gain` for the raw feed, or with
    ``position_filter: kalman`` (the filter's velocities) :func:`navigation.best_flow_gain`.
    """
    if not sc.flow_gain_from_noise:
        return sc.flow_gain
    if sc.position_filter == 'kalman':
        from formation_control.core.navigation import best_flow_gain
        return best_flow_gain(sc)
    return best_gain(sc)
