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
Symmetric circular patterns (Sepulchre, Paley and Leonard 2007): splay, (M, N), slots.

The laws: finite differences of phi' and of sigma = -dV/dphase, V' of the first-order law,
V_c monotone under backstepping; the runs: splay from several seeds (particles of first and
second order, rigid bodies), the (3, 12) pattern, slot patterns on random graphs; the scenario
refuses a pattern in a flow.
"""
from dataclasses import fields, replace

from formation_control.core import graphs, laws, scenario
from formation_control.core.control import Controller
from formation_control.sim import metrics, simulator
import numpy as np
import pytest

from runs import CONFIG, SEEDS, views

CHORD_RTOL = 1e-2


def random_view(n, rng, speed=None):
    """Return a view of n vehicles with random positions, phases, rates and speeds."""
    s = np.ones(n) if speed is None else speed
    return laws.View(rng.normal(size=n) + 1j * rng.normal(size=n), rng.uniform(-np.pi, np.pi, n),
                     rng.normal(size=n), s, np.zeros(n))


def moved(view, h):
    """Return the view after h seconds of unit-speed motion at constant rates (O(h^3))."""
    e = view.e
    r = view.r + h * view.speed * e + 0.5 * h ** 2 * view.speed * 1j * view.rate * e
    return replace(view, r=r, phase=view.phase + h * view.rate)


def patterns(n, rng):
    """Return the pattern laws to check, with the coupling each uses (None: all-to-all)."""
    g = graphs.build(n, 'random', degree=3.0, seed=1).coupling()
    beta = rng.uniform(0, 2 * np.pi, n)
    return [(laws.Moments((0.5,) * (n // 2)), None),
            (laws.Moments((0.3, 0.2, -0.1)), None),
            (laws.Slots(0.4, beta), None),
            (laws.Slots(0.4, beta), g)]


@pytest.mark.parametrize('case', range(4))
def test_phi_dot_is_the_time_derivative_of_phi(case):
    rng = np.random.default_rng(case)
    pattern, coupling = patterns(9, rng)[case]
    f = laws.Circular(1.3, -0.7, coupling=coupling, pattern=pattern)
    v, h = random_view(9, rng), 1e-5
    numeric = (f.terms(moved(v, h)).phi - f.terms(moved(v, -h)).phi) / (2 * h)
    np.testing.assert_allclose(f.terms(v).phi_dot, numeric, rtol=1e-6, atol=1e-7)
    b_num = (pattern.gradient(moved(v, h), coupling=coupling)[0]
             - pattern.gradient(moved(v, -h), coupling=coupling)[0]) / (2 * h)
    np.testing.assert_allclose(pattern.gradient(v, coupling=coupling)[1], b_num, atol=1e-7)


@pytest.mark.parametrize('case', range(4))
def test_b_is_the_gradient_of_the_pattern_potential(case):
    rng = np.random.default_rng(10 + case)
    pattern, coupling = patterns(8, rng)[case]
    v, h = random_view(8, rng), 1e-6
    numeric = []
    for k in range(8):
        up, down = v.phase.copy(), v.phase.copy()
        up[k] += h
        down[k] -= h
        numeric.append((pattern.potential(replace(v, phase=up), coupling)
                        - pattern.potential(replace(v, phase=down), coupling)) / (2 * h))
    np.testing.assert_allclose(pattern.gradient(v, coupling=coupling)[0], numeric, atol=1e-7)
    assert abs(np.sum(numeric)) < 1e-7            # U is invariant to a common rotation


@pytest.mark.parametrize('n', [5, 16, 19])
def test_a_vehicle_computes_its_moment_gradient_as_the_fleet_does_bit_for_bit(n):
    """
    A node's b_k (idx = k) equals entry k of the simulator's, alone or in a batch of fleets.

    n // 2 >= 8 moments included: the sum over m runs m by m whatever the shape.
    """
    rng = np.random.default_rng(n)
    pattern = laws.Moments(tuple(rng.uniform(-0.5, 0.5, n // 2)))
    views = [random_view(n, rng) for _ in range(3)]
    batch = laws.View(*(np.stack([getattr(v, f.name) for v in views])
                        for f in fields(laws.View)))
    together = pattern.gradient(batch)
    for i, v in enumerate(views):
        fleet = pattern.gradient(v)
        for k in range(n):
            for alone, whole, batched in zip(pattern.gradient(v, k), fleet, together):
                assert alone.tolist() == [whole[k]] == [batched[i, k]]


@pytest.mark.parametrize('case', range(4))
def test_sigma_is_minus_dV_dphase_and_the_issue_form_holds_at_unit_speed_only(case):
    """sigma_k = -dV/dphase_k = (phi_k - omega0 s_k)/(K omega0^2): the issue's form needs s = 1."""
    rng = np.random.default_rng(20 + case)
    pattern, coupling = patterns(7, rng)[case]
    K, w0 = 0.8, 1.6
    f = laws.Circular(K, w0, coupling=coupling, pattern=pattern)
    for speed in (np.ones(7), rng.uniform(0.5, 1.5, 7)):
        v, h = random_view(7, rng, speed), 1e-6
        numeric = []
        for k in range(7):
            up, down = v.phase.copy(), v.phase.copy()
            up[k] += h
            down[k] -= h
            numeric.append(-(f.potential(replace(v, phase=up))
                             - f.potential(replace(v, phase=down))) / (2 * h))
        t = f.terms(v)
        np.testing.assert_allclose(t.sigma, numeric, atol=1e-6)
        np.testing.assert_allclose(t.sigma, (t.phi - w0 * v.speed) / (K * w0 ** 2), atol=1e-12)
        issue_form = (t.phi - w0) / (K * w0 ** 2)
        assert np.allclose(t.sigma, issue_form) == bool(np.all(speed == 1))


