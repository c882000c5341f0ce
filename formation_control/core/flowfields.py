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
Flowfields: the flow ``f(t, x, y)`` (m/s, map frame) each vehicle is integrated in.

The thesis' flow is uniform and steady (1.4), (8.1): ``f = flow``. The other models add to that
background ``flow`` a term that varies in time or space:

=================  ==========================================================================
``flow_model``     ``f(t, x, y) - flow``
=================  ==========================================================================
``uniform``        0 (the thesis)
``time_varying``   ``A e^{i 2 pi t / T}``: a uniform flow turning once per flow_period T, of
                   amplitude A = flow_amplitude (a tidal current); ``|f'| = 2 pi A / T``
``shear``          ``G clip(y, -w, w)`` along x: a shear layer of gradient G = flow_shear and
                   half-width w = flow_shear_width, uniform beyond it
``vortex``         Rankine vortex of circulation Gamma, core radius R, centre c: tangential
                   speed ``Gamma rho / (2 pi R^2)`` inside the core, ``Gamma / (2 pi rho)``
                   outside, at distance rho from c
``grid``           the file's ``fx, fy`` on a rectangular grid, bilinearly interpolated (held
                   at the border value outside); the background ``flow`` is added too
=================  ==========================================================================

Along a vehicle's path ``r(t)`` the flow it meets changes at ``f' = f_t + (grad f) r'``
(:meth:`Flowfield.jet`, :class:`Jet`): the laws' views need it where the flow is known
(docs/errata.md, "Known time-varying and non-uniform flows").

A grid file is an ``.npz`` with ``x`` (nx,), ``y`` (ny,) increasing, and ``fx, fy`` (ny, nx);
or a CSV with a header ``x,y,fx,fy`` and one row per grid node (any order).
"""
from __future__ import annotations

from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import NoReturn, TYPE_CHECKING

from formation_control.core.geometry import ComplexArray, RealArray
import numpy as np

if TYPE_CHECKING:
    from formation_control.core.parameters import Scenario

Grid = tuple[RealArray, RealArray, ComplexArray]
"""The lines x, y (m) of a gridded flow and the flow at its nodes (m/s), shape (ny, nx)."""


@dataclass(frozen=True)
class Jet:
    """
    The partial derivatives of the flow at each vehicle, to second order (complex m/s per s, m).

    ``f_t, f_tt`` in time at a fixed place, ``f_x, f_y, f_xx, f_xy, f_yy`` in space; the mixed
    time-space ones are zero for every model (the turning flow is uniform, the others steady).
    """

    f_t: ComplexArray
    f_x: ComplexArray
    f_y: ComplexArray
    f_tt: ComplexArray
    f_xx: ComplexArray
    f_xy: ComplexArray
    f_yy: ComplexArray

    def rate(self, v: ComplexArray) -> ComplexArray:
        """Return ``f' = f_t + f_x v_x + f_y v_y`` along a path of velocity v (complex m/s^2)."""
        return self.f_t + self.f_x * v.real + self.f_y * v.imag

    def accel(self, v: ComplexArray, v_dot: ComplexArray) -> ComplexArray:
        """
        Return ``f''`` along a path of velocity v and acceleration v_dot (complex m/s^3).

        ``f_tt + f_xx v_x^2 + 2 f_xy v_x v_y + f_yy v_y^2 + f_x v_x' + f_y v_y'``.
        """
        x, y = v.real, v.imag
        return (self.f_tt + self.f_xx * x * x + 2.0 * self.f_xy * x * y + self.f_yy * y * y
                + self.f_x * v_dot.real + self.f_y * v_dot.imag)


class FlowfieldError(ValueError):
    """A flowfield cannot be built (bad grid file); the message names the parameter."""


def _fail(name: str, value: object, allowed: str) -> NoReturn:
    raise FlowfieldError(f"parameter '{name}' = {value!r} is invalid: {allowed}")


