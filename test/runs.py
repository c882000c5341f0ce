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

"""Simulated runs of the shipped scenarios, cached so that several tests share one run."""
from functools import lru_cache
from pathlib import Path

from formation_control.core import scenario
from formation_control.core.control import Controller
from formation_control.sim import simulator
import numpy as np

CONFIG = Path(__file__).resolve().parents[1] / 'config'
SEEDS = (1, 2, 3)
DURATIONS = {
    'rigid_parallel': 20.0, 'rigid_parallel_cop': 20.0, 'rigid_parallel_flow': 20.0,
    'rigid_circular': 60.0, 'rigid_circular_flow': 120.0,
    'particle_circular': 60.0, 'particle_circular_flow': 75.0, 'first_order_circular': 50.0,
    'particle_parallel': 30.0, 'particle_parallel_flow': 30.0,
    'particle_parallel_proportional': 30.0, 'first_order_parallel': 30.0,
}
"""
Simulated seconds the tests run a scenario for, where shorter than its file's ``duration`` (the
thesis figure's): at least 1.5 times the shortest run every test of it passes on (measured on
the prefixes of the full runs, which a shorter run equals: 10, 10, 10, 40, 75, 40, 50, 30, 15,
15, 15, 15 s). rigid_circular_center and rigid_circular_flow_center need their 150 s.
"""

SOURCES = {'known': (), 'estimated': ('flow_source:=estimated',)}
"""The overrides of a flow source: told the flow (the scenario's default) or estimating it."""


@lru_cache(maxsize=None)
def run_of(name, seed, overrides=()):
    sc = scenario.load(CONFIG / f'{name}.yaml', overrides, seed=seed,
                       duration=DURATIONS.get(name))
    return simulator.simulate(sc)


def assert_equal_runs(fleet, offline, atol=1e-6):
    """Assert that a fleet's record equals the offline simulator's run of the same scenario."""
    assert fleet.t.shape == offline.t.shape
    np.testing.assert_allclose(fleet.t, offline.t)
    np.testing.assert_allclose(fleet.X, offline.X, rtol=0, atol=atol)
    np.testing.assert_allclose(fleet.U, offline.U, rtol=0, atol=atol)


def offline_run(cfg, overrides=()):
    """Return the offline simulator's run of the scenario file ``cfg`` with ``overrides``."""
    return simulator.simulate(scenario.load(cfg, list(overrides)))


def views(run):
    """Return the controller and its particle view at every recorded instant."""
    ctrl = Controller(run.sc)
    return ctrl, [ctrl.view(X, U[1]) for X, U in zip(run.X, run.U)]
