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
The formation table (core/formations.py): one object per ``formation``.

Each formation's default and allowed K, its law object, the radius of its steady motion, the
rate its laws act at, and the names its convergence is judged by, which sim/metrics defines.
"""
from formation_control.core import laws, parameters, scenario
from formation_control.core.control import Controller
from formation_control.core.errors import ScenarioError
from formation_control.core.formations import centre_lag_limit, FORMATIONS, of
from formation_control.core.steering import NoLagLimit
from formation_control.sim import metrics
import numpy as np
import pytest
from runs import CONFIG


def test_the_table_holds_every_formation_with_its_default_gain():
    assert tuple(FORMATIONS) == parameters.FORMATIONS == ('parallel', 'circular')
    defaults = {name: f.default_K for name, f in FORMATIONS.items()}
    assert defaults == {'parallel': -1.0, 'circular': 1.0}
    for name, f in FORMATIONS.items():
        assert scenario.resolve({'formation': name}).K == f.default_K


@pytest.mark.parametrize('params, match', [
    ({'formation': 'parallel', 'K': 0.5}, r"'K' = 0.5 .*parallel needs K < 0"),
    ({'formation': 'circular', 'K': -0.5}, r"'K' = -0.5 .*circular needs K > 0"),
    ({'formation': 'circular', 'omega0': 0.0}, r"'omega0' = 0.0 .*omega0 != 0"),
])
def test_each_formation_refuses_the_gains_its_law_does_not_converge_with(params, match):
    with pytest.raises(ScenarioError, match=match):
        scenario.resolve(params)


def test_the_law_object_and_the_steady_motion_of_each_formation():
    parallel = scenario.resolve({'formation': 'parallel', 'K': -0.3})
    circular = scenario.resolve({'formation': 'circular', 'K': 0.2, 'omega0': -0.25,
                                 'c0': [1.0, 2.0], 'informed': [1]})
    f = Controller(parallel).formation
    assert isinstance(f, laws.Parallel) and f.K == -0.3
    assert of(parallel).radius(parallel) is None
    assert of(parallel).law_rate(parallel, 0.5)[0] == 0.3
    c = Controller(circular).formation
    assert isinstance(c, laws.Circular) and (c.K, c.omega0, c.c0) == (0.2, -0.25, 1 + 2j)
    assert of(circular).radius(circular) == 4.0
    assert of(circular).law_rate(circular, 0.5)[0] == 0.125


def test_the_errors_and_conditions_each_formation_names_are_defined():
    for f in FORMATIONS.values():
        assert set(f.band_errors) <= set(metrics.ERRORS) and set(f.band_errors) <= set(
            metrics.BANDS)
        assert set(f.conditions) <= set(metrics.CONDITIONS)


def _rotating_rates(z, circular, steer, tau):
    """Return the rates of (c, theta - omega0 t, rate, applied) in the frame turning at omega0."""
    c, phase, rate, applied = np.split(z, [2 * len(z) // 5, 3 * len(z) // 5, 4 * len(z) // 5])
    c = c[:len(c) // 2] + 1j * c[len(c) // 2:]
    w0 = circular.omega0
    n = len(phase)
    view = laws.View(c - 1j * np.exp(1j * phase) / w0, phase, rate, np.ones(n), np.zeros(n))
    u = steer(circular, view)
    dc = -1j * w0 * c + np.exp(1j * phase) * (1.0 - rate / w0)
    return np.concatenate([dc.real, dc.imag, rate - w0, applied, (u - applied) / tau])


def _growth(circular, steer, tau, phases):
    """Return the largest real part of the package's laws linearised on the circle, lag tau."""
    n, w0 = len(phases), circular.omega0
    z = np.concatenate([np.zeros(2 * n), phases, np.full(n, w0), np.zeros(n)])
    h, jac = 1e-6, np.empty((5 * n, 5 * n))
    for i in range(5 * n):
        dz = np.zeros(5 * n)
        dz[i] = h
        jac[:, i] = (_rotating_rates(z + dz, circular, steer, tau)
                     - _rotating_rates(z - dz, circular, steer, tau)) / (2 * h)
    ev = np.linalg.eigvals(jac)
    moving = (abs(ev) > 1e-5) & (abs(abs(ev) - abs(w0)) > 1e-5)   # not the phases, translation
    return ev[moving].real.max()


