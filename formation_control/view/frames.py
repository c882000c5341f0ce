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
The frames a viewer draws in (REP-105), from the fleet's picture.

Each vehicle's base frame (``base_frame``, default ``vehicle_{id}/base_link``) is placed in the
world frame at its pose (r_k, theta_k) of the picture; when the world frame is not ``map``,
``map`` is its parent by identity (a fleet localised without drift: map = odom), so a ``map``
frame is always there. The 3D panels of Foxglove-type apps and RViz draw in any of them: the
world frame, or a vehicle's base frame to follow that vehicle. On the ROS graph the monitor
publishes :func:`static_transforms` on ``/tf_static`` and :func:`vehicle_transforms` on ``/tf``
(:mod:`formation_control.ros.tf`); its live view serves both on its ``/tf`` channel.
"""
import math
from typing import NamedTuple

from formation_control.protocol.names import BASE_FRAME, base_frame, WORLD_FRAME
from formation_control.view.picture import Picture

MAP_FRAME = 'map'


class Transform(NamedTuple):
    """The pose of ``child`` in ``parent``: translation (m) and rotation (unit quaternion)."""

    parent: str
    child: str
    translation: tuple[float, float, float]
    rotation: tuple[float, float, float, float]
    """(x, y, z, w)."""


def planar(parent: str, child: str, z: complex, angle: float) -> Transform:
    """Return the Transform of a planar pose: position ``z`` (complex, m), yaw ``angle``."""
    return Transform(parent, child, (float(z.real), float(z.imag), 0.0),
                     (0.0, 0.0, math.sin(0.5 * angle), math.cos(0.5 * angle)))


def static_transforms(world: str = WORLD_FRAME) -> list[Transform]:
    """Return the Transforms that never change: ``map`` to the world frame, if they differ."""
    return [] if world == MAP_FRAME else [planar(MAP_FRAME, world, 0j, 0.0)]


def vehicle_transforms(picture: Picture, world: str = WORLD_FRAME,
                       base: str = BASE_FRAME) -> list[Transform]:
    """Return the Transforms of a Picture's vehicles: each base frame in the world frame."""
    return [planar(world, base_frame(base, k + 1), z, float(theta))
            for k, (z, theta) in enumerate(zip(picture.positions, picture.headings))]


def fleet_transforms(picture: Picture, world: str = WORLD_FRAME,
                     base: str = BASE_FRAME) -> list[Transform]:
    """Return the Transforms of a Picture: ``map`` to the world frame, the world to each base."""
    return static_transforms(world) + vehicle_transforms(picture, world, base)
