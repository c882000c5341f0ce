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
The plant's sensors: what each vehicle measures of itself, with noise, bias, rate and latency.

All off by default (:func:`active`): then a vehicle measures its state exactly every control
period, as before. Otherwise, at each control step n the plant samples, per vehicle:

- a position fix (GNSS): the true position plus ``gnss_sigma`` noise per axis, every
  ``1 / (gnss_rate dt_control)`` steps (every step at ``gnss_rate: 0``), the last fix held
  between fixes;
- its heading (compass) plus ``heading_bias`` and ``heading_sigma`` noise; its yaw rate (gyro)
  plus ``yaw_rate_sigma`` noise;
- its ground velocity (GNSS Doppler) plus ``velocity_sigma`` noise per axis, map frame;
- its velocity through the water or air (DVL, pitot), rigid bodies, in its body frame:
  ``u + water_bias`` and v, plus ``water_sigma`` noise each;

and hands over the sample of step ``n - L``, ``L = sensor_latency / dt_control`` (the first
sample until then). Every draw comes from the vehicle's own stream (seeded by the scenario's
seed, ``world_seed``, its id; :mod:`world`), eight normals per vehicle per step whatever is
used, so the plant node and the simulator hand the same numbers to each vehicle. The odometry
carries the matching REP-105 covariances (:func:`covariances`).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from formation_control.core.errors import refuse
from formation_control.core.geometry import ComplexArray, RealArray
from formation_control.core.models import ROW_OMEGA, ROW_THETA, ROW_U, ROW_V, ROW_X, ROW_Y
from formation_control.core.vehicles import vehicle_model
from formation_control.core.world import stream
import numpy as np

if TYPE_CHECKING:
    from formation_control.core.parameters import Scenario

NOISES = ('gnss_x', 'gnss_y', 'heading', 'yaw_rate', 'velocity_x', 'velocity_y', 'water_u',
          'water_v')
"""The normal draws of one vehicle at one step, in order."""
CHUNK = 128
"""Steps of draws a vehicle's stream takes at a time (the sequence does not depend on it)."""


def active(sc: Scenario) -> bool:
    """Return whether any sensor is imperfect (else the vehicles measure their state)."""
    return bool(sc.gnss_sigma or sc.gnss_rate or sc.heading_sigma or sc.heading_bias
                or sc.yaw_rate_sigma or sc.velocity_sigma or sc.water_sigma or sc.water_bias
                or sc.sensor_latency)


def fix_every(sc: Scenario) -> int:
    """Return the control steps between two position fixes (1: every step)."""
    return 1 if sc.gnss_rate == 0 else int(round(1.0 / (sc.gnss_rate * sc.dt_control)))


def latency_steps(sc: Scenario) -> int:
    """Return the control steps a sample is late by."""
    return int(round(sc.sensor_latency / sc.dt_control))


def covariances(sc: Scenario) -> tuple[list[float], list[float]]:
    """
    Return the odometry's ``pose.covariance`` and ``twist.covariance`` (6 x 6, row-major).

    x, y: ``gnss_sigma^2``; yaw: ``heading_sigma^2`` (the bias is not noise and is left out);
    the twist's x, y: ``velocity_sigma^2`` (map-frame noise, the same in any frame); yaw rate:
    ``yaw_rate_sigma^2``; zero elsewhere (REP-105: variances on the diagonal).
    """
    pose, twist = [0.0] * 36, [0.0] * 36
    pose[0] = pose[7] = sc.gnss_sigma ** 2
    pose[35] = sc.heading_sigma ** 2
    twist[0] = twist[7] = sc.velocity_sigma ** 2
    twist[35] = sc.yaw_rate_sigma ** 2
    return pose, twist


@dataclass(frozen=True)
class Sample:
    """
    What the vehicles measure at one step.

    Attributes
    ----------
    X : ndarray, shape (6, N)
        The state each vehicle reads: fix, heading, yaw rate; u, v from its ground velocity
        less the flow it is told (told the flow), its water velocity (estimating rigid
        bodies) or 1, 0 (particles).
    v_ground : ndarray of complex, shape (N,)
        The measured ground velocity (m/s, map frame).
    water : ndarray, shape (2, N)
        The measured velocity through the water, body frame (u, v), rigid bodies.

    """

    X: RealArray
    v_ground: ComplexArray
    water: RealArray