def read_grid(path: str | PathLike[str]) -> tuple[RealArray, RealArray, ComplexArray]:
    """
    Read a gridded flow file.

    Parameters
    ----------
    path : str or path-like
        ``.npz`` (``x``, ``y``, ``fx``, ``fy``) or ``.csv`` (columns ``x,y,fx,fy``).

    Returns
    -------
    x, y, f : ndarray, shapes (nx,), (ny,), (ny, nx) complex
        Grid lines (m, strictly increasing, at least 2 each) and the flow at the nodes (m/s).

    Raises
    ------
    FlowfieldError
        Missing or unreadable file, wrong shapes, a non-increasing axis, NaN or inf.

    """
    name = 'flow_grid_file'
    p = Path(path)
    if not str(path) or not p.is_file():
        _fail(name, str(path), 'no such file: give an .npz (x, y, fx, fy) or a .csv '
              '(x,y,fx,fy) grid of the flow')
    try:
        if p.suffix == '.npz':
            with np.load(p) as d:
                x, y, fx, fy = (np.asarray(d[k], float) for k in ('x', 'y', 'fx', 'fy'))
        else:
            table = np.genfromtxt(p, delimiter=',', names=True)
            x, y = np.unique(table['x']), np.unique(table['y'])
            fx, fy = np.full((y.size, x.size), np.nan), np.full((y.size, x.size), np.nan)
            col, row = np.searchsorted(x, table['x']), np.searchsorted(y, table['y'])
            fx[row, col], fy[row, col] = table['fx'], table['fy']
    except (OSError, KeyError, ValueError) as err:
        _fail(name, str(path), f'cannot read the grid ({err}); an .npz needs arrays x, y, fx, '
              f'fy and a .csv the header x,y,fx,fy')
    if x.ndim != 1 or y.ndim != 1 or x.size < 2 or y.size < 2 or \
            fx.shape != (y.size, x.size) or fy.shape != fx.shape:
        _fail(name, str(path), f'x (nx >= 2,), y (ny >= 2,) and fx, fy (ny, nx) expected, got '
              f'x {x.shape}, y {y.shape}, fx {fx.shape}, fy {fy.shape}')
    if not (np.all(np.diff(x) > 0) and np.all(np.diff(y) > 0)):
        _fail(name, str(path), 'the grid lines x and y must be strictly increasing')
    if not (np.all(np.isfinite(fx)) and np.all(np.isfinite(fy))):
        _fail(name, str(path), 'the grid has NaN or inf flow values (or missing nodes)')
    return x, y, fx + 1j * fy


