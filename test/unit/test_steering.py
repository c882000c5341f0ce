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
The steering-law table (core/steering.py): one object per ``controller``.

Each law's bandwidth is its gain's modulus, its phase acceleration is the law of core/laws.py,
its actuator-lag limit the Routh bound of docs/errata.md; a law without a derived limit raises
naming itself instead of passing as stable under any lag.
"""
from formation_control.core import laws, parameters, scenario
from formation_control.core.control import Controller
from formation_control.core.steering import law, LAWS, NoLagLimit, SteeringLaw
import numpy as np
import pytest


def test_the_table_holds_every_controller_by_its_name():
    assert tuple(LAWS) == parameters.CONTROLLERS
    assert all(steer.name == name for name, steer in LAWS.items())
    gains = {name: steer.gain for name, steer in LAWS.items()}
    assert gains == {'first_order': 'K', 'backstepping': 'kappa', 'proportional': 'K_p',
                     'pi': 'K_P'}


@pytest.mark.parametrize('name, model, value', [('backstepping', 'second_order', 3.0),
                                                ('proportional', 'second_order', 4.0),
                                                ('pi', 'rigid_couple', 7.0),
                                                ('first_order', 'first_order', -2.0)])
def test_the_bandwidth_is_the_modulus_of_the_laws_gain(name, model, value):
    params = {'controller': name, 'model': model, LAWS[name].gain: value}
    sc = scenario.resolve(params)
    assert law(sc) is LAWS[name] and law(sc).bandwidth(sc) == abs(value)


def test_the_lag_limit_is_the_routh_bound_of_each_law():
    assert LAWS['backstepping'].lag_limit(5.0, 1.0) == pytest.approx(1.2)
    assert LAWS['proportional'].lag_limit(5.0, 1.0) == pytest.approx(1.0)
    tau = LAWS['pi'].lag_limit(10.0, 1.0, 15.0)
    for t, stable in ((0.99 * tau, True), (1.01 * tau, False)):
        roots = np.roots([t, 1.0, 10.0, 10.0 + 15.0, 15.0])
        assert np.all(roots.real < 0) == stable
    assert LAWS['first_order'].lag_limit(5.0, 1.0) == np.inf


def test_a_law_without_a_derived_lag_limit_raises_naming_itself():
    class Bang(SteeringLaw):
        name = 'bang_bang'
        gain = 'kappa'

    with pytest.raises(NoLagLimit, match="'bang_bang'.*'actuator_lag'"):
        Bang().lag_limit(5.0, 1.0)
    with pytest.raises(NoLagLimit, match="'bang_bang'.*'actuator_lag'"):
        Bang().lag_loop(0.1, 5.0)


@pytest.mark.parametrize('name, gain, f, K_I', [('backstepping', 2.5, 0.7, 0.0),
                                                ('proportional', 3.0, 0.4, 0.0),
                                                ('pi', 6.0, 0.8, 4.0)])
def test_each_laws_lag_loop_closed_on_the_formation_rate_gives_its_lag_limit(name, gain, f, K_I):
    """``s P + f Phi`` (phi = -f e, v = s e) is Hurwitz below lag_limit and not above it."""
    steer = LAWS[name]
    tau = steer.lag_limit(gain, f, K_I)
    for t, stable in ((0.99 * tau, True), (1.01 * tau, False)):
        P, Phi, _ = steer.lag_loop(t, gain, K_I)
        loop = np.polyadd(np.polymul([1.0, 0.0], P), f * Phi)
        assert bool(np.all(np.roots(loop).real < 0)) == stable


def test_the_phase_acceleration_is_the_law_of_core_laws():
    rng = np.random.default_rng(3)
    n = 5
    view = laws.View(rng.normal(size=n) + 1j * rng.normal(size=n), rng.uniform(-3, 3, n),
                     rng.normal(size=n), np.ones(n), np.zeros(n))
    sc = scenario.resolve({'num_vehicles': n, 'kappa': 3.0, 'K_p': 2.0})
    f = Controller(sc).formation
    lam, kept = LAWS['backstepping'].phase_accel(f, view, slice(None), sc, None)
    np.testing.assert_array_equal(lam, laws.backstepping(f, view, 3.0))
    assert kept is None
    lam, _ = LAWS['proportional'].phase_accel(f, view, slice(None), sc, None)
    np.testing.assert_array_equal(lam, laws.proportional(f, view, 2.0))
    err = f.terms(view, slice(None)).phi - view.rate
    lam, integral = LAWS['pi'].phase_accel(f, view, slice(None), sc, None)
    np.testing.assert_allclose(integral, err * sc.dt_control)
    np.testing.assert_allclose(lam, sc.K_P * err + sc.K_I * err * sc.dt_control)
    with pytest.raises(TypeError, match='first_order'):
        LAWS['first_order'].phase_accel(f, view, slice(None), sc, None)
