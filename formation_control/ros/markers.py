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
RViz markers of a fleet's :class:`~formation_control.view.picture.Picture` (MarkerArray).

Each vehicle's heading arrow, its ground-velocity arrow in a flow, its trail, the circle
centres c_k, the prescribed centre c0, the live links and the metrics as text, in the
monitor's ``world_frame``.
"""
from formation_control.protocol import messages
from formation_control.view import palette, picture
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

HEADING, VELOCITY, TRAIL, CENTRE, TARGET, LINK, LABEL = (
    ColorRGBA(r=r, g=g, b=b, a=a) for r, g, b, a in (
        palette.HEADING, palette.VELOCITY, palette.TRAIL, palette.CENTRE, palette.TARGET,
        palette.LINK, palette.LABEL))
DISC = tuple(ColorRGBA(r=r, g=g, b=b, a=a) for r, g, b, a in palette.DISC)


def _marker(ns, frame, name, ident, kind, color):
    m = Marker()
    messages.set_stamp(m.header, ns)
    m.header.frame_id = frame
    m.ns, m.id, m.type, m.action, m.color = name, ident, kind, Marker.ADD, color
    m.pose.orientation.w = 1.0
    return m


def _point(z):
    return Point(x=float(z.real), y=float(z.imag))


def vehicle_markers(ns, frame, k, position, heading, ground_velocity, trail, disc=None):
    """
    Return vehicle k's heading arrow, ground-velocity arrow (None: no flow), trail and disc.

    ``disc``: (diameter d_min, level 0 ok / 1 warn / 2 error), the safety disc; None: none.
    """
    arrow = _marker(ns, frame, 'heading', k, Marker.ARROW, HEADING)
    arrow.pose.position = _point(position)
    messages.yaw_quaternion(arrow.pose.orientation, heading)
    arrow.scale.x, arrow.scale.y, arrow.scale.z = picture.HEADING_LENGTH, 0.12, 0.12
    out = [arrow]
    if ground_velocity is not None:
        vel = _marker(ns, frame, 'velocity', k, Marker.ARROW, VELOCITY)
        vel.points = [_point(position), _point(position + ground_velocity)]
        vel.scale.x, vel.scale.y, vel.scale.z = 0.05, 0.12, 0.12
        out.append(vel)
    line = _marker(ns, frame, 'trail', k, Marker.LINE_STRIP, TRAIL)
    line.points = [_point(z) for z in trail]
    line.scale.x = picture.TRAIL_WIDTH
    out.append(line)
    if disc is not None:
        ring = _marker(ns, frame, 'disc', k, Marker.CYLINDER, DISC[disc[1]])
        ring.pose.position = _point(position)
        ring.scale.x, ring.scale.y, ring.scale.z = disc[0], disc[0], picture.DISC_HEIGHT
        out.append(ring)
    return out


def centre_markers(ns, frame, centres, target):
    """Return the circle centres c_k as spheres and the prescribed centre c0 (None: none)."""
    spheres = _marker(ns, frame, 'centres', 0, Marker.SPHERE_LIST, CENTRE)
    spheres.points = [_point(c) for c in centres]
    spheres.scale.x = spheres.scale.y = spheres.scale.z = picture.CENTRE_SIZE
    out = [spheres]
    if target is not None:
        disc = _marker(ns, frame, 'target_centre', 0, Marker.CYLINDER, TARGET)
        disc.pose.position = _point(target)
        disc.scale.x = disc.scale.y = picture.TARGET_SIZE[0]
        disc.scale.z = picture.TARGET_SIZE[1]
        out.append(disc)
    return out


def link_marker(ns, frame, positions, edges):
    """Return the live links ((L, 2), 0-based) as one LINE_LIST marker."""
    line = _marker(ns, frame, 'links', 0, Marker.LINE_LIST, LINK)
    line.points = [_point(z) for z in picture.link_points(positions, edges)]
    line.scale.x = picture.LINK_WIDTH
    return line


def metrics_marker(ns, frame, values, positions):
    """Return the metrics of the sample as a text marker above the fleet (RViz shows no topics)."""
    text = _marker(ns, frame, 'metrics', 0, Marker.TEXT_VIEW_FACING, LABEL)
    text.pose.position = _point(picture.label_position(positions))
    text.scale.z = 0.3
    text.text = picture.metrics_text(values)
    return text


def fleet_markers(pic, values, frame):
    """
    Return the MarkerArray of a fleet.

    Parameters
    ----------
    pic : formation_control.view.picture.Picture
        What to draw.
    values : dict of str to float
        The metrics of the sample shown (``formation/metrics``).
    frame : str
        The world frame (the monitor's ``world_frame``).

    Returns
    -------
    visualization_msgs.msg.MarkerArray

    """
    msg = MarkerArray()
    for vehicle in picture.vehicles(pic):
        msg.markers += vehicle_markers(pic.ns, frame, *vehicle)
    if pic.centres is not None:
        msg.markers += centre_markers(pic.ns, frame, pic.centres, pic.target)
    msg.markers.append(link_marker(pic.ns, frame, pic.positions, pic.edges))
    msg.markers.append(metrics_marker(pic.ns, frame, values, pic.positions))
    return msg