@pytest.mark.parametrize('case', range(4))
def test_first_order_law_has_V_dot_minus_sum_of_squares(case):
    """V' = -(1/(K omega0^2)) sum (phi_k - omega0)^2 when every rate is phi_k (unit speed)."""
    rng = np.random.default_rng(30 + case)
    pattern, coupling = patterns(10, rng)[case]
    K, w0 = 1.1, -0.9
    f = laws.Circular(K, w0, coupling=coupling, pattern=pattern)
    v = random_view(10, rng)
    v = replace(v, rate=f.terms(v).phi)
    h = 1e-5
    numeric = (f.potential(moved(v, h)) - f.potential(moved(v, -h))) / (2 * h)
    expected = -np.sum((v.rate - w0) ** 2) / (K * w0 ** 2)
    assert numeric == pytest.approx(expected, rel=1e-6)


def test_moment_potential_is_zero_on_its_pattern():
    n = 12
    splay = laws.View(np.zeros(n, complex), 2 * np.pi * np.arange(n) / n, np.zeros(n),
                      np.ones(n), np.zeros(n))
    assert laws.Moments((0.5,) * 6).potential(splay) == pytest.approx(0, abs=1e-12)
    clusters = replace(splay, phase=2 * np.pi * (np.arange(n) % 3) / 3)
    m = laws.Moments((0.5, 0.5, -0.1))
    assert m.potential(clusters) == pytest.approx(0, abs=1e-12)
    np.testing.assert_allclose(abs(m.moments(clusters.phase)), [0, 0, 1 / 3], atol=1e-12)
    assert m.potential(splay) > 0


def splay_run(name, seed, overrides=()):
    sc = scenario.load(CONFIG / f'{name}.yaml', list(overrides), seed=seed)
    return simulator.simulate(sc)


def assert_on_one_circle(run, final, ctrl):
    sc = run.sc
    c = ctrl.formation.centres(final)
    assert np.max(abs(c - c.mean())) < 1e-2
    np.testing.assert_allclose(abs(final.r - c.mean()), 1 / abs(sc.omega0), rtol=1e-2)


SPLAYS = [('particle_circular_splay', ()),
          ('first_order_circular', ('num_vehicles:=12', 'pattern:=splay', 'duration:=80.0')),
          ('rigid_circular_splay', ())]


@pytest.mark.slow
@pytest.mark.parametrize('seed', SEEDS)
@pytest.mark.parametrize('name, overrides', SPLAYS)
def test_splay_spaces_the_vehicles_evenly_on_one_circle(name, overrides, seed):
    run = splay_run(name, seed, overrides)
    ctrl, vs = views(run)
    sc, final = run.sc, vs[-1]
    assert_on_one_circle(run, final, ctrl)
    snap = metrics.snapshot(ctrl, run.X[-1], run.U[-1])
    assert snap.phase_orders[0] < 1e-2
    assert max(snap.phase_orders) < 1e-2                       # |p_m| = 0, m = 1..floor(N/2)
    chord = 2 * np.sin(np.pi / sc.num_vehicles) / abs(sc.omega0)
    assert snap.min_separation == pytest.approx(chord, rel=CHORD_RTOL)
    first = metrics.snapshot(ctrl, run.X[0], run.U[0])
    assert first.min_separation < 0.8 * chord or first.phase_orders[0] > 0.05


