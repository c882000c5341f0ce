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
The formations, one object each, chosen once by name (the ``formation`` parameter).

The parallel formation (1.12), (3.7): every vehicle on one course, K < 0; the circular
formation (1.16), (3.14): every vehicle on one circle of radius ``1/|omega0|``, K > 0. Each
carries what the rest of the package asks of it: its default and allowed gain K, its
:mod:`laws` object, the radius of its steady motion (none: straight), the rate its laws act
at, whether it steers the heading in still water, whether symmetric patterns apply, and the
names of the errors and conditions its convergence is judged by (:mod:`sim.metrics`).
:data:`FORMATIONS` is the table; :func:`of` picks a scenario's.
"""
from __future__ import annotations

import math
from typing import ClassVar

from formation_control.core import graphs, laws
from formation_control.core.errors import refuse as _fail
from formation_control.core.geometry import RealArray
from formation_control.core.parameters import Scenario
from formation_control.core.stability import formation_rate
from formation_control.core.steering import law as steering_law, NoLagLimit
from formation_control.core.vehicles import vehicle_model
import numpy as np

PHASE_SPREADS = np.linspace(0.0, 0.25, 5)
"""The values of ``q = (1 - |mean e^{2 i theta}|^2) / 4`` the centre loop is checked at."""


class FormationKind:
    """
    A formation: the shape the laws steer the fleet to.

    Attributes
    ----------
    name : str
        The value of the ``formation`` parameter.
    default_K : float
        The formation gain K (1/s) of a scenario that gives none.
    steers_heading : bool
        In a known zero flow the rigid bodies' law steers the heading theta with rate omega
        ((7.3) with (3.7)) instead of the course.
    patterns : bool
        Symmetric patterns (places on the circle) apply.
    band_errors : tuple of str
        The steady-state errors of the band test (:data:`sim.metrics.BANDS`), in order.
    conditions : tuple of str
        The conditions of the exact convergence test (:func:`sim.metrics.conditions`).

    """

    name: ClassVar[str]
    default_K: ClassVar[float]
    steers_heading: ClassVar[bool] = False
    patterns: ClassVar[bool] = False
    band_errors: ClassVar[tuple[str, ...]]
    conditions: ClassVar[tuple[str, ...]]

    def check(self, sc: Scenario) -> None:
        """Refuse gains the formation's law does not converge with (ScenarioError)."""
        raise NotImplementedError

    def law(self, sc: Scenario, coupling: laws.Coupling | None,
            pattern: laws.Moments | laws.Slots | None, cross: float) -> laws.Formation:
        """
        Return the formation law over the whole fleet.

        Parameters
        ----------
        sc : Scenario
            Its gains (K, omega0, c0, informed).
        coupling : laws.Coupling or None
            The communication graph's coupling; None: all-to-all.
        pattern : laws.Moments or laws.Slots or None
            The phase potential of a symmetric pattern (:func:`control.pattern_law`).
        cross : float
            The scale of the circular backstepping law's cross term, ``1 / (L T)^2``
            (:func:`control.law_units`).

        """
        raise NotImplementedError

    def radius(self, sc: Scenario) -> float | None:
        """Return the radius of the steady motion (m); None: straight motion."""
        return None

    def law_rate(self, sc: Scenario, s_min: float) -> tuple[float, str]:
        """Return the rate the laws act at (rad/s) for a ground speed ``s_min``, and its name."""
        raise NotImplementedError

    def lag_limit(self, sc: Scenario) -> tuple[float, str]:
        """
        Return the longest actuator lag (s) the formation's linearised loops are stable with.

        Parameters
        ----------
        sc : Scenario
            The steering law, its gains and the formation's.

        Returns
        -------
        (float, str)
            The limit and the loop it comes from. The base: the steering loop's
            (:meth:`steering.SteeringLaw.lag_limit` at :func:`stability.formation_rate`).

        Raises
        ------
        NoLagLimit
            No limit is derived for the law or the formation.

        """
        steer, f = steering_law(sc), formation_rate(sc)
        return (steer.lag_limit(steer.bandwidth(sc), f, sc.K_I),
                f'the steering loop ({steer.gain}, formation rate {f:.3g} 1/s)')

    def lag_caveat(self, sc: Scenario) -> str | None:
        """Return why :meth:`lag_limit` may not hold for the scenario's vehicles; None: it does."""
        return None


class ParallelFormation(FormationKind):
    """Parallel motion (1.12), (3.7): the phases synchronise, ``K < 0``."""

    name = 'parallel'
    default_K = -1.0
    steers_heading = True
    band_errors = ('course_spread',)
    conditions = ('order', 'turn_rate')

    def check(self, sc: Scenario) -> None:
        """Refuse ``K >= 0``."""
        if not sc.K < 0:
            _fail('K', sc.K, 'formation parallel needs K < 0 (1.12), (3.7)')

    def law(self, sc: Scenario, coupling: laws.Coupling | None,
            pattern: laws.Moments | laws.Slots | None, cross: float) -> laws.Formation:
        """Return :class:`laws.Parallel` with gain K (no pattern, no cross term)."""
        return laws.Parallel(sc.K, coupling)

    def law_rate(self, sc: Scenario, s_min: float) -> tuple[float, str]:
        """Return ``|K|``, the gain of the alignment (1.12)."""
        return abs(sc.K), 'the parallel gain |K|'


