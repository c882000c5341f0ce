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
A parameter the run does not read is refused (or warned about), never accepted in silence.

Each parameter states in the table which configurations read it (:attr:`parameters.Spec.reads`,
:data:`parameters.READERS`); issue 43, item 5. The walk covers every parameter and every
configuration axis; the messages of the package name only parameters that exist.
"""
import ast
from dataclasses import replace
import itertools
from pathlib import Path
import re

from formation_control import core
from formation_control.core import aircraft, graphs, parameters
from formation_control.core.errors import ScenarioError
from formation_control.core.parameters import CHOICES, DEFAULTS, PARAMETERS, READERS
from formation_control.core.scenario import resolve
from formation_control.core.vehicles import MODEL_NAMES
import pytest

BASE = {'num_vehicles': 6, 'duration': 1.0}
NOT_READ = 'not read by this run: it applies to'
AXES = sorted({r.axis for r in READERS.values()})


def values_of(axis):
    """Return every value a configuration axis takes."""
    return MODEL_NAMES if axis == 'model' else CHOICES[axis]


def probe(name):
    """Return a valid value of parameter ``name`` other than its default."""
    default, spec = getattr(DEFAULTS, name), PARAMETERS[name]
    special = {'jsbsim_aircraft': 'c182', 'flow_grid_file': 'flow.npz', 'informed': [1],
               'graph_offsets': [1, 2], 'graph_edges': [1, 2, 2, 3, 3, 4, 4, 5, 5, 6],
               'graph_degree': 3.0, 'airspeed': 55.0, 'flow_shear': 0.05, 'max_airspeed': 60.0,
               'geodetic_origin': [40.0, -76.94], 'pattern_M': 3}
    if name in special:
        return special[name]
    if spec.choices:
        return next(c for c in spec.choices if c != default)
    if isinstance(default, bool):
        return not default
    if isinstance(default, int):
        return default + 1
    if isinstance(default, float):
        return 1.5 * default if default else (-0.5 if spec.high == 0 else 0.5)
    if isinstance(default, tuple):
        return [1.0, 1.0] if len(default) == 2 else [1.0] * BASE['num_vehicles']
    raise AssertionError(name)


def readable(values):
    """Return ``values`` with the axes its parameters need to be read (their own too)."""
    values = dict(values)
    for _ in range(len(AXES)):
        for name in list(values):
            for reader in map(READERS.__getitem__, PARAMETERS[name].reads):
                now = values.get(reader.axis, getattr(DEFAULTS, reader.axis))
                if now not in reader.values:
                    values[reader.axis] = reader.values[0]
    return values


def outside(reader):
    """Return a value of the reader's axis it does not read: the default, or the first other."""
    default = getattr(DEFAULTS, reader.axis)
    return default if default not in reader.values else next(
        v for v in values_of(reader.axis) if v not in reader.values)


def scenario_of(values):
    """Return a :class:`Scenario` of ``values`` without the checks (lists as tuples)."""
    return replace(DEFAULTS, **{k: tuple(v) if isinstance(v, list) else v
                                for k, v in {**BASE, **values}.items()})


COMPANIONS = {'flow_period': {'flow_amplitude': 0.2}, 'flow_shear_width': {'flow_shear': 0.02},
              'flow_shear': {'flow_shear_width': 5.0}, 'flow_center': {'flow_circulation': 0.5},
              'flow_radius': {'flow_circulation': 0.5},
              'max_turn_rate': {'controller': 'first_order'},
              'K_P': {'model': 'rigid_couple'}, 'K_I': {'model': 'rigid_couple'},
              'law_variant': {'model': 'rigid_couple'},
              'jsbsim_aircraft': {'airspeed': 55.0}}
"""What else a run that reads a parameter needs to be valid (the probe alone is not)."""
READ_BY_SOME = [name for name, spec in PARAMETERS.items() if spec.reads]


