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
One vehicle node (one vehicle per computer), in the fleet's namespace.

    ros2 launch formation_control vehicle.launch.py scenario:=rigid_circular vehicle_id:=3

Arguments: scenario, namespace, vehicle_id, mode, world_frame, base_frame.
"""
from formation_control.ros.launching import vehicle_actions
from launch import LaunchDescription


def generate_launch_description():
    return LaunchDescription(vehicle_actions())
