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

"""The walk that refuses bytes no message fits, before rosidl's C type support prints on them."""
from formation_control.ros import interface as itf
from formation_control.ros.fits import fits
from formation_control_msgs.msg import FormationState
from nav_msgs.msg import Odometry
import numpy as np
import pytest
from rcl_interfaces.msg import Parameter, ParameterEvent, ParameterValue
from rclpy.serialization import serialize_message
from std_msgs.msg import Empty, String

VALUES = [ParameterValue(type=1, bool_value=True), ParameterValue(type=4, string_value='abc'),
          ParameterValue(type=5, byte_array_value=[b'a', b'b']),
          ParameterValue(type=7, integer_array_value=[1, 2, 3]),
          ParameterValue(type=8, double_array_value=[]),
          ParameterValue(type=9, string_array_value=['x', '', 'yyy'])]
MESSAGES = [Empty(), String(data='hé'), Odometry(child_frame_id='vehicle_1/base_link'),
            itf.state_msg(1, 5, np.ones(6), (1j, 0.3, 0.2, 1.0), [2, 3], [True, False]),
            itf.state_msg(1, 5, np.ones(6), (1j, 0.3, 0.2, 1.0)),
            ParameterEvent(node='/vehicle_1', new_parameters=[
                Parameter(name=f'p{i}', value=v) for i, v in enumerate(VALUES)],
                changed_parameters=[Parameter(name='kappa', value=VALUES[0])])]


@pytest.mark.parametrize('msg', MESSAGES, ids=lambda m: type(m).__name__)
def test_every_message_fits_its_bytes_and_none_its_cut_bytes(msg):
    data = serialize_message(msg)
    assert fits(data, type(msg))
    assert fits(data + b'\x00' * 8, type(msg))
    if len(data) > 8:
        assert not fits(data[:len(data) // 2], type(msg))


@pytest.mark.parametrize('length', [b'\xff\xff\xff\x7f', b'\xff\xff\xff\xff'])
def test_a_sequence_longer_than_the_bytes_does_not_fit(length):
    msg = itf.state_msg(1, 5, np.ones(6), (1j, 0.3, 0.2, 1.0), [2, 3], [True, False])
    data = serialize_message(msg)
    at = data.index(b'\x02\x00\x00\x00\x02\x00\x00\x00')         # neighbour_ids: 2, [2, 3]
    assert not fits(data[:at] + length + data[at + 4:], FormationState)
    assert not fits(b'\x00\x00\x00\x00' + data[4:], FormationState)     # read big-endian
