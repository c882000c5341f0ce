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
The world a real fleet meets, plant side: vehicles unlike their model, lagging actuators, gusts.

Every part is off by default (:func:`active`), and then the plant integrates the nominal model
exactly as before. The controllers always keep the nominal scenario; only the plant (the
simulator's :class:`simulator.Stepper`, which the plant node's :class:`fleet.FleetPlant` holds
too) integrates the true vehicles of a :class:`World`:

- **model mismatch**: per vehicle, factors on the mass m0, inertia I0, drag h, drag-moment
  lever l1 (``rigid_cop``), thrust and steering effectiveness (particles: steering only),
  given per vehicle (``mismatch_<name>``) or drawn uniform in ``[1 - mismatch, 1 + mismatch]``;
- **actuators**: the applied input ``a`` follows the held command ``U`` through a first-order lag
  of time constant ``actuator_lag`` and a rate limit (``max_thrust_rate``,
  ``max_steering_rate``), updated at the start of each integration step ``dt`` and held over
  it: ``a <- a + clip((U - a)(1 - e^{-dt/tau}), -rate dt, rate dt)``, from the first command
  (the actuator starts at it);
- **gusts**: per vehicle a complex Gauss-Markov (Ornstein-Uhlenbeck) flow component of standard
  deviation ``gust_intensity`` per axis and correlation time ``gust_time`` (a Dryden-type gust
  of correlation length L met at speed V has ``gust_time = L / V``), discretised exactly at the
  integration step, ``g <- a g + sigma sqrt(1 - a^2) w`` with ``a = e^{-dt/T}``, stationary from
  the start, and held over the step on top of the flowfield.

Everything random comes from per-vehicle streams, seeded by (scenario seed, ``world_seed``,
vehicle id, channel): a vehicle's draws depend neither on the other vehicles, nor on the batch of
fleets it runs in, nor on the order a plant serves them, so the plant node and the simulator draw
the same numbers.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace

from formation_control.core import formations
from formation_control.core.errors import refuse as _fail
from formation_control.core.geometry import ComplexArray, RealArray
from formation_control.core.models import deriv, Plant, rk4, ROW_OMEGA, ROW_X, ROW_Y
from formation_control.core.parameters import MISMATCH_ARRAYS, MISMATCH_NAMES, Scenario
from formation_control.core.vehicles import vehicle_model
import numpy as np

TAG = 0x776f726c
"""The first word of every world stream's seed ('worl')."""
CHANNELS = {'mismatch': 1, 'gust': 2, 'sensors': 3}
CHUNK = 256
"""Normal draws a vehicle's gust stream takes at a time (the sequence does not depend on it)."""
GUST_CHANNELS = ('gust_x', 'gust_y')
"""What a run in gusts records of each vehicle beside the state: its gust (m/s, map frame)."""


def active(sc: Scenario) -> bool:
    """Return whether any part of the world is on (else the plant is the nominal model)."""
    return bool(sc.mismatch or any(getattr(sc, f'mismatch_{n}') for n in MISMATCH_NAMES)
                or sc.actuator_lag or sc.max_thrust_rate or sc.max_steering_rate
                or sc.gust_intensity)


def stream(seed: int, world_seed: int, k: int, channel: str) -> np.random.Generator:
    """Return vehicle k's (1..N) random stream of ``channel`` (mismatch, gust, sensors)."""
    return np.random.default_rng([TAG, seed, world_seed, k, CHANNELS[channel]])


def mismatch_factors(sc: Scenario, seed: int | None = None) -> dict[str, RealArray]:
    """
    Return each vehicle's true-to-nominal factor of every :data:`MISMATCH_NAMES` parameter.

    Parameters
    ----------
    sc : scenario.Scenario
        Its ``mismatch`` spread, the per-vehicle ``mismatch_<name>`` lists (they win over the
        spread), ``world_seed``.
    seed : int, optional
        The fleet's seed; ``sc.seed`` by default.

    Returns
    -------
    dict of str to ndarray, shape (N,)
        ``1 + mismatch u`` with u uniform in [-1, 1] from vehicle k's own stream (six draws,
        one per name, whether or not a list replaces them), or the list's entries.

    """
    seed = sc.seed if seed is None else seed
    n = sc.num_vehicles
    drawn = np.ones((n, len(MISMATCH_NAMES)))
    if sc.mismatch:
        for k in range(n):
            u = stream(seed, sc.world_seed, k + 1, 'mismatch').uniform(-1.0, 1.0,
                                                                       len(MISMATCH_NAMES))
            drawn[k] = 1.0 + sc.mismatch * u
    out = {}
    for j, name in enumerate(MISMATCH_NAMES):
        given = getattr(sc, f'mismatch_{name}')
        out[name] = np.array(given, float) if given else drawn[:, j]
    return out