def test_every_reader_is_one_value_set_of_an_axis_and_named_in_the_table():
    for name, spec in PARAMETERS.items():
        assert set(spec.reads) <= set(READERS), name
    for text, reader in READERS.items():
        assert reader.text == text
        assert set(reader.values) < set(values_of(reader.axis)), text
    assert {'plant_backend', 'model', 'formation', 'controller', 'flow_source', 'flow_estimator',
            'flow_model', 'position_filter', 'pattern', 'graph', 'safety'} == set(AXES)


@pytest.mark.parametrize('name', READ_BY_SOME)
def test_a_value_where_the_run_does_not_read_it_is_refused_naming_what_reads_it(name):
    for reader in map(READERS.__getitem__, PARAMETERS[name].reads):
        values = readable({name: probe(name)})
        values = readable({**values, reader.axis: outside(reader)})
        values[reader.axis] = outside(reader)
        for other in [n for n, _ in parameters.unread(scenario_of(values)) if n != name]:
            del values[other]                        # an axis only the others' readers need
        sc = scenario_of(values)
        failing = [r for r in map(READERS.__getitem__, PARAMETERS[name].reads) if not r.holds(sc)]
        assert reader in failing
        reader = min(failing, key=lambda r: bool(r.shared))
        value = repr(probe(name)).replace('[', r'\[').replace('(', r'\(')
        message = (rf"parameter '{name}' = {value} is (invalid: )?{NOT_READ} "
                   rf'{re.escape(reader.text)} only '
                   rf"\({reader.axis} is '{getattr(sc, reader.axis)}'\)")
        if not reader.shared:
            with pytest.raises(ScenarioError, match=message + '.*; leave it out$'):
                resolve({**BASE, **values})
        else:
            notes = parameters.check_read(scenario_of(values))
            assert len(notes) == 1 and re.match(message + ': ignored', notes[0]), notes
            try:
                assert any(re.match(message, w) for w in resolve({**BASE, **values}).warnings)
            except ScenarioError as err:             # refused for another reason, named
                assert NOT_READ not in str(err)


@pytest.mark.parametrize('name', READ_BY_SOME)
def test_a_value_where_the_run_reads_it_is_accepted(name):
    values = readable({**COMPANIONS.get(name, {}), name: probe(name)})
    if name == 'flow_grid_file':                     # no such file: refused for that
        with pytest.raises(ScenarioError, match="'flow_grid_file' = 'flow.npz' is invalid: no "
                           'such file'):
            resolve({**BASE, **values})
        return
    sc = resolve({**BASE, **values})
    assert getattr(sc, name) == scenario_of({name: probe(name)}).__getattribute__(name)
    assert not [w for w in sc.warnings if NOT_READ in w]


@pytest.mark.parametrize('name', list(PARAMETERS))
def test_every_axis_value_that_keeps_the_readers_leaves_the_parameter_read(name):
    mine = {READERS[r].axis for r in PARAMETERS[name].reads}
    for axis in AXES:
        for value in values_of(axis):
            values = readable({name: probe(name), axis: value})
            if values[axis] != value or any(values.get(a, getattr(DEFAULTS, a)) != v
                                            for a, v in readable({name: probe(name)}).items()
                                            if a in mine):
                continue                             # the axis is one of the parameter's own
            assert name not in [n for n, _ in parameters.unread(scenario_of(values))], (
                axis, value)
    every = [dict(zip(mine, combo)) for combo in itertools.product(
        *(values_of(a) for a in sorted(mine)))] if mine else [{}]
    for combo in every:
        sc = scenario_of({**combo, name: probe(name)})
        holds = all(READERS[r].holds(sc) for r in PARAMETERS[name].reads)
        assert (name in [n for n, _ in parameters.unread(sc)]) == (not holds), combo


