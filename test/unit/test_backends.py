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

"""The plant backends chosen by name, and the vehicles' onboard step at any shape."""
from dataclasses import replace

from formation_control.core import scenario
from formation_control.core.models import Plant, rk4_step, ROW_OMEGA
from formation_control.core.world import World
from formation_control.sim import backends, simulator
from formation_control.sim.onboard import OnboardStep
import numpy as np
import pytest
from runs import CONFIG


@pytest.mark.parametrize('name, overrides, chosen', [
    ('rigid_circular', [], backends.Native),
    ('rigid_circular', ['gust_intensity:=0.05'], backends.NativeInWorld),
    ('first_order_circular', ['actuator_lag:=0.1'], backends.NativeInWorld),
    ('aircraft_circular', [], backends.JSBSim),
])
def test_the_backend_is_chosen_once_by_name_from_the_table(name, overrides, chosen):
    sc = scenario.load(CONFIG / f'{name}.yaml', overrides)
    assert backends.backend_of(sc) is chosen
    assert chosen in backends.BACKENDS.values()
    assert chosen.takes_demand == (sc.plant_backend == 'jsbsim')


def test_a_native_plant_refuses_an_autopilot_demand_naming_the_parameter():
    sc = scenario.load(CONFIG / 'particle_circular.yaml')
    stepper = simulator.Stepper(sc)
    with pytest.raises(ValueError, match="parameter 'plant_backend' = 'native'.*jsbsim"):
        stepper.backend.law_input(np.zeros(1), np.ones((2, 1)))


def test_the_native_first_order_plant_holds_the_turn_rate_in_the_state():
    sc = scenario.load(CONFIG / 'first_order_circular.yaml', ['num_vehicles:=3'])
    stepper = simulator.Stepper(sc)
    U = np.array([[0.0, 0.0, 0.0], [0.1, -0.2, 0.3]])
    stepper.hold(U)
    np.testing.assert_array_equal(stepper.X[ROW_OMEGA], U[1])


def test_the_world_with_its_nominal_vehicles_is_the_models_rk4_step_bit_for_bit():
    """World.step and models.rk4_step share one RK4 (models.rk4): no gust, unit factors."""
    sc = scenario.load(CONFIG / 'rigid_circular_flow.yaml', ['num_vehicles:=5'])
    sc = replace(sc, mismatch_m0=(1.0,) * 5)
    X, rng = scenario.initial_state(sc), np.random.default_rng(1)
    U = rng.uniform(-1, 1, (2, 5))
    plant, ours = Plant.of(sc), World(sc, (5,))
    for n in range(5):
        t = n * sc.dt_integration
        expected = rk4_step(X, U, sc.dt_integration, plant, t)
        X = ours.step(X, U, t)
        np.testing.assert_array_equal(X, expected)


@pytest.mark.parametrize('name', ['rigid_circular_flow_center', 'particle_parallel_flow'])
def test_the_onboard_step_of_a_batch_equals_each_fleet_alone(name):
    """One step for (B, N) vehicles commands as B steps of (N,): the shape is only the batch."""
    sc = scenario.load(CONFIG / f'{name}.yaml', ['num_vehicles:=4', 'informed:=[1, 3]'])
    X = simulator.initial_states(sc, [1, 2, 3])
    batch = OnboardStep(sc, (3, 4))
    alone = [OnboardStep(sc, (4,)) for _ in range(3)]
    for _ in range(3):
        flow = complex(sc.flow_c)
        U = batch.command(batch.observe(X, flow))
        for b, step in enumerate(alone):
            np.testing.assert_allclose(step.command(step.observe(X[:, b], flow)), U[:, b],
                                       rtol=0, atol=1e-12)
        X = X + 0.01 * np.cos(X)
    np.testing.assert_array_equal(batch.U, U)