def recorded_gust(channels: Mapping[str, RealArray]) -> complex | ComplexArray:
    """
    Return the gust a record's ``channels`` carry (:data:`GUST_CHANNELS`), complex m/s; else 0.

    The gust each vehicle met over the integration step that ended at the sample: with the
    flowfield it is the flow the vehicle moves in, ``(u + i v) e^{i theta} + f + g`` its true
    ground velocity (8.1), whose direction is the course the formation's metrics read.
    """
    if GUST_CHANNELS[0] not in channels:
        return 0.0
    return np.asarray(channels['gust_x']) + 1j * np.asarray(channels['gust_y'])


def rate_limits(sc: Scenario) -> RealArray:
    """Return the rate limit of each input row (2,) (unit/s; inf: none)."""
    rates = (sc.max_thrust_rate if vehicle_model(sc.model).rigid else 0.0, sc.max_steering_rate)
    return np.array([r if r > 0 else np.inf for r in rates])


class World:
    """
    The true vehicles, actuators and gusts of a scenario's fleet, or of a batch of fleets.

    Parameters
    ----------
    sc : scenario.Scenario
        The scenario (:func:`active`).
    shape : tuple of int
        ``(N,)`` for one fleet, ``(B, N)`` for a batch.
    seeds : sequence of int, optional
        The seed of each fleet of a batch (B); ``sc.seed`` for every one by default.

    Attributes
    ----------
    plant : models.Plant
        The true vehicles: the nominal plant with m0, I0, h, l1 multiplied by their factors
        (arrays of ``shape``).
    effect : ndarray, shape (2,) + shape
        The thrust and steering effectiveness factors.
    applied : ndarray, shape (2,) + shape, or None
        The actuators' output, None before the first command.
    gust : ndarray of complex, shape ``shape``
        The gust of each vehicle now (m/s, map frame).

    """

    def __init__(self, sc: Scenario, shape: tuple[int, ...],
                 seeds: Sequence[int] | None = None) -> None:
        self.sc, self.shape = sc, shape
        fleets = [sc.seed] * (shape[0] if len(shape) > 1 else 1) if seeds is None else \
            [int(s) for s in seeds]
        factors = [mismatch_factors(sc, s) for s in fleets]

        def per(name: str) -> RealArray:
            return np.array([f[name] for f in factors]).reshape(shape)

        nominal = Plant.of(sc)
        self.plant = replace(nominal, m0=nominal.m0 * per('m0'), I0=nominal.I0 * per('I0'),
                             h=nominal.h * per('h'), l1=nominal.l1 * per('l1'))
        self.effect = np.array([per('thrust'), per('steering')])
        if not nominal.model.rigid:
            self.effect[0] = 1.0
        self.decay = 1.0 - np.exp(-sc.dt_integration / sc.actuator_lag) if sc.actuator_lag \
            else 1.0
        self.step_limit = (rate_limits(sc) * sc.dt_integration).reshape(
            (2,) + (1,) * len(shape))
        self.applied: RealArray | None = None
        self.gust = np.zeros(shape, complex)
        self.streams = [stream(s, sc.world_seed, k + 1, 'gust') for s in fleets
                        for k in range(sc.num_vehicles)] if sc.gust_intensity else []
        self.buffer = np.empty((len(self.streams), 0))
        self.used = 0
        if self.streams:
            self.gust = sc.gust_intensity * self._normals()
            self.gust_decay = float(np.exp(-sc.dt_integration / sc.gust_time))

    def _normals(self) -> ComplexArray:
        """Return the next complex standard normal pair of every vehicle, ``shape``."""
        if self.used + 2 > self.buffer.shape[1]:
            self.buffer = np.array([g.standard_normal(2 * CHUNK) for g in self.streams])
            self.used = 0
        w = self.buffer[:, self.used:self.used + 2]
        self.used += 2
        return (w[:, 0] + 1j * w[:, 1]).reshape(self.shape)

    def actuate(self, U: RealArray) -> RealArray:
        """Advance the actuators one integration step towards the commands U; return a."""
        if self.applied is None:
            self.applied = np.array(U, float)
        else:
            change = (U - self.applied) * self.decay
            self.applied = self.applied + np.clip(change, -self.step_limit, self.step_limit)
        return self.applied

    def blow(self) -> ComplexArray:
        """Advance every vehicle's gust one integration step; return it (m/s)."""
        if self.streams:
            a = self.gust_decay
            self.gust = a * self.gust + self.sc.gust_intensity * np.sqrt(1.0 - a * a) * \
                self._normals()
        return self.gust

    def rates(self, X: RealArray, a: RealArray, t: float) -> RealArray:
        """Return dX/dt of the true vehicles with the applied inputs ``a`` and the gust."""
        k = deriv(X, a * self.effect, self.plant, t)
        k[ROW_X] += self.gust.real
        k[ROW_Y] += self.gust.imag
        return k

    def step(self, X: RealArray, U: RealArray, t: float) -> RealArray:
        """
        Return the state one integration step later, the commands U held.

        The actuators and gusts advance first (:meth:`actuate`, :meth:`blow`), then one RK4
        step (:func:`models.rk4`) of the true vehicles with them held; a first-order
        particle's omega is its applied turn rate.
        """
        dt = self.sc.dt_integration
        a = self.actuate(U)
        self.blow()
        if self.plant.model.first_order:
            X = np.array(X, float)
            X[ROW_OMEGA] = a[1] * self.effect[1]
        return rk4(lambda X, t: self.rates(X, a, t), X, dt, t)


