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
Collective-motion steering laws on the "particle view" of a fleet (Ch. 1, 3, 4, 5, 7).

Every law here acts on a :class:`View`: for each vehicle its position ``r`` (complex), the
phase it steers (theta, gamma or psi), the rate of that phase, and its inertial speed ``s``
with ``s'``. The laws return, for the vehicles ``idx`` only, the desired phase rate ``phi``
(first-order laws) or the desired phase acceleration (backstepping, proportional). All-to-all
sums are O(N) means, so the same call serves one vehicle that knows the views it has
received (``idx=[k]``) and the whole fleet (``idx=None``).

The arrays of a view may carry leading axes, a batch of independent fleets (B, N): every mean
and neighbour sum is over the last axis, so each fleet's law is the single fleet's, computed
with the same reductions.

On a communication graph (a :class:`Coupling`), the means become the Laplacian sums of
Sepulchre, Paley and Leonard, "Stabilization of planar collective motion with limited
communication", IEEE TAC 53(3), 2008: each vehicle sums over its neighbours only, divided by
a fleet-wide nu; on the complete graph with nu = N they are the all-to-all laws. The
derivations are in docs/errata.md, "Laplacian laws".

Symmetric circular patterns (Sepulchre, Paley and Leonard, "Stabilization of planar collective
motion: all-to-all communication", IEEE TAC 52(5), 2007) add a phase potential U to the
circular law (:class:`Moments`, :class:`Slots`); docs/errata.md, "Symmetric patterns".
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
import functools
from functools import cached_property
from typing import Any, TypeAlias

from formation_control.core.geometry import ComplexArray, inner, IntArray, RealArray
import numpy as np
from numpy.typing import NDArray

Index: TypeAlias = 'slice | int | Sequence[int] | NDArray[np.integer[Any]]'
"""The vehicles a law is evaluated for: all (``slice(None)``), one, or some."""
Value: TypeAlias = 'float | RealArray'
"""A per-fleet value: a float for one fleet, an array for a batch of fleets."""


def _mean(x: NDArray[Any]) -> NDArray[Any]:
    """Return the mean over the fleet (the last axis), kept as an axis of length 1."""
    return x.mean(axis=-1, keepdims=True)


def _fleet(x: NDArray[Any] | float) -> Value:
    """Return a per-fleet value: a float for one fleet, the array for a batch of fleets."""
    return float(x) if np.ndim(x) == 0 else x


@dataclass
class View:
    """
    Particle view of N vehicles.

    Attributes
    ----------
    r : (N,) complex positions (m)
    phase : (N,) steered phase (rad): theta (1.3), gamma (1.8) or psi = theta + beta (7.11)
    rate : (N,) phase rate (rad/s): xi_k, Omega_k or omega_k
    speed : (N,) inertial speed s_k (m/s), 1 for unit particles, (1.6) in flow
    speed_dot : (N,) s_k' (m/s^2), (4.9) in flow

    """

    r: ComplexArray
    phase: RealArray
    rate: RealArray
    speed: RealArray
    speed_dot: RealArray

    @cached_property
    def e(self) -> ComplexArray:
        """(N,) complex unit vectors ``e_k = e^{i phase_k}`` (computed once per view)."""
        return np.exp(1j * self.phase)

    def ahead(self, tau: RealArray | float) -> View:
        """
        Return the view ``tau`` (N,) seconds later, at constant phase rate and speed.

        ``phase + rate tau`` and ``r + s e^{i phase} (e^{i rate tau} - 1) / (i rate)``, the arc
        each vehicle is on (``r + s e^{i phase} tau`` at zero rate), to ``O(tau^2)`` in the
        phase and speed changes; a vehicle with ``tau = 0`` is left exactly as it is.
        """
        tau = np.asarray(tau, float)
        turn = self.rate * tau
        small = abs(turn) < 1e-8
        arc = np.where(small, tau, np.expm1(1j * turn) / (1j * np.where(small, 1.0, self.rate)))
        return View(self.r + self.speed * self.e * arc, self.phase + turn, self.rate,
                    self.speed + self.speed_dot * tau, self.speed_dot)


@dataclass(frozen=True)
class Coupling:
    """
    The communication graph among the M vehicles of a view, for the Laplacian laws.

    Attributes
    ----------
    src, dst : (2E,) int
        Every undirected edge in both directions, as indices into the view (a_kj = 1).
    nu : float
        The fleet-wide constant the neighbour sums are divided by (> 0).
    n : int
        The fleet size N of the parallel potential ``<e, L e> / (2 N nu)``.

    """

    src: IntArray
    dst: IntArray
    nu: float
    n: int

    def total(self, per_arc: RealArray, m: int) -> RealArray:
        """
        Return ``sum_j a_kj x_kj`` for each of the m vehicles, from the values on the arcs.

        ``per_arc`` is (2E,), or (..., 2E) for a batch of fleets (one sum per fleet).
        """
        if np.ndim(per_arc) == 1:
            return np.asarray(np.bincount(self.src, weights=per_arc, minlength=m), float)
        lead = np.shape(per_arc)[:-1]
        fleets = int(np.prod(lead))
        index = (np.arange(fleets)[:, None] * m + self.src).ravel()
        sums = np.bincount(index, weights=np.ravel(per_arc), minlength=fleets * m)
        return np.asarray(sums, float).reshape(lead + (m,))

    def laplacian(self, x: ComplexArray) -> ComplexArray:
        """Return ``(L x)_k = sum_j a_kj (x_k - x_j)`` of the complex values x (..., M)."""
        d = x[..., self.src] - x[..., self.dst]
        m = x.shape[-1]
        return self.total(d.real, m) + 1j * self.total(d.imag, m)


@dataclass(frozen=True)
class Terms:
    """
    The terms of a formation law for the vehicles ``idx`` of a view.

    Attributes
    ----------
    phi : (n,) desired phase rate phi_k (rad/s)
    phi_dot : (n,) its time derivative phi_k' along the motion (rad/s^2)
    sigma : (n,) cross term ``-dV/dphase_k`` that the backstepping laws add

    """

    phi: RealArray
    phi_dot: RealArray
    sigma: RealArray


@dataclass(frozen=True)
class Parallel:
    """
    Phase synchronisation, ``phi_k = -K <p, i e_k>`` with K < 0 (1.12), (1.18), (3.1), (4.1).

    Potential ``V = (1 - |p|^2) / 2`` (1.11); ``sigma_k = <p, i e_k> / N`` is the term
    ``-dV/dphase_k`` that the backstepping law (3.7), (4.3) adds. On a graph (``coupling``):
    ``q_k = (1/nu) sum_j a_kj sin(phase_j - phase_k)``, ``phi_k = -K q_k``,
    ``sigma_k = q_k / N``, ``V = <e, L e> / (2 N nu)``.
    """

    K: float
    coupling: Coupling | None = None

    def terms(self, view: View, idx: Index = slice(None)) -> Terms:
        """
        Return phi, phi' and sigma of the parallel law for the vehicles ``idx``.

        Parameters
        ----------
        view : View
            Particle view of the N vehicles known.
        idx : index, optional
            The vehicles to compute for (an index into the N of ``view``); all by default.

        Returns
        -------
        Terms
            ``phi_k = -K <p, i e_k>`` (1.12), (1.18), (4.1) with ``p = mean(e)``;
            ``phi_k' = -K (<mean(e w), e_k> - w_k <p, e_k>)`` with w the phase rates, the O(N)
            form of the pairwise sum in (3.7), (4.3); ``sigma_k = <p, i e_k> / N``.

        """
        if self.coupling is not None:
            return self._graph_terms(view, idx, self.coupling)
        e = view.e
        p = _mean(e)
        pw = _mean(e * view.rate)
        ek, wk = e[..., idx], view.rate[..., idx]
        q = inner(p, 1j * ek)
        phi_dot = -self.K * (inner(pw, ek) - wk * inner(p, ek))
        return Terms(-self.K * q, phi_dot, q / e.shape[-1])

    def _graph_terms(self, view: View, idx: Index, g: Coupling) -> Terms:
        """Return the terms on the graph: phi_k' = -(K/nu) sum_j a_kj cos(dphase)(w_j - w_k)."""
        m = view.phase.shape[-1]
        d = view.phase[..., g.dst] - view.phase[..., g.src]
        q = g.total(np.sin(d), m)[..., idx] / g.nu
        dw = view.rate[..., g.dst] - view.rate[..., g.src]
        phi_dot = -self.K * g.total(np.cos(d) * dw, m)[..., idx] / g.nu
        return Terms(-self.K * q, phi_dot, q / g.n)

    def potential(self, view: View) -> Value:
        """
        Return the potential of phase synchrony.

        Parameters
        ----------
        view : View
            Particle view of the N vehicles.

        Returns
        -------
        float, or ndarray (one per fleet) for a batch
            ``V = (1 - |p|^2) / 2`` (1.11), in [0, 1/2]; 0 when all phases agree. On a graph
            ``<e, L e> / (2 N nu) = sum_arcs (1 - cos(phase_j - phase_k)) / (2 N nu)``.

        """
        g = self.coupling
        if g is not None:
            d = view.phase[..., g.dst] - view.phase[..., g.src]
            return _fleet(np.sum(1.0 - np.cos(d), axis=-1) / (2.0 * g.n * g.nu))
        return _fleet(0.5 * (1.0 - abs(_mean(view.e)[..., 0]) ** 2))


@dataclass(frozen=True)
class Moments:
    """
    Phase potential of the symmetric patterns, from the moments of the phases (all-to-all).

    ``p_m = (1/(m N)) sum_j e^{i m phase_j}`` and ``U = sum_m K_m (N/2) (|p_m|^2 - d_m)``
    with ``d_m = 1/m^2`` where ``K_m < 0`` (so that U = 0 on the (M, N) pattern), else 0.
    Splay (``|p_m|`` = 0, m = 1..floor(N/2)): every K_m > 0; (M, N) pattern (M clusters of N/M):
    ``K_m > 0`` for m < M and ``K_M < 0``.

    Attributes
    ----------
    gains : tuple of float
        K_1, K_2, ... (rad/s): ``gains[m - 1]`` is K_m.

    """

    gains: tuple[float, ...]

    def moments(self, phase: RealArray) -> ComplexArray:
        """Return ``p_m`` (complex) for m = 1..len(gains) of the phases (N,)."""
        return np.array([np.exp(1j * m * phase).mean(axis=-1) / m
                         for m in range(1, len(self.gains) + 1)])

    def gradient(self, view: View, idx: Index = slice(None),
                 coupling: Coupling | None = None) -> tuple[RealArray, RealArray]:
        """
        Return ``b_k = dU/dphase_k`` and its time derivative for the vehicles idx.

        Parameters
        ----------
        view : View
            Particle view of the N vehicles known (the means run over them).
        idx : index, optional
            The vehicles to compute for.
        coupling : Coupling or None
            Ignored: the moments are fleet means (all-to-all).

        Returns
        -------
        b, b_dot : ndarray, shape (n,)
            ``b_k = sum_m K_m <p_m, i e^{i m phase_k}>`` (rad/s) and
            ``b_k' = sum_m K_m (<mean(w e^{i m phase}), e^{i m phase_k}>
            - m w_k <p_m, e^{i m phase_k}>)`` (rad/s^2), w the phase rates.

        """
        ph, w = view.phase, view.rate
        shape = (-1,) + (1,) * np.ndim(ph)
        m = np.arange(1, len(self.gains) + 1).reshape(shape)
        gain = np.asarray(self.gains).reshape(shape)
        E = np.exp(1j * m * ph)                                # (M, ..., N): e^{i m phase}
        pm, pw = _mean(E) / m, _mean(w * E)
        idx = [idx] if isinstance(idx, (int, np.integer)) else idx
        Ek, wk = E[..., idx], w[..., idx]
        b = gain * inner(pm, 1j * Ek)
        b_dot = gain * (inner(pw, Ek) - m * wk * inner(pm, Ek))
        return functools.reduce(np.add, b), functools.reduce(np.add, b_dot)   # m by m: any idx

    def potential(self, view: View, coupling: Coupling | None = None) -> Value:
        """Return ``U = sum_m K_m (N/2) (|p_m|^2 - d_m)`` (rad/s) of the view's phases."""
        n = view.phase.shape[-1]
        u = 0.0
        for m, (gain, pm) in enumerate(zip(self.gains, self.moments(view.phase)), start=1):
            u += gain * 0.5 * n * (abs(pm) ** 2 - (1.0 / m ** 2 if gain < 0 else 0.0))
        return _fleet(u)


@dataclass(frozen=True)
class Slots:
    """
    Phase potential of slot patterns: synchronise ``phase_k - beta_k`` (any connected graph).

    With ``x_k = e^{i (phase_k - beta_k)}``: all-to-all ``U = K_s (N/2) (1 - |mean(x)|^2)``;
    on a graph ``U = K_s <x, L x> / (2 nu) = K_s sum_arcs (1 - cos(psi_j - psi_k)) / (2 nu)``,
    the Laplacian parallel potential (times ``K_s N``). Splay slots ``beta_k = 2 pi k / N``,
    (M, N) slots ``beta_k = 2 pi (k mod M) / M``.

    Attributes
    ----------
    gain : float
        K_s (rad/s), > 0.
    beta : ndarray, shape (N,)
        The slot offset of each vehicle of the view (rad).

    """

    gain: float
    beta: RealArray

    def gradient(self, view: View, idx: Index = slice(None),
                 coupling: Coupling | None = None) -> tuple[RealArray, RealArray]:
        """
        Return ``b_k = dU/dphase_k`` and its time derivative for the vehicles idx.

        Parameters
        ----------
        view : View
            Particle view of the vehicles known; ``beta`` holds their offsets.
        idx : index, optional
            The vehicles to compute for.
        coupling : Coupling or None
            The communication graph among the view's vehicles; None = all-to-all.

        Returns
        -------
        b, b_dot : ndarray, shape (n,)
            ``b_k = -K_s q_k``, ``q_k = (1/nu) sum_j a_kj sin(psi_j - psi_k)`` (all-to-all
            ``<mean(x), i x_k>``) and ``b_k' = -K_s (1/nu) sum_j a_kj cos(psi_j - psi_k)
            (w_j - w_k)`` (all-to-all ``<mean(w x), x_k> - w_k <mean(x), x_k>``).

        """
        psi, w = view.phase - self.beta, view.rate
        if coupling is None:
            x = np.exp(1j * psi)
            p, pw = _mean(x), _mean(w * x)
            xk, wk = x[..., idx], w[..., idx]
            return -self.gain * inner(p, 1j * xk), -self.gain * (inner(pw, xk) - wk * inner(p, xk))
        g, m = coupling, psi.shape[-1]
        d = psi[..., g.dst] - psi[..., g.src]
        q = g.total(np.sin(d), m)[..., idx] / g.nu
        q_dot = g.total(np.cos(d) * (w[..., g.dst] - w[..., g.src]), m)[..., idx] / g.nu
        return -self.gain * q, -self.gain * q_dot

    def potential(self, view: View, coupling: Coupling | None = None) -> Value:
        """Return U (rad/s): ``K_s (N/2)(1 - |mean x|^2)``, on a graph ``K_s <x, L x>/(2 nu)``."""
        psi = view.phase - self.beta
        if coupling is None:
            p = _mean(np.exp(1j * psi))[..., 0]
            return _fleet(self.gain * 0.5 * psi.shape[-1] * (1.0 - abs(p) ** 2))
        d = psi[..., coupling.dst] - psi[..., coupling.src]
        return _fleet(self.gain * np.sum(1.0 - np.cos(d), axis=-1) / (2.0 * coupling.nu))


@dataclass(frozen=True)
class Circular:
    """
    Circular formation, ``phi_k = omega0 (s_k + K G_k)`` with K > 0.

    Here ``G_k = <e_k, P_k c> + a_k0 <e_k, c_k - c0>`` and ``c_k = r_k + i e_k / omega0``
    (1.16), (1.19), (3.9), (4.4); the prescribed-centre term of (7.17), (7.18) is switched on
    per vehicle by ``informed``. Potential (7.18): ``<c, P c>/2 + sum a_k0 |c_k - c0|^2 / 2``.
    ``sigma_k = G_k / omega0`` is the cross term of the backstepping laws (3.14), (4.8), (7.25).
    On a graph (``coupling``) ``P_k c`` becomes ``C_k / nu`` with
    ``C_k = sum_j a_kj (c_k - c_j)``, and the potential ``<c, L c> / (2 nu) + ...``.

    A symmetric ``pattern`` (phase potential U, gradient ``b_k = dU/dphase_k``) gives
    ``phi_k = omega0 (s_k + K G_k) - b_k``, potential ``V = S + U / (K omega0^2)`` and
    ``sigma_k = -dV/dphase_k = G_k / omega0 - b_k / (K omega0^2)
    = (phi_k - omega0 s_k) / (K omega0^2)`` (docs/errata.md, "Symmetric patterns").

    Attributes
    ----------
    K : float
        Formation gain (1/s), > 0.
    omega0 : float
        Curvature (rad/m), != 0: circles of radius ``1/|omega0|``, turning at ``omega0 s_k``.
    c0 : complex
        Prescribed centre (m).
    informed : array_like of float, shape (N,), or None
        a_k0: 1 for the vehicles that know c0, 0 for the others; None = nobody.
    coupling : Coupling or None
        The communication graph among the view's vehicles; None = all-to-all.
    pattern : Moments or Slots or None
        The phase potential of a symmetric pattern (flow-free only); None = places free.
    cross_scale : float
        The factor ``1 / (L T)^2`` of sigma for laws written in units of length L and time T
        (m, s; :func:`control.law_units`): phi and phi' do not depend on the units, sigma (the
        gradient of the potential in units of L^2, an acceleration in units of 1/T^2) does.
        1 in the thesis' units (unit-speed particles, T = 1 s).

    """

    K: float
    omega0: float
    c0: complex = 0j
    informed: RealArray | None = None
    coupling: Coupling | None = None
    pattern: Moments | Slots | None = None
    cross_scale: float = 1.0

    def centres(self, view: View) -> ComplexArray:
        """
        Return the circle centres of the vehicles.

        Parameters
        ----------
        view : View
            Particle view of the N vehicles; the phase is the direction of the velocity.

        Returns
        -------
        ndarray of complex, shape (N,)
            ``c_k = r_k + i e_k / omega0`` (m), (1.14); the errata's (7.11) correction uses the
            velocity heading psi (gamma in a flow), not the body heading.

        """
        return view.r + 1j * view.e / self.omega0

    def _a0(self, n: int, idx: Index = slice(None)) -> RealArray | float:
        """Return a_k0 of the vehicles idx of n (0.0 when nobody is informed)."""
        if self.informed is None:
            return 0.0
        return np.broadcast_to(self.informed, (n,))[..., idx]

    def terms(self, view: View, idx: Index = slice(None)) -> Terms:
        """
        Return phi, phi' and sigma of the circular law for the vehicles ``idx``.

        Parameters
        ----------
        view : View
            Particle view of the N vehicles known (speeds s and s' are used: flow, rigid).
        idx : index, optional
            The vehicles to compute for (an index into the N of ``view``); all by default.

        Returns
        -------
        Terms
            ``phi_k = omega0 (s_k + K G_k)`` (1.16), (4.4), (7.17) and
            ``phi_k' = omega0 (s_k' + K G_k')`` (3.14), (4.8), (7.12), (7.25) corrected, with
            ``G_k' = w_k <i e_k, P_k c> + (s_k - w_k/omega0) - <mean(c'), e_k>
            + a_k0 (w_k <i e_k, c_k - c0> + s_k - w_k/omega0)`` and
            ``c_k' = e_k (s_k - w_k/omega0)`` (w the phase rates); ``sigma_k = G_k / omega0``.
            With a pattern, ``phi_k - b_k``, ``phi_k' - b_k'`` and
            ``sigma_k - b_k / (K omega0^2)``.

        """
        e = view.e
        c = view.r + 1j * e / self.omega0
        c_dot = e * (view.speed - view.rate / self.omega0)
        ek, wk, ck = e[..., idx], view.rate[..., idx], c[..., idx]
        a0 = self._a0(e.shape[-1], idx)
        if self.coupling is None:
            pc = ck - _mean(c)                                       # P_k c
            pc_dot = c_dot[..., idx] - _mean(c_dot)
        else:
            pc = self.coupling.laplacian(c)[..., idx] / self.coupling.nu   # C_k / nu
            pc_dot = self.coupling.laplacian(c_dot)[..., idx] / self.coupling.nu
        dc0 = ck - self.c0
        g = inner(ek, pc) + a0 * inner(ek, dc0)
        ck_dot_along = view.speed[..., idx] - wk / self.omega0            # <e_k, c_k'>
        g_dot = (wk * inner(1j * ek, pc) + inner(ek, pc_dot)
                 + a0 * (wk * inner(1j * ek, dc0) + ck_dot_along))
        phi = self.omega0 * (view.speed[..., idx] + self.K * g)
        phi_dot = self.omega0 * (view.speed_dot[..., idx] + self.K * g_dot)
        sigma = g / self.omega0
        if self.pattern is not None:
            b, b_dot = self.pattern.gradient(view, idx, self.coupling)
            phi, phi_dot = phi - b, phi_dot - b_dot
            sigma = sigma - b / (self.K * self.omega0 ** 2)
        if self.cross_scale != 1.0:
            sigma = sigma * self.cross_scale
        return Terms(phi, phi_dot, sigma)

    def potential(self, view: View) -> Value:
        """
        Return the potential of the circular formation.

        Parameters
        ----------
        view : View
            Particle view of the N vehicles.

        Returns
        -------
        float, or ndarray (one per fleet) for a batch
            ``V = sum_k |c_k - mean(c)|^2 / 2 + sum_k a_k0 |c_k - c0|^2 / 2`` (m^2), (1.14),
            (7.18); 0 when every centre is the common one (and c0, if anyone is informed).
            A pattern adds ``U / (K omega0^2)`` (m^2).

        """
        c = self.centres(view)
        prescribed = 0.5 * np.sum(self._a0(c.shape[-1]) * abs(c - self.c0) ** 2, axis=-1)
        if self.pattern is not None:
            prescribed += self.pattern.potential(view, self.coupling) / (
                self.K * self.omega0 ** 2)
        g = self.coupling
        if g is not None:
            spread = np.sum(abs(c[..., g.src] - c[..., g.dst]) ** 2, axis=-1) / (4.0 * g.nu)
        else:
            spread = 0.5 * np.sum(abs(c - _mean(c)) ** 2, axis=-1)
        return _fleet(spread + prescribed)


def first_order(formation: Formation, view: View, idx: Index = slice(None)) -> RealArray:
    """
    Return the first-order steering law, ``phase_k' = phi_k``.

    Parameters
    ----------
    formation : Parallel or Circular
        The formation law.
    view : View
        Particle view of the N vehicles known.
    idx : index, optional
        The vehicles to steer; all by default.

    Returns
    -------
    ndarray, shape (n,)
        The desired phase rate ``phi_k`` (rad/s), (1.12), (1.16), (1.18), (1.19), (7.17).

    """
    return formation.terms(view, idx).phi


def backstepping(formation: Formation, view: View, kappa: float,
                 idx: Index = slice(None)) -> RealArray:
    """
    Return the backstepping phase acceleration.

    Parameters
    ----------
    formation : Parallel or Circular
        The formation law whose phase rate ``phi_k`` the rates are steered to.
    view : View
        Particle view of the N vehicles known.
    kappa : float
        Backstepping gain (1/s), > 0.
    idx : index, optional
        The vehicles to steer; all by default.

    Returns
    -------
    ndarray, shape (n,)
        ``sigma_k - kappa z_k + phi_k'`` (rad/s^2) with ``z_k = rate_k - phi_k``: (3.7),
        (3.14), (4.3), (4.8), (7.12), (7.25).

    Notes
    -----
    The composite function ``V_c = V + sum z_k^2 / 2`` (:func:`composite_lyapunov`) then has
    ``V_c' = sum (-|K| or K/N) (...)^2 - kappa z_k^2 <= 0``.

    """
    t = formation.terms(view, idx)
    return t.sigma - kappa * (view.rate[..., idx] - t.phi) + t.phi_dot


def proportional(formation: Formation, view: View, K_p: float,
                 idx: Index = slice(None)) -> RealArray:
    """
    Return the proportional phase acceleration.

    Parameters
    ----------
    formation : Parallel or Circular
        The formation law whose phase rate ``phi_k`` the rates are steered to.
    view : View
        Particle view of the N vehicles known.
    K_p : float
        Proportional gain (1/s), > 0.
    idx : index, optional
        The vehicles to steer; all by default.

    Returns
    -------
    ndarray, shape (n,)
        ``-K_p z_k`` (rad/s^2) with ``z_k = rate_k - phi_k``, (5.5).

    """
    return -K_p * (view.rate[..., idx] - formation.terms(view, idx).phi)


def composite_lyapunov(formation: Formation, view: View) -> Value:
    """
    Return the composite Lyapunov value of the backstepping laws.

    Parameters
    ----------
    formation : Parallel or Circular
        The formation law (its potential V and phase rates phi).
    view : View
        Particle view of the whole fleet.

    Returns
    -------
    float, or ndarray (one per fleet) for a batch
        ``V_c = V + sum_k z_k^2 / 2`` with ``z_k = rate_k - phi_k`` (2.10); it never increases
        under :func:`backstepping`.

    """
    z = view.rate - formation.terms(view).phi
    return _fleet(formation.potential(view) + 0.5 * np.sum(z ** 2, axis=-1))


Formation: TypeAlias = 'Parallel | Circular'
"""A formation law: parallel (1.12) or circular (1.16)."""
