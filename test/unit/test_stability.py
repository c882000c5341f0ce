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

"""Numerical safety: step limits derived from the model, a diverging run stopped with its cause."""
import warnings

from formation_control import cli
from formation_control.core import models, stability
from formation_control.core.scenario import resolve
from formation_control.protocol.fleet import FleetPlant
import numpy as np
import pytest

RIGID = {'model': 'rigid', 'num_vehicles': 3}


def test_the_limits_are_those_of_rk4_and_of_a_held_command():
    def rk4(z):
        return 1 + z + z ** 2 / 2 + z ** 3 / 6 + z ** 4 / 24
    assert abs(rk4(-stability.RK4_LIMIT + 0.005)) < 1 < abs(rk4(-stability.RK4_LIMIT - 0.005))

    def held(gT):                              # e -> (1 - g T) e over one held period
        return abs(1 - gT)
    assert held(stability.HOLD_LIMIT - 0.005) < 1 < held(stability.HOLD_LIMIT + 0.005)


def test_the_surge_drag_rate_is_the_linearised_model():
    sc = resolve(RIGID)
    plant = models.Plant.of(sc)
    X = np.zeros((6, 2))
    X[models.ROW_U] = sc.u0 + np.array([-1e-6, 1e-6])
    du, _, _ = models.body_accel(X, np.array([[sc.h * sc.u0 ** 2] * 2, [0.0, 0.0]]), plant)
    rate = -(du[1] - du[0]) / 2e-6
    (drag,) = [m for m in stability.modes(sc) if m[0] == 'surge drag']
    assert drag[2] == pytest.approx(rate, rel=1e-6) and drag[2] == 10.0


def test_a_step_too_large_for_the_fastest_mode_is_warned_about():
    assert resolve(RIGID).warnings == ()
    (note,) = resolve({**RIGID, 'dt_integration': 0.025, 'dt_control': 0.25,
                       'record_dt': 0.25}).warnings
    assert note.startswith('dt_control = 0.25 s against the steering loop kappa = 5 1/s')
    (note,) = resolve({**RIGID, 'dt_integration': 0.2, 'dt_control': 0.2,
                       'record_dt': 0.2}).warnings
    assert 'dt_integration = 0.2 s against the surge drag 2 h u0 / m0 = 10 1/s' in note
    assert 'dt_integration <= 0.279 s' in note and 'may oscillate or diverge' in note


def test_a_diverging_run_stops_with_its_time_vehicle_and_cause(capsys):
    with warnings.catch_warnings():
        warnings.simplefilter('error')                   # no numpy overflow warning at all
        code = cli.main(['sim', 'rigid_circular', '-p', 'dt_control:=0.5', '-p',
                         'dt_integration:=0.25', '-p', 'record_dt:=0.5'])
    err = capsys.readouterr().err
    assert code == 2
    assert 'warning: dt_control = 0.5 s against the steering loop kappa' in err
    assert 'the run will diverge' in err
    assert 'error: the integration diverged at t = 1.000 s: vehicle ' in err
    assert 'Likely cause: dt_control = 0.5 s against the steering loop kappa = 5 1/s: ' \
           'kappa * dt_control = 2.5 (stable below 2; dt_control <= 0.4 s)' in err


def test_the_plant_stops_a_vehicle_whose_state_explodes_before_it_overflows():
    fleet = FleetPlant(resolve(RIGID))
    fleet.stepper.X[models.ROW_U, 1] = 2 * stability.EXPLODING
    fleet.hold([False] * 3, True)
    assert fleet.integrate().tolist() == [1]
    assert fleet.stopped.tolist() == [False, True, False]