def steady_speed(sc: Scenario, thrust: RealArray, drag: RealArray) -> RealArray:
    """
    Return the steady forward speed of rigid bodies in straight motion under model mismatch.

    Parameters
    ----------
    sc : scenario.Scenario
        The nominal u0, K_f, m0, h.
    thrust, drag : array_like
        Each vehicle's thrust-effectiveness and drag factors (:func:`mismatch_factors`).

    Returns
    -------
    ndarray
        The stable root u of ``(f_T h - h_true) u^2 - f_T m0 K_f u + f_T m0 K_f u0 = 0``: the
        thrust (7.1) ``T = h s u + m0 K_f (u0 - u)`` with v = omega = 0, scaled by f_T, against
        the true drag ``h_true u^2`` (the true mass drops out). With ``d = f_T h - h_true``:
        u0 at d = 0; ``2 c u0 / (c + sqrt(c^2 - 4 d c u0))`` with ``c = f_T m0 K_f``, below u0
        for d < 0 and above it for d > 0; NaN (no steady speed: it runs away) for
        ``d > c / (4 u0)`` (docs/errata.md, "Model mismatch").

    """
    c = np.asarray(thrust, float) * sc.m0 * sc.K_f
    d = np.asarray(thrust, float) * sc.h - np.asarray(drag, float) * sc.h
    disc = c * c - 4.0 * d * c * sc.u0
    with np.errstate(invalid='ignore'):
        return np.where(disc >= 0, 2.0 * c * sc.u0 / (c + np.sqrt(disc)), np.nan)


def speed_under_bias(sc: Scenario, b: RealArray) -> RealArray:
    """
    Return the steady forward speed of rigid bodies whose measured u is off by ``b`` (m/s).

    Parameters
    ----------
    sc : scenario.Scenario
        The nominal u0, K_f, m0, h (the true vehicles are nominal).
    b : array_like
        Each vehicle's error of its measured speed through the water (m/s): an untold gust
        along its body x, a DVL bias.

    Returns
    -------
    ndarray
        In straight motion the thrust (7.1) of the measured ``u + b``,
        ``h (u + b)^2 + m0 K_f (u0 - u - b)``, meets the drag ``h u^2`` at
        ``u = (m0 K_f (u0 - b) + h b^2) / (m0 K_f - 2 h b)``: to first order
        ``u - u0 = (2 h u0 / (m0 K_f) - 1) b``, the drag cancellation amplifying the error
        (9 b with the thesis' h = 5, u0 = m0 = K_f = 1; docs/errata.md, "Model mismatch").

    """
    b = np.asarray(b, float)
    c = sc.m0 * sc.K_f
    return (c * (sc.u0 - b) + sc.h * b * b) / (c - 2.0 * sc.h * b)


def check(sc: Scenario) -> tuple[str, ...]:
    """
    Refuse a world no vehicle could have or the loop could bear; return the warnings.

    A mismatch factor must stay positive; an actuator lag is held against the formation's
    limit (:meth:`formations.FormationKind.lag_limit`, the smaller of the steering loop's and,
    on a circle, the centre loop's: refused from it, warned from half of it).
    """
    if sc.mismatch >= 1:
        _fail('mismatch', sc.mismatch, 'must be < 1: a factor 1 - mismatch <= 0 makes a mass, '
              'inertia or drag non-positive')
    for name in MISMATCH_ARRAYS:
        if name != 'mismatch_l1' and any(v <= 0 for v in getattr(sc, name)):
            _fail(name, list(getattr(sc, name)), 'every factor must be > 0 (a non-positive '
                  'mass, inertia, drag or effectiveness)')
    notes = []
    if sc.actuator_lag:
        limit, loop = formations.of(sc).lag_limit(sc)
        text = (f'actuator_lag = {sc.actuator_lag:g} s against {loop}, stable only for a lag '
                f'below {limit:.3g} s (docs/errata.md, "Actuator lag")')
        if sc.actuator_lag >= limit:
            _fail('actuator_lag', sc.actuator_lag, f'{text}: the loop would diverge; lower the '
                  f'lag or the gains')
        if sc.actuator_lag > 0.5 * limit:
            notes.append(f'{text}: past half of it, expect slow, oscillating turns, and from a '
                         f'start far from the formation perhaps no settling (the limit is that '
                         f'of the linearised loop; measured on circles: 2 to 6 of 8 starts '
                         f'settle at 0.8 of it, 8 of 8 at 0.5)')
        caveat = formations.of(sc).lag_caveat(sc)
        if caveat:
            notes.append(f'actuator_lag = {sc.actuator_lag:g} s: {caveat}')
    return tuple(notes)
