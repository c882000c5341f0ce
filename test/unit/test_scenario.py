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
Scenario validation, the shipped configs, overrides and initial states.

Every kind of bad input is refused before anything runs, with a message that names the
parameter and what it may be.
"""
from dataclasses import fields
import json
import math
from pathlib import Path
import re

from formation_control.core import parameters, scenario
from formation_control.core.errors import ScenarioError, UsageError
from formation_control.core.parameters import (PARAMETER_NAMES, parse_override, read_params,
                                               Scenario)
from formation_control.core.scenario import initial_state, load, resolve
from formation_control.core.steering import held_force_loop_gain, rhp_zero
from formation_control.protocol import node_parameters
import numpy as np
import pytest

CONFIGS = sorted((Path(__file__).resolve().parents[2] / 'config').glob('*.yaml'))
RIGID = {'model': 'rigid', 'num_vehicles': 5}
INIT_ARRAYS = ('init_x', 'init_y', 'init_theta', 'init_omega', 'init_u', 'init_v')


def _refused(match, **params):
    with pytest.raises(ScenarioError, match=match) as info:
        resolve(params)
    return str(info.value)


def _write(path, text):
    path.write_text(text, encoding='utf-8')
    return path


# --- formation gains -------------------------------------------------------------------------

def test_parallel_needs_negative_K():
    _refused(r"parameter 'K' = 1\.0 is invalid: formation parallel needs K < 0",
             formation='parallel', K=1.0)


def test_circular_needs_positive_K():
    _refused(r"parameter 'K' = -1\.0 is invalid: formation circular needs K > 0",
             formation='circular', K=-1.0)


@pytest.mark.parametrize('formation, rule', [('parallel', 'K < 0'), ('circular', 'K > 0')])
def test_explicit_K_zero_is_refused(formation, rule):
    _refused(rf"parameter 'K' = 0\.0 is invalid: formation {formation} needs {rule}",
             formation=formation, K=0)


@pytest.mark.parametrize('formation, K', [('parallel', -1.0), ('circular', 1.0)])
def test_K_omitted_takes_the_thesis_value(formation, K):
    sc = resolve({'formation': formation})
    assert sc.K == K
    assert isinstance(sc.K, float)


def test_circular_needs_nonzero_omega0():
    _refused(r"parameter 'omega0' = 0\.0 is invalid: formation circular needs omega0 != 0",
             formation='circular', omega0=0)
    assert resolve({'formation': 'circular', 'omega0': -0.5}).omega0 == -0.5


# --- flow ------------------------------------------------------------------------------------

@pytest.mark.parametrize('model, controller', [('second_order', 'backstepping'),
                                               ('first_order', 'first_order')])
@pytest.mark.parametrize('flow', [[1.0, 0.0], [0.6, 0.8], [0.0, -1.5]])
def test_unit_speed_particles_need_flow_below_one(model, controller, flow):
    _refused(r"parameter 'flow' = \[.*\] is invalid: unit-speed particles need \|flow\| < 1 m/s",
             model=model, controller=controller, flow=flow)
    assert resolve({'model': model, 'controller': controller, 'flow': [0.99, 0.0]}).flow == (
        0.99, 0.0)


@pytest.mark.parametrize('u0, flow', [(1.0, [1.0, 0.0]), (2.0, [1.2, 1.6]), (2.0, [0.0, 2.5])])
def test_rigid_bodies_need_flow_below_u0(u0, flow):
    _refused(rf"parameter 'flow' = \[.*\] is invalid: rigid bodies need \|flow\| < u0 = {u0} m/s",
             **RIGID, u0=u0, flow=flow)


def test_rigid_flow_between_one_and_u0_is_accepted():
    assert resolve(dict(RIGID, u0=2.0, flow=[1.5, 0.0])).flow_c == 1.5


# --- gains and time steps --------------------------------------------------------------------

@pytest.mark.parametrize('value', [0, -1.0])
@pytest.mark.parametrize('name, base', [('kappa', {}), ('K_p', {}), ('K_f', RIGID),
                                        ('K_P', RIGID), ('u0', RIGID), ('m0', RIGID),
                                        ('I0', RIGID), ('l', RIGID), ('h', RIGID)])
def test_non_positive_gain_is_refused(name, base, value):
    _refused(rf"parameter '{name}' = {float(value)!r} is invalid: must be > 0",
             **base, **{name: value})


def test_negative_K_I_is_refused():
    _refused(r"parameter 'K_I' = -0\.5 is invalid: must be >= 0", **RIGID, K_I=-0.5)
    assert resolve(dict(RIGID, K_I=0)).K_I == 0.0


@pytest.mark.parametrize('value', [0, -0.1])
@pytest.mark.parametrize('name', ['dt_control', 'dt_integration', 'duration', 'record_dt',
                                  'init_box'])
def test_non_positive_time_step_or_size_is_refused(name, value):
    _refused(rf"parameter '{name}' = {float(value)!r} is invalid: must be > 0", **{name: value})


@pytest.mark.parametrize('dt_integration', [0.003, 0.015, 0.04])
def test_dt_integration_must_divide_dt_control(dt_integration):
    _refused(rf"parameter 'dt_integration' = {dt_integration} is invalid: must divide "
             r'dt_control = 0\.02 into a whole number of steps', dt_integration=dt_integration)


@pytest.mark.parametrize('dt_control, dt_integration, substeps',
                         [(0.02, 0.002, 10), (0.3, 0.1, 3), (0.05, 0.05, 1)])
def test_dt_integration_dividing_dt_control_is_accepted(dt_control, dt_integration, substeps):
    sc = resolve({'dt_control': dt_control, 'dt_integration': dt_integration,
                  'record_dt': dt_control})
    assert sc.substeps == substeps


@pytest.mark.parametrize('name, value', [('duration', 10.01), ('record_dt', 0.03),
                                         ('record_dt', 0.01)])
def test_duration_and_record_dt_are_whole_control_periods(name, value):
    _refused(rf"parameter '{name}' = {value} is invalid: must be a whole number \(>= 1\) of "
             r'control periods dt_control = 0\.02', **{name: value})


# --- names, lengths, values, types -----------------------------------------------------------

@pytest.mark.parametrize('names, shown', [
    (['kapa'], "unknown parameter 'kapa' (did you mean 'kappa'?)"),
    (['Kp', 'numVehicles'], "unknown parameters 'Kp' (did you mean 'K_p'?), 'numVehicles' (did "
     "you mean 'num_vehicles'?)"),
    (['warnings'], "unknown parameter 'warnings'")])
def test_unknown_parameter_names_its_near_miss_in_one_short_line(names, shown):
    message = _refused(re.escape(shown), **dict.fromkeys(names, 1))
    assert message == shown + '; every parameter: formation-control params (docs/parameters.md)'
    assert len(message) < 200


@pytest.mark.parametrize('name, value', [('flow', [0.1, 0.0, 0.0]), ('c0', [1.0]),
                                         ('flow', []), ('c0', [1.0, 2.0, 3.0])])
def test_flow_and_c0_need_two_entries(name, value):
    _refused(rf"parameter '{name}' = \[.*\] is invalid: must be a list of 2 numbers \[x, y\]",
             **{name: value})


@pytest.mark.parametrize('count', [3, 5])
@pytest.mark.parametrize('name', INIT_ARRAYS)
def test_init_arrays_need_one_entry_per_vehicle(name, count):
    _refused(rf"parameter '{name}' = \[.*\] is invalid: must have num_vehicles = 4 entries",
             **RIGID | {'num_vehicles': 4}, **{name: [1.0] * count})


@pytest.mark.parametrize('name, value', [('K', float('nan')), ('kappa', float('nan')),
                                         ('kappa', float('inf')), ('omega0', -float('inf')),
                                         ('duration', float('inf'))])
def test_nan_and_inf_scalars_are_refused(name, value):
    _refused(rf"parameter '{name}' = .* is invalid: must be finite \(no NaN or inf\)",
             **{name: value})


@pytest.mark.parametrize('name, value', [('flow', [float('nan'), 0.0]),
                                         ('flow', [0.0, float('inf')]),
                                         ('c0', [float('nan'), 0.0]),
                                         ('init_x', [0.0] * 15 + [float('nan')])])
def test_nan_and_inf_in_lists_are_refused(name, value):
    _refused(rf"parameter '{name}' = .* is invalid: must be a list of finite numbers",
             **{name: value})


@pytest.mark.parametrize('name, value, rule', [
    ('num_vehicles', '3', 'must be an integer'),
    ('num_vehicles', 2.5, 'must be an integer'),
    ('num_vehicles', True, 'must be an integer'),
    ('seed', 'one', 'must be an integer'),
    ('model', 1, 'must be one of first_order | second_order | rigid'),
    ('formation', None, 'must be one of parallel | circular'),
    ('K', '-1', 'must be a number'),
    ('kappa', True, 'must be a number'),
    ('cancel_drag_moment', 1, 'must be true or false'),
    ('flow', 0.5, 'must be a list'),
    ('flow', [0.1, 'a'], 'must be a list of finite numbers'),
    ('informed', '1', 'must be a list'),
    ('informed', [1.5], r'must be a list of vehicle ids \(integers\)'),
])
def test_wrong_type_is_refused(name, value, rule):
    _refused(rf"parameter '{name}' = .* is invalid: {rule}", **{name: value})


def test_integral_float_is_accepted_as_integer():
    sc = resolve({'num_vehicles': 3.0, 'informed': [2.0]})
    assert sc.num_vehicles == 3 and isinstance(sc.num_vehicles, int)
    assert sc.informed == (2,) and isinstance(sc.informed[0], int)


def test_num_vehicles_must_be_at_least_one():
    _refused(r"parameter 'num_vehicles' = 0 is invalid: must be >= 1", num_vehicles=0)


@pytest.mark.parametrize('name, value, allowed', [
    ('model', 'boat', 'first_order | second_order | rigid | rigid_couple | rigid_cop | vessel'),
    ('formation', 'line', 'parallel | circular'),
    ('controller', 'pid', 'first_order | backstepping | proportional | pi'),
    ('law_variant', 'exact', 'practical | full'),
    ('model', 'Rigid', 'first_order | second_order | rigid | rigid_couple | rigid_cop | vessel'),
])
def test_unknown_choice_lists_the_allowed_values(name, value, allowed):
    _refused(rf"parameter '{name}' = '{value}' is invalid: allowed values: "
             + allowed.replace('|', r'\|') + '$', **{name: value})


@pytest.mark.parametrize('model, controller', [('second_order', 'first_order'),
                                               ('first_order', 'backstepping'),
                                               ('first_order', 'proportional'),
                                               ('rigid', 'first_order')])
def test_first_order_controller_goes_with_first_order_model_only(model, controller):
    _refused(rf"parameter 'controller' = '{controller}' is invalid: model 'first_order' goes "
             r"with controller 'first_order' only", model=model, controller=controller)


@pytest.mark.parametrize('informed', [[0], [5], [1, 2, 5], [-1]])
def test_informed_ids_must_lie_in_one_to_N(informed):
    _refused(r"parameter 'informed' = \[.*\] is invalid: vehicle ids must lie in 1\.\.4",
             num_vehicles=4, informed=informed)
    assert resolve({'num_vehicles': 4, 'informed': [1, 4]}).informed_mask.tolist() == [
        1.0, 0.0, 0.0, 1.0]


@pytest.mark.parametrize('init_u', [[1.0, 0.0, 1.0], [1.0, 1.0, -0.5]])
def test_rigid_bodies_start_with_positive_u(init_u):
    _refused(r"parameter 'init_u' = \[.*\] is invalid: rigid bodies start with forward speed "
             r'u > 0 m/s', **RIGID | {'num_vehicles': 3}, init_u=init_u)


# --- physical conditions of the rigid-body laws ----------------------------------------------

@pytest.mark.parametrize('model', ['rigid', 'rigid_cop'])
def test_right_half_plane_zero_far_below_bandwidth_is_refused(model):
    params = dict(RIGID, model=model, I0=1.0, kappa=5.0)
    message = _refused(r'right-half-plane zero at u0\*sqrt\(h\*l/I0\) = 1\.58 rad/s, below half '
                       r'the steering bandwidth 5 rad/s', **params)
    assert 'parameters u0, h, l, I0' in message
    sc = resolve(dict(params, kappa=3.0))
    assert rhp_zero(sc) == pytest.approx(math.sqrt(2.5))
    assert 'right-half-plane zero' in sc.warnings[0]


def test_right_half_plane_zero_below_bandwidth_only_warns():
    sc = resolve(dict(RIGID, I0=0.25))
    assert len(sc.warnings) == 1
    assert 'right-half-plane zero u0*sqrt(h*l/I0) = 3.16 rad/s' in sc.warnings[0]
    assert resolve(RIGID).warnings == ()


def test_moment_couple_has_no_tail_zero_check():
    assert resolve(dict(RIGID, model='rigid_couple', I0=1.0, kappa=5.0)).warnings == ()


@pytest.mark.parametrize('h', [1.0, 1.5])
def test_pi_needs_drag_rate_above_integral_ratio(h):
    _refused(rf'PI steering \(8\.24\) needs h\*u0/m0 = {h:g} > K_I/K_P = 1\.5 '
             r'\(parameters h, u0, m0, K_I, K_P\)',
             **dict(RIGID, model='rigid_couple', controller='pi', h=h, K_P=10.0, K_I=15.0))
    assert resolve(dict(RIGID, model='rigid_couple', controller='pi', h=1.6)).h == 1.6


def test_full_law_on_tail_steering_with_default_gains_is_refused():
    assert held_force_loop_gain(resolve(RIGID)) == pytest.approx(1.0)
    message = _refused(r'one-sample loop through the held force with gain '
                       r'bandwidth\*I0/\(l\*m0\*u0\) = 1, which must stay below 0\.8',
                       **RIGID, law_variant='full')
    assert 'law_variant' in message and 'rigid_couple' in message


def test_full_law_is_accepted_on_moment_couple_and_at_low_gain():
    assert resolve(dict(RIGID, model='rigid_couple', law_variant='full')).law_variant == 'full'
    assert resolve(dict(RIGID, law_variant='full', kappa=3.0)).law_variant == 'full'


def test_pi_on_tail_steering_with_default_gains_is_refused():
    _refused(r'held force with gain bandwidth\*I0/\(l\*m0\*u0\) = 2,', **RIGID, controller='pi')


# --- files and overrides ---------------------------------------------------------------------

def test_configs_are_shipped():
    assert len(CONFIGS) >= 14


@pytest.mark.parametrize('path', CONFIGS, ids=lambda p: p.stem)
def test_every_config_loads(path):
    params = read_params(path)
    sc = resolve(params)
    assert sc == load(path)
    assert sc.warnings == ()
    for name, value in params.items():
        expected = tuple(value) if isinstance(value, list) else value
        assert getattr(sc, name) == expected, name
    assert resolve(json.loads(sc.to_json())) == sc


def test_overrides_apply_with_the_right_types(config_dir):
    sc = load(config_dir / 'particle_parallel.yaml',
              ['num_vehicles:=3', 'flow:=[0.1, 0.0]', 'K:=-2', 'seed := 7'])
    assert sc.num_vehicles == 3 and type(sc.num_vehicles) is int
    assert sc.flow == (0.1, 0.0) and all(type(f) is float for f in sc.flow)
    assert sc.K == -2.0 and type(sc.K) is float
    assert sc.seed == 7
    assert sc.kappa == 5.0 and sc.duration == 60.0


def test_keyword_values_override_overrides_and_none_is_ignored(config_dir):
    sc = load(config_dir / 'particle_parallel.yaml', ['duration:=10.0'], duration=2.0,
              seed=None)
    assert sc.duration == 2.0
    assert sc.seed == 1


def test_bad_override_is_validated(config_dir):
    with pytest.raises(ScenarioError, match=r"parameter 'K' = 1\.0 is invalid"):
        load(config_dir / 'particle_parallel.yaml', ['K:=1.0'])


@pytest.mark.parametrize('text, expected', [('K:=-2', ('K', -2)),
                                            ('flow:=[0.1, 0.0]', ('flow', [0.1, 0.0])),
                                            ('model:=rigid', ('model', 'rigid')),
                                            (' seed := 3 ', ('seed', 3)),
                                            ('cancel_drag_moment:=false',
                                             ('cancel_drag_moment', False))])
def test_parse_override(text, expected):
    assert parse_override(text) == expected


def test_override_without_assignment_is_refused():
    with pytest.raises(ScenarioError, match=r"override 'K=1' must read name:=value"):
        parse_override('K=1')


@pytest.mark.parametrize('text', ['num_vehicles: 3\nmodel: rigid\n',
                                  'plant:\n  ros__parameters:\n    num_vehicles: 3\n',
                                  '/**:\n  parameters:\n    num_vehicles: 3\n', ''])
def test_file_without_ros_parameters_section_is_refused(tmp_path, text):
    path = _write(tmp_path / 'bare.yaml', text)
    with pytest.raises(UsageError, match=r'bare\.yaml: a scenario is a ROS 2 parameter file '
                                         r"with a '/\*\*: ros__parameters:' section"):
        load(path)


def test_empty_ros_parameters_section_gives_defaults(tmp_path):
    path = _write(tmp_path / 'empty.yaml', '/**:\n  ros__parameters:\n')
    assert read_params(path) == {}
    sc = load(path)
    assert (sc.num_vehicles, sc.model, sc.formation, sc.K) == (16, 'second_order', 'parallel',
                                                               -1.0)


def test_parameter_file_errors_name_the_parameter(tmp_path):
    path = _write(tmp_path / 's.yaml', '/**:\n  ros__parameters:\n    kappa: -2.0\n')
    with pytest.raises(ScenarioError, match=r"parameter 'kappa' = -2\.0 is invalid: must be > 0"):
        load(path)


# --- initial state ---------------------------------------------------------------------------

@pytest.mark.parametrize('params, speed', [({'model': 'second_order'}, 1.0),
                                           ({'model': 'first_order',
                                             'controller': 'first_order'}, 1.0),
                                           ({'model': 'rigid', 'u0': 1.5}, 1.5),
                                           ({'model': 'rigid_couple', 'u0': 0.7}, 0.7)])
def test_random_initial_state(params, speed):
    sc = resolve(dict(params, num_vehicles=50, seed=11))
    X = initial_state(sc)
    assert X.shape == (6, 50)
    np.testing.assert_array_equal(X, initial_state(sc))
    assert not np.allclose(X[:3], initial_state(resolve(dict(params, num_vehicles=50,
                                                             seed=12)))[:3])
    assert np.all(np.abs(X[:2]) <= 5.0)
    assert np.ptp(X[0]) > 5.0 and np.ptp(X[1]) > 5.0
    assert np.all(np.abs(X[2]) <= np.pi) and np.ptp(X[2]) > np.pi
    np.testing.assert_array_equal(X[3], 0.0)
    np.testing.assert_array_equal(X[4], speed)
    np.testing.assert_array_equal(X[5], 0.0)


def test_init_box_sets_the_square():
    X = initial_state(resolve({'num_vehicles': 40, 'init_box': 2.0}))
    assert np.all(np.abs(X[:2]) <= 1.0)


def test_explicit_initial_state_is_used():
    values = {'init_x': [1.0, -2.0, 30.0], 'init_y': [0.5, 0.0, -7.0],
              'init_theta': [0.1, 3.0, -1.0], 'init_omega': [0.2, 0.0, -0.3],
              'init_u': [0.8, 1.2, 1.0], 'init_v': [0.0, -0.1, 0.05]}
    X = initial_state(resolve(dict(values, model='rigid', num_vehicles=3)))
    np.testing.assert_array_equal(X, np.array([values[name] for name in INIT_ARRAYS]))


def test_partial_explicit_state_keeps_the_random_draw():
    base = resolve({'num_vehicles': 3, 'seed': 5})
    X = initial_state(resolve({'num_vehicles': 3, 'seed': 5, 'init_x': [7.0, 8.0, 9.0]}))
    np.testing.assert_array_equal(X[0], [7.0, 8.0, 9.0])
    np.testing.assert_array_equal(X[1:], initial_state(base)[1:])


def test_particles_keep_unit_speed_whatever_init_u():
    X = initial_state(resolve({'num_vehicles': 2, 'init_u': [0.0, 3.0],
                               'init_v': [0.5, 0.5], 'init_omega': [0.4, -0.4]}))
    np.testing.assert_array_equal(X[4], 1.0)
    np.testing.assert_array_equal(X[5], 0.0)
    np.testing.assert_array_equal(X[3], [0.4, -0.4])


# --- the parameter table ---------------------------------------------------------------------

def test_parameter_doc_is_the_generated_table():
    """docs/parameters.md is what ``formation-control params`` prints (it cannot drift)."""
    doc = Path(__file__).resolve().parents[2] / 'docs' / 'parameters.md'
    generated = parameters.markdown() + node_parameters.markdown()
    assert doc.read_text(encoding='utf-8') == generated, (
        'docs/parameters.md is stale: run formation-control params > docs/parameters.md')


def test_every_parameter_is_in_the_table_with_a_description():
    assert list(parameters.PARAMETERS) == list(PARAMETER_NAMES)
    assert {f.name for f in fields(Scenario)} == set(PARAMETER_NAMES) | {'warnings'}
    for name in PARAMETER_NAMES:
        assert parameters.PARAMETERS[name].text and parameters.describe(name), name
        assert f'| `{name}` |' in parameters.markdown()


@pytest.mark.parametrize('name', [n for n, s in parameters.PARAMETERS.items()
                                  if s.low is not None])
def test_each_range_of_the_table_is_enforced(name):
    """A value just outside the documented range is refused with that range in the message."""
    spec = parameters.PARAMETERS[name]
    value = spec.low if spec.above else spec.low - 1
    base = {} if Scenario().model in spec.models else RIGID
    _refused(rf"parameter '{name}' = .* is invalid: must be {'>' if spec.above else '>='} "
             rf'{spec.low:g}', **base, **{name: value})
    resolve(dict(base, **{name: getattr(Scenario(), name)}))


RING = {'formation': 'circular', 'graph': 'ring', 'num_vehicles': 12}


@pytest.mark.parametrize('params, match', [
    ({**RING, 'graph_nu': 0.2}, r"'graph_nu' = 0.2 is invalid: must be >= the largest degree 2"),
    ({'graph_nu': 3.0, 'num_vehicles': 6}, r"'graph_nu' = 3.0 .* largest degree 5"),
    ({**RING, 'graph_edges': [1, 2]}, r"'graph_edges' = \[1, 2\] is invalid: not read by this "
                                      r"run: it applies to graph explicit only \(graph is 'ring'"),
    ({'graph_offsets': [2]}, r"'graph_offsets' = \[2\] is invalid: not read by this run: it "
                             r'applies to graph circulant'),
    ({'graph': 'explicit', 'graph_edges': [[1, 2], [2, 3]], 'num_vehicles': 3},
     r"'graph_edges' = \[\[1, 2\], \[2, 3\]\] is invalid: .*flat list"),
    ({'flow_model': 'vortex'}, r"'flow_circulation' = 0.0 is invalid: flow_model vortex needs"),
    ({'flow_model': 'time_varying'}, r"'flow_amplitude' = 0.0 .* say flow_model: uniform"),
    ({'flow_model': 'shear'}, r"'flow_shear' = 0.0 is invalid"),
    ({'flow': [0.97, 0.0], 'flow_source': 'estimated'},
     r"'flow' = \[0.97, 0.0\] is invalid: flow_source estimated clamps each estimate to 0.95"),
    ({'formation': 'circular', 'pattern': 'splay', 'flow_model': 'vortex',
      'flow_circulation': 1.0}, r"flow_model = 'vortex' \(flow = \[0.0, 0.0\] m/s\) is not a "
                                r'zero flow'),
])
def test_parameters_that_would_be_ignored_or_mislead_are_refused_by_name(params, match):
    with pytest.raises(scenario.ScenarioError, match=match):
        resolve(params)


def test_the_largest_degree_is_a_valid_nu_and_the_estimate_below_its_clamp_runs():
    assert resolve({**RING, 'graph_nu': 2.0}).comm_graph.nu == 2.0
    assert resolve({'flow': [0.94, 0.0], 'flow_source': 'estimated'}).flow_source == 'estimated'


@pytest.mark.parametrize('period, warned', [(0.5, True), (38.0, True), (39.0, False)])
@pytest.mark.parametrize('source', ['known', 'estimated'])
def test_a_flow_turning_too_fast_for_the_steady_view_is_warned_about(period, warned, source):
    """An estimate's rate is not known; a known flow's is taken into the laws: no warning."""
    sc = resolve({'formation': 'circular', 'flow_model': 'time_varying', 'flow_amplitude': 0.3,
                  'flow_period': period, 'flow_source': source})
    notes = [w for w in sc.warnings if w.startswith(f'flow_period = {period:g} s')]
    assert bool(notes) is (warned and source == 'estimated')
    if notes:
        assert 'flow_source estimated: an estimate has no known rate' in notes[0]
        assert f'|df/dt| = 2 pi A / T = {2 * math.pi * 0.3 / period:.3g} m/s^2' in notes[0]
        assert 'Use flow_period >= 38.5 s' in notes[0]


@pytest.mark.parametrize('params, note', [
    ({'flow_source': 'estimated'}, r'the true circle is kept only to within the lag of the '
     r'estimate, \|fhat - f\| <= \|grad f\| \(speed \+ max \|f\|\) / lambda_f = 0.0625 m/s'),
    ({'model': 'rigid', 'flow_source': 'known'}, r'law_variant practical drops the rates\): the '
     r'circle is kept only approximately'),
    ({'flow_source': 'known'}, None),
    ({'model': 'rigid_couple', 'controller': 'pi', 'flow_source': 'known'}, None),
])
def test_a_shear_the_laws_take_as_uniform_is_warned_about(params, note):
    sc = resolve({'formation': 'circular', 'flow_model': 'shear', 'flow_shear': 0.05, **params})
    notes = [w for w in sc.warnings if w.startswith('flow_model shear (|grad f| up to 0.05 1/s)')]
    assert len(notes) == (note is not None)
    if note:
        assert re.search(note, notes[0]), notes[0]


@pytest.mark.parametrize('params, warned', [
    ({'flow_circulation': 2.0, 'flow_radius': 1.5}, True),       # 2 k = 0.283 > 0.1 x 0.788
    ({'flow_circulation': 1.0, 'flow_radius': 2.0}, False),      # 2 k = 0.080 < 0.1 x 0.92
    ({'flow_circulation': 2.0, 'flow_radius': 1.5, 'flow_source': 'estimated'}, False),
])
def test_a_vortex_rim_that_kicks_the_course_rate_is_warned_about(params, warned):
    sc = resolve({'formation': 'circular', 'flow_model': 'vortex', **params})
    notes = [w for w in sc.warnings if 'the gradient of the flow jumps at the rim' in w]
    assert len(notes) == warned
    if warned:
        assert 'kicked by up to 0.283 rad/s, more than 0.1 of the rate of the laws, 0.788' in \
            notes[0]


def test_an_estimate_lagging_by_half_the_speed_margin_is_refused():
    """|grad f| (1 + 0.4) / lambda_f = 0.1 x 1.4 / 0.4 = 0.35 >= (1 - 0.4) / 2: no bound."""
    params = {'formation': 'circular', 'flow_model': 'shear', 'flow_shear': 0.1,
              'flow_shear_width': 4.0, 'flow_source': 'estimated', 'flow_gain': 0.4}
    with pytest.raises(scenario.ScenarioError, match=r"'flow_model' = 'shear' is invalid: .*"
                       r'= 0.35 m/s, at least half the speed margin speed - max \|f\| = 0.6 m/s'):
        resolve(params)
    assert resolve({**params, 'flow_gain': 0.5}).flow_gain == 0.5
