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
Collective motion in three dimensions: steered unit-speed particles on SE(3) (issue 46).

The model (S1), a particle's natural (Bishop) frame with an optional roll rate ``w``::

    r_k' = x_k,   x_k' = u_k y_k + v_k z_k,   y_k' = -u_k x_k + w_k z_k,
    z_k' = -v_k x_k - w_k y_k,

that is ``R_k' = R_k [Omega_k]_x`` with ``R_k = [x_k y_k z_k]`` in SO(3) and body angular
velocity ``Omega_k = (w_k, -v_k, u_k)``. The curvature controls u, v turn the velocity x; w
only rolls the frame about it, and no law here depends on it. A fleet is ``r`` (N, 3) and
``R`` (N, 3, 3) (columns x, y, z); :func:`step` integrates (S1) exactly for controls held over
the step (S2).

The laws (derivations in docs/laws.md, "Three dimensions (first step)"), each a potential V
and curvature controls with ``V' <= 0``:

- :class:`Parallel`: ``V = (1 - |p|^2)/2``, ``p = mean(x)`` (S3); ``u_k = -K <q_k, y_k>``,
  ``v_k = -K <q_k, z_k>`` (S4), K < 0, i.e. ``x_k' = -K (I - x_k x_k^T) q_k``.
- :class:`Circular`: circle centres ``c_k = r_k + (b x x_k)/omega0`` (S6) about a common axis
  direction b, ``V = S + A`` with S the spread of the centres projected across b and A the
  axial alignment (S7); ``x_k' = omega0 b x x_k - K (I - x_k x_k^T) h_k`` (S9), K > 0. With
  ``axial = 0`` circles of radius ``1/|omega0|`` about one axis line; with ``axial != 0``
  helices of that axis, axial speed ``axial`` and radius ``sqrt(1 - axial^2)/|omega0|``.

On a communication graph (a :class:`laws.Coupling`) the fleet means become Laplacian sums over
the neighbours divided by nu, as in the planar laws; with the complete graph and nu = N they
are the all-to-all laws.

