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
The Laplacian laws on communication graphs, re-derived in tests.

The complete graph with nu = N is the all-to-all law; on rings and random graphs the analytic
phi' equals a finite difference along trajectories, sigma equals -dV/dphase, V_c never
increases, and the fleets converge; a fleet converges while its graph switches.
"""
from dataclasses import replace

from formation_control.core import graphs, laws
from formation_control.core.control import Controller
from formation_control.core.errors import ScenarioError
from formation_control.core.models import rk4_step
from formation_control.core.scenario import load, resolve
from formation_control.sim import metrics, simulator
from formation_control.sim.simulator import Stepper
import numpy as np
import pytest
from runs import CONFIG
from test_laws import _trajectory_states, check_phi_dot_rigid, H, PARTICLE_CASES, RIGID_CASES

GRAPHS = [{'graph': 'ring'}, {'graph': 'random', 'graph_degree': 3, 'graph_seed': 5},
          {'graph': 'circulant', 'graph_offsets': [1, 3]}]


def _random_seed(graph, seed):
    """Return the graph_seed a random graph reads (other graphs read none)."""
    return {'graph_seed': seed} if graph.get('graph') == 'random' else {}


def _sc(case, graph, n=8, **kw):
    params = {'num_vehicles': n, 'model': 'second_order', 'controller': 'backstepping',
              'seed': 3, 'duration': 20.0}
    params.update(case, **graph, **kw)
    if 'model' in case and case['model'] != 'second_order':
        params.pop('controller') if 'controller' not in case else None
    return resolve(params)


@pytest.mark.parametrize('case', PARTICLE_CASES + RIGID_CASES, ids=str)
def test_complete_graph_with_nu_n_is_the_all_to_all_law(case):
    base = _sc(case, {}, n=6)
    graph = _sc(case, {'graph': 'complete', 'graph_nu': 6.0}, n=6)
    assert base.all_to_all and not graph.all_to_all
    a, b = Controller(base), Controller(graph)
    for X, U in _trajectory_states(base, times=(0.0, 1.3)):
        va, vb = a.view(X, U[1]), b.view(X, U[1])
        ta, tb = a.formation.terms(va), b.formation.terms(vb)
        for name in ('phi', 'phi_dot', 'sigma'):
            np.testing.assert_allclose(getattr(tb, name), getattr(ta, name), rtol=0,
                                       atol=1e-12, err_msg=name)
        assert b.formation.potential(vb) == pytest.approx(a.formation.potential(va), abs=1e-12)
        np.testing.assert_allclose(b.command(vb, X), a.command(va, X), rtol=0, atol=1e-10)


@pytest.mark.parametrize('graph', GRAPHS, ids=str)
@pytest.mark.parametrize('case', PARTICLE_CASES, ids=str)
def test_phi_dot_matches_finite_difference_on_graphs(case, graph):
    sc = _sc(case, graph)
    ctrl = Controller(sc)
    assert ctrl.formation.coupling is not None
    for X, U in _trajectory_states(sc):
        def phi_at(Xs):
            return ctrl.formation.terms(ctrl.view(Xs, U[1])).phi
        fd = (phi_at(rk4_step(X, U, H, ctrl.plant))
              - phi_at(rk4_step(X, U, -H, ctrl.plant))) / (2 * H)
        analytic = ctrl.formation.terms(ctrl.view(X, U[1])).phi_dot
        np.testing.assert_allclose(analytic, fd, atol=1e-6 * (1 + np.max(abs(fd))))


@pytest.mark.parametrize('graph', GRAPHS[:2], ids=str)
@pytest.mark.parametrize('case', RIGID_CASES, ids=str)
def test_phi_dot_matches_finite_difference_on_graphs_rigid(case, graph):
    check_phi_dot_rigid(_sc(case, graph, n=7, seed=4))


@pytest.mark.parametrize('graph', GRAPHS, ids=str)
@pytest.mark.parametrize('case', PARTICLE_CASES[:4], ids=str)
def test_sigma_is_minus_the_gradient_of_the_potential(case, graph):
    sc = _sc(case, graph)
    ctrl = Controller(sc)
    view = ctrl.view(*_trajectory_states(sc, times=(0.5,))[0][:1])
    sigma = ctrl.formation.terms(view).sigma
    h = 1e-6
    for k in range(sc.num_vehicles):
        def potential(dphase):
            phase = view.phase.copy()
            phase[k] += dphase
            return ctrl.formation.potential(replace(view, phase=phase))
        assert sigma[k] == pytest.approx(-(potential(h) - potential(-h)) / (2 * h), abs=1e-7)


@pytest.mark.slow
@pytest.mark.parametrize('graph', GRAPHS, ids=str)
@pytest.mark.parametrize('case', PARTICLE_CASES[:4], ids=str)
def test_composite_lyapunov_never_increases_on_a_fixed_graph(case, graph):
    sc = _sc(case, graph, dt_control=0.002, dt_integration=0.002, duration=6.0)
    st = Stepper(sc)
    v = []
    for _ in range(sc.periods):
        st.command()
        v.append(laws.composite_lyapunov(st.ctrl.formation, st.ctrl.view(st.X, st.U[1])))
        st.advance()
    v = np.array(v)
    assert v[-1] < 0.7 * v[0]
    assert np.max(np.diff(v)) <= 1e-6 * v[0]


def test_a_vehicle_hearing_its_ring_neighbours_commands_as_the_fleet_does():
    """The law restricted to a vehicle and its two neighbours equals its row of the fleet's."""
    sc = _sc({'formation': 'circular', 'informed': [3], 'c0': [1.0, 0.0]}, {'graph': 'ring'})
    ctrl = Controller(sc)
    X = _trajectory_states(sc, times=(1.0,))[0][0]
    fleet = ctrl.command(ctrl.view(X), X)
    for k in range(1, 9):
        members = np.zeros(8, bool)
        members[[j - 1 for j in sc.comm_graph.neighbours(k)] + [k - 1]] = True
        own = int(np.count_nonzero(members[:k - 1]))
        U = Controller(sc).command(ctrl.view(X[:, members]), X[:, [k - 1]], [own],
                                   members=members)
        np.testing.assert_allclose(U[:, 0], fleet[:, k - 1], rtol=0, atol=1e-12)


