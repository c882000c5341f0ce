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
actuator lag its linearised loop is stable with (docs/errata.md, "Actuator lag"), whether it
integrates (anti-windup) and whether it reads the course rate from the model with the held
force. :data:`LAWS` is the table; :func:`law` picks a scenario's.
"""
from __future__ import annotations

from typing import ClassVar, TYPE_CHECKING

from formation_control.core import laws
from formation_control.core.errors import ScenarioError
from formation_control.core.geometry import RealArray
import numpy as np

if TYPE_CHECKING:
    from formation_control.core.parameters import Scenario


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
        (:func:`scenario.uses_held_force`).

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


LAWS: dict[str, SteeringLaw] = {law.name: law for law in (FirstOrder(), Backstepping(),
                                                          Proportional(), PI())}
"""The steering-law table: ``controller`` value -> law."""


def law(sc: Scenario) -> SteeringLaw:
    """Return the steering law of a scenario (its ``controller``)."""
    return LAWS[sc.controller]