@pytest.mark.parametrize('values, steer', [
    ({'num_vehicles': 6, 'kappa': 3.0, 'K': 0.5},
     lambda f, v: laws.backstepping(f, v, 3.0)),
    ({'num_vehicles': 5, 'kappa': 4.0, 'K': 0.8, 'omega0': 0.5},
     lambda f, v: laws.backstepping(f, v, 4.0)),
    ({'num_vehicles': 4, 'controller': 'proportional', 'K_p': 2.0, 'K': 1.0, 'omega0': 2.0},
     lambda f, v: laws.proportional(f, v, 2.0)),
])
def test_the_circles_lag_limit_is_where_the_package_law_linearised_turns_unstable(values, steer):
    """The Jacobian of laws.Circular with the steering law, phases drawn, at 0.98 and 1.02."""
    sc = scenario.load(CONFIG / 'particle_circular.yaml', **values)
    limit = centre_lag_limit(sc)
    phases = np.random.default_rng(43).uniform(0.0, 2 * np.pi, sc.num_vehicles)
    circular = laws.Circular(sc.K, sc.omega0)
    assert _growth(circular, steer, 0.98 * limit, phases) < 0
    assert _growth(circular, steer, 1.02 * limit, phases) > 0


def test_the_backstepping_centre_limit_has_its_routh_closed_form():
    """``tau < (kappa + K - kappa w^2 / a1) / (1/w^2 + kappa K)``, a1 = w^2 + 1/w^2 + kappa K."""
    for kappa, K, w in ((3.0, 0.5, 1.0), (4.0, 0.8, 0.5), (2.0, 1.0, 2.0)):
        sc = scenario.load(CONFIG / 'particle_circular.yaml', kappa=kappa, K=K, omega0=w)
        a1 = w ** 2 + w ** -2 + kappa * K
        routh = (kappa + K - kappa * w ** 2 / a1) / (w ** -2 + kappa * K)
        assert centre_lag_limit(sc) == pytest.approx(routh, rel=1e-8)
        assert of(sc).lag_limit(sc)[0] == pytest.approx(min(routh, 1 / kappa + 1 / K))


def test_a_lag_on_a_circle_without_a_derived_limit_is_refused_and_first_order_has_none():
    assert centre_lag_limit(scenario.load(CONFIG / 'first_order_circular.yaml')) == np.inf
    for name, values in (('particle_circular_ring', {}), ('particle_circular_splay', {}),
                         ('particle_circular', {'informed': [1], 'c0': [1.0, 0.0]})):
        with pytest.raises(NoLagLimit, match="'actuator_lag'"):
            scenario.load(CONFIG / f'{name}.yaml', actuator_lag=0.01, **values)


def test_where_the_centre_loops_limit_is_not_derived_a_lag_is_warned_about():
    """Rigid bodies and a flow: the caveat, with the measured figures, reaches the warnings."""
    for name in ('rigid_circular', 'particle_circular_flow'):
        sc = scenario.load(CONFIG / f'{name}.yaml', actuator_lag=0.02)
        assert of(sc).lag_caveat(sc) and any(
            'actuator_lag = 0.02' in w and 'measured' in w for w in sc.warnings)
    for name in ('particle_circular', 'particle_parallel', 'rigid_parallel'):
        sc = scenario.load(CONFIG / f'{name}.yaml', actuator_lag=0.02)
        assert of(sc).lag_caveat(sc) is None and sc.warnings == ()
