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
The type of ``/tf`` and ``/tf_static``: tf2_msgs/msg/TFMessage, the one of ROS 2 Jazzy.

``make setup`` builds it from third_party/tf2_msgs when the venv has none: the standard
definition, and the type of this environment (built or a ROS installation's) has Jazzy's RIHS01
type hash, which every endpoint of ``/tf`` announces.
"""
import json
import os
from pathlib import Path
import sys

from rosbags.typesys import get_typestore, Stores
from rosidl_adapter.parser import parse_message_file

PACKAGE = Path(__file__).resolve().parents[2] / 'third_party' / 'tf2_msgs'
JAZZY_HASH = 'RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087'
"""``ros2 topic info --verbose /tf`` on a ROS 2 Jazzy installation."""
TYPE = 'tf2_msgs/msg/TFMessage'


def test_the_definition_is_the_standard_one():
    spec = parse_message_file('tf2_msgs', str(PACKAGE / 'msg' / 'TFMessage.msg'))
    assert [(str(f.type), f.name) for f in spec.fields] == [
        ('geometry_msgs/TransformStamped[]', 'transforms')]
    assert not spec.constants
    assert get_typestore(Stores.ROS2_JAZZY).hash_rihs01(TYPE) == JAZZY_HASH


def test_the_tfmessage_of_this_environment_has_the_jazzy_type_hash():
    prefixes = os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) + [sys.prefix]
    found = [Path(p) / 'share' / 'tf2_msgs' / 'msg' / 'TFMessage.json' for p in prefixes if p]
    description = json.loads(next(f for f in found if f.is_file()).read_text())
    hashes = {h['type_name']: h['hash_string'] for h in description['type_hashes']}
    assert hashes[TYPE] == JAZZY_HASH
