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
The tracked benchmarks: ``make bench`` runs them, ``make bench-compare BASE=<rev>`` compares.

They measure the code of whichever ``formation_control`` is imported (``PYTHONPATH`` chooses),
with the scenario files of that tree, so the same definitions time a base commit and the work
tree alike (tools/bench_compare.py).
"""
import os
from pathlib import Path

import formation_control
from formation_control.core import scenario
import pytest

CONFIG = Path(formation_control.__file__).resolve().parents[1] / 'config'


def pytest_report_header():
    """Name the tree whose code is timed."""
    return f'formation_control timed: {Path(formation_control.__file__).parent}'


@pytest.fixture
def load():
    """Return a loader of the scenario file ``name`` with ``num_vehicles`` overridden."""
    def loaded(name, n, *overrides):
        return scenario.load(CONFIG / f'{name}.yaml', [f'num_vehicles:={n}', *overrides])
    return loaded


@pytest.fixture
def one_core():
    """Run the benchmark pinned to one core (as bench/sim_throughput.py), then restore."""
    cores = os.sched_getaffinity(0)
    os.sched_setaffinity(0, {min(cores)})
    yield
    os.sched_setaffinity(0, cores)
