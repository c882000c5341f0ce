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
The 3-D laws of core/spatial.py re-derived in tests.

The exact SE(3) step (a step is two half steps; a constant turn is the circle), the frames
orthonormal over long runs, each potential's analytic rate against a central difference along
trajectories and non-positive under its law, the equilibria reached from several seeds (axis,
radius and pitch fitted to the recorded positions), and the planar laws of core/laws.py as the
special case of a fleet in a plane about a vertical axis.
"""
from formation_control.core import graphs, laws, spatial
from formation_control.core.errors import ScenarioError
import numpy as np
import pytest

H = 1e-3
DT = 0.02
DT_LONG = 0.05

LAWS = {
    'parallel': lambda g: spatial.Parallel(-1.0, coupling=g),
    'circular': lambda g: spatial.Circular(1.0, 1.0, coupling=g),
    'circular_tilted': lambda g: spatial.Circular(0.6, -0.8, (1.0, -2.0, 0.5), coupling=g),
    'helical': lambda g: spatial.Circular(1.0, 0.7, (0.0, 1.0, 1.0), axial=0.4, coupling=g),
}
GRAPHS = {'all': None, 'ring': graphs.build(8, 'ring').coupling(),
          'random': graphs.build(8, 'random', degree=3, seed=2).coupling()}


def _fleet(seed, n=8, spread=4.0):
    """Return random positions (N, 3) and random frames in SO(3) (N, 3, 3)."""
    rng = np.random.default_rng(seed)
    Q, T = np.linalg.qr(rng.normal(size=(n, 3, 3)))
    Q = Q * np.sign(np.diagonal(T, axis1=1, axis2=2))[:, None, :]
    Q[:, :, 2] *= np.linalg.det(Q)[:, None]
    return spread * rng.normal(size=(n, 3)), Q


def _run(law, r, R, steps, dt=DT):
    """Return the positions and frames at each step of the closed loop (steps + 1 samples)."""
    rs, Rs = [r], [R]
    for _ in range(steps):
        u, v, w = law.controls(r, R)
        r, R = spatial.step(r, R, u, v, dt, w)
        rs.append(r)
        Rs.append(R)
    return np.array(rs), np.array(Rs)


def test_a_step_is_two_half_steps_and_a_constant_turn_is_a_circle():
    r, R = _fleet(0, n=5)
    rng = np.random.default_rng(1)
    u, v, w = rng.normal(scale=2.0, size=(3, 5))
    u[0], v[0], w[0] = 1e-5, -2e-5, 0.0                    # the series branch
    one = spatial.step(r, R, u, v, 0.3, w)
    two = spatial.step(*spatial.step(r, R, u, v, 0.15, w), u, v, 0.15, w)
    np.testing.assert_allclose(one[0], two[0], atol=1e-13)
    np.testing.assert_allclose(one[1], two[1], atol=1e-13)
    t, k = 2.0, 0.8
    rt, Rt = spatial.step(r, R, k, 0.0, t)
    x, y = R[:, :, 0], R[:, :, 1]
    np.testing.assert_allclose(rt, r + (np.sin(k * t) * x + (1 - np.cos(k * t)) * y) / k,
                               atol=1e-13)
    np.testing.assert_allclose(Rt[:, :, 2], R[:, :, 2], atol=1e-15)


def test_frames_stay_orthonormal_over_long_runs():
    r, R = _fleet(3, n=100)
    rng = np.random.default_rng(4)
    for _ in range(4000):                   # without the polar step: 2e-14, and growing
        u, v, w = rng.normal(scale=3.0, size=(3, 100))
        r, R = spatial.step(r, R, u, v, 0.05, w)
    gram = np.swapaxes(R, 1, 2) @ R
    assert abs(gram - np.eye(3)).max() < 2e-15
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=2e-15)


@pytest.mark.parametrize('graph', GRAPHS, ids=str)
@pytest.mark.parametrize('name', LAWS, ids=str)
def test_potential_rate_is_the_derivative_and_never_positive_under_the_law(name, graph):
    law = LAWS[name](GRAPHS[graph])
    rs, Rs = _run(law, *_fleet(5), 400)
    rng = np.random.default_rng(6)
    V = [law.potential(r, R) for r, R in zip(rs, Rs)]
    assert np.all(np.diff(V) <= 1e-9 * V[0])
    for r, R in zip(rs[::100], Rs[::100]):
        for u, v in (law.controls(r, R)[:2], rng.normal(size=(2, len(r)))):
            V_at = [law.potential(*spatial.step(r, R, u, v, m * H)) for m in (-2, -1, 1, 2)]
            fd = (V_at[0] - 8 * V_at[1] + 8 * V_at[2] - V_at[3]) / (12 * H)
            assert law.potential_rate(r, R, u, v) == pytest.approx(fd, rel=1e-9, abs=1e-11)
        rate = law.potential_rate(r, R, *law.controls(r, R)[:2])
        assert rate == pytest.approx(_dissipation(law, r, R), rel=1e-12, abs=1e-14)
        assert rate <= 0.0


def _dissipation(law, r, R):
    """Return the law's V' written out here: (S5) or (S10), from the states alone."""
    x, y, z = R[:, :, 0], R[:, :, 1], R[:, :, 2]
    n, g = len(r), law.coupling
    A = np.ones((n, n)) - np.eye(n) if g is None else np.zeros((n, n))
    if g is not None:
        A[g.src, g.dst] = 1.0
    nu = n if g is None else g.nu
    if isinstance(law, spatial.Parallel):
        q = x.mean(axis=0) if g is None else A @ x / nu
        return law.K / n * np.sum(np.sum(q * y, 1) ** 2 + np.sum(q * z, 1) ** 2)
    b = np.array(law.b) / np.linalg.norm(law.b)
    c = r + np.cross(b, x) / law.omega0
    pc = c - np.outer(c @ b, b)
    d = (np.diag(A.sum(1)) - A) @ pc / nu
    h = law.omega0 * np.cross(d, b) + np.outer(x @ b - law.axial, b)
    perp = h - np.sum(h * x, 1)[:, None] * x
    return -law.K / law.omega0 ** 2 * np.sum(perp ** 2)


@pytest.mark.parametrize('name', LAWS, ids=str)
def test_the_complete_graph_with_nu_n_is_the_all_to_all_law(name):
    r, R = _fleet(7)
    complete = graphs.build(8, 'complete', nu=8.0).coupling()
    a, b = LAWS[name](None), LAWS[name](complete)
    np.testing.assert_allclose(a.controls(r, R), b.controls(r, R), rtol=1e-12, atol=1e-12)
    assert a.potential(r, R) == pytest.approx(b.potential(r, R), rel=1e-12)


@pytest.mark.parametrize('seed', [11, 12, 13])
@pytest.mark.parametrize('graph', ['all', 'ring'])
def test_parallel_aligns_the_velocities(seed, graph):
    law = LAWS['parallel'](GRAPHS[graph])
    rs, Rs = _run(law, *_fleet(seed), 600 if graph == 'all' else 1200, DT_LONG)
    x = Rs[-1][:, :, 0]
    assert np.linalg.norm(x.mean(axis=0)) > 1 - 1e-9
    last = np.diff(rs[-2:], axis=0)[0]
    assert np.linalg.norm(last - DT_LONG * x.mean(axis=0), axis=1).max() < 1e-6


@pytest.mark.parametrize('seed', [51, 52])
def test_parallel_with_k_positive_balances_the_velocities(seed):
    law = spatial.Parallel(1.0)
    r, R = _fleet(seed)
    assert law.potential_rate(r, R, *law.controls(r, R)[:2]) > 0.0      # (S5), K > 0
    _, Rs = _run(law, r, R, 800, DT_LONG)
    assert np.linalg.norm(Rs[-1][:, :, 0].mean(axis=0)) < 1e-5


def _fit(positions, dt):
    """
    Return the axis direction, axial speed, axis point, radius and fit residual of a helix.

    The velocities (central differences) lie on a circle of the sphere whose plane's normal is
    the axis n and whose offset is the axial speed; the positions projected across n lie on a
    circle fitted by least squares (|p|^2 = 2 <o, p> + k).
    """
    vel = (positions[2:] - positions[:-2]) / (2 * dt)
    centred = vel - vel.mean(axis=0)
    n = np.linalg.svd(centred)[2][-1]
    axial = vel.mean(axis=0) @ n
    if axial < 0:
        n, axial = -n, -axial
    basis = np.linalg.svd(np.eye(3) - np.outer(n, n))[0][:, :2]
    p = positions @ basis
    M = np.column_stack([2 * p, np.ones(len(p))])
    sol = np.linalg.lstsq(M, np.sum(p * p, 1), rcond=None)[0]
    o, k = sol[:2], sol[2]
    radius = np.sqrt(k + o @ o)
    residual = np.abs(np.linalg.norm(p - o, axis=1) - radius).max()
    return n, axial, basis @ o, radius, residual


@pytest.mark.parametrize('seed', [21, 22, 23])
@pytest.mark.parametrize('name,graph', [('circular', 'all'), ('circular_tilted', 'all'),
                                        ('helical', 'all'), ('circular', 'ring')])
def test_circular_and_helical_reach_one_axis_radius_and_pitch(name, graph, seed):
    law = LAWS[name](GRAPHS[graph])
    rs, _ = _run(law, *_fleet(seed), 1600 if graph == 'all' else 3600, DT_LONG)
    orbit = int(np.ceil(2 * np.pi / abs(law.omega0) / DT_LONG)) + 2
    fits = [_fit(rs[-orbit:, k], DT_LONG) for k in range(rs.shape[1])]
    b = np.array(law.b) / np.linalg.norm(law.b)
    radius = np.sqrt(1 - law.axial ** 2) / abs(law.omega0)
    for n, axial, point, rho, residual in fits:
        assert residual < 1e-6
        assert rho == pytest.approx(radius, rel=1e-4)
        assert axial == pytest.approx(abs(law.axial), abs=1e-4)
        assert abs(abs(n @ b) - 1) < 1e-6
        assert 2 * np.pi * axial / abs(law.omega0) == pytest.approx(
            2 * np.pi * abs(law.axial) / abs(law.omega0), abs=1e-3)
    points = np.array([f[2] for f in fits])
    across = points - points.mean(axis=0)
    across -= np.outer(across @ b, b)
    assert np.linalg.norm(across, axis=1).max() < 1e-3


def _helix_fleet(law, seed, n=6):
    """Return a fleet on the law's formation by construction, and how to place it at time t."""
    rng = np.random.default_rng(seed)
    b = np.array(law.b)
    e1 = np.cross(b, rng.normal(size=3))
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(b, e1)
    o, phase, height = rng.normal(size=3), rng.uniform(0, 2 * np.pi, n), rng.normal(size=n)
    rho = np.sqrt(1 - law.axial ** 2) / abs(law.omega0)

    def at(t):
        ph = phase + law.omega0 * t
        r = o + np.outer(height + law.axial * t, b) + rho * (
            np.outer(np.cos(ph), e1) + np.outer(np.sin(ph), e2))
        x = law.axial * b + np.sign(law.omega0) * np.sqrt(1 - law.axial ** 2) * (
            -np.outer(np.sin(ph), e1) + np.outer(np.cos(ph), e2))
        return r, x

    r, x = at(0.0)
    y = np.cross(x, rng.normal(size=(n, 3)))
    y /= np.linalg.norm(y, axis=1)[:, None]
    return r, np.stack([x, y, np.cross(x, y)], -1), at


