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

"""The recorder finds formation_control_msgs' definitions in a venv without a ROS install."""
from pathlib import Path
import sys

from formation_control.bags import schemas
from formation_control.ros import bag
import pytest

VENV_SHARE = str(Path(sys.prefix) / 'share' / schemas.MSGS)


@pytest.mark.parametrize('prefix', [None, 'empty'], ids=['unset', 'without the package'])
def test_the_messages_share_is_the_venvs_when_the_ament_index_lacks_it(prefix, monkeypatch,
                                                                       tmp_path):
    if prefix is None:
        monkeypatch.delenv('AMENT_PREFIX_PATH', raising=False)
    else:
        monkeypatch.setenv('AMENT_PREFIX_PATH', str(tmp_path))
    assert bag.msgs_share() == VENV_SHARE
    assert {name for name, _ in schemas.msg_files(bag.msgs_share())} >= \
        {f'{schemas.MSGS}/msg/FormationState'}


def test_without_the_messages_anywhere_the_recorder_says_what_to_source(monkeypatch, tmp_path):
    monkeypatch.delenv('AMENT_PREFIX_PATH', raising=False)
    monkeypatch.setattr(bag.sys, 'prefix', str(tmp_path))
    with pytest.raises(bag.RecordError, match='source the ROS 2 workspace that built it'):
        bag.msgs_share()
