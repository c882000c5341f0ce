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
RViz markers of a fleet (visualization_msgs/MarkerArray in ``map``).

Each vehicle's heading arrow, its ground-velocity arrow in a flow, its trail, the circle
centres c_k and the prescribed centre c0.
"""
from formation_control.core.models import position, ROW_THETA
from formation_control.protocol import messages
from formation_control.ros import interface as itf
from formation_control.view import palette
from geometry_msgs.msg import Point
import numpy as np
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

HEADING, VELOCITY, TRAIL, CENTRE, TARGET, LINK, LABEL = (
    ColorRGBA(r=r, g=g, b=b, a=a) for r, g, b, a in (
        palette.HEADING, palette.VELOCITY, palette.TRAIL, palette.CENTRE, palette.TARGET,
        palette.LINK, palette.LABEL))


def _marker(ns, name, ident, kind, color):
    m = Marker()
    messages.set_stamp(m.header, ns)
    m.header.frame_id = itf.WORLD_FRAME
    m.ns, m.id, m.type, m.action, m.color = name, ident, kind, Marker.ADD, color
    m.pose.orientation.w = 1.0
    return m


def _point(z):
    return Point(x=float(z.real), y=float(z.imag))


def vehicle_markers(ns, k, position, heading, ground_velocity, trail):
    """Return the heading arrow, ground-velocity arrow (None: no flow) and trail of vehicle k."""
    arrow = _marker(ns, 'heading', k, Marker.ARROW, HEADING)
    arrow.pose.position = _point(position)
    messages.yaw_quaternion(arrow.pose.orientation, heading)
    arrow.scale.x, arrow.scale.y, arrow.scale.z = 0.6, 0.12, 0.12
    out = [arrow]
    if ground_velocity is not None:
        vel = _marker(ns, 'velocity', k, Marker.ARROW, VELOCITY)
        vel.points = [_point(position), _point(position + ground_velocity)]
        vel.scale.x, vel.scale.y, vel.scale.z = 0.05, 0.12, 0.12
        out.append(vel)
    line = _marker(ns, 'trail', k, Marker.LINE_STRIP, TRAIL)
    line.points = [_point(z) for z in trail]
    line.scale.x = 0.03
    out.append(line)
    return out


def centre_markers(ns, centres, target):
    """Return the circle centres c_k as spheres and the prescribed centre c0 (None: none)."""
    spheres = _marker(ns, 'centres', 0, Marker.SPHERE_LIST, CENTRE)
    spheres.points = [_point(c) for c in centres]
    spheres.scale.x = spheres.scale.y = spheres.scale.z = 0.1
    out = [spheres]
    if target is not None:
        disc = _marker(ns, 'target_centre', 0, Marker.CYLINDER, TARGET)
        disc.pose.position = _point(target)
        disc.scale.x = disc.scale.y = 0.25
        disc.scale.z = 0.02
        out.append(disc)
    return out


def link_marker(ns, positions, edges):
    """
    Return the live links of the communication graph as one LINE_LIST marker.

    Parameters
    ----------
    ns : int
        Stamp (ns).
    positions : array_like of complex, shape (N,)
        Vehicle positions (m).
    edges : array_like of int, shape (L, 2)
        The live links, 0-based vehicle indices.

    """
    line = _marker(ns, 'links', 0, Marker.LINE_LIST, LINK)
    line.points = [_point(positions[i]) for edge in edges for i in edge]
    line.scale.x = 0.02
    return line


METRICS_SHOWN = (('order_parameter', '|p|'), ('lyapunov', 'V_c'),
                 ('centre_spread', 'centre spread (m)'), ('speed_error', 'speed error (m/s)'))
"""The metrics the text marker lists, with their labels, where the formation has them."""


def metrics_marker(ns, values, positions):
    """
    Return the metrics of the sample as a text marker above the fleet (RViz shows no topics).

    Parameters
    ----------
    ns : int
        Stamp (ns) of the metrics sample.
    values : dict of str to float
        The metrics by name (``formation/metrics``).
    positions : array_like of complex, shape (N,)
        Vehicle positions (m): the text stands 1 m above the highest, at their mean x.

    """
    text = _marker(ns, 'metrics', 0, Marker.TEXT_VIEW_FACING, LABEL)
    r = np.asarray(positions)
    text.pose.position = _point(complex(r.real.mean(), r.imag.max() + 1.0))
    text.scale.z = 0.3
    text.text = '\n'.join(f'{label} = {values[name]:.4f}' for name, label in METRICS_SHOWN
                          if name in values and np.isfinite(values[name]))
    return text


def fleet_markers(ns, X, ground_velocity, trails, centres=None, target=None):
    """
    Return the MarkerArray of a fleet.

    Parameters
    ----------
    ns : int
        Stamp (ns).
    X : array_like, shape (6, N)
        States (rows of :mod:`models`).
    ground_velocity : array_like of complex, shape (N,), or None
        Ground velocities (m/s), :func:`models.ground_velocity`; None: no velocity arrows.
    trails : sequence of N sequences of complex
        Each vehicle's recent positions (m).
    centres : array_like of complex, shape (N,), optional
        Circle centres c_k (m).
    target : complex, optional
        Prescribed centre c0 (m).

    Returns
    -------
    visualization_msgs.msg.MarkerArray

    """
    msg = MarkerArray()
    r = position(X)
    for i in range(X.shape[1]):
        vel = None if ground_velocity is None else ground_velocity[i]
        msg.markers += vehicle_markers(ns, i + 1, complex(r[i]), float(X[ROW_THETA, i]), vel,
                                       trails[i])
    if centres is not None:
        msg.markers += centre_markers(ns, centres, target)
    return msg
