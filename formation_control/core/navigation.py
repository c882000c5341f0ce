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

The filter keeps the vehicle's ground and through-water velocities too
(:meth:`PositionFilter.velocities`), which an estimating vehicle's flow estimator takes instead
of its raw Doppler and DVL velocities: each predicted by the model's change of the through-water
velocity over the step (the flow held), corrected every step by its measurement with the
steady-state gain of the Gauss-Markov velocity the model does not know there
(:func:`velocity_gains`). :func:`flow_error` derives the flow estimate's error from
both gains and the noise, :func:`best_flow_gain` the bandwidth that minimises it.
"""
from __future__ import annotations

from functools import lru_cache
import math
from typing import TYPE_CHECKING

from formation_control.core.geometry import ComplexArray, RealArray
from formation_control.core.models import ground_velocity, integrate, Plant, ROW_X, ROW_Y
from formation_control.core.sensors import fix_every
from formation_control.core.vehicles import vehicle_model
import numpy as np

if TYPE_CHECKING:
    from formation_control.core.parameters import Scenario


def position_gain(sc: Scenario) -> tuple[float, float, float]:
    """
    Return the filter's fix gain k, and its error variances P (after a fix) and Q (m^2).

    See the module docstring; k = 1 (take every fix) when the fixes have no noise.
    """
    T = fix_every(sc) * sc.dt_control
    s = sc.velocity_sigma if sc.flow_source == 'known' else sc.water_sigma
    R = sc.gnss_sigma ** 2
    Q = s * s * sc.dt_control * T + (sc.filter_drift * T) ** 2
    k = steady_gain(Q, R)
    return k, k * R, Q


def steady_gain(Q: float, R: float) -> float:
    """
    Return the steady-state Kalman gain of a random walk of step variance Q seen in noise R.

    The Riccati fixed point ``P- = (Q + sqrt(Q^2 + 4 Q R)) / 2``, ``k = P- / (P- + R)``; 1 (take
    every measurement) when it has no noise.
    """
    if R == 0:
        return 1.0
    prior = 0.5 * (Q + math.sqrt(Q * Q + 4.0 * Q * R))
    return prior / (prior + R)


def unknown_velocity(sc: Scenario) -> float:
    """
    Return the standard deviation (m/s per axis) of the velocity the vehicle's model lacks.

    ``sqrt(gust_intensity^2 + filter_drift^2)``: the gust and what the filter allows besides
    (mismatch, a flow it has not learnt), taken as one Gauss-Markov process of correlation time
    ``gust_time``.
    """
    return math.hypot(sc.gust_intensity, sc.filter_drift)


def velocity_gains(sc: Scenario) -> tuple[float, float]:
    """
    Return the gains (k_g, k_w) of the ground and through-water velocity channels (per step).

    Between two steps the model predicts the change of the vehicle's through-water velocity.
    What it does not know is taken as the increments of Gauss-Markov processes of time
    ``gust_time`` (``1 - e^{-2 dt / gust_time}`` of their variance per step): for the ground
    velocity the flow's change and the model's error (:func:`unknown_velocity`), seen in the
    Doppler noise ``velocity_sigma^2``; for the through-water velocity the model's error alone
    (``filter_drift``), seen in :func:`water_noise` squared (:func:`steady_gain` each).
    """
    a = math.exp(-sc.dt_control / sc.gust_time)
    step = 1.0 - a * a
    return (steady_gain(unknown_velocity(sc) ** 2 * step, sc.velocity_sigma ** 2),
            steady_gain(sc.filter_drift ** 2 * step, water_noise(sc) ** 2))


def water_noise(sc: Scenario) -> float:
    """
    Return the noise (m/s per map axis) of the measured through-water velocity ``v_rel``.

    The DVL's ``water_sigma`` (rigid bodies; isotropic in the body frame, so in the map frame)
    and the heading noise turning the speed V (u0, or 1 for particles) across the track,
    ``V heading_sigma``, shared on average by the two map axes.
    """
    rigid = vehicle_model(sc.model).rigid
    speed = sc.u0 if rigid else 1.0
    water = sc.water_sigma if rigid else 0.0
    return math.sqrt(water ** 2 + 0.5 * (speed * sc.heading_sigma) ** 2)


@lru_cache(maxsize=256)
def _flow_error(dt: float, lam: float, gains: tuple[float, float], sigma: float, time: float,
                doppler: float, water: float, heading: float = 0.0, push: float = 0.0) -> float:
    """Return the rms flow-estimate error per axis of the sampled cascade (:func:`flow_error`)."""
    (kg, kw), ag, a = gains, math.exp(-dt / time), math.exp(-lam * dt)
    c, b, half = sigma * math.sqrt(1.0 - ag * ag), 1.0 - a, water / math.sqrt(2.0)
    A = np.array([[ag, 0.0, 0.0, 0.0, 0.0],
                  [kg * ag, 1.0 - kg, 0.0, 0.0, -(1.0 - kg) * push],
                  [0.0, 0.0, 1.0 - kw, 0.0, -(1.0 - kw) * push],
                  [b * kg * ag, b * (1.0 - kg), -b * (1.0 - kw), a, (kg - kw) * b * push],
                  [0.0, 0.0, 0.0, 0.0, 0.0]])
    w = np.array([0.0, 0.0, kw, -b * kw, 0.0])
    B = np.column_stack([[c, kg * c, 0.0, b * kg * c, 0.0],
                         [0.0, kg * doppler, 0.0, b * kg * doppler, 0.0],
                         w * half + np.array([0.0, 0.0, 0.0, 0.0, half]), w * half, w * heading])
    P = np.linalg.solve(np.eye(25) - np.kron(A, A), (B @ B.T).ravel()).reshape(5, 5)
    C = np.array([-1.0, 0.0, 0.0, 1.0, 0.0])
    return float(math.sqrt(max(C @ P @ C, 0.0)))


def thrust_push(sc: Scenario) -> float:
    """
    Return the true speed change per unit of speed noise in a step that the model misses (s).

    A rigid body thrusting from a measured speed off by n moves by ``c n dt`` more than its
    model, started from the measured speed, predicts (:func:`sensors.speed_under_noise`:
    ``K_f + c``), c its surge drag rate (``2 h u0 / m0`` for the thesis' bodies,
    :meth:`vehicles.base.VehicleModel.surge_mode`); 0 for particles, whose command moves
    model and vehicle alike.
    """
    surge = vehicle_model(sc.model).surge_mode(sc)
    return surge[1] * sc.dt_control if surge is not None else 0.0


def flow_error(sc: Scenario, gain: float | None = None,
               gains: tuple[float, float] | None = None, sigma: float | None = None) -> float:
    """
    Return the steady rms error (m/s per axis) of the flow estimate fed by the filter.

    Per map axis and step n, with the flow ``f`` a Gauss-Markov process (``sigma``, by default
    ``gust_intensity``; time ``gust_time``), the Doppler noise ``n_v`` (``velocity_sigma``), the
    through-water noise ``n_w`` (:func:`water_noise`: the DVL's along and across the body, half
    of each per map axis, and the heading's) and the true speed change the model misses,
    ``e_n = p q_n-1`` (:func:`thrust_push` p, q the along-body part of the last step's DVL
    noise), the channels' errors against the true velocities:

    - ground, ``y_g = ghat - v_rel``: ``y_g,n = (1 - k_g)(y_g,n-1 - e_n) + k_g (f_n + n_v,n)``;
    - through the water, ``y_w = what - v_rel``: ``y_w,n = (1 - k_w)(y_w,n-1 - e_n) + k_w n_w,n``;
    - the flow filter ``fhat_n = a fhat_n-1 + (1 - a)(y_g,n - y_w,n)``, ``a = e^{-lambda_f dt}``.

    The state (f, y_g, y_w, fhat, q) is linear in white noise: its steady covariance P solves
    the discrete Lyapunov equation ``P = A P A^T + B B^T``, and the error is ``fhat - f``.
    ``gain`` (lambda_f, 1/s) and ``gains`` (k_g, k_w) default to the scenario's
    (:func:`filtered_bandwidth`, :func:`velocity_gains`); ``gains = (1, 1)`` is the raw feed
    (e then cancels: the raw difference ``v_ground - v_rel`` holds no model).
    """
    rigid = vehicle_model(sc.model).rigid
    speed = sc.u0 if rigid else 1.0
    return _flow_error(sc.dt_control, filtered_bandwidth(sc) if gain is None else float(gain),
                       velocity_gains(sc) if gains is None else gains,
                       sc.gust_intensity if sigma is None else sigma, sc.gust_time,
                       sc.velocity_sigma, sc.water_sigma if rigid else 0.0,
                       speed * sc.heading_sigma / math.sqrt(2.0),
                       0.0 if gains == (1.0, 1.0) else thrust_push(sc))


def flow_lag(sc: Scenario, gain: float | None = None) -> float:
    """
    Return the lag (s) of the cascade behind a flow that changes at a constant rate.

    The two first-order stages add their time constants: ``dt (1 - k_g) / k_g`` of the
    ground-velocity channel and ``dt a / (1 - a)`` of the flow filter (about 1 / lambda_f): a
    flow ramp of rate r is followed ``r * flow_lag`` behind (the through-water channel sees no
    flow).
    """
    dt, k = sc.dt_control, velocity_gains(sc)[0]
    a = math.exp(-(filtered_bandwidth(sc) if gain is None else gain) * dt)
    return dt * (1.0 - k) / k + dt * a / (1.0 - a)


@lru_cache(maxsize=64)
def _best(dt: float, gains: tuple[float, float], sigma: float, time: float, doppler: float,
          water: float) -> float:
    """Return the lambda_f in [0.01, 1 / dt] of least :func:`_flow_error` (1/s)."""
    def error(log: float) -> float:
        return _flow_error(dt, math.exp(log), gains, sigma, time, doppler, water)
    grid = np.linspace(math.log(0.01), math.log(1.0 / dt), 121)
    i = int(np.argmin([error(float(g)) for g in grid]))
    low, high = float(grid[max(i - 1, 0)]), float(grid[min(i + 1, grid.size - 1)])
    for _ in range(40):
        m1, m2 = low + 0.382 * (high - low), low + 0.618 * (high - low)
        low, high = (low, m2) if error(m1) <= error(m2) else (m1, high)
    return math.exp(0.5 * (low + high))


def best_flow_gain(sc: Scenario) -> float:
    """
    Return the flow filter's bandwidth (1/s) the vehicle chooses from its noise.

    The minimiser of :func:`flow_error` for the flow the vehicle's design assumes, a
    Gauss-Markov process of :func:`unknown_velocity` (the gust and ``filter_drift``) and time
    ``gust_time``, with its own channel gains and noise, the speed change its model misses left
    out (a log grid over ``[0.01, 1 / dt]`` refined by golden section).
    """
    return _best(sc.dt_control, velocity_gains(sc), unknown_velocity(sc), sc.gust_time,
                 sc.velocity_sigma, water_noise(sc))


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
        self.k_g, self.k_w = velocity_gains(sc)
        self.X: RealArray | None = None
        self.z: ComplexArray | None = None
        self.g: ComplexArray | None = None
        self.w: ComplexArray | None = None
        self.ahead: RealArray | None = None

    def _ahead(self, X: RealArray, U_held: RealArray) -> RealArray:
        """Return the last estimate X carried over one period by the model (plain RK4)."""
        return integrate(X, U_held, self.sc.dt_control, 1, self.still)

    def velocities(self, v_ground: ComplexArray, v_rel: ComplexArray,
                   U_held: RealArray) -> tuple[ComplexArray, ComplexArray]:
        """
        Return the filtered ground and through-water velocities of the vehicles (m/s, map frame).

        From the measured ``v_ground`` (Doppler) and ``v_rel`` (DVL and compass, or a
        particle's heading): each predicted by the model's change of the through-water velocity
        over the period from the last estimate under the held commands ``U_held`` (the flow
        held), corrected with its gain (:func:`velocity_gains`); the first measurements
        initialise them. Call it before :meth:`update` of the same step, which reuses the
        prediction.
        """
        z, zw = np.asarray(v_ground, complex), np.asarray(v_rel, complex)
        if self.X is None or self.g is None or self.w is None:
            self.g, self.w = z.copy(), zw.copy()
        else:
            self.ahead = self._ahead(self.X, U_held)
            turn = ground_velocity(self.ahead, 0.0) - ground_velocity(self.X, 0.0)
            self.g = self.g + turn + self.k_g * (z - self.g - turn)
            self.w = self.w + turn + self.k_w * (zw - self.w - turn)
        return self.g.copy(), self.w.copy()

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
            ahead = self._ahead(self.X, U_held) if self.ahead is None else self.ahead
            prior = ahead[ROW_X] + 1j * ahead[ROW_Y] + self.sc.dt_control * np.asarray(flow)
            rhat = np.where(z != self.z, prior + self.k * (z - prior), prior)
        self.z, self.ahead = z, None
        X[ROW_X], X[ROW_Y] = rhat.real, rhat.imag
        self.X = X
        return X.copy()


def flow_input(navigator: PositionFilter | None, seen: RealArray, v_ground: ComplexArray,
               U_held: RealArray) -> tuple[ComplexArray, ComplexArray]:
    """
    Return the ground and through-water velocities an estimating vehicle's estimator takes.

    The filter's (:meth:`PositionFilter.velocities`) when the vehicle has one, else the measured
    ones: ``v_ground`` and the through-water velocity of its measured state ``seen``.
    """
    v_rel = ground_velocity(seen, 0.0)
    if navigator is None:
        return np.asarray(v_ground, complex), v_rel
    return navigator.velocities(v_ground, v_rel, U_held)


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


def filtered_bandwidth(sc: Scenario) -> float:
    """Return the flow filter's bandwidth (1/s) here: :func:`best_flow_gain` or flow_gain."""
    return best_flow_gain(sc) if sc.flow_gain_from_noise else sc.flow_gain