@pytest.mark.slow
@pytest.mark.parametrize('seed', SEEDS)
@pytest.mark.parametrize('name, overrides', [
    ('particle_circular_splay', ()), ('particle_circular_symmetric', ()),
    ('first_order_circular', ('num_vehicles:=12', 'pattern:=splay'))])
def test_composite_lyapunov_never_increases(name, overrides, seed):
    """V_c of backstepping and V of the first-order law (z = 0), sampled every 0.1 s."""
    run = splay_run(name, seed, (*overrides, 'duration:=20.0'))
    ctrl = Controller(run.sc)
    vc = np.array([metrics.snapshot(ctrl, X, U).lyapunov for X, U in zip(run.X, run.U)])
    assert np.all(np.diff(vc) <= 1e-9 * vc[0])
    assert vc[-1] < 0.5 * vc[0]


@pytest.mark.slow
@pytest.mark.parametrize('seed', SEEDS)
def test_symmetric_pattern_forms_equal_clusters(seed):
    run = splay_run('particle_circular_symmetric', seed)
    ctrl, vs = views(run)
    assert_on_one_circle(run, vs[-1], ctrl)
    p = laws.Moments((1.0,) * 6).moments(vs[-1].phase)
    np.testing.assert_allclose(abs(p[:2]), 0, atol=1e-2)       # m < M
    assert abs(p[2]) == pytest.approx(1 / 3, abs=1e-2)         # |p_M| = 1/M


@pytest.mark.slow
def test_a_large_clustering_gain_leaves_unequal_clusters():
    """The gain pitfall: K_3 = -0.2 leaves seed 2 of (3, 12) in a local minimum."""
    run = splay_run('first_order_circular', 2, (
        'num_vehicles:=12', 'pattern:=symmetric', 'pattern_M:=3', 'pattern_gain_M:=0.2',
        'duration:=100.0'))
    _, vs = views(run)
    p = laws.Moments((1.0,) * 3).moments(vs[-1].phase)
    assert abs(p[2]) < 1 / 3 - 0.05 or abs(p[0]) > 0.05


@pytest.mark.slow
@pytest.mark.parametrize('graph_seed', [1, 2])
@pytest.mark.parametrize('pattern', ['splay', 'symmetric'])
def test_slot_patterns_on_random_connected_graphs(pattern, graph_seed):
    run = splay_run('particle_circular_splay', graph_seed, (
        'graph:=random', 'graph_degree:=3.0', f'graph_seed:={graph_seed}', f'pattern:={pattern}',
        *(['pattern_M:=4'] if pattern == 'symmetric' else []), 'duration:=250.0'))
    sc = run.sc
    assert sc.pattern_slots
    ctrl, vs = views(run)
    assert isinstance(ctrl.formation.pattern, laws.Slots)
    final = vs[-1]
    assert_on_one_circle(run, final, ctrl)
    x = np.exp(1j * (final.phase - sc.pattern_offsets))
    assert abs(x.mean()) > 1 - 1e-4                          # phase_k - beta_k synchronised
    p = laws.Moments((1.0,) * 6).moments(final.phase)
    if pattern == 'splay':
        assert max(abs(p)) < 1e-2
        chord = 2 * np.sin(np.pi / sc.num_vehicles)
        snap = metrics.snapshot(ctrl, run.X[-1], run.U[-1])
        assert snap.min_separation == pytest.approx(chord, rel=CHORD_RTOL)
    else:
        np.testing.assert_allclose(abs(p[:3]), 0, atol=1e-2)
        assert abs(p[3]) == pytest.approx(1 / 4, abs=1e-2)


def test_slot_offsets_follow_the_members():
    sc = scenario.load(CONFIG / 'particle_circular_splay.yaml', ['pattern_form:=slots'])
    ctrl = Controller(sc)
    members = np.ones(12, bool)
    members[[2, 7]] = False
    f = ctrl.formation_of(members)
    np.testing.assert_allclose(f.pattern.beta, sc.pattern_offsets[members])
    np.testing.assert_allclose(sc.pattern_offsets, 2 * np.pi * np.arange(12) / 12)
    sym = replace(sc, pattern='symmetric', pattern_M=3)
    np.testing.assert_allclose(sym.pattern_offsets[:4], [0, 2 * np.pi / 3, 4 * np.pi / 3, 0])


