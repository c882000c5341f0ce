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
A fleet: the plant, one vehicle node per vehicle and the monitor, from a scenario file.

    ros2 launch formation_control fleet.launch.py scenario:=rigid_circular namespace:=fleet_a

Arguments (`ros2 launch formation_control fleet.launch.py --show-args`): scenario, namespace,
mode, num_vehicles, duration, vehicles_per_process, monitor, record (a bag directory),
record_path, params_file, world_frame, base_frame, secure, heal_after. The warden (heal_after > 0)
restarts a vehicle process the fleet waits on past heal_after seconds (docs/reliability.md). The
launch ends when the plant has run the scenario's duration; Ctrl-C stops every node.
"""
from formation_control.ros.launching import fleet_actions
from launch import LaunchDescription


def generate_launch_description():
    return LaunchDescription(fleet_actions())
