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
The picture of a fleet the monitor shows, one for both renderers.

The RViz markers (:mod:`formation_control.ros.markers`) and the Foxglove scene
(:mod:`formation_control.view.scene`) draw the same :class:`Picture` with the same sizes (m)
and colours (:mod:`formation_control.view.palette`): each vehicle's heading arrow, its
ground-velocity arrow in a flow (m/s drawn as m), its trail, its safety disc (diameter d_min,
coloured by how near its nearest neighbour is), the live links, the circle centres c_k and the
prescribed centre c0.
"""
from collections.abc import Iterator, Mapping, Sequence
from typing import Any, NamedTuple, Optional

from formation_control.core import separation
from formation_control.core.geometry import ComplexArray, IntArray
from formation_control.core.models import position, ROW_THETA
import numpy as np

HEADING_LENGTH = 0.6
"""Length of the heading arrows (m)."""
TRAIL_WIDTH = 0.03
LINK_WIDTH = 0.02
CENTRE_SIZE = 0.1
DISC_HEIGHT = 0.01
"""Thickness of the safety discs (m)."""
"""Diameter of the spheres at the circle centres c_k (m)."""
TARGET_SIZE = (0.25, 0.02)
"""Diameter and height of the disc at the prescribed centre c0 (m)."""
LABEL_HEIGHT = 1.0
"""The metrics text stands this high (m) above the highest vehicle, at their mean x."""
METRICS_SHOWN = (('order_parameter', '|p|'), ('lyapunov', 'V_c'),
                 ('centre_spread', 'centre spread (m)'), ('speed_error', 'speed error (m/s)'))
"""The metrics the text lists, with their labels, where the formation has them."""


class Picture(NamedTuple):
    """
    A fleet at one instant, as :func:`scene.fleet_scene` takes it (in this order).

    Attributes
    ----------
    ns : int
        Stamp (ns) of the state shown.
    positions : numpy.ndarray of complex, shape (N,)
        r_k (m).
    headings : numpy.ndarray, shape (N,)
        theta_k (rad).
    ground_velocity : numpy.ndarray of complex, shape (N,), or None
        Ground velocities (m/s); None: no velocity arrows (no flow).
    trails : sequence of N sequences of complex
        Each vehicle's recent positions (m), oldest first.
    edges : array_like of int, shape (L, 2)
        The live links, 0-based.
    centres : numpy.ndarray of complex, shape (N,), or None
        Circle centres c_k (m); None: not a circular formation.
    target : complex or None
        The prescribed centre c0 (m).
    d_min : float or None
        The separation distance (m): each vehicle's safety disc has this diameter (None: none).

    """

    ns: int
    positions: np.ndarray
    headings: np.ndarray
    ground_velocity: Optional[np.ndarray]
    trails: Sequence[Sequence[complex]]
    edges: Any
    centres: Optional[np.ndarray] = None
    target: Optional[complex] = None
    d_min: Optional[float] = None


def of_states(ns: int, X: Any, ground_velocity: Optional[np.ndarray],
              trails: Sequence[Sequence[complex]], edges: Any,
              centres: Optional[np.ndarray] = None, target: Optional[complex] = None,
              d_min: Optional[float] = None) -> Picture:
    """Return the :class:`Picture` of the states ``X`` (6, N) (rows of :mod:`models`)."""
    return Picture(ns, position(X), np.asarray(X[ROW_THETA], float), ground_velocity, trails,
                   edges, centres, target, d_min)


def disc_levels(positions: ComplexArray, d_min: float) -> IntArray:
    """
    Return each vehicle's separation level (N,): 0, 1 within 2 d_min of another, 2 within d_min.

    The grades of the monitor's separation diagnostics (WARN, ERROR), per vehicle, from the
    pairs within 2 d_min (:func:`~formation_control.core.separation.pairs_within`).
    """
    z = np.asarray(positions, complex)
    levels = np.zeros(z.size, np.int64)
    i, j, distance = separation.pairs_within(np.stack([z.real, z.imag], axis=-1), 2.0 * d_min)
    level = np.where(distance < d_min, 2, 1)
    np.maximum.at(levels, i, level)
    np.maximum.at(levels, j, level)
    return levels


def vehicles(picture: Picture) -> Iterator[
        tuple[int, complex, float, complex | None, Sequence[complex],
              tuple[float, int] | None]]:
    """
    Yield each vehicle's (k, position, heading, ground velocity or None, trail, disc).

    ``disc``: (diameter d_min, level of :func:`disc_levels`), or None without a d_min.
    """
    d_min = picture.d_min
    levels = None if d_min is None else disc_levels(picture.positions, d_min)
    for i, z in enumerate(picture.positions):
        ground = picture.ground_velocity
        yield (i + 1, complex(z), float(picture.headings[i]),
               None if ground is None else complex(ground[i]), picture.trails[i],
               None if d_min is None or levels is None else (float(d_min), int(levels[i])))


def link_points(positions: Sequence[complex] | ComplexArray,
                edges: Any) -> list[complex]:
    """Return the ends of each live link, in pairs: [r_i, r_j, ...] (complex, m)."""
    return [complex(positions[i]) for edge in edges for i in edge]


def label_position(positions: Sequence[complex] | ComplexArray) -> complex:
    """Return where the metrics text stands (complex, m)."""
    r = np.asarray(positions)
    return complex(r.real.mean(), r.imag.max() + LABEL_HEIGHT)


def metrics_text(values: Mapping[str, float]) -> str:
    """Return the lines of the metrics text of a sample ({name: value})."""
    return '\n'.join(f'{label} = {values[name]:.4f}' for name, label in METRICS_SHOWN
                     if name in values and np.isfinite(values[name]))