def test_moment_gains_of_the_patterns():
    sc = scenario.load(CONFIG / 'particle_circular_symmetric.yaml')
    assert Controller(sc).formation.pattern == laws.Moments((0.5, 0.5, -0.1))
    splay = scenario.load(CONFIG / 'particle_circular_splay.yaml')
    assert Controller(splay).formation.pattern == laws.Moments((0.5,) * 6)
    assert Controller(replace(splay, pattern='none')).formation.pattern is None


@pytest.mark.parametrize('name', ['particle_circular_splay', 'rigid_circular_splay',
                                  'particle_circular_symmetric'])
def test_a_pattern_in_a_flow_is_refused(name):
    with pytest.raises(scenario.ScenarioError, match='in a flow no fixed phase pattern'):
        scenario.load(CONFIG / f'{name}.yaml', ['flow:=[0.3, 0.0]'])


@pytest.mark.parametrize('overrides, match', [
    (['pattern:=symmetric', 'pattern_M:=5'], "'pattern_M' = 5"),
    (['pattern:=symmetric', 'pattern_M:=12'], "'pattern_M' = 12"),
    (['pattern:=symmetric', 'pattern_M:=1'], "'pattern_M' = 1"),
    (['pattern_form:=moments', 'graph:=ring'], "'pattern_form' = 'moments'"),
    (['formation:=parallel', 'K:=-1.0'], 'needs formation circular'),
    (['pattern_gain:=0.0'], "'pattern_gain' = 0.0"),
])
def test_impossible_patterns_are_refused(overrides, match):
    with pytest.raises(scenario.ScenarioError, match=match):
        scenario.load(CONFIG / 'particle_circular_splay.yaml', overrides)


def run_without(sc, gone, X0, seconds):
    """Return the state after ``seconds`` in which the vehicles ``gone`` are silent."""
    st = simulator.Stepper(sc, X0)
    members = np.ones(sc.num_vehicles, bool)
    members[list(gone)] = False
    ctrl = st.ctrl
    for _ in range(int(round(seconds / sc.dt_control))):
        U = np.zeros_like(st.U)
        Xm = st.X[:, members]
        U[:, members] = ctrl.command(ctrl.view(Xm), Xm, members=members)
        st.hold(U)
        st.advance()
    return st.X[:, members], members


@pytest.mark.slow
@pytest.mark.parametrize('form', ['moments', 'slots'])
def test_a_vehicle_that_drops_out(form):
    """Moments: the others re-spread as a splay of N - 1; slots: they keep theirs, a gap stays."""
    sc = scenario.load(CONFIG / 'first_order_circular.yaml', [
        'num_vehicles:=12', 'pattern:=splay', f'pattern_form:={form}', 'duration:=80.0'])
    full = simulator.simulate(sc)
    X, members = run_without(sc, [2], full.X[-1], 80.0)
    ctrl = Controller(sc)
    f = ctrl.formation_of(members)
    v = ctrl.view(X)
    c = f.centres(v)
    assert np.max(abs(c - c.mean())) < 1e-2
    sep = metrics.min_separation(v.r)
    if form == 'moments':
        assert max(metrics.phase_orders(v.phase)) < 1e-2
        assert sep == pytest.approx(2 * np.sin(np.pi / 11), rel=CHORD_RTOL)
    else:
        assert abs(np.exp(1j * (v.phase - sc.pattern_offsets[members])).mean()) > 1 - 1e-6
        assert sep == pytest.approx(2 * np.sin(np.pi / 12), rel=CHORD_RTOL)
        gaps = np.sort(np.diff(np.sort(np.mod(v.phase, 2 * np.pi))))
        assert gaps[-1] == pytest.approx(4 * np.pi / 12, abs=1e-3)   # the empty slot


