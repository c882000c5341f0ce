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

"""The processes of a fleet and the parameters they are given (``swarm``, the launch files)."""
from __future__ import annotations

from os import PathLike
from pathlib import Path

from formation_control.core.scenario import Scenario
from formation_control.protocol import names
import yaml

RECORDED_DEPTH = 500
"""With a bag: the history of the odometry, state and command writers (samples; 10 s at
50 Hz). DDS matches a writer to the recorder's reader on each side in its own time; a writer
that matches after the first steps resends its transient-local history, which must still
hold step 0."""


RECORDED_TOPICS = ('odom', 'formation_state', 'cmd')
"""The per-vehicle topics whose writers keep :data:`RECORDED_DEPTH` samples under a bag."""


def write_params(sc: Scenario, path: str | PathLike[str], recorded: bool = False,
                 namespace: str = '/') -> str:
    """
    Write the resolved scenario as a ROS 2 parameter file at ``path``; return the path.

    Empty lists are left out: ROS types them. ``recorded``: the state writers keep
    :data:`RECORDED_DEPTH` samples (``qos_overrides`` of the topics in ``namespace``), so the
    bag misses no step.
    """
    values = {k: v for k, v in sc.to_dict().items() if v != []}
    prefix = names.namespace_prefix(namespace)
    if recorded:
        values['qos_overrides'] = {
            f'{prefix}vehicle_{k}/{name}': {'publisher': {'depth': RECORDED_DEPTH}}
            for k in range(1, sc.num_vehicles + 1) for name in RECORDED_TOPICS}
    Path(path).write_text(yaml.safe_dump({'/**': {'ros__parameters': values}}))
    return str(path)
