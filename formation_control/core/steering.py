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
The steering laws, one object each, chosen once by name (the ``controller`` parameter).

A law turns the formation law's phase rate ``phi`` (1.12), (1.16) into a command: the phase
rate itself (first order, (1.12), (1.16)) or a phase acceleration: backstepping (3.7),
(3.14), (7.12), proportional (5.5), PI (8.24). Each carries what the rest of the package asks
of it: the gain whose modulus is its steering bandwidth, its phase acceleration, the longest
actuator lag its linearised loop is stable with (docs/errata.md, "Actuator lag") and that loop
through the lag, which the circle's centre loop closes on (:mod:`formations`), whether it
integrates (anti-windup) and whether it reads the course rate from the model with the held
force. :data:`LAWS` is the table; :func:`law` picks a scenario's; :func:`check` refuses a
rigid-body steering loop that would diverge (tail steering's right-half-plane zero, the full
law's loop through the held force, the PI law's drag condition).
"""
from __future__ import annotations

import math
from typing import ClassVar

from formation_control.core import laws
from formation_control.core.errors import refuse as _fail, ScenarioError
from formation_control.core.geometry import RealArray
from formation_control.core.parameters import Scenario
from formation_control.core.vehicles import vehicle_model
import numpy as np


class NoLagLimit(ScenarioError):
    """A steering law without a derived actuator-lag limit was asked for one."""


class SteeringLaw:
    """
    A steering law: how a vehicle's phase is steered to the formation law's rate ``phi``.

    Attributes
    ----------
    name : str
        The value of the ``controller`` parameter.
    gain : str
        The parameter whose modulus is the steering bandwidth (1/s).
    order : int
        1: the law commands the phase rate (a first-order vehicle); 2: its acceleration.
    feedforward : bool
        The command adds ``phi'`` (:func:`stability.cascade_matrix`).
    integrates : bool
        The law keeps an integrator per vehicle (anti-windup applies).
    held_force : bool
        On rigid bodies the law reads the course rate from the model with the held force
        (:func:`uses_held_force`).

    """

    name: ClassVar[str]
    gain: ClassVar[str]
    order: ClassVar[int] = 2
    feedforward: ClassVar[bool] = False
    integrates: ClassVar[bool] = False
    held_force: ClassVar[bool] = False

    def bandwidth(self, sc: Scenario) -> float:
        """Return how fast the steering loop acts (1/s): the modulus of :attr:`gain`."""
        return abs(float(getattr(sc, self.gain)))

    def phase_rate(self, formation: laws.Formation, view: laws.View,
                   idx: laws.Index) -> RealArray:
        """Return the commanded phase rate (rad/s) of a first-order law (others: TypeError)."""
        raise TypeError(f'steering law {self.name!r} commands a phase acceleration, not a rate')

    def phase_accel(self, formation: laws.Formation, view: laws.View, idx: laws.Index,
                    sc: Scenario, integral: RealArray | None
                    ) -> tuple[RealArray, RealArray | None]:
        """
        Return the phase acceleration of the vehicles ``idx`` and the law's new integrator.

        Parameters
        ----------
        formation : laws.Parallel or laws.Circular
            The formation law.
        view : laws.View
            Views of the vehicles known.
        idx : index
            The vehicles commanded, into the vehicles of ``view``.
        sc : Scenario
            Its gains and control period.
        integral : ndarray or None
            The integrator of each commanded vehicle (None before the first command).

        Returns
        -------
        (ndarray, ndarray or None)
            The phase acceleration (rad/s^2), shape (n,), and the integrator after this
            control period (``integral`` unchanged for a law without one).

        """
        raise TypeError(f'steering law {self.name!r} commands a phase rate, not an '
                        f'acceleration')

    def lag_limit(self, gain: float, f: float, K_I: float = 0.0) -> float:
        """
        Return the longest actuator lag tau (s) the law's linearised loop is stable with.

        Parameters
        ----------
        gain : float
            The steering bandwidth (1/s), :meth:`bandwidth`.
        f : float
            Rate of the formation loop (1/s), :func:`stability.formation_rate`.
        K_I : float
            The PI law's integral gain (1/s^2).

        Raises
        ------
        NoLagLimit
            The law has no derived limit (a law is never taken as stable under any lag
            without one).

        """
        raise NoLagLimit(f'steering law {self.name!r} has no derived actuator-lag limit: '
                         "parameter 'actuator_lag' cannot be checked against it")

    def lag_loop(self, tau: float, gain: float, K_I: float = 0.0
                 ) -> tuple[RealArray, RealArray, RealArray]:
        """
        Return the law's linearised loop through the lag, ``P v = Phi phi~ + Sigma sigma~``.

        Parameters
        ----------
        tau : float
            The actuator lag (s).
        gain : float
            The steering bandwidth (1/s), :meth:`bandwidth`.
        K_I : float
            The PI law's integral gain (1/s^2).

        Returns
        -------
        (ndarray, ndarray, ndarray)
            The coefficients (highest power first) of the polynomials P, Phi, Sigma in s that
            relate the rate error ``v = rate - phi`` at rest, the deviation ``phi~`` of the
            formation's phase rate and that ``sigma~`` of the cross term, the applied input
            lagging the command, ``tau a' = u - a`` (docs/errata.md, "Actuator lag in the
            circle's centre loop").

        Raises
        ------
        NoLagLimit
            The law has no derived loop.

        """
        raise NoLagLimit(f'steering law {self.name!r} has no derived loop through an actuator '
                         "lag: parameter 'actuator_lag' cannot be checked against it")


class FirstOrder(SteeringLaw):
    """The first-order law ``phase' = phi`` (1.12), (1.16), on first-order vehicles (1.1)."""

    name = 'first_order'
    gain = 'K'
    order = 1

    def phase_rate(self, formation: laws.Formation, view: laws.View,
                   idx: laws.Index) -> RealArray:
        """Return ``phi`` (rad/s), :func:`laws.first_order`."""
        return laws.first_order(formation, view, idx)

    def lag_limit(self, gain: float, f: float, K_I: float = 0.0) -> float:
        """Return inf: a first-order loop through a lag (``tau s^2 + s + g``) is always stable."""
        return np.inf

    def lag_loop(self, tau: float, gain: float, K_I: float = 0.0
                 ) -> tuple[RealArray, RealArray, RealArray]:
        """Return ``P = tau s + 1``, ``Phi = 1``, ``Sigma = 0``: the rate lags phi."""
        return np.array([tau, 1.0]), np.ones(1), np.zeros(1)