@pytest.mark.slow
def test_report_states_the_predicted_pattern_and_the_plot_marks_the_places(tmp_path):
    from formation_control.sim import report
    from formation_control.sim.plotting import plot_run
    run = splay_run('particle_circular_splay', 1)
    out, rows = report.report(run)
    assert out['pattern'] == 'splay: 12 vehicles 30 deg apart, chord 0.5176 m (moments)'
    text = report.format_report('splay', out, rows)
    assert 'predicted pattern  splay: 12 vehicles' in text
    table = {name: (value, predicted) for name, value, predicted, _ in rows}
    for m in range(1, 7):
        value, predicted = table[f'phase_order_{m}']
        assert predicted == 0.0 and value < 1e-2
    value, predicted = table['min_separation']
    assert predicted == pytest.approx(2 * np.sin(np.pi / 12))
    assert value == pytest.approx(predicted, rel=CHORD_RTOL)
    d = plot_run(run, tmp_path / 'splay.png')
    assert (tmp_path / 'splay.png').stat().st_size > 0
    np.testing.assert_allclose(d['places'], run.X[-1, 0] + 1j * run.X[-1, 1])
    assert d['phase_orders'].shape == (run.t.size, 6)
    sym = scenario.load(CONFIG / 'particle_circular_symmetric.yaml')
    assert report.pattern_text(sym) == '(3, 12): 3 clusters of 4, 120 deg apart (moments)'
    pred = report.predictions(sym, scenario.initial_state(sym))
    assert pred['phase_order_3'][0] == pytest.approx(1 / 3)
    assert pred['phase_order_6'][0] == pytest.approx(1 / 6)
    assert pred['phase_order_2'][0] == 0.0 and pred['min_separation'][0] == 0.0
    assert 'phase_order_1' not in report.predictions(replace(sym, pattern='none'),
                                                     scenario.initial_state(sym))


def circle_state(sc, phase):
    """Return the states (6, N) of vehicles on the unit circle about 0 heading along it."""
    X = np.zeros((6, sc.num_vehicles))
    r = -1j * np.exp(1j * phase) / sc.omega0                 # c_k = r_k + i e_k / omega0 = 0
    X[0], X[1], X[2] = r.real, r.imag, phase
    X[3], X[4] = sc.omega0, 1.0
    return X


@pytest.mark.parametrize('n', [8, 12, 16])
def test_a_paired_splay_is_not_converged_and_says_why(n):
    """The twisted state q = 1 of ring slots: phases 4 pi k / N, N/2 coincident pairs."""
    sc = scenario.load(CONFIG / 'particle_circular_splay.yaml', [f'num_vehicles:={n}'])
    ctrl = Controller(sc)
    k = np.arange(n)
    for phase, unmet in [(2 * np.pi * k / n, []),
                         (4 * np.pi * k / n, ['phase_moments', 'separation'])]:
        X = circle_state(sc, phase)
        snap = metrics.snapshot(ctrl, X, np.zeros((2, n)))
        assert snap.spread < 1e-12 and metrics.conditions(sc, snap)['radius']
        assert metrics.unmet(sc, snap) == unmet
        assert bool(metrics.converged(sc, snap)) is not unmet


def test_unequal_or_too_few_clusters_are_not_converged():
    sc = scenario.load(CONFIG / 'particle_circular_symmetric.yaml')
    n, m = sc.num_vehicles, sc.pattern_M
    ctrl = Controller(sc)
    k = np.arange(n)
    for phase, ok in [(2 * np.pi * (k % m) / m, True), (2 * np.pi * (k % (m - 1)) / (m - 1),
                                                        False)]:
        snap = metrics.snapshot(ctrl, circle_state(sc, phase), np.zeros((2, n)))
        assert bool(metrics.converged(sc, snap)) is ok
        assert ok or metrics.unmet(sc, snap) == ['phase_moments']