@pytest.mark.parametrize('name', ['circular', 'circular_tilted', 'helical'])
def test_the_formation_is_a_relative_equilibrium_flown_exactly(name):
    law = LAWS[name](None)
    r, R0, at = _helix_fleet(law, 41)
    assert law.potential(r, R0) < 1e-28
    R = R0
    for _ in range(2000):
        u, v, w = law.controls(r, R)
        r, R = spatial.step(r, R, u, v, 0.05, w)
    r_t, _ = at(100.0)
    np.testing.assert_allclose(r, r_t, rtol=0, atol=1e-10)
    b, angle = np.array(law.b), law.omega0 * 100.0
    turn = (np.cos(angle) * np.eye(3) + np.sin(angle) * spatial.hat(b)
            + (1 - np.cos(angle)) * np.outer(b, b))
    np.testing.assert_allclose(R, turn @ R0, rtol=0, atol=1e-11)   # one twist: rigid about b


def test_flying_along_the_axis_is_an_equilibrium_but_not_a_minimum():
    law = LAWS['circular'](None)
    n = 6
    r = np.outer(np.arange(n), law.b)
    R = np.tile(np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]), (n, 1, 1))
    np.testing.assert_array_equal(R[:, :, 0], np.tile(law.b, (n, 1)))
    np.testing.assert_array_equal(law.controls(r, R)[:2], 0.0)     # no curvature: it stays
    assert law.potential(r, R) == pytest.approx(n / (2 * law.omega0 ** 2))
    r, R = spatial.step(r, R, 1e-4, 0.0, 1.0)                  # nudge
    assert law.potential_rate(r, R, *law.controls(r, R)[:2]) < 0.0
    rs, Rs = _run(law, r, R, 2000, DT_LONG)
    assert law.potential(rs[-1], Rs[-1]) < 1e-8


