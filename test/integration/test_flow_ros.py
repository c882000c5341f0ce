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
The flow in the ROS nodes: lockstep runs equal the offline simulator.

Rigid bodies that estimate the flow from odometry and the plant's through-water velocity
(``/vehicle_k/water_velocity``), and particles in a vortex, told its local flow with each odometry
or estimating it; each vehicle's estimate is in its diagnostics and its formation_state, from which
the plant records it; a vehicle refuses consensus.
"""
from diagnostic_msgs.msg import DiagnosticArray
from formation_control.core.errors import ScenarioError
from formation_control.protocol import names
from formation_control.ros import interface as itf
from formation_control.sim import simulator
import numpy as np
import pytest
from rosutil import CONFIG
from runs import assert_equal_runs, offline_run


def test_lockstep_rigid_fleet_estimating_the_flow_equals_the_offline_simulator(nodes, tmp_path):
    cfg = CONFIG / 'rigid_parallel_flow.yaml'
    overrides = ['duration:=3.0', 'flow_source:=estimated']
    diags = nodes.collect(DiagnosticArray, names.DIAGNOSTICS_TOPIC, itf.STREAM_QOS)
    fleet = nodes.lockstep_run(cfg, tmp_path / 'run.npz', *overrides)
    offline = offline_run(cfg, overrides)
    assert_equal_runs(fleet, offline)
    assert_recorded_estimates(fleet, offline)
    vehicles = {n.k: n for n in nodes.nodes if hasattr(n, 'me')}
    estimates = [complex(vehicles[k].me.onboard.flow[0]) for k in sorted(vehicles)]
    np.testing.assert_allclose(estimates, offline.flow_hat[-1], atol=1e-9)
    assert abs(estimates[0] - offline.sc.flow_c) < 0.1          # learning it after 3 s

    def reported():
        """Return vehicle 1's latest links report (a report may predate its learning)."""
        for msg in reversed(diags):
            for status in msg.status:
                if status.name == 'formation_control/vehicle_1/links':
                    return {v.key: v.value for v in status.values}

    def current():
        last = reported()
        return last and abs(float(last['flow_hat_x']) - estimates[0].real) < 1e-5
    assert nodes.spin_until(current, timeout=10.0), reported()
    assert reported()['flow_source'] == 'estimated'
    assert abs(float(reported()['flow_hat_x']) - offline.sc.flow_c.real) < 0.2


@pytest.mark.parametrize('source', ['known', 'estimated'])
def test_lockstep_particles_in_a_vortex_equal_the_offline_simulator(nodes, tmp_path, source):
    """
    Told: the plant sends each vehicle its local flow with its odometry, which it pairs.

    Estimating: a particle needs no second sensor (its own velocity is e^{i theta}).
    """
    cfg = CONFIG / 'particle_circular.yaml'
    overrides = ['num_vehicles:=4', 'duration:=2.0', 'flow_model:=vortex',
                 'flow_circulation:=2.0', 'flow_radius:=2.0', f'flow_source:={source}']
    fleet = nodes.lockstep_run(cfg, tmp_path / 'run.npz', *overrides)
    offline = offline_run(cfg, overrides)
    assert_equal_runs(fleet, offline)
    assert np.ptp(abs(offline.flow_hat[-1])) > 0.01             # each vehicle its own flow
    assert isinstance(fleet, simulator.Run)
    if source == 'estimated':
        assert_recorded_estimates(fleet, offline)
    else:
        assert fleet.flow_hat is None                           # nothing to record


def assert_recorded_estimates(fleet, offline):
    """Check the plant's record holds each vehicle's estimate (its formation_state)."""
    assert fleet.flow_hat.shape == offline.flow_hat.shape
    heard = np.isfinite(fleet.flow_hat)
    assert heard[:-1].all()                            # the last states may come after the end
    np.testing.assert_allclose(fleet.flow_hat[heard], offline.flow_hat[heard], rtol=0,
                               atol=1e-9)


def test_a_vehicle_node_refuses_flow_consensus(nodes):
    with pytest.raises(ScenarioError, match="'flow_consensus' = 0.5 is invalid for a vehicle"):
        nodes.vehicle(1, CONFIG / 'particle_parallel_flow.yaml', 'flow_source:=estimated',
                      'flow_consensus:=0.5')