def _converged_from(name, seeds, **overrides):
    out = []
    for seed in seeds:
        sc = load(CONFIG / f'{name}.yaml', [f'{k}:={v}' for k, v in overrides.items()],
                  seed=seed)
        out.append(simulator.summary(simulator.simulate(sc)))
    return out


@pytest.mark.slow
@pytest.mark.parametrize('name, graph', [
    ('particle_circular_ring', {}), ('rigid_circular_ring', {}),
    ('particle_circular_ring', {'graph': 'random', 'graph_degree': 4})])
def test_circular_fleets_converge_on_rings_and_random_graphs(name, graph):
    for seed in (1, 2, 3):
        for s in _converged_from(name, (seed,), **graph, **_random_seed(graph, seed)):
            assert s['converged'], s
            assert s['centre_spread'] < 1e-2
            assert s['radius'] == pytest.approx(s['radius_target'], rel=1e-2)


@pytest.mark.slow
@pytest.mark.parametrize('graph, seed', [({}, 1), ({'graph': 'random', 'graph_degree': 3}, 2)],
                         ids=str)
def test_rigid_circle_on_a_graph_moves_onto_the_centre_two_vehicles_know(graph, seed):
    sc = load(CONFIG / 'rigid_circular_ring.yaml',
              [f'{k}:={v}' for k, v in dict(graph, **_random_seed(graph, seed), informed=[2, 6],
                                            c0=[1.0, -1.0]).items()], seed=seed)
    run = simulator.simulate(sc)
    snap = metrics.snapshot(Controller(sc), run.X[-1], run.U[-1])
    assert simulator.summary(run)['converged']
    assert abs(snap.centre - (1.0 - 1.0j)) < 1e-2


@pytest.mark.slow
def test_parallel_fleets_converge_on_random_connected_graphs():
    for s in _converged_from('particle_parallel_random', (1, 2, 3)):
        assert s['converged'], s
        assert s['order_parameter'] > 0.999