class Flowfield:
    """
    The flow of a scenario, evaluated for the whole fleet at once.

    Parameters
    ----------
    sc : scenario.Scenario
        Any object with ``flow_model``, ``flow_c`` and the model's parameters.

    Attributes
    ----------
    uniform : bool
        The flow is ``value`` everywhere, always (the integrators' fast path).
    value : complex
        The background uniform flow ``flow`` (m/s).
    max_speed : float
        An upper bound of ``|f|`` over all times and places (m/s), exact for every model.

    """

    def __init__(self, sc: Scenario) -> None:
        self.model = sc.flow_model
        self.value = complex(sc.flow_c)
        self.uniform = self.model == 'uniform'
        extra = 0.0
        if self.model == 'time_varying':
            self.amplitude, self.rate = sc.flow_amplitude, 2.0 * np.pi / sc.flow_period
            extra = sc.flow_amplitude
        elif self.model == 'shear':
            self.shear, self.width = sc.flow_shear, sc.flow_shear_width
            extra = abs(sc.flow_shear) * sc.flow_shear_width
        elif self.model == 'vortex':
            self.centre = complex(*sc.flow_center)
            self.radius, self.circulation = sc.flow_radius, sc.flow_circulation
            extra = abs(sc.flow_circulation) / (2.0 * np.pi * sc.flow_radius)
        elif self.model == 'grid':
            self.x, self.y, self.grid = read_grid(sc.flow_grid_file)
            self.grid = self.grid + self.value
            self.max_speed = float(np.max(abs(self.grid)))
            return
        self.max_speed = abs(self.value) + extra

    def __call__(self, t: float | RealArray, x: RealArray,
                 y: RealArray) -> ComplexArray:
        """
        Return the flow at the time ``t`` and the positions ``x, y``.

        Parameters
        ----------
        t : float
            Time (s).
        x, y : array_like, same shape
            Positions (m, map frame).

        Returns
        -------
        ndarray of complex, shape of ``x``
            ``f = fx + i fy`` (m/s); for the uniform model ``value`` broadcast.

        """
        shape = np.shape(x)
        if self.model == 'uniform':
            return np.full(shape, self.value)
        if self.model == 'time_varying':
            return np.full(shape, self.value + self.amplitude * np.exp(1j * self.rate * t))
        if self.model == 'shear':
            return np.asarray(self.value + self.shear * np.clip(y, -self.width, self.width),
                              complex)
        if self.model == 'vortex':
            return self.value + self._vortex(np.asarray(x) + 1j * np.asarray(y) - self.centre)
        return self._bilinear(np.asarray(x, float), np.asarray(y, float))

    def _vortex(self, d: ComplexArray) -> ComplexArray:
        """Return the Rankine vortex's velocity at the offsets d from its centre (complex m)."""
        rho2 = np.maximum(abs(d) ** 2, self.radius ** 2)
        return 1j * d * self.circulation / (2.0 * np.pi * rho2)

    def _bilinear(self, x: RealArray, y: RealArray) -> ComplexArray:
        """Return the grid flow bilinearly interpolated at x, y (held at the border)."""
        xs, ys = np.clip(x, self.x[0], self.x[-1]), np.clip(y, self.y[0], self.y[-1])
        i = np.clip(np.searchsorted(self.x, xs) - 1, 0, self.x.size - 2)
        j = np.clip(np.searchsorted(self.y, ys) - 1, 0, self.y.size - 2)
        a = (xs - self.x[i]) / (self.x[i + 1] - self.x[i])
        b = (ys - self.y[j]) / (self.y[j + 1] - self.y[j])
        g = self.grid
        return ((1 - b) * ((1 - a) * g[j, i] + a * g[j, i + 1])
                + b * ((1 - a) * g[j + 1, i] + a * g[j + 1, i + 1]))

    def max_rate(self) -> float:
        """Return a bound of ``|df/dt|`` at a fixed place (m/s^2): 2 pi A / T, else 0."""
        return self.amplitude * self.rate if self.model == 'time_varying' else 0.0

    def max_gradient(self) -> float:
        """
        Return a bound of the Jacobian's norm ``|grad f|`` over every place (1/s).

        Shear ``|G|``; vortex ``|Gamma| / (2 pi R^2)`` (a rotation inside the core, and the
        anti-holomorphic ``|d f / d conj(z)| = |Gamma| / (2 pi rho^2)`` outside); grid the
        largest slope along x plus the largest along y (bilinear: a cell's slopes lie
        between those of its edges); 0 for the others.
        """
        if self.model == 'shear':
            return abs(self.shear)
        if self.model == 'vortex':
            return abs(self.circulation) / (2.0 * np.pi * self.radius ** 2)
        if self.model != 'grid':
            return 0.0
        g = self.grid
        fx = abs(np.diff(g, axis=1)) / np.diff(self.x)
        fy = abs(np.diff(g, axis=0)) / np.diff(self.y)[:, None]
        return float(np.max(fx) + np.max(fy))

    def jet(self, x: RealArray, y: RealArray, f: ComplexArray) -> Jet:
        """
        Return the derivatives of the flow at the positions x, y where the flow is ``f``.

        Parameters
        ----------
        x, y : array_like, same shape
            Positions (m, map frame).
        f : array_like of complex, shape of ``x``
            The flow there (m/s), as measured or told: the turning flow's time derivatives
            follow from it, ``f_t = i w (f - flow)``, ``f_tt = -w^2 (f - flow)``, so no clock
            is needed.

        Returns
        -------
        Jet
            Shear: ``f_y = G`` inside the layer ``|y| < w``. Vortex, ``d = r - c``: inside the
            core ``f = i k d``, ``f_x = i k``, ``f_y = -k`` (``k = Gamma / (2 pi R^2)``);
            outside ``f = q / conj(d)`` (``q = i Gamma / (2 pi)``), ``f_x = -q / conj(d)^2``,
            ``f_y = i q / conj(d)^2``, ``f_xx = -f_yy = 2 q / conj(d)^3``,
            ``f_xy = -2 i q / conj(d)^3``. Grid: the bilinear cell's slopes and its
            ``f_xy``, zero across a border the flow is held at. The second derivatives
            jump (shear, vortex: f' itself jumps) where the layer's edge, the core's rim or a
            cell edge is crossed.

        """
        x, y = np.asarray(x, float), np.asarray(y, float)
        zero = np.zeros(np.shape(x), complex)
        parts = dict.fromkeys(('f_t', 'f_x', 'f_y', 'f_tt', 'f_xx', 'f_xy', 'f_yy'), zero)
        if self.model == 'time_varying':
            d = np.asarray(f, complex) - self.value
            parts.update(f_t=1j * self.rate * d, f_tt=-self.rate ** 2 * d)
        elif self.model == 'shear':
            parts['f_y'] = np.where(abs(y) < self.width, self.shear, 0.0) + zero
        elif self.model == 'vortex':
            parts.update(self._vortex_jet(x + 1j * y - self.centre))
        elif self.model == 'grid':
            parts.update(self._grid_jet(x, y))
        return Jet(**parts)

    def _vortex_jet(self, d: ComplexArray) -> dict[str, ComplexArray]:
        """Return the Rankine vortex's partial derivatives at the offsets d from its centre."""
        inside = abs(d) < self.radius
        k = self.circulation / (2.0 * np.pi * self.radius ** 2)
        cd = np.conj(np.where(inside, 1.0, d))
        q = 1j * self.circulation / (2.0 * np.pi)
        second = np.where(inside, 0.0, 2.0 * q / cd ** 3)
        return {'f_x': np.where(inside, 1j * k, -q / cd ** 2),
                'f_y': np.where(inside, -k, 1j * q / cd ** 2),
                'f_xx': second, 'f_xy': -1j * second, 'f_yy': -second}

    def _grid_jet(self, x: RealArray, y: RealArray) -> dict[str, ComplexArray]:
        """Return the bilinear cell's partial derivatives at x, y (zero where held)."""
        xs, ys = np.clip(x, self.x[0], self.x[-1]), np.clip(y, self.y[0], self.y[-1])
        i = np.clip(np.searchsorted(self.x, xs) - 1, 0, self.x.size - 2)
        j = np.clip(np.searchsorted(self.y, ys) - 1, 0, self.y.size - 2)
        dx, dy = self.x[i + 1] - self.x[i], self.y[j + 1] - self.y[j]
        a, b = (xs - self.x[i]) / dx, (ys - self.y[j]) / dy
        g = self.grid
        g00, g01, g10, g11 = g[j, i], g[j, i + 1], g[j + 1, i], g[j + 1, i + 1]
        in_x = (x > self.x[0]) & (x < self.x[-1])
        in_y = (y > self.y[0]) & (y < self.y[-1])
        f_x = np.where(in_x, ((1 - b) * (g01 - g00) + b * (g11 - g10)) / dx, 0.0)
        f_y = np.where(in_y, ((1 - a) * (g10 - g00) + a * (g11 - g01)) / dy, 0.0)
        f_xy = np.where(in_x & in_y, (g11 - g10 - g01 + g00) / (dx * dy), 0.0)
        return {'f_x': f_x, 'f_y': f_y, 'f_xy': f_xy}
