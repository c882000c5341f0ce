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
The world a real fleet meets in the ROS nodes: lockstep runs equal the offline simulator.

With model mismatch, lagging and rate-limited actuators and gusts on (same seeds), and with the
sensors of core/sensors.py (noise, bias, a fix rate below the step rate, latency): the plant node
integrates the true vehicles of core/world.py and samples their sensors with the same
per-vehicle streams as the simulator; a rigid body told the flow reads the gust it is not told
in its water speed, an estimating one measures it in its flow (with its DVL's noise and bias);
particles in a vortex are told the flowfield only; an estimating rigid body with the position
filter feeds its flow estimator the filter's velocities.

The liveness timeouts are lifted: in lockstep a neighbour that has not answered a step within
``neighbor_timeout`` wall seconds (default 1 s) leaves the sums of that step's command, and a
vehicle silent for ``command_timeout`` gets a zero command. On a loaded machine a step can take
that long, and the run then differs from the simulator by a wall-clock event (once 2e-4), not
by a sample or a draw: the sensors are drawn per step index and seed.
"""
from formation_control.core import world
import numpy as np
import pytest
from rosutil import CONFIG
from runs import assert_equal_runs, offline_run

WORLD = ('mismatch:=0.02', 'actuator_lag:=0.05', 'max_steering_rate:=40.0',
         'gust_intensity:=0.05', 'gust_time:=2.0', 'world_seed:=3')
EXACT = ('neighbor_timeout:=60.0', 'command_timeout:=120.0')
SENSORS = ('gnss_sigma:=0.3', 'gnss_rate:=10.0', 'heading_sigma:=0.01', 'heading_bias:=0.02',
           'yaw_rate_sigma:=0.02', 'velocity_sigma:=0.02', 'water_sigma:=0.01',
           'water_bias:=0.01', 'sensor_latency:=0.04')


@pytest.mark.parametrize('name, extra', [
    ('rigid_circular', ()),
    ('rigid_circular', ('position_filter:=kalman', *SENSORS)),
    ('rigid_parallel_flow', ('flow_source:=estimated', *SENSORS)),
    ('rigid_parallel_flow', ('flow_source:=estimated', 'position_filter:=kalman',
                             'flow_gain_from_noise:=true', *SENSORS)),
    ('rigid_parallel_flow', ('flow_source:=estimated', 'max_thrust_rate:=20.0')),
    ('particle_circular', ('num_vehicles:=4', 'flow_model:=vortex', 'flow_circulation:=2.0',
                           'flow_radius:=2.0', *SENSORS)),
])
def test_lockstep_fleet_in_the_world_equals_the_offline_simulator(nodes, tmp_path, name, extra):
    cfg = CONFIG / f'{name}.yaml'
    overrides = ['duration:=3.0', *WORLD, *extra]
    fleet = nodes.lockstep_run(cfg, tmp_path / 'run.npz', *overrides, *EXACT)
    offline = offline_run(cfg, overrides)
    assert world.active(offline.sc)
    assert_equal_runs(fleet, offline)
    nominal = offline_run(cfg, ['duration:=3.0', *extra])
    assert np.max(abs(offline.X[-1, :2] - nominal.X[-1, :2])) > 1e-3     # the world acted