class CircularFormation(FormationKind):
    """Circular motion (1.16), (3.14), (7.17): one circle of radius ``1/|omega0|``, ``K > 0``."""

    name = 'circular'
    default_K = 1.0
    patterns = True
    band_errors = ('centre_spread', 'radius_error')
    conditions = ('centre_spread', 'radius')

    def check(self, sc: Scenario) -> None:
        """Refuse ``K <= 0`` and ``omega0 = 0``."""
        if not sc.K > 0:
            _fail('K', sc.K, 'formation circular needs K > 0 (1.16), (3.14)')
        if sc.omega0 == 0:
            _fail('omega0', sc.omega0, 'formation circular needs omega0 != 0 (radius '
                  '1/|omega0|)')

    def law(self, sc: Scenario, coupling: laws.Coupling | None,
            pattern: laws.Moments | laws.Slots | None, cross: float) -> laws.Formation:
        """Return :class:`laws.Circular` (K, omega0, c0, the informed vehicles, the pattern)."""
        return laws.Circular(sc.K, sc.omega0, sc.c0_c, sc.informed_mask, coupling, pattern,
                             cross)

    def radius(self, sc: Scenario) -> float | None:
        """Return ``1/|omega0|`` (m)."""
        return 1.0 / abs(sc.omega0)

    def law_rate(self, sc: Scenario, s_min: float) -> tuple[float, str]:
        """Return the circle's own turn rate ``|omega0| s_min``."""
        return abs(sc.omega0) * s_min, "the circle's own turn rate |omega0| (s - |f|)"

    def lag_limit(self, sc: Scenario) -> tuple[float, str]:
        """
        Return the smaller of the steering loop's and the centre loop's lag limits (s).

        The centre loop (:func:`centre_lag_limit`) is derived all-to-all, without a pattern
        or a prescribed centre; elsewhere it raises NoLagLimit.
        """
        steer = steering_law(sc)
        loop = (centre_lag_limit(sc), f"the circle's centre loop ({steer.gain} = "
                f'{steer.bandwidth(sc):g}, K = {sc.K:g}, omega0 = {sc.omega0:g})')
        return min(super().lag_limit(sc), loop)

    def lag_caveat(self, sc: Scenario) -> str | None:
        """
        Return why the centre loop's limit may not hold here: rigid bodies, a flow; else None.

        The limit is derived for particles in still water; the figures quoted are measured
        (docs/errata.md, "Actuator lag in the circle's centre loop").
        """
        if vehicle_model(sc.model).rigid:
            return ("the centre loop's limit is derived for particles: a rigid body's speed "
                    'and sway are not in it (measured: rigid_circular, seed 12, loses its '
                    'centres from 0.2 s of lag, 0.23 of the limit)')
        if sc.flow_c != 0 or sc.flow_model != 'uniform':
            return ("the centre loop's limit is derived in still water: in a flow the course "
                    'rate varies along the circle and the lag leaves the centres apart in '
                    'proportion to it (measured: particle_circular_flow, |f| = 0.5 m/s, seed '
                    '12: 2 cm at 0.1 of the limit, lost from 0.45 of it)')
        return None


def centre_loop(sc: Scenario, tau: float, q: float) -> tuple[RealArray, RealArray]:
    """
    Return the characteristic polynomials of the circle's centre loop through a lag tau.

    Parameters
    ----------
    sc : Scenario
        The steering law and gains, K, omega0, the speed (1; rigid bodies u0).
    tau : float
        The actuator lag (s).
    q : float
        ``(1 - |mean e^{2 i theta}|^2) / 4`` in [0, 1/4] of the phases on the circle.

    Returns
    -------
    (ndarray, ndarray)
        ``M (s^2 + W^2) + s A`` (the modes that leave the mean centre at rest) and
        ``M^2 (s^2 + W^2) + s M A + q A^2`` (the modes that move it), with ``W = omega0 s0``,
        ``M = omega0 P``, ``A = omega0 K Phi + Sigma / omega0`` of the law's loop
        (:meth:`steering.SteeringLaw.lag_loop`); docs/errata.md, "Actuator lag in the
        circle's centre loop".

    """
    steer = steering_law(sc)
    P, Phi, Sigma = steer.lag_loop(tau, steer.bandwidth(sc), sc.K_I)
    speed = sc.u0 if vehicle_model(sc.model).rigid else 1.0
    rotation = np.array([1.0, 0.0, (sc.omega0 * speed) ** 2])
    M = sc.omega0 * P
    A = np.polyadd(sc.omega0 * sc.K * Phi, Sigma / sc.omega0)
    sMA = np.polymul([1.0, 0.0], np.polymul(M, A))
    single = np.polyadd(np.polymul(M, rotation), np.polymul([1.0, 0.0], A))
    coupled = np.polyadd(np.polyadd(np.polymul(np.polymul(M, M), rotation), sMA),
                         q * np.polymul(A, A))
    return single, coupled