@pytest.mark.slow
def test_a_fleet_converges_while_its_graph_switches_between_connected_graphs():
    """Every 2 s the fleet switches between a ring and a random connected graph."""
    sc = load(CONFIG / 'particle_circular_ring.yaml', ['duration:=60'], seed=4)
    other = replace(sc, graph='random', graph_degree=3.0, graph_seed=9)
    ctrls = [Controller(sc), Controller(other)]
    assert not np.array_equal(sc.comm_graph.edges, other.comm_graph.edges)
    st = Stepper(sc)
    periods_per_switch = int(round(2.0 / sc.dt_control))
    for n in range(sc.periods):
        st.vehicles.ctrl = ctrls[(n // periods_per_switch) % 2]
        st.command()
        st.advance()
    snap = metrics.snapshot(ctrls[0], st.X, st.U)
    assert metrics.converged(sc, snap), snap


@pytest.mark.parametrize('params, message', [
    ({'graph': 'explicit', 'graph_edges': [1, 2, 3, 4]}, r"'graph_edges' .* is not connected"),
    ({'graph': 'explicit', 'graph_edges': [1, 2, 2, 1, 2, 3, 3, 4]},
     r"'graph_edges' .* more than once \(edges are undirected"),
    ({'graph': 'explicit', 'graph_edges': [1, 9, 1, 2]}, r"'graph_edges' .* ids must lie in 1"),
    ({'graph': 'explicit', 'graph_edges': [2, 2, 1, 2, 2, 3, 3, 4]}, r"'graph_edges' .* self"),
    ({'graph': 'circulant', 'graph_offsets': [2]}, r"'graph_offsets' = \[2\] is invalid"),
    ({'graph': 'circulant', 'graph_offsets': [1.5]},
     r"'graph_offsets' = \[1.5\] is invalid: must be a list of integers"),
    ({'graph': 'mesh'}, r"'graph' = 'mesh' is invalid: allowed values: complete \| ring"),
    ({'graph_nu': -2.0}, r"'graph_nu' = -2.0 is invalid: must be >= 0"),
])
def test_bad_graphs_fail_before_anything_runs(params, message):
    with pytest.raises(ScenarioError, match=message):
        resolve(dict(num_vehicles=4, **params))


def test_a_graph_is_refused_with_the_reason_it_must_be_undirected():
    with pytest.raises(graphs.GraphError, match='a one-way'):
        graphs.build(4, 'explicit', edges=[1, 2, 2, 1, 2, 3, 3, 4])


@pytest.mark.slow
def test_the_plot_draws_the_communication_graph(tmp_path):
    from formation_control.sim.plotting import plot_run
    sc = load(CONFIG / 'particle_circular_ring.yaml', ['duration:=1.0'])
    run = simulator.simulate(sc)
    links = plot_run(run, tmp_path / 'ring.png')['links']
    assert (tmp_path / 'ring.png').stat().st_size > 0
    assert links.shape == (sc.num_vehicles, 2)
    r = run.X[-1, 0] + 1j * run.X[-1, 1]
    np.testing.assert_array_equal(links, r[sc.comm_graph.edges])
    complete = simulator.simulate(load(CONFIG / 'particle_circular.yaml', ['duration:=0.1']))
    assert plot_run(complete, tmp_path / 'all.png')['links'].size == 0


@pytest.mark.slow
def test_a_parallel_ring_has_a_stable_twisted_state():
    """Documented pitfall: phases winding once around a ring of 12 are a stable equilibrium."""
    n = 12
    rng = np.random.default_rng(1)
    theta = 2 * np.pi * np.arange(n) / n + 0.05 * rng.standard_normal(n)
    sc = resolve({'num_vehicles': n, 'model': 'second_order', 'formation': 'parallel',
                  'graph': 'ring', 'duration': 60.0, 'init_theta': theta.tolist()})
    run = simulator.simulate(sc)
    final = metrics.snapshot(Controller(sc), run.X[-1], run.U[-1])
    assert final.order < 1e-2 and final.max_rate < 1e-3      # still, but not synchronised
    steps = np.angle(np.exp(1j * np.diff(np.append(run.X[-1, 2], run.X[-1, 2, 0]))))
    np.testing.assert_allclose(steps, 2 * np.pi / n, atol=1e-3)


@pytest.mark.slow
@pytest.mark.parametrize('formation', ['parallel', 'circular'])
@pytest.mark.parametrize('flow', [[0.0, 0.0], [0.4, -0.2]])
def test_potential_never_increases_first_order_on_a_ring(formation, flow):
    sc = resolve({'num_vehicles': 8, 'model': 'first_order', 'controller': 'first_order',
                  'formation': formation, 'flow': flow, 'graph': 'ring', 'seed': 2,
                  'dt_control': 0.002, 'dt_integration': 0.002, 'duration': 8.0})
    st = Stepper(sc)
    v = []
    for _ in range(sc.periods):
        st.command()
        v.append(st.ctrl.formation.potential(st.ctrl.view(st.X)))
        st.advance()
    assert v[-1] < 0.7 * v[0]
    assert np.max(np.diff(v)) <= 1e-7 * v[0]


@pytest.mark.slow
@pytest.mark.parametrize('name', ['first_order_circular', 'particle_parallel_proportional',
                                  'particle_circular_flow'])
def test_first_order_proportional_and_flow_laws_converge_on_a_circulant_graph(name):
    sc = load(CONFIG / f'{name}.yaml', ['num_vehicles:=10', 'graph:=circulant',
                                        'graph_offsets:=[1, 2]', 'duration:=150'], seed=2)
    run = simulator.simulate(sc)
    assert simulator.summary(run)['converged'], simulator.summary(run)