def _planar(r, R):
    """Return the planar view of a fleet in the plane z = 0 (complex positions, headings)."""
    x = R[:, :, 0]
    return laws.View(r[:, 0] + 1j * r[:, 1], np.arctan2(x[:, 1], x[:, 0]),
                     np.zeros(len(r)), np.ones(len(r)), np.zeros(len(r)))


def _embedded(seed, n=8):
    """Return a planar fleet as a 3-D one: positions in z = 0, frames with z_k = e_z."""
    rng = np.random.default_rng(seed)
    theta = rng.uniform(-np.pi, np.pi, n)
    r = np.column_stack([3 * rng.normal(size=(n, 2)), np.zeros(n)])
    c, s, zero, one = np.cos(theta), np.sin(theta), np.zeros(n), np.ones(n)
    R = np.stack([np.column_stack([c, s, zero]), np.column_stack([-s, c, zero]),
                  np.column_stack([zero, zero, one])], -1)
    return r, R


def _planar_step(view, phi, dt):
    """
    Return the planar fleet dt later, turning at phi held: exactly, on its arcs.

    ``theta + phi dt`` and ``r + e^{i theta} dt (e^{i psi} - 1)/(i psi)``, ``psi = phi dt``,
    written ``sin psi/psi + i (1 - cos psi)/psi`` with sinc (no branch at psi = 0).
    """
    psi = phi * dt
    arc = np.sinc(psi / np.pi) + 0.5j * psi * np.sinc(psi / (2 * np.pi)) ** 2
    return laws.View(view.r + view.e * dt * arc, view.phase + psi, view.rate, view.speed,
                     view.speed_dot)


