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
Every topic, frame and namespace name of a fleet: the one place that normalises a namespace.

Topic names are relative, so a fleet lives in the namespace of its nodes (``-r
__ns:=/fleet_a``); only ``DIAGNOSTICS_TOPIC`` is absolute. Frames follow REP-105: the
``world`` frame (default ``map``) and one base frame per vehicle (``vehicle_{id}/base_link``).
"""
from __future__ import annotations

WORLD_FRAME = 'map'
BASE_FRAME = 'vehicle_{id}/base_link'

DIAGNOSTICS_TOPIC = '/diagnostics'
CLOCK_TOPIC = 'clock'
SCENARIO_TOPIC = 'formation/scenario'
METRICS_TOPIC = 'formation/metrics'
FAULTS_TOPIC = 'formation/faults'
"""swarm: each scripted fault as it is applied (std_msgs/String, JSON)."""
MARKERS_TOPIC = 'formation/markers'
START_TOPIC = 'formation/start'
"""std_msgs/Empty, latched: a plant with ``wait_for_start`` holds its step 0 until it hears it."""
SCENE_TOPIC = 'formation/scene'
"""The Foxglove live view's SceneUpdate channel (not a ROS topic), named as the monitor resolves
it (``/fleet_a/formation/scene``)."""
VEHICLE_TOPICS = ('odom', 'flow', 'water_velocity', 'formation_state', 'cmd', 'cmd_vel')
"""The topics of each vehicle k, ``vehicle_k/<name>`` (:func:`topic`); ``cmd_vel``: an
aircraft's autopilot demand (geometry_msgs/TwistStamped), plant_backend jsbsim only."""
KNOWN_FLOW_TOPICS = ('odom', 'flow', 'formation_state', 'cmd')
"""Those of a vehicle of a fleet of particles or rigid bodies in a known flow (the bag
recorder's default; :func:`~formation_control.protocol.onboard.vehicle_topics` in general)."""


def namespace_prefix(namespace: str) -> str:
    """
    Return the topic prefix of a fleet's namespace.

    ``''``, ``'/'`` -> ``'/'``; ``'fleet_a'``, ``'/fleet_a/'`` -> ``'/fleet_a/'``.
    """
    return '/' + ''.join(f'{part}/' for part in namespace.split('/') if part)


def namespace_of(namespace: str) -> str:
    """Return the normalised namespace: ``'/'`` or ``'/fleet_a'`` (no trailing slash)."""
    return namespace_prefix(namespace).rstrip('/') or '/'


def status_prefix(namespace: str) -> str:
    """
    Return the prefix of a /diagnostics status name in ``namespace``.

    ``/diagnostics`` is shared by every fleet of a domain, so in a namespace each status name
    starts with it: ``''``, ``'/'`` -> ``''``; ``'/fleet_a'`` -> ``'fleet_a/'``.
    """
    return namespace_prefix(namespace)[1:]


def resolve(namespace: str, name: str) -> str:
    """Return the absolute name of a relative ``name`` in ``namespace`` (absolute kept)."""
    return name if name.startswith('/') else namespace_prefix(namespace) + name


def topic(k: int, name: str) -> str:
    """Return the relative name of vehicle k's topic ``name`` (in the node's namespace)."""
    return f'vehicle_{k}/{name}'


def base_frame(template: str, k: int) -> str:
    """Return vehicle k's base frame: ``template`` with ``{id}`` replaced by k."""
    return template.replace('{id}', str(k))


class Frames:
    """
    The frames of a fleet (REP-105): ``world`` and the ``base`` template of each vehicle.

    Odometry poses and flows are in ``world``; odometry twists, commands and formation states
    in :meth:`base` of their vehicle.
    """

    def __init__(self, world: str = WORLD_FRAME, base: str = BASE_FRAME) -> None:
        self.world, self.template = world, base

    def base(self, k: int) -> str:
        return base_frame(self.template, k)

    def vehicle_of(self, frame: str) -> int | None:
        """Return the id k whose base frame is ``frame``, else None."""
        head, _, tail = self.template.partition('{id}')
        middle = frame[len(head):len(frame) - len(tail)]
        if frame.startswith(head) and frame.endswith(tail) and middle.isdigit():
            return int(middle)
        return None


DEFAULT_FRAMES = Frames()
