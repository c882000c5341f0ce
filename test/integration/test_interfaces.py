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
formation_control_msgs as colcon builds it beside formation_control, used as a ROS user does.

In a shell that sourced the workspace's ``install/local_setup.bash``: the real ``ros2 interface``
shows the commented definitions, and Python serializes and deserializes every message.
"""
import json
import os
from pathlib import Path
import shutil
import subprocess
import sys

import pytest

ROOT = Path(__file__).resolve().parents[2]
MSGS = 'formation_control_msgs'
NAMES = ('FaultEvent', 'FormationMetrics', 'FormationState', 'VehicleCommand')
BIN = Path(sys.executable).parent
ROS2 = str(BIN / 'ros2') if (BIN / 'ros2').exists() else shutil.which('ros2')

ROUND_TRIP = r"""
import json, math, sys
from rclpy.serialization import deserialize_message, serialize_message
import formation_control_msgs.msg as interfaces

def filled(cls, seed):
    msg = cls()
    for i, (name, kind) in enumerate(msg.get_fields_and_field_types().items(), start=seed):
        value = getattr(msg, name)
        if kind in ('double', 'float'):
            value = 0.25 * i - 3.0
        elif kind.startswith(('uint', 'int')):
            value = i % 7 + 1
        elif kind == 'boolean':
            value = i % 2 == 0
        elif kind == 'string':
            value = f'{name}:{i}'
        elif kind == 'sequence<uint32>':
            value = [i, i + 2, 70000]
        elif kind == 'sequence<boolean>':
            value = [True, False, True]
        elif kind == 'std_msgs/Header':
            value.stamp.sec, value.stamp.nanosec, value.frame_id = i, 999_999_999, 'map'
        elif kind == 'builtin_interfaces/Time':
            value.sec, value.nanosec = i + 1, 500_000_000
        else:
            sys.exit(f'{cls.__name__}.{name}: no test value for {kind}')
        setattr(msg, name, value)
    return msg

out = {}
for name in sys.argv[1:]:
    cls = getattr(interfaces, name)
    msg = filled(cls, seed=len(name))
    data = serialize_message(msg)
    back = deserialize_message(data, cls)
    fresh = cls()
    nan = cls()
    for field, kind in nan.get_fields_and_field_types().items():
        if kind == 'double':
            setattr(nan, field, math.nan)
    nan_back = deserialize_message(serialize_message(nan), cls)
    out[name] = dict(
        equal=back == msg, differs=data != serialize_message(fresh), size=len(data),
        version=fresh.interface_version, constant=cls.INTERFACE_VERSION,
        nan=all(math.isnan(getattr(nan_back, f)) for f, k
                in nan.get_fields_and_field_types().items() if k == 'double'))
print(json.dumps(out))
"""


def _sourced(ws, command, timeout=120):
    """Run ``command`` in bash after ``source install/local_setup.bash``; return the result."""
    env = dict(os.environ, PATH=f'{BIN}{os.pathsep}{os.environ["PATH"]}')
    return subprocess.run(['bash', '-c', f'source install/local_setup.bash && {command}'],
                          cwd=ws, env=env, capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope='module')
def ws(colcon_workspace):
    if not (colcon_workspace / 'install' / MSGS).is_dir():
        pytest.skip(f'{MSGS} was not built: cmake or a C++ compiler is missing')
    return colcon_workspace


@pytest.mark.skipif(ROS2 is None, reason='the ros2 command line is not installed: neither in '
                    'the venv (make setup installs it from ../shared/ros2-tools) nor on PATH')
def test_ros2_interface_shows_the_commented_definitions(ws):
    shown = _sourced(ws, f'"{ROS2}" interface package {MSGS} && ' + ' && '.join(
        f'echo "=== {name}" && "{ROS2}" interface show {MSGS}/msg/{name}' for name in NAMES))
    assert shown.returncode == 0, shown.stdout + shown.stderr
    listing, *shows = shown.stdout.split('=== ')
    assert sorted(listing.split()) == [f'{MSGS}/msg/{name}' for name in NAMES]
    for name, text in zip(NAMES, shows):
        lines = text.splitlines()
        assert lines[0] == name
        source = (ROOT / MSGS / 'msg' / f'{name}.msg').read_text().splitlines()
        assert [line for line in source if line and line not in lines] == [], name
    state = shows[NAMES.index('FormationState')]
    assert 'float64 phase_rate            # rad/s' in state
    assert '\tbuiltin_interfaces/Time stamp' in state            # the header, expanded


def test_every_message_survives_a_serialization_round_trip(ws):
    done = _sourced(ws, f'"{sys.executable}" - {" ".join(NAMES)} <<\'EOF\'\n{ROUND_TRIP}\nEOF')
    assert done.returncode == 0, done.stdout + done.stderr
    got = json.loads(done.stdout.splitlines()[-1])
    assert sorted(got) == list(NAMES)
    for name, result in got.items():
        assert result['equal'] and result['differs'] and result['nan'], (name, result)
        assert result['version'] == result['constant'] == 1, (name, result)
