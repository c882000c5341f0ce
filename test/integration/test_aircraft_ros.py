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
JSBSim aircraft in the ROS nodes: the plant flies them, lockstep equals the offline simulator.

The plant node integrates each vehicle with its own FGFDMExec (plant_backend: jsbsim); each
vehicle node commands from its odometry in the map frame, and the plant's autopilot turns the
command into the turn-rate demand the offline simulator holds.
"""
import numpy as np
import pytest
from rosutil import CONFIG
from runs import assert_equal_runs, offline_run

pytest.importorskip('jsbsim')


@pytest.mark.parametrize('cfg', ['aircraft_circular', 'aircraft_parallel'])
def test_lockstep_aircraft_equal_the_offline_simulator(nodes, tmp_path, cfg):
    cfg = CONFIG / f'{cfg}.yaml'
    overrides = ['num_vehicles:=3', 'duration:=2.0']
    fleet = nodes.lockstep_run(cfg, tmp_path / 'run.npz', *overrides)
    offline = offline_run(cfg, overrides)
    assert_equal_runs(fleet, offline)
    for name in ('altitude', 'bank', 'turn_rate_demand'):
        np.testing.assert_allclose(fleet.channels[name], offline.channels[name], rtol=0,
                                   atol=1e-6)
    assert np.ptp(offline.X[:, 2]) > 0.01                        # they turned
