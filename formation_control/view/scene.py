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
The Foxglove live view's messages: a fleet as a ``foxglove.SceneUpdate``, its metrics as JSON.

Pure functions of the monitor's arrays (no ROS): the same
:class:`~formation_control.view.picture.Picture` the RViz markers show
(:mod:`formation_control.ros.markers`), in the monitor's ``world_frame`` (default ``map``).
One entity per vehicle (``vehicle_k``: heading arrow, ground-velocity arrow, trail, label),
``centres`` (the circle centres c_k and the prescribed centre c0) and ``links`` (the live links
of the graph).
"""
import cmath
from collections.abc import Mapping, Sequence
import math
from typing import Any

from formation_control.protocol.messages import stamp_parts
from formation_control.protocol.names import WORLD_FRAME
from formation_control.view import palette, picture
from foxglove.messages import (ArrowPrimitive, Color, CylinderPrimitive, KeyValuePair,
                               LinePrimitive, LinePrimitiveLineType, Point3, Pose, Quaternion,
                               SceneEntity, SceneUpdate, SpherePrimitive, TextPrimitive, Timestamp,
                               Vector3)

HEADING, VELOCITY, TRAIL, CENTRE, TARGET, LINK, LABEL = (
    Color(r=r, g=g, b=b, a=a) for r, g, b, a in (
        palette.HEADING, palette.VELOCITY, palette.TRAIL, palette.CENTRE, palette.TARGET,
        palette.LINK, palette.LABEL))
DISC = tuple(Color(r=r, g=g, b=b, a=a) for r, g, b, a in palette.DISC)


def stamp(ns: int) -> Timestamp:
    """Return the foxglove Timestamp of a time in ns."""
    return Timestamp(*stamp_parts(ns))


def _pose(z: complex, angle: float = 0.0) -> Pose:
    return Pose(position=Vector3(x=float(z.real), y=float(z.imag), z=0.0),
                orientation=Quaternion(x=0.0, y=0.0, z=math.sin(0.5 * angle),
                                       w=math.cos(0.5 * angle)))


def _point(z: complex) -> Point3:
    return Point3(x=float(z.real), y=float(z.imag), z=0.0)


def _arrow(z: complex, angle: float, length: float, color: Color,
           width: float) -> ArrowPrimitive:
    head = min(0.15, 0.3 * length)
    return ArrowPrimitive(pose=_pose(z, angle), shaft_length=length - head,
                          shaft_diameter=width, head_length=head, head_diameter=2.5 * width,
                          color=color)


def vehicle_entity(ns: int, k: int, position: complex, heading: float,
                   ground_velocity: complex | None, trail: Sequence[complex],
                   disc: tuple[float, int] | None = None,
                   frame: str = WORLD_FRAME) -> SceneEntity:
    """
    Return the SceneEntity ``vehicle_k``.

    Parameters
    ----------
    ns : int
        Stamp (ns).
    k : int
        Vehicle id.
    position : complex
        r_k (m, map).
    heading : float
        theta_k (rad).
    ground_velocity : complex or None
        Ground velocity (m/s); None: no arrow (no flow: it is the heading).
    trail : sequence of complex
        Recent positions (m), oldest first.
    disc : (float, int), optional
        The safety disc: its diameter d_min (m) and level (0 ok, 1 warn, 2 error:
        :func:`~formation_control.view.picture.disc_levels`); None: none.
    frame : str, optional
        The world frame of the positions.

    """
    arrows = [_arrow(position, heading, picture.HEADING_LENGTH, HEADING, 0.05)]
    if ground_velocity is not None and abs(ground_velocity) > 0:
        arrows.append(_arrow(position, cmath.phase(ground_velocity), abs(ground_velocity),
                             VELOCITY, 0.03))
    lines = [LinePrimitive(type=LinePrimitiveLineType.LineStrip, pose=_pose(0j),
                           thickness=picture.TRAIL_WIDTH, points=[_point(z) for z in trail],
                           color=TRAIL)]
    label = TextPrimitive(pose=_pose(position + 0.25j), billboard=True, font_size=14.0,
                          scale_invariant=True, color=LABEL, text=str(k))
    cylinders = []
    if disc is not None:
        size = Vector3(x=disc[0], y=disc[0], z=picture.DISC_HEIGHT)
        cylinders.append(CylinderPrimitive(pose=_pose(position), size=size, bottom_scale=1.0,
                                           top_scale=1.0, color=DISC[disc[1]]))
    return SceneEntity(timestamp=stamp(ns), frame_id=frame, id=f'vehicle_{k}', arrows=arrows,
                       lines=lines, texts=[label], cylinders=cylinders,
                       metadata=[KeyValuePair(key='vehicle_id', value=str(k))])


def centres_entity(ns: int, centres: Sequence[complex], target: complex | None = None,
                   frame: str = WORLD_FRAME) -> SceneEntity:
    """Return the SceneEntity ``centres``: c_k as spheres, c0 (None: none) as a flat disc."""
    size = Vector3(x=picture.CENTRE_SIZE, y=picture.CENTRE_SIZE, z=picture.CENTRE_SIZE)
    spheres = [SpherePrimitive(pose=_pose(c), size=size, color=CENTRE) for c in centres]
    cylinders = []
    if target is not None:
        width, height = picture.TARGET_SIZE
        disc = Vector3(x=width, y=width, z=height)
        cylinders.append(CylinderPrimitive(pose=_pose(target), size=disc, bottom_scale=1.0,
                                           top_scale=1.0, color=TARGET))
    return SceneEntity(timestamp=stamp(ns), frame_id=frame, id='centres', spheres=spheres,
                       cylinders=cylinders)


def links_entity(ns: int, positions: Sequence[complex], edges: Any,
                 frame: str = WORLD_FRAME) -> SceneEntity:
    """Return the SceneEntity ``links``: one segment per live link (edges (L, 2), 0-based)."""
    points = [_point(z) for z in picture.link_points(positions, edges)]
    line = LinePrimitive(type=LinePrimitiveLineType.LineList, pose=_pose(0j),
                         thickness=picture.LINK_WIDTH, points=points, color=LINK)
    return SceneEntity(timestamp=stamp(ns), frame_id=frame, id='links', lines=[line])


def fleet_scene(ns: int, positions: Any, headings: Any, ground_velocity: Any,
                trails: Sequence[Sequence[complex]], edges: Any, centres: Any = None,
                target: complex | None = None, d_min: float | None = None,
                frame: str = WORLD_FRAME) -> SceneUpdate:
    """
    Return the SceneUpdate of a fleet: every vehicle and its disc, the live links, the centres.

    Parameters
    ----------
    ns : int
        Stamp (ns) of the state shown.
    positions : array_like of complex, shape (N,)
        r_k (m).
    headings : array_like, shape (N,)
        theta_k (rad).
    ground_velocity : array_like of complex, shape (N,), or None
        Ground velocities (m/s); None: no velocity arrows (no flow).
    trails : sequence of N sequences of complex
        Each vehicle's recent positions (m).
    edges : array_like of int, shape (L, 2)
        Live links, 0-based.
    centres : array_like of complex, shape (N,), optional
        Circular formations: c_k = r_k + i e^{i phase_k} / omega0 (m).
    target : complex, optional
        The prescribed centre c0 (m).
    d_min : float, optional
        The separation distance (m): each vehicle's safety disc (None: none).
    frame : str, optional
        The world frame (the monitor's ``world_frame``).

    Returns
    -------
    foxglove.messages.SceneUpdate

    """
    pic = picture.Picture(ns, positions, headings, ground_velocity, trails, edges,
                          d_min=d_min)
    entities = [vehicle_entity(ns, *vehicle, frame) for vehicle in picture.vehicles(pic)]
    entities.append(links_entity(ns, positions, edges, frame))
    if centres is not None:
        entities.append(centres_entity(ns, centres, target, frame))
    return SceneUpdate(entities=entities)


def metrics_schema(doc: Mapping[str, str]) -> dict[str, Any]:
    """
    Return the JSON schema of the metrics messages; ``doc``: {metric name: description}.

    One plain ``"type"`` a field (no type arrays, which the parsers of Foxglove Studio 1.x and
    Lichtblick reject with the whole channel); the description holds the unit.
    """
    properties = {'timestamp': {'type': 'object', 'title': 'time',
                                'properties': {'sec': {'type': 'integer'},
                                               'nsec': {'type': 'integer'}}}}
    properties.update({name: {'type': 'number', 'description': text}
                       for name, text in doc.items()})
    return {'type': 'object', 'title': 'formation_control.Metrics', 'properties': properties}


def metrics_message(ns: int, values: Mapping[str, float]) -> dict[str, Any]:
    """
    Return a metrics sample as JSON: ``timestamp`` (sec, nsec) and each finite metric by name.

    A metric without a value (NaN: not defined for the fleet, e.g. ``radius`` of a rigid-body
    fleet) is left out, so every field present is a number, as the schema says.
    """
    sec, nsec = stamp_parts(ns)
    out: dict[str, Any] = {'timestamp': {'sec': sec, 'nsec': nsec}}
    out.update({name: float(v) for name, v in values.items() if math.isfinite(v)})
    return out