def centre_lag_limit(sc: Scenario) -> float:
    """
    Return the longest lag (s) the circle's linearised centre loop is stable with.

    Every polynomial of :func:`centre_loop` at each :data:`PHASE_SPREADS` must be Hurwitz;
    the largest such tau is bisected from a stable one, inf past 1e6 s (the first-order law).
    Raises NoLagLimit on a graph, with a pattern or a prescribed centre (not derived).
    """
    if not sc.all_to_all or sc.pattern != 'none' or sc.informed:
        raise NoLagLimit("the circle's centre loop through an actuator lag is derived "
                         'all-to-all, without a pattern or a prescribed centre only: '
                         "parameter 'actuator_lag' cannot be checked here (graph, pattern, "
                         'informed)')

    def stable(tau: float) -> bool:
        return all(bool(np.all(np.roots(p).real < 0)) for q in PHASE_SPREADS
                   for p in centre_loop(sc, tau, q))

    high = 1.0
    while stable(high):
        high *= 2.0
        if high > 1e6:
            return float(np.inf)
    low = 0.0
    for _ in range(32):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if stable(mid) else (low, mid)
    return low


FORMATIONS: dict[str, FormationKind] = {f.name: f for f in (ParallelFormation(),
                                                            CircularFormation())}
"""The formation table: ``formation`` value -> formation."""


def default_K(formation: str) -> float:
    """Return the formation gain K of a scenario that gives none: -1 parallel, 1 circular."""
    if formation not in FORMATIONS:
        _fail('formation', formation, f"allowed values: {' | '.join(FORMATIONS)}")
    return FORMATIONS[formation].default_K


def of(sc: Scenario) -> FormationKind:
    """Return the formation of a scenario."""
    return FORMATIONS[sc.formation]


def check(sc: Scenario) -> tuple[str, ...]:
    """Refuse gains the formation's law does not converge with and a pattern that cannot be."""
    of(sc).check(sc)
    _check_pattern(sc)
    return ()


def _check_pattern(sc: Scenario) -> None:
    """Refuse a symmetric pattern that cannot exist or that the laws do not reach."""
    if sc.pattern == 'none':
        return
    if not of(sc).patterns:
        _fail('pattern', sc.pattern, 'a symmetric pattern places vehicles on the circle: it '
              'needs formation circular')
    if sc.flow_c != 0 or sc.flow_model != 'uniform':
        flow = (f'flow = {list(sc.flow)} m/s' if sc.flow_model == 'uniform' else
                f'flow_model = {sc.flow_model!r} (flow = {list(sc.flow)} m/s)')
        _fail('pattern', sc.pattern, f'{flow} is not a zero flow: in a flow no '
              f'fixed phase pattern exists on a circle (the course rate omega0 s_k varies '
              f'with the course, so the vehicles move along the circle relative to each '
              f'other); use flow: [0.0, 0.0] or pattern: none')
    n, m = sc.num_vehicles, sc.pattern_M
    if sc.pattern == 'symmetric' and not (2 <= m < n and n % m == 0):
        _fail('pattern_M', m, f'symmetric needs 2 <= M < num_vehicles = {n} with M dividing '
              f'num_vehicles (M clusters of N/M); M = N is pattern: splay')
    if sc.pattern_form == 'moments' and not sc.all_to_all:
        _fail('pattern_form', sc.pattern_form, 'the moments are fleet means (all-to-all): on a '
              'limited graph their Laplacian form converges only locally; use slots (or auto)')
    if sc.pattern_slots and not sc.comm_graph.complete:
        _check_slot_traps(sc)


def _check_slot_traps(sc: Scenario) -> None:
    """Refuse slots on a graph whose phase potential has stable states other than synchrony."""
    n = sc.num_vehicles
    if sc.graph in ('ring', 'circulant'):
        offsets = (1,) if sc.graph == 'ring' else sc.graph_offsets
        twisted = graphs.twisted_states(n, offsets)
        if not twisted:
            return
        where = (f'a ring of {n}' if sc.graph == 'ring' else
                 f'the circulant graph {list(offsets)} on {n}')
        rule = ' (|q| < N/4)' if sc.graph == 'ring' else ''
        found = (f'{where} has stable twisted states for slots: psi_k = 2 pi q k / N with '
                 f"q = {', '.join(map(str, twisted))}{rule}")
    else:
        share = graphs.slot_traps(sc.comm_graph)
        if share == 0:
            return
        found = (f'the {sc.graph} graph on {n} has stable slot states other than synchrony: '
                 f'{share:.0%} of {graphs.TRAP_STARTS} random phase starts end in one')
    dense = math.ceil(0.75 * (n - 1))
    _fail('graph', sc.graph, f'{found}, where a slot pattern stops with its slots wrongly filled '
          f'(a splay in coincident pairs, clusters in the wrong number or order). Use graph: '
          f'complete (the moment form), a tree (graph: explicit without cycles), or a denser '
          f'graph (every degree >= {dense} = 3 (N - 1) / 4 synchronises from almost every start)')