class Sensors:
    """
    The sensors of a scenario's fleet, or of a batch of fleets.

    Parameters
    ----------
    sc : scenario.Scenario
    shape : tuple of int
        ``(N,)`` for one fleet, ``(B, N)`` for a batch.
    seeds : sequence of int, optional
        The seed of each fleet of a batch (B); ``sc.seed`` for every one by default.

    """

    def __init__(self, sc: Scenario, shape: tuple[int, ...],
                 seeds: Sequence[int] | None = None) -> None:
        self.sc, self.shape = sc, shape
        fleets = [sc.seed] * (shape[0] if len(shape) > 1 else 1) if seeds is None else \
            [int(s) for s in seeds]
        self.streams = [stream(s, sc.world_seed, k + 1, 'sensors') for s in fleets
                        for k in range(sc.num_vehicles)]
        self.buffer = np.empty((len(self.streams), 0, len(NOISES)))
        self.used = 0
        self.fix = np.zeros(shape, complex)
        self.samples: dict[int, Sample] = {}
        self.every, self.late = fix_every(sc), latency_steps(sc)

    def _normals(self) -> RealArray:
        """Return the next step's draws, shape (len(NOISES),) + shape."""
        if self.used >= self.buffer.shape[1]:
            self.buffer = np.array([g.standard_normal((CHUNK, len(NOISES)))
                                    for g in self.streams])
            self.used = 0
        w = self.buffer[:, self.used].T
        self.used += 1
        return w.reshape((len(NOISES),) + self.shape)

    def sample(self, n: int, X: RealArray, v_ground: ComplexArray,
               told: ComplexArray | None) -> Sample:
        """
        Return what the vehicles measure at control step n (the sample of step n - latency).

        Parameters
        ----------
        n : int
            The control step; a step sampled before returns the same sample (a plant that
            sends a step's odometry again draws nothing new).
        X : ndarray, shape (6,) + shape
            The true states.
        v_ground : ndarray of complex, shape ``shape``
            The true ground velocities (gusts included).
        told : ndarray of complex, shape ``shape``, or None
            The flow each vehicle is told (``flow_source: known``); None when it estimates.

        """
        if n not in self.samples:
            self.samples[n] = self._draw(n, X, v_ground, told)
            for old in [m for m in self.samples if m < n - self.late]:
                del self.samples[old]
        return self.samples.get(max(0, n - self.late), self.samples[min(self.samples)])

    def _draw(self, n: int, X: RealArray, v_ground: ComplexArray,
              told: ComplexArray | None) -> Sample:
        sc, w = self.sc, self._normals()
        if n % self.every == 0:
            self.fix = X[ROW_X] + 1j * X[ROW_Y] + sc.gnss_sigma * (w[0] + 1j * w[1])
        theta = X[ROW_THETA] + sc.heading_bias + sc.heading_sigma * w[2]
        ground = np.asarray(v_ground) + sc.velocity_sigma * (w[4] + 1j * w[5])
        water = np.array([X[ROW_U] + sc.water_bias + sc.water_sigma * w[6],
                          X[ROW_V] + sc.water_sigma * w[7]])
        seen = np.array(X, float)
        seen[ROW_X], seen[ROW_Y] = self.fix.real, self.fix.imag
        seen[ROW_THETA] = theta
        seen[ROW_OMEGA] = X[ROW_OMEGA] + sc.yaw_rate_sigma * w[3]
        if vehicle_model(sc.model).rigid:
            if told is None:
                seen[ROW_U], seen[ROW_V] = water
            else:
                rel = (ground - told) * np.exp(-1j * theta)
                seen[ROW_U], seen[ROW_V] = rel.real, rel.imag
        return Sample(seen, ground, water)


def check_rates(sc: Scenario) -> str | None:
    """Return why ``gnss_rate`` or ``sensor_latency`` cannot be, or None."""
    if sc.gnss_rate:
        steps = 1.0 / (sc.gnss_rate * sc.dt_control)
        if steps < 1 - 1e-9:
            return (f"gnss_rate: {sc.gnss_rate:g} Hz is above the plant's step rate "
                    f'1 / dt_control = {1 / sc.dt_control:g} Hz')
        if abs(steps - round(steps)) > 1e-6:
            return (f'gnss_rate: 1 / (gnss_rate dt_control) = {steps:.4g} must be a whole '
                    f'number of control periods')
    steps = sc.sensor_latency / sc.dt_control
    if abs(steps - round(steps)) > 1e-6:
        return f'sensor_latency: {sc.sensor_latency:g} s must be a whole number of dt_control'
    return None


def check(sc: Scenario) -> tuple[str, ...]:
    """Refuse a fix rate or a latency the plant's control step cannot give; no warnings."""
    rates = check_rates(sc)
    if rates:
        name, why = rates.split(': ', 1)
        refuse(name, getattr(sc, name), why)
    return ()


def speed_under_noise(sc: Scenario) -> tuple[float, float]:
    """
    Return the mean offset and the standard deviation (m/s) of a rigid body's speed u - u0.

    A vehicle reads its speed through the water with white noise n of ``sigma^2`` per step
    (``water_sigma`` estimating the flow, its DVL; ``velocity_sigma`` told it, from its
    Doppler less the told flow). In straight motion the thrust (7.1) of the measured
    ``u + n``, ``h (u + n)^2 + m0 K_f (u0 - u - n)``, against the drag ``h u^2`` gives
    ``m0 du' = -m0 K_f du + (2 h u0 - m0 K_f) n + h n^2``: the mean offset
    ``h sigma^2 / (m0 K_f)``, and, the noise held over each period (spectral density
    ``sigma^2 dt``), the variance ``c^2 sigma^2 dt / (2 K_f)`` with ``c = 2 h u0 / m0 - K_f``,
    the drag cancellation amplifying the noise (docs/errata.md, "The world a real fleet meets").
    The spread is an upper estimate: measured 0.72-0.91 of it.
    """
    sigma = sc.velocity_sigma if sc.flow_source == 'known' else sc.water_sigma
    c = 2.0 * sc.h * sc.u0 / sc.m0 - sc.K_f
    return (sc.h * sigma ** 2 / (sc.m0 * sc.K_f),
            abs(c) * sigma * float(np.sqrt(sc.dt_control / (2.0 * sc.K_f))))