@pytest.mark.parametrize('n', range(3, 41))
def test_ring_twisted_states_are_stable_exactly_for_q_below_n_over_4(n):
    assert graphs.twisted_states(n, (1,)) == [q for q in range(1, n // 2 + 1) if 4 * q < n]


@pytest.mark.parametrize('offsets, q, stable', [
    ((1,), 1, True), ((1,), 2, True), ((1,), 3, False), ((1, 3), 1, True), ((1, 3), 2, False),
    ((2, 3), 1, False)])
def test_the_twisted_hessian_is_that_of_the_phase_potential(offsets, q, stable):
    """Finite differences of U = sum_arcs (1 - cos(dpsi)) / 2 at psi_k = 2 pi q k / 12."""
    g = graphs.build(12, 'circulant', offsets=offsets)
    src, dst = g.arcs
    psi0 = 2 * np.pi * q * np.arange(12) / 12

    def u(psi):
        return 0.5 * np.sum(1 - np.cos(psi[dst] - psi[src]))
    h, eye = 1e-4, np.eye(12)
    H = np.array([[(u(psi0 + h * (a + b)) - u(psi0 + h * (a - b)) - u(psi0 - h * (a - b))
                    + u(psi0 - h * (a + b))) / (4 * h * h) for b in eye] for a in eye])
    eig = np.sort(np.linalg.eigvalsh(H))[1:]                 # the common rotation: 0
    assert bool(np.all(eig > 1e-6)) is stable
    assert (q in graphs.twisted_states(12, offsets)) is stable


@pytest.mark.parametrize('n', [8, 12, 16])
def test_the_phase_census_finds_the_ring_traps_and_none_on_trees_or_dense_graphs(n):
    assert graphs.slot_traps(graphs.build(n, 'ring')) > 0.1
    tree = [x for k in range(2, n + 1) for x in (k // 2, k)]        # a binary tree
    assert graphs.slot_traps(graphs.build(n, 'explicit', edges=tree)) == 0
    dense = tuple(range(1, (n + 1) // 2))
    assert graphs.slot_traps(graphs.build(n, 'circulant', offsets=dense)) == 0


@pytest.mark.parametrize('n', [8, 12, 16])
@pytest.mark.parametrize('pattern', ['splay', 'symmetric'])
def test_slots_on_a_ring_are_refused_with_the_graph_property_and_what_to_use(n, pattern):
    with pytest.raises(scenario.ScenarioError) as err:
        scenario.load(CONFIG / 'particle_circular_splay.yaml', [
            f'num_vehicles:={n}', 'graph:=ring', f'pattern:={pattern}',
            *(['pattern_M:=4'] if pattern == 'symmetric' else [])])
    text = str(err.value)
    assert text.startswith(f"parameter 'graph' = 'ring' is invalid: a ring of {n} has stable "
                           f'twisted states for slots: psi_k = 2 pi q k / N with q = 1')
    assert '(|q| < N/4)' in text and 'coincident pairs' in text
    assert 'Use graph: complete (the moment form), a tree' in text


def test_slots_on_a_graph_the_census_traps_are_refused():
    edges = [x for k in range(1, 12) for x in (k, k + 1)] + [12, 1, 1, 7]   # two 7-cycles
    assert graphs.slot_traps(graphs.build(12, 'explicit', edges=edges)) > 0
    with pytest.raises(scenario.ScenarioError, match=r"'graph' = 'explicit' is invalid: the "
                       r'explicit graph on 12 has stable slot states other than synchrony'):
        scenario.load(CONFIG / 'particle_circular_splay.yaml', [
            'graph:=explicit', f'graph_edges:={edges}'])


CENSUS_SEEDS = range(1, 21)


def census(sc, seeds=CENSUS_SEEDS):
    """Return the end of a batch of runs of sc, one per seed, and its convergence conditions."""
    out = simulator.simulate(sc, simulator.initial_states(sc, seeds), simulator.Outcome(sc))
    return out, metrics.conditions(sc, out.final)


@pytest.mark.slow
@pytest.mark.parametrize('n', [8, 12, 16])
def test_census_slots_forced_on_a_ring_pair_and_are_reported_unconverged(n):
    """The refusal's reason, from 20 seeds: ring slots (past the refusal) end paired."""
    sc = scenario.load(CONFIG / 'particle_circular_splay.yaml', [
        f'num_vehicles:={n}', 'duration:=250.0', 'record_dt:=5.0'])
    ring = replace(sc, graph='ring', pattern_form='slots')
    out, cond = census(ring)
    chord = 2 * np.sin(np.pi / n)
    paired = out.final.min_separation < 0.01 * chord
    assert paired.sum() >= 3                                 # measured: 7, 7, 8 of 20
    assert not np.any(out.flags[-1][paired]) and not np.any(cond['separation'][paired])
    assert np.all(cond['centre_spread'])                     # on one circle all the same


@pytest.mark.slow
@pytest.mark.parametrize('n', [8, 12, 16])
def test_census_no_seed_ends_paired_on_the_graphs_the_pattern_is_allowed_on(n):
    """20 seeds of the splay on the complete graph (moments): all converged, none paired."""
    sc = scenario.load(CONFIG / 'particle_circular_splay.yaml', [
        f'num_vehicles:={n}', 'duration:=250.0', 'record_dt:=5.0'])
    out, cond = census(sc)
    chord = 2 * np.sin(np.pi / n)
    assert np.all(out.final.min_separation > (1 - CHORD_RTOL) * chord)
    assert np.all(out.flags[-1]) and all(np.all(v) for v in cond.values())
