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

"""Whole commands as a user runs them: ``sim``, and a lockstep ``swarm`` of real nodes."""
import json
import os
from pathlib import Path
import subprocess
import sys

import pytest

CLI = Path(sys.executable).parent / 'formation-control'


def run(*args):
    subprocess.run([str(CLI), *args], check=True, capture_output=True, text=True,
                   env=dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST'), timeout=600)


def test_sim_command(benchmark):
    """``formation-control sim rigid_circular_flow`` at N = 20 000 for 0.4 s, summary included."""
    benchmark.pedantic(run, ('sim', 'rigid_circular_flow', '-p', 'num_vehicles:=20000',
                             '--duration', '0.4'), rounds=3)


@pytest.mark.parametrize('per_process', [1, 'auto'])
def test_lockstep_swarm(benchmark, tmp_path, per_process):
    """A lockstep swarm of 16 on a ring, 2 s of fleet time, no monitor, start-up included."""
    summary = tmp_path / 'summary.json'

    def swarm():
        run('swarm', 'rigid_circular', '-p', 'num_vehicles:=16', '-p', 'graph:=ring',
            '--duration', '2', '--no-monitor', '--vehicles-per-process', str(per_process),
            '--summary', str(summary))
    benchmark.pedantic(swarm, rounds=3)
    factor = json.loads(summary.read_text())['real_time_factor']
    benchmark.extra_info['real_time_factor'] = factor
    assert factor > 0
