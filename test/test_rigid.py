"""
Rigid-body scenarios (Ch. 6-8, App. A) from several seeds: convergence and the steady states
of the thesis' analysis (with the errata's corrections), and measured bounds where a law is
only practically stable.
"""
import numpy as np
import pytest

from formation_control.core import metrics
from runs import run_of, SEEDS, views

U0_TOL = 1e-3


def _final(run):
    return run.X[-1]


def _late(run, seconds):
    return run.t >= run.t[-1] - seconds


@pytest.mark.parametrize('seed', SEEDS)
@pytest.mark.parametrize('name', ['rigid_parallel', 'rigid_parallel_cop'])
def test_rigid_parallel_without_flow(name, seed):
    """Theorem 6: common heading, u -> u0, v -> 0 (beta -> 0)."""
    run = run_of(name, seed)
    X = _final(run)
    assert abs(np.exp(1j * X[2]).mean()) > 0.999
    np.testing.assert_allclose(X[4], run.sc.u0, atol=U0_TOL)
    np.testing.assert_allclose(X[5], 0.0, atol=1e-3)
    np.testing.assert_allclose(X[3], 0.0, atol=1e-3)


@pytest.mark.parametrize('seed', SEEDS)
def test_rigid_parallel_in_flow_crab_angle_8_17(seed):
    """Theorem 8: common inertial heading, beta -> 0, beta_hat -> (8.17), s_hat -> (8.17)."""
    run = run_of('rigid_parallel_flow', seed)
    sc, X = run.sc, _final(run)
    _, vs = views(run)
    assert abs(vs[-1].e.mean()) > 0.999
    np.testing.assert_allclose(X[4], sc.u0, atol=U0_TOL)
    beta, beta_hat = metrics.crab_angles(X, sc.flow_c)
    np.testing.assert_allclose(beta, 0.0, atol=1e-3)
    expected, s_hat = metrics.parallel_flow_crab(sc, X[2])
    np.testing.assert_allclose(beta_hat, expected, atol=1e-3)
    np.testing.assert_allclose(vs[-1].speed, s_hat, atol=1e-3)
    assert np.max(abs(beta_hat)) > 0.05 or abs(np.sin(X[2]).mean()) < 0.1


@pytest.mark.parametrize('seed', SEEDS)
@pytest.mark.parametrize('name', ['rigid_circular', 'rigid_circular_center'])
def test_rigid_circular_steady_turn(name, seed):
    """Theorem 7 / Corollary 1: one circle of radius 1/|omega0|, u -> u0, v -> v0 < 0 (outward)."""
    run = run_of(name, seed)
    sc, X = run.sc, _final(run)
    ctrl, vs = views(run)
    c = ctrl.formation.centres(vs[-1])
    v0, s0, beta0, yaw_rate = metrics.steady_turn(sc)
    assert v0 == pytest.approx(-0.2) and s0 == pytest.approx(1.0198, abs=1e-4)
    assert np.max(abs(c - c.mean())) < 1e-2
    np.testing.assert_allclose(abs(vs[-1].r - c.mean()), 1 / abs(sc.omega0), rtol=1e-2)
    np.testing.assert_allclose(X[4], sc.u0, atol=U0_TOL)
    np.testing.assert_allclose(X[5], v0, atol=1e-3)
    np.testing.assert_allclose(X[3], yaw_rate, atol=1e-3)
    np.testing.assert_allclose(metrics.crab_angles(X, 0)[0], beta0, atol=1e-3)
    if sc.informed:
        assert abs(c.mean() - sc.c0_c) < 1e-2


@pytest.mark.parametrize('seed', SEEDS)
def test_rigid_circular_center_moves_the_centre(seed):
    """Only vehicle 1 knows c0, yet the circle moves there; without c0 it settles elsewhere."""
    free = run_of('rigid_circular', seed)
    ctrl, vs = views(free)
    assert abs(ctrl.formation.centres(vs[-1]).mean()) > 0.05


@pytest.mark.parametrize('seed', SEEDS)
def test_full_law_with_a_slower_loop_converges(seed):
    """The full (7.12) law (s', beta' from the model, beta'' omitted) with kappa = 2."""
    run = run_of('rigid_circular', seed, overrides=('law_variant:=full', 'kappa:=2.0'))
    X = _final(run)
    ctrl, vs = views(run)
    c = ctrl.formation.centres(vs[-1])
    assert np.max(abs(c - c.mean())) < 1e-2
    np.testing.assert_allclose(X[5], metrics.steady_turn(run.sc)[0], atol=1e-3)


def _pi_figures(run, seconds=50.0):
    ctrl, vs = views(run)
    late = [v for v, keep in zip(vs, _late(run, seconds)) if keep]
    centres = np.array([ctrl.formation.centres(v).mean() for v in late])
    spread = max(np.max(abs(ctrl.formation.centres(v) - ctrl.formation.centres(v).mean()))
                 for v in late)
    radius = np.array([np.mean(abs(v.r - ctrl.formation.centres(v).mean())) for v in late])
    error = max(np.max(abs(ctrl.formation.terms(v).phi - v.rate)) for v in late)
    drift = abs(centres[-1] - centres[0]) / seconds
    return centres, spread, radius, error, drift


@pytest.mark.parametrize('seed', SEEDS)
def test_pi_in_flow_is_only_practically_stable(seed):
    """
    Proposition 1 claims asymptotic stability; measured (errata): the PI (8.24) leaves a periodic
    tracking error, the centres stay within a few cm of each other, and the common centre drifts.
    """
    run = run_of('rigid_circular_flow', seed)
    sc = run.sc
    centres, spread, radius, error, drift = _pi_figures(run)
    np.testing.assert_allclose(_final(run)[4], sc.u0, atol=1e-2)
    assert spread < 0.1
    np.testing.assert_allclose(radius, 1 / sc.omega0, rtol=0.03)
    assert 0.05 < error < 0.2
    assert 0.005 < drift < 0.03


@pytest.mark.parametrize('seed', SEEDS)
def test_pi_in_flow_with_prescribed_centre_keeps_a_bounded_offset(seed):
    run = run_of('rigid_circular_flow_center', seed)
    sc = run.sc
    centres, spread, radius, error, drift = _pi_figures(run)
    assert np.max(abs(centres - sc.c0_c)) < 0.1
    assert drift < 0.002
    assert spread < 0.08
    np.testing.assert_allclose(radius, 1 / sc.omega0, rtol=0.03)
