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

A grid file is an ``.npz`` with ``x`` (nx,), ``y`` (ny,) increasing, and ``fx, fy`` (ny, nx);
or a CSV with a header ``x,y,fx,fy`` and one row per grid node (any order).
"""
from __future__ import annotations

from os import PathLike
from pathlib import Path
from typing import NoReturn, TYPE_CHECKING

from formation_control.core.geometry import ComplexArray, RealArray
import numpy as np

if TYPE_CHECKING:
    from formation_control.core.scenario import Scenario

FLOW_MODELS = ('uniform', 'time_varying', 'shear', 'vortex', 'grid')
Grid = tuple[RealArray, RealArray, ComplexArray]
"""The lines x, y (m) of a gridded flow and the flow at its nodes (m/s), shape (ny, nx)."""


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
