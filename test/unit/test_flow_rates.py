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
The laws in a known flow that varies in time or space: df/dt and grad f (issue 28, item 4).

The flow's derivatives (:meth:`flowfields.Flowfield.jet`) against finite differences of the
field; the view's course rate ``Omega = g omega + <i v, f'> / s^2`` and ``s'`` against finite
differences of the true course and speed along closed-loop trajectories in each flow; the
inversions (5.1), (5.4) giving the commanded course rate and acceleration; the composite
Lyapunov function non-increasing where the flow is smooth along the paths (docs/errata.md,
"Known time-varying and non-uniform flows").
"""
from formation_control.core import control, flowfields, laws, models, scenario
from formation_control.core.control import Controller
from formation_control.sim.simulator import Stepper
import numpy as np
import pytest

H = 1e-4

FLOWS = {
    'time_varying': {'flow_model': 'time_varying', 'flow': [0.2, 0.1], 'flow_amplitude': 0.3,
                     'flow_period': 20.0},
    'shear': {'flow_model': 'shear', 'flow_shear': 0.08, 'flow_shear_width': 6.0},
    'vortex': {'flow_model': 'vortex', 'flow_circulation': 2.0, 'flow_radius': 1.5,
               'flow_center': [0.5, -0.3]},
    'grid': {'flow_model': 'grid'},
}
"""Flows with strong rates and gradients (|f'| up to 0.1 m/s^2, |grad f| up to 0.14 1/s)."""


def _grid_file(tmp_path):
    """Write a smooth, far from bilinear flow on a grid of 1 m cells; return its path."""
    gx, gy = np.linspace(-8.0, 8.0, 17), np.linspace(-7.0, 7.0, 15)
    X, Y = np.meshgrid(gx, gy)
    fx, fy = 0.2 * np.sin(0.3 * Y) + 0.05 * np.cos(0.4 * X), 0.15 * np.cos(0.25 * X + 0.2 * Y)
    path = tmp_path / 'flow.npz'
    np.savez(path, x=gx, y=gy, fx=fx, fy=fy)
    return path


def _scenario(tmp_path, name, **values):
    flow = dict(FLOWS[name])
    if name == 'grid':
        flow['flow_grid_file'] = str(_grid_file(tmp_path))
    params = {'num_vehicles': 6, 'model': 'second_order', 'controller': 'backstepping',
              'formation': 'circular', 'seed': 3, **flow}
    params.update(values)
    return scenario.resolve(params)


def _true_view(ctrl, X, F, t):
    """Return the view of X with the true flow at time t (rates as the controller takes them)."""
    return ctrl.view(X, F, ctrl.plant.flow(t, X[models.ROW_X], X[models.ROW_Y]))


def _samples(sc, times=(0.0, 0.5, 1.2)):
    """Return (t, X, U) on a closed-loop trajectory of ``sc``: the state and the input held."""
    st, out = Stepper(sc), []
    for target in times:
        while st.t < target - 1e-9:
            st.command()
            st.advance()
        U = st.command().copy()                         # first order: also the state's omega
        out.append((st.t, st.X.copy(), U))
    return out


@pytest.mark.parametrize('name', list(FLOWS))
def test_jet_is_the_derivative_of_the_flowfield(tmp_path, name):
    """Central differences of f (in t, x, y) and of its first derivatives give the jet."""
    field = flowfields.Flowfield(_scenario(tmp_path, name))
    x = np.array([0.3, 1.37, -2.41, 3.5, 4.2, -0.4])        # off the grid lines
    y = np.array([0.2, -0.8, 2.5, -3.3, 0.6, -5.1])
    t, d = 7.0, 1e-5
    jet = field.jet(x, y, field(t, x, y))

    def first(tt, xx, yy):
        j = field.jet(xx, yy, field(tt, xx, yy))
        return j.f_t, j.f_x, j.f_y

    fd = [(field(t + d, x, y) - field(t - d, x, y)) / (2 * d),
          (field(t, x + d, y) - field(t, x - d, y)) / (2 * d),
          (field(t, x, y + d) - field(t, x, y - d)) / (2 * d)]
    for got, want in zip((jet.f_t, jet.f_x, jet.f_y), fd):
        np.testing.assert_allclose(got, want, atol=1e-8)
    f_tt = (first(t + d, x, y)[0] - first(t - d, x, y)[0]) / (2 * d)
    dx = [(a - b) / (2 * d) for a, b in zip(first(t, x + d, y), first(t, x - d, y))]
    dy = [(a - b) / (2 * d) for a, b in zip(first(t, x, y + d), first(t, x, y - d))]
    for got, want in ((jet.f_tt, f_tt), (jet.f_xx, dx[1]), (jet.f_xy, dy[1]),
                      (jet.f_xy, dx[2]), (jet.f_yy, dy[2])):
        np.testing.assert_allclose(got, want, atol=1e-7)
    turns = np.exp(1j * np.linspace(0, 2 * np.pi, 73))[:, None]
    stretch = np.max(abs(jet.f_x * turns.real + jet.f_y * turns.imag))    # max |(grad f) v|
    assert stretch <= field.max_gradient() + 1e-12
    assert np.max(abs(jet.rate(np.full(6, 1 + 1j)))) > 1e-3


@pytest.mark.parametrize('name', list(FLOWS))
@pytest.mark.parametrize('model, controller', [('second_order', 'backstepping'),
                                               ('first_order', 'first_order'),
                                               ('rigid_couple', 'pi')])
def test_course_rate_and_speed_rate_match_finite_differences_along_the_run(
        tmp_path, name, model, controller):
    """
    Omega and s' of the view are d/dt of the true course gamma and speed s in each flow.

    The uniform-flow view (the laws before issue 28) misses them by ``<i v, f'> / s^2`` and
    ``<v, f'> / s``, more than 1e-3 here.
    """
    sc = _scenario(tmp_path, name, model=model, controller=controller)
    ctrl = Controller(sc)
    assert ctrl.rates
    steady = Controller(sc)
    steady.rates = False
    for t, X, U in _samples(sc):
        if model == 'rigid_couple':
            U = np.vstack([ctrl.thrust(X), U[1]])       # the view's input: thrust now, F held
        plus = models.integrate(X, U, H / 4, 4, ctrl.plant, t)
        minus = models.integrate(X, U, -H / 4, 4, ctrl.plant, t)
        ahead, behind = _true_view(ctrl, plus, U[1], t + H), _true_view(ctrl, minus, U[1], t - H)
        rate = np.angle(np.exp(1j * (ahead.phase - behind.phase))) / (2 * H)
        speed_dot = (ahead.speed - behind.speed) / (2 * H)
        view = _true_view(ctrl, X, U[1], t)
        np.testing.assert_allclose(view.rate, rate, atol=1e-6 * (1 + np.max(abs(rate))))
        np.testing.assert_allclose(view.speed_dot, speed_dot, atol=1e-6)
        old = _true_view(steady, X, U[1], t)
        assert max(np.max(abs(old.rate - rate)), np.max(abs(old.speed_dot - speed_dot))) > 1e-3


@pytest.mark.parametrize('name', list(FLOWS))
def test_inversions_give_the_commanded_course_rate_and_acceleration(tmp_path, name):
    """(5.1) with f': theta' = (w - h) / g turns the course at w; (5.4) with f', f'': lambda."""
    sc = _scenario(tmp_path, name)
    ctrl = Controller(sc)
    rng = np.random.default_rng(5)
    for t, X, _ in _samples(sc):
        f = ctrl.plant.flow(t, X[0], X[1])
        lam = rng.uniform(-0.5, 0.5, X.shape[1])
        U = np.zeros((2, X.shape[1]))
        U[1] = control.body_accel_from_inertial(lam, X[2], X[3], f, ctrl.jet(X, f))
        plus = models.integrate(X, U, H / 4, 4, ctrl.plant, t)
        minus = models.integrate(X, U, -H / 4, 4, ctrl.plant, t)
        fd = (_true_view(ctrl, plus, None, t + H).rate
              - _true_view(ctrl, minus, None, t - H).rate) / (2 * H)
        np.testing.assert_allclose(fd, lam, atol=1e-6)
        w = rng.uniform(-1.0, 1.0, X.shape[1])
        first = X.copy()
        first[models.ROW_OMEGA] = control.body_rate_from_inertial(w, X[2], f, ctrl.jet(X, f))
        plant = models.Plant.of(scenario.resolve({**sc.to_dict(), 'model': 'first_order',
                                                  'controller': 'first_order'}))
        U1 = np.vstack([np.zeros(X.shape[1]), first[models.ROW_OMEGA]])
        plus = models.integrate(first, U1, H / 4, 4, plant, t)
        minus = models.integrate(first, U1, -H / 4, 4, plant, t)
        course = [np.angle(np.exp(1j * Z[2]) + ctrl.plant.flow(s, Z[0], Z[1]))
                  for s, Z in ((t + H, plus), (t - H, minus))]
        np.testing.assert_allclose(np.angle(np.exp(1j * (course[0] - course[1]))) / (2 * H), w,
                                   atol=1e-6)


LYAPUNOV_FLOWS = {
    'time_varying': FLOWS['time_varying'],
    'shear': FLOWS['shear'],
    'vortex': {'flow_model': 'vortex', 'flow_circulation': 3.0, 'flow_radius': 1.0,
               'flow_center': [4.0, 0.0]},
}
"""Flows smooth along the paths: a shear layer wider than the fleet, a vortex core it avoids."""


def _lyapunov_series(sc, rates):
    """Return V_c of the true view along a run whose laws take the flow's rates or not."""
    st, truth = Stepper(sc), Controller(sc)
    st.ctrl.rates = rates
    values, far = [], np.inf
    for _ in range(int(round(sc.duration / sc.dt_control))):
        st.command()
        values.append(laws.composite_lyapunov(truth.formation,
                                              _true_view(truth, st.X, st.U[1], st.t)))
        if sc.flow_model == 'vortex':
            far = min(far, np.min(abs(models.position(st.X) - complex(*sc.flow_center))))
        st.advance()
    if sc.flow_model == 'vortex':
        assert far > sc.flow_radius                       # never in the core: f is smooth
    return np.array(values)


@pytest.mark.slow
@pytest.mark.parametrize('name', list(LYAPUNOV_FLOWS))
def test_composite_lyapunov_never_increases_in_a_known_flow_that_varies(name):
    """
    V_c' = -K sum G_k^2 - kappa sum z_k^2 <= 0 with the true Omega, s' (errata).

    The uniform-flow law's V_c stalls: after 8 s it is more than 5 times this law's (12-90).
    """
    sc = scenario.resolve({'num_vehicles': 6, 'model': 'second_order', 'formation': 'circular',
                           'seed': 3, 'dt_control': 0.002, 'dt_integration': 0.002,
                           'duration': 8.0, 'init_box': 1.0, **LYAPUNOV_FLOWS[name]})
    v = _lyapunov_series(sc, True)
    assert v[-1] < 1e-3 * v[0]
    assert np.max(np.diff(v)) <= 1e-6 * v[0]
    assert _lyapunov_series(sc, False)[-1] > 5 * v[-1]