In the plane (``z_k = b = e_z``, positions in z = 0) both laws are the planar ones of
:mod:`formation_control.core.laws` with the same K and omega0: ``u_k = phi_k``, ``v_k = 0``.
"""
from __future__ import annotations

from dataclasses import dataclass

from formation_control.core.errors import refuse
from formation_control.core.geometry import RealArray
from formation_control.core.laws import Coupling
import numpy as np

_SMALL = 1e-2
"""Below this rotation angle (rad) per step, :func:`step` uses the series of its weights."""


def hat(w: RealArray) -> RealArray:
    """
    Return the skew-symmetric matrices ``[w]_x`` with ``[w]_x a = w x a``.

    Parameters
    ----------
    w : ndarray, shape (..., 3)
        The vectors.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``[[0, -w3, w2], [w3, 0, -w1], [-w2, w1, 0]]``.

    """
    w = np.asarray(w, float)
    zero = np.zeros(w.shape[:-1])
    return np.stack([np.stack([zero, -w[..., 2], w[..., 1]], -1),
                     np.stack([w[..., 2], zero, -w[..., 0]], -1),
                     np.stack([-w[..., 1], w[..., 0], zero], -1)], -2)


def _weights(theta: RealArray) -> tuple[RealArray, RealArray, RealArray]:
    """Return ``sin t/t``, ``(1 - cos t)/t^2`` and ``(t - sin t)/t^3`` (series for small t)."""
    small = theta < _SMALL
    t = np.where(small, 1.0, theta)
    t2 = theta * theta
    a = np.where(small, 1 - t2 / 6 * (1 - t2 / 20 * (1 - t2 / 42)), np.sin(t) / t)
    b = np.where(small, 0.5 - t2 / 24 * (1 - t2 / 30 * (1 - t2 / 56)), (1 - np.cos(t)) / t ** 2)
    c = np.where(small, 1 / 6 - t2 / 120 * (1 - t2 / 42 * (1 - t2 / 72)),
                 (t - np.sin(t)) / t ** 3)
    return a, b, c


def step(r: RealArray, R: RealArray, u: RealArray | float, v: RealArray | float, dt: float,
         w: RealArray | float = 0.0) -> tuple[RealArray, RealArray]:
    """
    Return the fleet dt later, exactly, with the controls held over the step.

    Parameters
    ----------
    r : ndarray, shape (N, 3)
        Positions (m).
    R : ndarray, shape (N, 3, 3)
        Frames ``[x y z]`` in SO(3), x the unit velocity.
    u, v : float or ndarray, shape (N,)
        Curvature controls (rad/s): ``x' = u y + v z`` (S1).
    dt : float
        The step (s); negative steps integrate backwards.
    w : float or ndarray, shape (N,)
        Roll rate about x (rad/s), 0 for the natural frame.

    Returns
    -------
    r, R : ndarray
        ``r + dt R J(dt Omega) e_1`` and ``R exp(dt [Omega]_x)`` (S2), ``Omega = (w, -v, u)``,
        with ``exp(A) = I + (sin t/t) A + ((1 - cos t)/t^2) A^2`` and the left Jacobian
        ``J = I + ((1 - cos t)/t^2) A + ((t - sin t)/t^3) A^2``, ``t = |dt Omega|``; then one
        Newton step of the polar decomposition, ``R (3 I - R^T R)/2``, which squares the
        departure from orthonormality so that round-off does not accumulate over the steps.

    """
    omega = np.stack(np.broadcast_arrays(w, -np.asarray(v, float), u), -1) * dt
    n = len(r)
    omega = np.broadcast_to(omega, (n, 3))
    A = hat(omega)
    A2 = A @ A
    a, b, c = (x[:, None, None] for x in _weights(np.linalg.norm(omega, axis=-1)))
    eye = np.eye(3)
    E = eye + a * A + b * A2
    J = eye + b * A + c * A2
    R1 = R @ E
    R1 = 0.5 * R1 @ (3.0 * eye - np.swapaxes(R1, -1, -2) @ R1)
    return r + dt * (R @ J[:, :, 0:1])[:, :, 0], R1


def _neighbours(g: Coupling, X: RealArray) -> RealArray:
    """Return ``sum_j a_kj X_j`` (N, 3) of the vectors X (N, 3) on the graph g."""
    return np.stack([g.total(X[g.dst, i], len(X)) for i in range(3)], -1)


def _columns(R: RealArray) -> tuple[RealArray, RealArray, RealArray]:
    """Return the columns x, y, z (N, 3) of the frames R (N, 3, 3)."""
    return R[:, :, 0], R[:, :, 1], R[:, :, 2]


def _dot(a: RealArray, b: RealArray) -> RealArray:
    """Return the inner products of the rows of a and b."""
    return np.einsum('...i,...i->...', a, b)


@dataclass(frozen=True)
class Parallel:
    """
    Velocity alignment in 3-D: ``u_k = -K <q_k, y_k>``, ``v_k = -K <q_k, z_k>`` (S4).

    All-to-all ``q_k = p = mean(x)`` and ``V = (1 - |p|^2)/2`` (S3); on a graph
    ``q_k = (1/nu) sum_j a_kj x_j`` and ``V = sum_arcs |x_j - x_k|^2 / (4 N nu)``. Then
    ``V' = (K/N) sum_k |(I - x_k x_k^T) q_k|^2`` (S5): K < 0 aligns the velocities, K > 0
    balances them (p -> 0). The planar law (1.12) is the case ``z_k = e_z``.

    Attributes
    ----------
    K : float
        Gain (rad/s), != 0.
    coupling : laws.Coupling or None
        The communication graph; None = all-to-all.

    """

    K: float
    coupling: Coupling | None = None

    def __post_init__(self) -> None:
        """Refuse K = 0."""
        if not np.isfinite(self.K) or self.K == 0.0:
            refuse('K', self.K, 'a finite gain != 0 (< 0 aligns, > 0 balances)')

    def _q(self, R: RealArray) -> RealArray:
        """Return q_k (N, 3): the mean velocity, or the neighbours' sum over nu."""
        x = R[:, :, 0]
        if self.coupling is None:
            return np.broadcast_to(x.mean(axis=0), x.shape)
        return _neighbours(self.coupling, x) / self.coupling.nu

    def controls(self, r: RealArray, R: RealArray) -> tuple[RealArray, RealArray, RealArray]:
        """
        Return the curvature controls and roll rate of the parallel law.

        Parameters
        ----------
        r : ndarray, shape (N, 3)
            Positions (m); unused (the law depends on the frames only).
        R : ndarray, shape (N, 3, 3)
            Frames.

        Returns
        -------
        u, v, w : ndarray, shape (N,)
            ``-K <q_k, y_k>`` and ``-K <q_k, z_k>`` (rad/s), (S4); no roll, w = 0.

        """
        q = self._q(R)
        _, y, z = _columns(R)
        return -self.K * _dot(q, y), -self.K * _dot(q, z), np.zeros(len(R))

    def potential(self, r: RealArray, R: RealArray) -> float:
        """
        Return the alignment potential.

        Parameters
        ----------
        r : ndarray, shape (N, 3)
            Positions (m); unused.
        R : ndarray, shape (N, 3, 3)
            Frames.

        Returns
        -------
        float
            ``V = (1 - |p|^2)/2`` (S3), in [0, 1/2]; on a graph
            ``sum_arcs |x_j - x_k|^2 / (4 N nu)``.

        """
        x = R[:, :, 0]
        g = self.coupling
        if g is None:
            return float(0.5 * (1.0 - _dot(x.mean(axis=0), x.mean(axis=0))))
        return float(np.sum((x[g.src] - x[g.dst]) ** 2) / (4.0 * g.n * g.nu))

    def potential_rate(self, r: RealArray, R: RealArray, u: RealArray,
                       v: RealArray) -> float:
        """
        Return dV/dt under any curvature controls.

        Parameters
        ----------
        r : ndarray, shape (N, 3)
            Positions (m); unused.
        R : ndarray, shape (N, 3, 3)
            Frames.
        u, v : ndarray, shape (N,)
            Curvature controls (rad/s).

        Returns
        -------
        float
            ``V' = -(1/N) sum_k <q_k, u_k y_k + v_k z_k>`` (S5); with the law's controls
            ``(K/N) sum_k (<q_k, y_k>^2 + <q_k, z_k>^2)``.

        """
        q = self._q(R)
        _, y, z = _columns(R)
        return float(-np.mean(u * _dot(q, y) + v * _dot(q, z)))


