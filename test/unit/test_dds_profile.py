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

"""The fleet's Fast DDS profile: what it sets, where it goes, and when the user's wins."""
import os
from pathlib import Path
import xml.etree.ElementTree as ET

from formation_control.ops import dds_profile, security
import pytest

NS = {'p': 'http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles'}
SHIPPED = Path(__file__).resolve().parents[2] / 'config' / 'fastdds.xml'


def _heartbeat_s(text):
    """Return the default writer profile's heartbeat period (s) of a profile document."""
    (writer,) = [w for w in ET.fromstring(text).findall('p:data_writer', NS)
                 if w.get('is_default_profile') == 'true']
    period = writer.find('p:times/p:heartbeatPeriod', NS)
    return int(period.find('p:sec', NS).text) + 1e-9 * int(period.find('p:nanosec', NS).text)


def test_the_profile_sets_a_writers_heartbeats_and_nothing_else():
    """Every 0.1 s, none with each sample: a default writer profile alone, no transport."""
    root = ET.fromstring(dds_profile.profile_xml())
    assert [child.tag.split('}')[1] for child in root] == ['data_writer']
    (writer,) = root
    assert [child.tag.split('}')[1] for child in writer] == ['qos', 'times']
    assert writer.find('p:qos/p:disable_heartbeat_piggyback', NS).text == 'true'
    assert _heartbeat_s(dds_profile.profile_xml()) == pytest.approx(0.1)


def test_the_shipped_copy_for_ros2_run_is_the_profile():
    assert SHIPPED.read_text() == dds_profile.profile_xml()


def test_a_tls_members_profile_carries_the_same_writer_section():
    fleet = security.roster(2)
    text = security.profile_xml(fleet[1], fleet)
    assert _heartbeat_s(text) == pytest.approx(0.1)
    assert ET.fromstring(text).find('p:participant', NS) is not None


def test_the_fleet_env_writes_the_profile_once_and_names_it(tmp_path):
    env = dds_profile.fleet_env({'PATH': '/bin'}, tmp_path)
    assert env == {'FASTRTPS_DEFAULT_PROFILES_FILE': str(tmp_path / 'fastdds.xml')}
    assert (tmp_path / 'fastdds.xml').read_text() == dds_profile.profile_xml()
    assert dds_profile.fleet_env({}, tmp_path) == env


@pytest.mark.parametrize('name', dds_profile.PROFILE_VARIABLES)
def test_a_profile_the_user_names_is_theirs(tmp_path, name):
    assert dds_profile.fleet_env({name: '/etc/fleet/mine.xml'}, tmp_path) == {}
    assert not (tmp_path / 'fastdds.xml').exists()


def test_given_names_the_profile_within_and_restores_the_environment(tmp_path, monkeypatch):
    for name in dds_profile.PROFILE_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    with dds_profile.given(tmp_path):
        assert os.environ['FASTRTPS_DEFAULT_PROFILES_FILE'] == str(tmp_path / 'fastdds.xml')
    assert 'FASTRTPS_DEFAULT_PROFILES_FILE' not in os.environ
    with dds_profile.given(None):
        assert 'FASTRTPS_DEFAULT_PROFILES_FILE' not in os.environ
    monkeypatch.setenv('FASTDDS_DEFAULT_PROFILES_FILE', '/etc/fleet/mine.xml')
    with dds_profile.given(tmp_path):
        assert 'FASTRTPS_DEFAULT_PROFILES_FILE' not in os.environ
    assert os.environ['FASTDDS_DEFAULT_PROFILES_FILE'] == '/etc/fleet/mine.xml'