@pytest.mark.parametrize('changes, match', [
    ({'turbulence': 3}, r"'turbulence' = 3 is invalid: not read by this run: it applies to "
                        r"plant_backend jsbsim only \(plant_backend is 'native'\)"),
    ({'flow_gain': 2.0}, r"'flow_gain' = 2.0 is invalid: not read by this run: it applies to "
                         r"flow_source estimated only \(flow_source is 'known'\)"),
    ({'K_f': 2.0}, r"'K_f' = 2.0 is invalid: not read by this run: it applies to rigid bodies "
                   r"only \(model is 'second_order'\)"),
    ({'filter_drift': 0.1, 'gnss_sigma': 0.5}, r"'filter_drift' = 0.1 is invalid: not read by "
     r"this run: it applies to position_filter kalman only \(position_filter is 'none'\)"),
    ({'bank_limit': 0.6}, r"'bank_limit' = 0.6 is invalid: .* plant_backend jsbsim only"),
    ({'graph_edges': [1, 2, 2, 3], 'graph': 'ring'}, r"'graph_edges' = \[1, 2, 2, 3\] is "
     r"invalid: not read by this run: it applies to graph explicit only \(graph is 'ring'\)"),
    ({'graph_offsets': [2]}, r"'graph_offsets' = \[2\] is invalid: .* graph circulant only"),
    ({'flow_observer_l1': 3.0, 'flow_source': 'estimated'}, r"'flow_observer_l1' = 3.0 is "
     r"invalid: .* flow_estimator observer only \(flow_estimator is 'filter'\)"),
])
def test_the_plausible_mistakes_of_issue_43_are_refused(changes, match):
    with pytest.raises(ScenarioError, match=match):
        resolve({**BASE, **changes})


def test_omega0_on_a_parallel_formation_is_warned_about_as_a_shared_files_gain():
    sc = resolve({**BASE, 'omega0': 0.5, 'kappa': 3.0, 'controller': 'backstepping'})
    assert [w for w in sc.warnings if NOT_READ in w] == [
        "parameter 'omega0' = 0.5 is not read by this run: it applies to formation circular only "
        "(formation is 'parallel'): ignored (warned, not refused: a fleet file is often flown in "
        'both formations (-p formation:=...))']
    sc = resolve({**BASE, 'omega0': 0.5, 'formation': 'circular'})
    assert not [w for w in sc.warnings if NOT_READ in w] and sc.omega0 == 0.5


SNAKE = re.compile(r'(?<![\w./])([a-z][a-z0-9]+(?:_[a-z][a-z0-9]+)+)(?![\w(/])')
QUOTED = re.compile(r"(?:'|`)(\w+)(?:'|`) = ")


def message_words():
    """Return the snake_case words and the ``'name' =`` names of the strings of core's code."""
    words = {}
    for path in Path(core.__file__).parent.rglob('*.py'):
        tree = ast.parse(path.read_text(encoding='utf-8'))
        docs = {id(node.body[0].value) for node in ast.walk(tree)
                if isinstance(node, (ast.Module, ast.FunctionDef, ast.ClassDef)) and node.body
                and isinstance(node.body[0], ast.Expr)}
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and (
                    id(node) not in docs and ' ' in node.value):
                for word in SNAKE.findall(node.value) + QUOTED.findall(node.value):
                    words.setdefault(word, path.name)
    return words


def test_the_messages_name_only_parameters_that_exist():
    functions = {'slot_traps': graphs, 'fly_demand': aircraft}   # named in messages
    config = Path(__file__).resolve().parents[2] / 'config'
    scenarios = {p.stem for p in config.glob('*.yaml')}
    allowed = (set(PARAMETERS) | {v for c in CHOICES.values() for v in c} | set(MODEL_NAMES)
               | set(functions) | scenarios)
    for name, module in functions.items():
        assert callable(getattr(module, name))
    words = message_words()
    assert {'flow_gain', 'plant_backend', 'bank_limit'} <= set(words)   # the scan sees them
    unknown = {w: where for w, where in words.items() if w not in allowed}
    assert not unknown, f'messages name parameters that do not exist: {unknown}'


def test_the_docs_table_says_what_reads_each_parameter():
    table = parameters.markdown()
    assert '| read by |' in table
    for name in PARAMETERS:
        assert re.search(rf'^\| `{name}` \|.*\| {re.escape(parameters.read_by(name))} \|', table,
                         re.M), name
    assert parameters.read_by('turbulence') == 'plant_backend jsbsim'
    assert parameters.read_by('K_P') == 'rigid bodies and controller pi (else warned)'
    assert parameters.read_by('seed') == 'every run'