@dataclass(frozen=True)
class Circular:
    """
    Circles (or helices) about a common axis: ``x_k' = omega0 b x x_k - K P_k h_k`` (S9).

    With ``c_k = r_k + (b x x_k)/omega0`` (S6), ``P = I - b b^T``, ``d_k = P (c_k - mean(c))``
    (on a graph ``(1/nu) sum_j a_kj P (c_k - c_j)``) and ``a_k = <b, x_k> - axial``: the
    potential (S7) ``V = sum |d_k|^2/2 + sum a_k^2 / (2 omega0^2)`` (on a graph the spread is
    ``sum_arcs |P (c_j - c_k)|^2 / (4 nu)``), ``h_k = omega0 d_k x b + a_k b`` (S8),
    ``P_k = I - x_k x_k^T`` and ``V' = -(K/omega0^2) sum_k |P_k h_k|^2`` (S10). In the
    controls of (S1): ``u_k = omega0 <b, z_k> - K <h_k, y_k>``,
    ``v_k = -omega0 <b, y_k> - K <h_k, z_k>``. The planar circular law (1.16) is the case
    ``z_k = b = e_z``.

    Attributes
    ----------
    K : float
        Formation gain (1/s), > 0.
    omega0 : float
        Turn rate about b (rad/s of unit-speed motion), != 0: circles of radius ``1/|omega0|``.
    b : tuple of float
        The axis direction (normalised here).
    axial : float
        The common velocity along b, ``|axial| < 1``: 0 circles, else helices of pitch
        ``2 pi axial / |omega0|`` and radius ``sqrt(1 - axial^2)/|omega0|``.
    coupling : laws.Coupling or None
        The communication graph; None = all-to-all.

    """

    K: float
    omega0: float
    b: tuple[float, float, float] = (0.0, 0.0, 1.0)
    axial: float = 0.0
    coupling: Coupling | None = None

    def __post_init__(self) -> None:
        """Refuse K <= 0, omega0 = 0, ``|axial| >= 1`` and a zero axis; normalise b."""
        if not self.K > 0.0 or not np.isfinite(self.K):
            refuse('K', self.K, 'a finite gain > 0')
        if not np.isfinite(self.omega0) or self.omega0 == 0.0:
            refuse('omega0', self.omega0, 'a finite turn rate != 0')
        if not abs(self.axial) < 1.0:
            refuse('axial', self.axial, 'a speed along the axis in (-1, 1)')
        norm = float(np.linalg.norm(self.b))
        if not np.isfinite(norm) or norm == 0.0:
            refuse('b', self.b, 'a finite non-zero axis direction')
        object.__setattr__(self, 'b', tuple(float(x) / norm for x in self.b))

    def centres(self, r: RealArray, R: RealArray) -> RealArray:
        """
        Return the circle centres.

        Parameters
        ----------
        r : ndarray, shape (N, 3)
            Positions (m).
        R : ndarray, shape (N, 3, 3)
            Frames.

        Returns
        -------
        ndarray, shape (N, 3)
            ``c_k = r_k + (b x x_k)/omega0`` (S6) (m): the point of the axis of the circle
            the particle would fly with ``x' = omega0 b x x``.

        """
        return r + np.cross(self.b, R[:, :, 0]) / self.omega0

    def _across(self, r: RealArray, R: RealArray) -> RealArray:
        """Return ``P c_k`` (N, 3): the centres projected on the plane normal to b."""
        b = np.asarray(self.b)
        c = self.centres(r, R)
        return c - np.outer(c @ b, b)

    def _spread(self, r: RealArray, R: RealArray) -> RealArray:
        """Return d_k (N, 3): the centres' spread across b, all-to-all or on the graph."""
        pc = self._across(r, R)
        g = self.coupling
        if g is None:
            return pc - pc.mean(axis=0)
        return (pc * g.total(np.ones(len(g.src)), len(pc))[:, None] - _neighbours(g, pc)) / g.nu

    def _h(self, r: RealArray, R: RealArray) -> RealArray:
        """Return ``h_k = omega0 d_k x b + a_k b`` (N, 3), (S8)."""
        b = np.asarray(self.b)
        a = R[:, :, 0] @ b - self.axial
        return self.omega0 * np.cross(self._spread(r, R), b) + np.outer(a, b)

    def controls(self, r: RealArray, R: RealArray) -> tuple[RealArray, RealArray, RealArray]:
        """
        Return the curvature controls and roll rate of the circular (helical) law.

        Parameters
        ----------
        r : ndarray, shape (N, 3)
            Positions (m).
        R : ndarray, shape (N, 3, 3)
            Frames.

        Returns
        -------
        u, v, w : ndarray, shape (N,)
            ``u_k = omega0 <b, z_k> - K <h_k, y_k>`` and
            ``v_k = -omega0 <b, y_k> - K <h_k, z_k>`` (rad/s), (S9);
            ``w_k = omega0 <b, x_k>`` (S11), the roll that V does not depend on, chosen so
            that the feed-forward is the body angular velocity ``omega0 R_k^T b``: at the
            formation every frame turns rigidly about b (one spatial twist), which a step
            with the controls held (:func:`step`) then integrates exactly.

        """
        b = np.asarray(self.b)
        h = self._h(r, R)
        x, y, z = _columns(R)
        return (self.omega0 * (z @ b) - self.K * _dot(h, y),
                -self.omega0 * (y @ b) - self.K * _dot(h, z), self.omega0 * (x @ b))

    def potential(self, r: RealArray, R: RealArray) -> float:
        """
        Return the potential of the circular (helical) formation.

        Parameters
        ----------
        r : ndarray, shape (N, 3)
            Positions (m).
        R : ndarray, shape (N, 3, 3)
            Frames.

        Returns
        -------
        float
            ``V = sum |P (c_k - mean(c))|^2/2 + sum (<b, x_k> - axial)^2/(2 omega0^2)`` (S7)
            (m^2); on a graph the first sum is ``sum_arcs |P (c_j - c_k)|^2 / (4 nu)``.

        """
        pc = self._across(r, R)
        a = R[:, :, 0] @ np.asarray(self.b) - self.axial
        g = self.coupling
        if g is None:
            spread = 0.5 * np.sum((pc - pc.mean(axis=0)) ** 2)
        else:
            spread = np.sum((pc[g.src] - pc[g.dst]) ** 2) / (4.0 * g.nu)
        return float(spread + 0.5 * np.sum(a * a) / self.omega0 ** 2)

    def potential_rate(self, r: RealArray, R: RealArray, u: RealArray,
                       v: RealArray) -> float:
        """
        Return dV/dt under any curvature controls.

        Parameters
        ----------
        r : ndarray, shape (N, 3)
            Positions (m).
        R : ndarray, shape (N, 3, 3)
            Frames.
        u, v : ndarray, shape (N,)
            Curvature controls (rad/s).

        Returns
        -------
        float
            ``V' = sum_k <d_k, c_k'> + sum_k a_k <b, x_k'> / omega0^2`` (S10) with
            ``x_k' = u_k y_k + v_k z_k`` and ``c_k' = x_k + (b x x_k')/omega0``; with the
            law's controls ``-(K/omega0^2) sum_k |P_k h_k|^2``.

        """
        b = np.asarray(self.b)
        x, y, z = _columns(R)
        xd = u[:, None] * y + v[:, None] * z
        cd = x + np.cross(b, xd) / self.omega0
        a = x @ b - self.axial
        return float(np.sum(_dot(self._spread(r, R), cd)) + np.sum(a * (xd @ b))
                     / self.omega0 ** 2)
