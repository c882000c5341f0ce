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
The fleet's Fast DDS profile: a reliable writer announces its samples every 0.1 s, not with each.

A reliable reader delivers in order: a sample it missed holds back every later one until the
writer's next heartbeat lets it ask for that sample again (or learn that it is gone). Fast
DDS's default period is 3 s, and a lockstep plant that waits for a vehicle sends that vehicle
little else: a vehicle process paused for a second (SIGSTOP, a starved core) heard no odometry
for 2-3 s after it resumed, and a sample lost on a radio link stalls a lockstep step as long
(docs/reliability.md). The heartbeat Fast DDS sends with each sample once a writer's history
is full (every sample of a keep-last writer after its first ten) is left out: each one made
every reader answer with an acknowledgement, a wake-up of two processes per sample
(docs/benchmarks.md, section 6); the periodic heartbeat bounds a repair at 0.1 s. Only the
writers' heartbeats are set: transports, discovery and the ROS QoS policies stay the
middleware's and the nodes' own.

The swarm and the launch files give this profile to the fleet's processes unless the user
names a profile of their own; ``config/fastdds.xml`` is a copy for ``ros2 run``, and a TLS
fleet's member profiles carry the same writer section (:mod:`formation_control.ops.security`).
"""
from contextlib import contextmanager
import os
from pathlib import Path

HEARTBEAT_PERIOD_NS = 100_000_000
"""A reliable writer's periodic heartbeat (ns); Fast DDS's default is 3 s."""

PROFILE_VARIABLES = ('FASTRTPS_DEFAULT_PROFILES_FILE', 'FASTDDS_DEFAULT_PROFILES_FILE')
"""A profile the user names in either of these is theirs: the fleet's is not imposed."""

FILE = 'fastdds.xml'

WRITER_SECTION = (
    '  <data_writer profile_name="formation_control_writer" is_default_profile="true">\n'
    '    <qos><disable_heartbeat_piggyback>true</disable_heartbeat_piggyback></qos>\n'
    '    <times>\n'
    f'      <heartbeatPeriod><sec>0</sec><nanosec>{HEARTBEAT_PERIOD_NS}</nanosec>'
    '</heartbeatPeriod>\n'
    '    </times>\n'
    '  </data_writer>\n')
"""The default writer profile of every fleet profile, TLS members' included."""


def profile_xml():
    """Return the fleet's Fast DDS XML profile: :data:`WRITER_SECTION` alone."""
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            '<!-- formation_control: reliable writers heartbeat every 0.1 s, not with each sample '
            '(docs/reliability.md) -->\n'
            '<profiles xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">\n'
            f'{WRITER_SECTION}</profiles>\n')


def names_a_profile(env):
    """Whether the environment ``env`` (a mapping) names a Fast DDS profile of its own."""
    return any(env.get(name) for name in PROFILE_VARIABLES)


def fleet_env(base, directory):
    """
    Return the variables that give a process the fleet's profile, written in ``directory``.

    Empty when ``base`` (the processes' environment) names a profile of its own.
    """
    if names_a_profile(base):
        return {}
    path = Path(directory).absolute() / FILE
    if not path.is_file():
        path.write_text(profile_xml())
    return {'FASTRTPS_DEFAULT_PROFILES_FILE': str(path)}


@contextmanager
def given(directory):
    """
    Name the fleet's profile (written in ``directory``) in this process's environment, within.

    For the participant made within: Fast DDS reads the profile once, at a process's first
    participant. Nothing changes with ``directory`` None or a profile named already.
    """
    added = {} if directory is None else fleet_env(os.environ, directory)
    os.environ.update(added)
    try:
        yield
    finally:
        for name in added:
            os.environ.pop(name, None)
