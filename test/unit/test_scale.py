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
Metrics at scale: the minimum separation equals the all-pairs minimum in O(N) memory.

And ``formation-control sim`` of a large fleet stays within a bounded memory, and so does the
monitor's sample (its hearing graph and lambda_2).
"""
import os
from pathlib import Path
import re
import subprocess
import sys
import tracemalloc

from formation_control.core import graphs
from formation_control.core.control import Controller
from formation_control.core.scenario import initial_state, load
from formation_control.protocol import watch
from formation_control.sim import metrics, simulator
import numpy as np
import pytest

CLI = Path(sys.executable).parent / 'formation-control'
CONFIG = Path(__file__).resolve().parents[2] / 'config'
SIZES = [1, 2, 3, 7, 8, 9, 16, 17, 33, 100, 257]
PEAK_BYTES_PER_VEHICLE = 400         # min_separation: a few (N,) arrays, not N^2
SIM_N = 20_000
SIM_PEAK_RSS = 1 << 29               # bytes (it takes ~110 MB); all pairs of one sample: 6.4 GB
MONITOR_PEAK_BYTES_PER_VEHICLE = 4000   # a (N, N) bool hearing table alone: 20 000 per vehicle


def all_pairs(r):
    """Return the smallest distance over every pair j != k (the definition), or nan."""
    n = r.shape[-1]
    if n < 2:
        return np.full(r.shape[:-1], np.nan)[()]
    d = abs(r[..., :, None] - r[..., None, :])
    d[..., np.arange(n), np.arange(n)] = np.inf
    return d.min(axis=(-2, -1))


def positions(kind, shape, rng):
    """Return fleets of the given shape (complex, m): spread, a lattice, few columns, a ring."""
    if kind == 'normal':
        return rng.normal(size=shape) + 1j * rng.normal(size=shape)
    if kind == 'lattice':      # ties between pairs and coincident vehicles
        return (rng.integers(0, 5, shape) + 1j * rng.integers(0, 5, shape)) * 0.25
    if kind == 'columns':      # many equal x
        return rng.integers(0, 3, shape) * 1.0 + 1j * rng.normal(size=shape)
    return np.broadcast_to(3.0 * np.exp(2j * np.pi * np.arange(shape[-1]) / shape[-1]), shape)


@pytest.mark.parametrize('kind', ['normal', 'lattice', 'columns', 'ring'])
@pytest.mark.parametrize('n', SIZES)
def test_min_separation_equals_the_all_pairs_minimum_bit_for_bit(kind, n):
    rng = np.random.default_rng(n)
    for shape in [(n,), (4, n), (2, 3, n)]:
        r = positions(kind, shape, rng)
        got = metrics.min_separation(r)
        assert np.shape(got) == shape[:-1]
        np.testing.assert_array_equal(got, all_pairs(r))


def test_min_separation_of_one_two_and_coincident_vehicles():
    assert np.isnan(metrics.min_separation(np.array([1 + 1j])))
    assert metrics.min_separation(np.array([0j, 3 + 4j])) == 5.0
    r = np.array([0j, 1.0, 5 + 5j, 1.0, 2j])
    assert metrics.min_separation(r) == 0.0
    np.testing.assert_array_equal(metrics.min_separation(np.array([[0j, 1.0], [2j, 2j]])),
                                  [1.0, 0.0])


def test_min_separation_needs_memory_linear_in_the_fleet():
    r = positions('normal', (SIM_N,), np.random.default_rng(0))
    tracemalloc.start()
    try:
        value = metrics.min_separation(r)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert value > 0
    assert peak < PEAK_BYTES_PER_VEHICLE * SIM_N


def test_snapshot_without_separation_is_otherwise_the_same():
    sc = load(CONFIG / 'particle_circular_splay.yaml', ['num_vehicles:=6'])
    ctrl, X = Controller(sc), initial_state(sc)
    U = np.zeros((2, 6))
    full = metrics.snapshot(ctrl, X, U).values()
    lean = metrics.snapshot(ctrl, X, U, separation=False).values()
    assert full.pop('min_separation') == all_pairs(ctrl.view(X).r)
    assert lean == full


def test_summary_and_outcome_keep_their_figures():
    sc = load(CONFIG / 'particle_circular.yaml', ['num_vehicles:=5', 'duration:=4.0'])
    run = simulator.simulate(sc)
    out = simulator.simulate(sc, simulator.initial_states(sc, [sc.seed]),
                             simulator.Outcome(sc))
    assert out.final.min_separation[0] == all_pairs(run.X[-1, 0] + 1j * run.X[-1, 1])
    assert simulator.summary(run)['converged'] == bool(out.flags[-1, 0])


@pytest.mark.slow
def test_sim_of_a_large_fleet_stays_within_bounded_memory(tmp_path):
    """
    20 000 rigid bodies: memory O(N + C), C the pairs that come within d_min of each other.

    The fleet starts packed, 200 to the square metre: at its own d_min (1 m, the vehicles'
    size) C is 8 million pairs, each one's closest approach computed; d_min 1 cm keeps C in
    the hundreds of thousands, and the separation verdict is still computed and printed.
    """
    env = dict(os.environ, OPENBLAS_NUM_THREADS='1', MPLBACKEND='Agg')
    log = tmp_path / 'out.txt'
    with open(log, 'w') as stream:
        proc = subprocess.Popen(
            [str(CLI), 'sim', str(CONFIG / 'rigid_circular_flow.yaml'),
             '-p', f'num_vehicles:={SIM_N}', '-p', 'record_dt:=0.1', '-p', 'd_min:=0.01',
             '--duration', '0.2'],
            stdout=stream, stderr=subprocess.STDOUT, env=env)
        _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    text = log.read_text()
    assert proc.returncode == 0, text
    assert f'{SIM_N} vehicles' in text and 'min_separation' in text
    assert re.search(r'\n +separation +(kept apart|no): closest ', text), text
    assert usage.ru_maxrss * 1024 < SIM_PEAK_RSS


def test_the_monitors_sample_of_a_large_fleet_needs_memory_linear_in_the_fleet():
    """A ring of 20 000 with links unheard: the live links, lambda_2 (large: NaN, or 0 split)."""
    sc = load(CONFIG / 'particle_circular_ring.yaml', [f'num_vehicles:={SIM_N}'])
    X = initial_state(sc)
    tracemalloc.start()
    try:
        w = watch.Watch(sc, '/', 0.0, stale_timeout=2.0, converge_within=60.0, trail_length=10,
                        clock=lambda: 0.0)
        for k in range(1, SIM_N + 1):
            w.state(k, {})
        w.state(2, {1: False})
        due = [w.odom(k, X[:, k - 1], 0) for k in range(1, SIM_N + 1)]
        path, _ = w.sample(0)
        w.state(SIM_N // 2, {SIM_N // 2 + 1: False})
        w.state(SIM_N // 2, {SIM_N // 2 + 1: True})
        w.state(100, {101: False})
        split, _ = w.sample(0)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert due[-1] and not any(due[:-1])
    assert path['live_links'] == SIM_N - 1 and np.isnan(path['algebraic_connectivity'])
    assert split['live_links'] == SIM_N - 2 and split['algebraic_connectivity'] == 0.0
    assert peak < MONITOR_PEAK_BYTES_PER_VEHICLE * SIM_N


def test_connectivity_past_the_dense_size_tells_a_split_graph():
    n = graphs.CONNECTIVITY_DENSE_MAX + 10
    ring = graphs.build(n, 'ring')
    everyone = np.ones(n, bool)
    assert np.isnan(graphs.connectivity(everyone, ring.edges))
    two_paths = graphs.live_edges(ring, everyone, {(0, 1), (n // 2, n // 2 + 1)})
    assert len(two_paths) == n - 2
    assert graphs.connectivity(everyone, two_paths) == 0.0
    small = graphs.build(12, 'ring')
    assert graphs.connectivity(np.ones(12, bool), small.edges) == pytest.approx(
        2.0 * (1.0 - np.cos(2.0 * np.pi / 12)))