class Backstepping(SteeringLaw):
    """Backstepping (3.7), (3.14), (4.3), (4.8), (7.12), (7.25): gain kappa, adds ``phi'``."""

    name = 'backstepping'
    gain = 'kappa'
    feedforward = True

    def phase_accel(self, formation: laws.Formation, view: laws.View, idx: laws.Index,
                    sc: Scenario, integral: RealArray | None
                    ) -> tuple[RealArray, RealArray | None]:
        """Return :func:`laws.backstepping` with gain kappa, and ``integral`` unchanged."""
        return laws.backstepping(formation, view, sc.kappa, idx), integral

    def lag_limit(self, gain: float, f: float, K_I: float = 0.0) -> float:
        """
        Return ``1/kappa + 1/f`` (s), inf for ``f <= 0``.

        ``u = -(kappa + f) e' - kappa f e`` through the lag: ``tau s^3 + s^2 + (kappa + f) s
        + kappa f``, stable (Routh) for ``tau < 1/kappa + 1/f``.
        """
        return 1.0 / gain + 1.0 / f if f > 0 else np.inf

    def lag_loop(self, tau: float, gain: float, K_I: float = 0.0
                 ) -> tuple[RealArray, RealArray, RealArray]:
        """Return ``P = tau s^2 + s + kappa``, ``Phi = s + kappa`` (phi' fed forward), ``1``."""
        return np.array([tau, 1.0, gain]), np.array([1.0, gain]), np.ones(1)


