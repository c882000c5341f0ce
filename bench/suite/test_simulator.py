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

"""The offline simulator, one core: a period, the batch path, the law of one vehicle, a metric."""
from formation_control.core import laws
from formation_control.core.control import Controller
from formation_control.core.scenario import initial_state
from formation_control.sim import metrics, simulator
import numpy as np
import pytest

pytestmark = pytest.mark.usefixtures('one_core')
SCENARIOS = ('rigid_circular_flow', 'particle_circular')


@pytest.mark.parametrize('n', [1_000, 100_000])
@pytest.mark.parametrize('name', SCENARIOS)
def test_control_period(benchmark, load, name, n):
    """One control period of a fleet of n: every command, then the RK4 steps it is held."""
    stepper = simulator.Stepper(load(name, n))

    def period():
        stepper.command()
        stepper.advance()
    benchmark.pedantic(period, rounds=7 if n > 10_000 else 50, warmup_rounds=1)
    assert np.all(np.isfinite(stepper.X))


def test_batch_path(benchmark, load):
    """The sweeps' batch path: 20 000 fleets of 5 through 0.2 s of rigid_circular."""
    sc = load('rigid_circular', 5, 'duration:=0.2')
    X0 = simulator.initial_states(sc, range(20_000))
    out = benchmark.pedantic(simulator.simulate, (sc, X0, simulator.Outcome(sc)), rounds=5)
    assert np.all(np.isfinite(out.X))


@pytest.mark.parametrize('name', ['rigid_circular', 'rigid_circular_flow'])
def test_law_of_one_vehicle(benchmark, load, name):
    """One vehicle's command from its own state and the views of its 15 neighbours."""
    sc = load(name, 16)
    ctrl = Controller(sc)
    X = initial_state(sc)
    fleet = ctrl.view(X)
    own = X[:, [0]]
    members = np.ones(16, bool)

    def step():
        mine = ctrl.view(own, np.zeros(1))
        view = laws.View(fleet.r, fleet.phase, fleet.rate, fleet.speed, fleet.speed_dot)
        view.speed_dot[0] = mine.speed_dot[0]
        return ctrl.command(view, own, [0], members=members)
    assert np.all(np.isfinite(benchmark(step)))


def test_min_separation(benchmark, load):
    """The minimum separation of 100 000 vehicles."""
    X = initial_state(load('rigid_circular_flow', 100_000))
    d = benchmark.pedantic(metrics.min_separation, (X[0] + 1j * X[1],), rounds=7)
    assert d > 0