PLANAR = [(spatial.Parallel(-1.0), laws.Parallel(-1.0)),
          (spatial.Circular(1.0, 1.0), laws.Circular(1.0, 1.0)),
          (spatial.Circular(0.5, -0.7), laws.Circular(0.5, -0.7)),
          (spatial.Parallel(-0.5, GRAPHS['ring']), laws.Parallel(-0.5, GRAPHS['ring'])),
          (spatial.Circular(1.0, 1.0, coupling=GRAPHS['random']),
           laws.Circular(1.0, 1.0, coupling=GRAPHS['random']))]


PLANAR_IDS = ['parallel', 'circular', 'circular_negative_omega0', 'parallel_ring',
              'circular_random_graph']


@pytest.mark.parametrize('pair', PLANAR, ids=PLANAR_IDS)
def test_the_planar_law_is_the_special_case(pair):
    law3, law2 = pair
    r, R = _embedded(31)
    u, v, w = law3.controls(r, R)
    view = _planar(r, R)
    np.testing.assert_allclose(u, laws.first_order(law2, view), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(v, 0.0)
    np.testing.assert_array_equal(w, 0.0)
    assert law3.potential(r, R) == pytest.approx(law2.potential(view), rel=1e-12)
    for _ in range(1500):
        view = _planar_step(view, laws.first_order(law2, view), DT)
        u, v, w = law3.controls(r, R)
        r, R = spatial.step(r, R, u, v, DT, w)
    np.testing.assert_array_equal(r[:, 2], 0.0)
    np.testing.assert_array_equal(R[:, :, 2], np.tile([0.0, 0.0, 1.0], (8, 1)))
    np.testing.assert_allclose(r[:, 0] + 1j * r[:, 1], view.r, rtol=0, atol=1e-10)
    np.testing.assert_allclose(R[:, 0, 0] + 1j * R[:, 1, 0], view.e, rtol=0, atol=1e-10)


@pytest.mark.parametrize('make,name', [
    (lambda: spatial.Parallel(0.0), 'K'),
    (lambda: spatial.Circular(-1.0, 1.0), 'K'),
    (lambda: spatial.Circular(1.0, 0.0), 'omega0'),
    (lambda: spatial.Circular(1.0, 1.0, axial=1.0), 'axial'),
    (lambda: spatial.Circular(1.0, 1.0, (0.0, 0.0, 0.0)), 'b')])
def test_bad_parameters_are_refused_by_name(make, name):
    with pytest.raises(ScenarioError, match=f"'{name}'"):
        make()