class Proportional(SteeringLaw):
    """The proportional law (5.5): ``-K_p (rate - phi)``."""

    name = 'proportional'
    gain = 'K_p'

    def phase_accel(self, formation: laws.Formation, view: laws.View, idx: laws.Index,
                    sc: Scenario, integral: RealArray | None
                    ) -> tuple[RealArray, RealArray | None]:
        """Return :func:`laws.proportional` with gain K_p, and ``integral`` unchanged."""
        return laws.proportional(formation, view, sc.K_p, idx), integral

    def lag_limit(self, gain: float, f: float, K_I: float = 0.0) -> float:
        """
        Return ``1/f`` (s), inf for ``f <= 0``.

        ``u = -kappa e' - kappa f e`` through the lag: stable (Routh) for ``tau < 1/f``.
        """
        return 1.0 / f if f > 0 else np.inf

    def lag_loop(self, tau: float, gain: float, K_I: float = 0.0
                 ) -> tuple[RealArray, RealArray, RealArray]:
        """Return ``P = tau s^2 + s + K_p``, ``Phi = K_p``, ``Sigma = 0``."""
        return np.array([tau, 1.0, gain]), np.array([gain]), np.zeros(1)


class PI(SteeringLaw):
    """PI steering (8.24): ``K_P e + K_I int e`` with ``e = phi - rate``."""

    name = 'pi'
    gain = 'K_P'
    integrates = True
    held_force = True

    def phase_accel(self, formation: laws.Formation, view: laws.View, idx: laws.Index,
                    sc: Scenario, integral: RealArray | None
                    ) -> tuple[RealArray, RealArray | None]:
        """Return ``K_P e + K_I int e`` (8.24), the integral advanced by one control period."""
        err = formation.terms(view, idx).phi - view.rate[idx]
        integral = (np.zeros_like(err) if integral is None else integral) + err * sc.dt_control
        return sc.K_P * err + sc.K_I * integral, integral

    def lag_limit(self, gain: float, f: float, K_I: float = 0.0) -> float:
        """
        Return the largest stable tau (s) by the roots; inf for ``f <= 0`` or past 1e6 s.

        ``u = -K_P (e' + f e) - K_I (e + f z)``, ``z' = e``, through the lag: the quartic
        ``tau s^4 + s^3 + K_P s^2 + (K_P f + K_I) s + K_I f``, bisected from a stable tau.
        """
        if f <= 0:
            return np.inf

        def stable(tau: float) -> bool:
            roots = np.roots([tau, 1.0, gain, gain * f + K_I, K_I * f])
            return bool(np.all(roots.real < 0))

        high = 1.0 / gain + 1.0 / f
        while stable(high):
            high *= 2.0
            if high > 1e6:
                return np.inf
        low = 0.0
        for _ in range(60):
            mid = 0.5 * (low + high)
            low, high = (mid, high) if stable(mid) else (low, mid)
        return low

    def lag_loop(self, tau: float, gain: float, K_I: float = 0.0
                 ) -> tuple[RealArray, RealArray, RealArray]:
        """Return ``P = tau s^3 + s^2 + K_P s + K_I``, ``Phi = K_P s + K_I``, ``0`` (times s)."""
        return np.array([tau, 1.0, gain, K_I]), np.array([gain, K_I]), np.zeros(1)


LAWS: dict[str, SteeringLaw] = {law.name: law for law in (FirstOrder(), Backstepping(),
                                                          Proportional(), PI())}
"""The steering-law table: ``controller`` value -> law."""


