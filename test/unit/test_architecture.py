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
The docs stay true to the code.

docs/architecture.md: its Layout lists every module, its floor table every floor's imports;
every repository path named in docs/ exists; core/errors.py describes every error class.

A module added without its line in the Layout fails here, naming the module and the folder
entry it belongs under.
"""
import ast
import re

from formation_control.core import errors
import pytest
from test_layers import floor, FLOORS, graph, PACKAGE

ROOT = PACKAGE.parent
DOC = ROOT / 'docs' / 'architecture.md'
FOLDERS = FLOORS[:-2]
"""The floors that are folders; ``swarm`` and ``cli`` are one module each."""
NAMED = re.compile(r'(?<![\w/.`-])(\w+)\.py\b')
"""A file name as the Layout lists a module: not a path (``bench/fleet_trace.py``), nor a file
it refers to in backquotes (```setup.py```)."""
PATH = re.compile(r'(?<![\w./-])((?:test|bench|tools|config|launch|foxglove|formation_control|'
                  r'docs|third_party|rviz)/[\w./-]*\.(?:py|c|md|yaml|xml|json|sh|txt|html|rviz|'
                  r'cfg|toml))\b')
"""A repository path with a file extension, as the docs name files."""


def layout_entries(text):
    """
    Return {entry: its text} of the Layout block.

    An entry starts at column 0 and goes on over the indented lines below it
    (``formation_control/core/``: its modules' lines).
    """
    block = text.split('## Layout', 1)[1].split('```')[1]
    entries, current = {}, None
    for line in block.splitlines():
        if line and not line[0].isspace():
            current = line.split()[0]
            entries[current] = line[len(current):]
        elif current is not None:
            entries[current] += '\n' + line
    return entries


def floor_table(text):
    """Return {floor: its "imports today" cell} of the floor table."""
    rows = re.findall(r'^\| `([\w.]+?)/?` \|.*\| (.*) \|$', text, re.MULTILINE)
    return {name.removesuffix('.py'): cell for name, cell in rows}


def test_the_layout_lists_every_module_under_its_folder():
    entries = layout_entries(DOC.read_text())
    missing, stale = [], []
    folders = [init.parent.relative_to(PACKAGE).as_posix() for top in FOLDERS
               for init in sorted((PACKAGE / top).rglob('__init__.py'))]
    for folder in folders:
        entry = f'formation_control/{folder}/'
        listed = set(NAMED.findall(entries.get(entry, '')))
        present = {p.stem for p in (PACKAGE / folder).glob('*.py') if p.stem != '__init__'}
        missing += [f'formation_control/{folder}/{m}.py' for m in sorted(present - listed)]
        stale += [f'formation_control/{folder}/{m}.py' for m in sorted(listed - present)]
    missing += [f'formation_control/{m}.py' for m in FLOORS[-2:]
                if f'formation_control/{m}.py' not in entries]
    assert not missing, (f'{DOC.name} does not list these modules: {", ".join(missing)}; '
                         f'add each as NAME.py, with what it holds, under the entry of its '
                         f'folder in the Layout')
    assert not stale, f'{DOC.name} lists modules that do not exist: {", ".join(stale)}'


def test_the_floor_table_gives_every_floor_its_imports():
    edges, _ = graph()
    table = floor_table(DOC.read_text())
    assert sorted(table) == sorted(FLOORS), f'the floor table of {DOC.name}: {sorted(table)}'
    wrong = []
    for name in FLOORS:
        i = FLOORS.index(name)
        code = {FLOORS[floor(b)] for a, targets in edges.items() if floor(a) == i
                for b in targets if floor(b) is not None and floor(b) != i}
        cell = table[name].split(';')[0]
        said = set(FLOORS[:i]) if 'every floor below' in cell else set(
            re.findall(r'`(\w+)`', cell)) & set(FLOORS)
        if said != code:
            wrong.append(f'{name}: the table says {sorted(said, key=FLOORS.index)}, the code '
                         f'imports {sorted(code, key=FLOORS.index)}')
    assert not wrong, f'the floor table of {DOC.name} is not the code: ' + '; '.join(wrong)


@pytest.mark.parametrize('page', sorted((ROOT / 'docs').rglob('*.md')),
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_every_path_the_docs_name_exists(page):
    named = sorted(set(PATH.findall(page.read_text())))
    gone = [path for path in named if not (ROOT / path).exists()]
    assert not gone, f'{page.relative_to(ROOT)} names paths that do not exist: {gone}'


def error_classes(package=PACKAGE):
    """Return the (module path, class name) of every exception class the package defines."""
    out = []
    for path in sorted(package.rglob('*.py')):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ClassDef) and any(
                    getattr(base, 'id', getattr(base, 'attr', '')).endswith(('Error', 'Exception'))
                    for base in node.bases):
                out.append((str(path.relative_to(package.parent)), node.name))
    return out


def test_the_errors_module_describes_every_error_class():
    found = error_classes()
    assert len(found) >= 12
    missing = [f'{name} ({path})' for path, name in found if f'{name}`' not in errors.__doc__]
    assert not missing, ('the docstring of formation_control/core/errors.py does not describe '
                         f'these error classes: {", ".join(missing)}')


def test_the_checks_see_a_missing_module_and_a_stale_one():
    text = ('## Layout\n\n```\nformation_control/core/    the maths:\n'
            '  models.py laws.py          models; laws, compiled (`setup.py`)\n'
            'formation_control/sim/     simulator.py (bench/fleet_trace.py reads it)\n```\n')
    entries = layout_entries(text)
    assert set(NAMED.findall(entries['formation_control/core/'])) == {'models', 'laws'}
    assert set(NAMED.findall(entries['formation_control/sim/'])) == {'simulator'}
    assert PATH.findall('see test/unit/test_scenario.py, not test/test_scenario.py.') == [
        'test/unit/test_scenario.py', 'test/test_scenario.py']