def law(sc: Scenario) -> SteeringLaw:
    """Return the steering law of a scenario (its ``controller``)."""
    return LAWS[sc.controller]


def rhp_zero(sc: Scenario) -> float:
    """
    Return the right-half-plane zero of tail steering, from the force F to the course.

    Parameters
    ----------
    sc : Scenario
        A rigid-body scenario (u0, h, l, I0).

    Returns
    -------
    float
        ``u0 sqrt(h l / I0)`` (rad/s): the side force at the tail first pushes the velocity
        the wrong way (errata, "Physical parameters").

    """
    return sc.u0 * math.sqrt(sc.h * sc.l / sc.I0)


def uses_held_force(sc: Scenario) -> bool:
    """
    Return whether the steering law reads the course rate from the model with the held force.

    The full law (``law_variant: full``) and the PI law (8.24) do (the exact rate and s' of
    :func:`control.rigid_view`); the practical law uses omega.
    """
    return law(sc).held_force or sc.law_variant == 'full'


def held_force_loop_gain(sc: Scenario) -> float:
    """
    Return the gain of the one-sample loop F -> beta' -> F of tail steering with the full law.

    Parameters
    ----------
    sc : Scenario
        A rigid-body scenario.

    Returns
    -------
    float
        ``bandwidth I0 / (l m0 u0)`` (:meth:`SteeringLaw.bandwidth`). With the full law, beta'
        (hence psi') contains F/m0 (7.7); computed from the held force it closes a loop
        through one sample that diverges when this gain nears 1.

    """
    return law(sc).bandwidth(sc) * sc.I0 / (sc.l * sc.m0 * sc.u0)


def check(sc: Scenario) -> tuple[str, ...]:
    """
    Refuse a law the vehicle model does not fly or a rigid-body loop that would diverge.

    The first-order law goes with first-order vehicles only. Tail steering's right-half-plane
    zero against the bandwidth, the full law's one-sample loop through the held force and the
    PI law's drag condition (errata, "Rigid-body practice"). Returns the warnings.
    """
    model = vehicle_model(sc.model)
    if model.first_order != (law(sc).order == 1):
        _fail('controller', sc.controller, "model 'first_order' goes with controller "
              "'first_order' only, and controller 'first_order' with model 'first_order' only")
    notes = []
    if model.tail_steering:
        zero, band = rhp_zero(sc), law(sc).bandwidth(sc)
        if zero < 0.5 * band:
            raise ScenarioError(
                f'tail steering has a right-half-plane zero at u0*sqrt(h*l/I0) = {zero:.3g} '
                f'rad/s, below half the steering bandwidth {band:.3g} rad/s: the law would '
                f'diverge. Raise u0, h or l, or lower I0 or the gain (parameters u0, h, l, I0)')
        if zero < band:
            notes.append(f'right-half-plane zero u0*sqrt(h*l/I0) = {zero:.3g} rad/s lies '
                         f'below the steering bandwidth {band:.3g} rad/s: expect slow, '
                         f'oscillating turns')
        gain = held_force_loop_gain(sc)
        if uses_held_force(sc) and gain >= 0.8:
            raise ScenarioError(
                f'the full law on tail steering closes a one-sample loop through the held force '
                f'with gain bandwidth*I0/(l*m0*u0) = {gain:.3g}, which must stay below 0.8 '
                f'(parameters law_variant, kappa or K_P, I0, l, m0, u0); use law_variant: '
                f'practical, or model: rigid_couple')
    if 'h' in model.params and law(sc).integrates:
        if not sc.h * sc.u0 / sc.m0 > sc.K_I / sc.K_P:
            raise ScenarioError(
                f'PI steering (8.24) needs h*u0/m0 = {sc.h * sc.u0 / sc.m0:.3g} > '
                f'K_I/K_P = {sc.K_I / sc.K_P:.3g} (parameters h, u0, m0, K_I, K_P)')
    return tuple(notes)
