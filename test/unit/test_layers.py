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
The floors of the package: every import goes down or stays level, and none goes round.

The floors, lowest first: ``core`` (the maths), ``sim`` (offline study), ``protocol`` (the
pure rules of the nodes), ``view``, ``bags``, ``ops``, ``ros`` (the nodes), ``swarm``, ``cli``.
Every import is counted, those inside functions and those for the type checker alone
(``if TYPE_CHECKING:``) too, so a circle cannot hide in either.
"""
import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / 'formation_control'
FLOORS = ('core', 'sim', 'protocol', 'view', 'bags', 'ops', 'ros', 'swarm', 'cli')
PURE = ('core', 'sim', 'protocol')
ROS_PREFIXES = ('rclpy', 'rcl_interfaces', 'rosidl', 'geometry_msgs', 'nav_msgs', 'std_msgs',
                'sensor_msgs', 'builtin_interfaces', 'rosgraph_msgs', 'visualization_msgs',
                'diagnostic_msgs')
"""ament_index_python is left out: it is pure Python, and ``parameters.find`` asks it for the
installed share directory only when a scenario is not a path (test_core_imports checks that a
simulation loads none of these, nor it)."""


def modules(package=PACKAGE):
    """Return {dotted module name: path} of every module of the package."""
    found = {}
    for path in sorted(package.rglob('*.py')):
        parts = path.relative_to(package.parent).with_suffix('').parts
        found['.'.join(parts[:-1] if parts[-1] == '__init__' else parts)] = path
    return found


def imports(path, known):
    """
    Return the names a module imports: modules of the package, other packages by name.

    Imports for the type checker alone (``if TYPE_CHECKING:``) count: a type the floor below
    needs from the floor above is a circle all the same.
    """
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            for alias in node.names:
                sub = f'{node.module}.{alias.name}'
                out.add(sub if sub in known else node.module)
    return out


def floor(module):
    """Return the index of a package module's floor in :data:`FLOORS` (None: the package)."""
    parts = module.split('.')
    return FLOORS.index(parts[1]) if len(parts) > 1 else None


def graph(package=PACKAGE):
    known = modules(package)
    return {m: {i for i in imports(p, known) if i in known and i != m}
            for m, p in known.items()}, known


def upward(edges):
    """Return the sorted (importer, imported) pairs that climb a floor."""
    return sorted((a, b) for a, targets in edges.items() for b in targets
                  if floor(a) is not None and floor(b) is not None and floor(b) > floor(a))


def circles(edges):
    """Return each import circle, the strongly connected components of 2 modules or more."""
    index, low, stack, on, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            part = []
            while True:
                w = stack.pop()
                on.discard(w)
                part.append(w)
                if w == v:
                    break
            if len(part) > 1:
                found.append(sorted(part))
    for v in sorted(edges):
        if v not in index:
            visit(v)
    return sorted(found)


def test_every_module_lives_on_a_floor():
    edges, _ = graph()
    assert [m for m in edges if m != 'formation_control' and floor(m) is None] == []


def test_no_import_climbs_a_floor():
    edges, _ = graph()
    assert upward(edges) == []


def test_no_import_circle():
    edges, _ = graph()
    assert circles(edges) == []


def test_the_pure_floors_import_nothing_from_ros():
    edges, known = graph()
    offending = sorted((m, i) for m, p in known.items() if floor(m) is not None
                       and FLOORS[floor(m)] in PURE for i in imports(p, known)
                       if i.startswith(ROS_PREFIXES))
    assert offending == []


def test_the_checks_see_a_climb_and_a_circle(tmp_path):
    """The checks fail, naming the pair, on a package that climbs and goes round."""
    pkg = tmp_path / 'formation_control'
    for sub, text in {'core/a.py': 'from formation_control.ros import b\n',
                      'ros/b.py': 'from formation_control.core import a\n',
                      'sim/c.py': 'def f():\n    import rclpy\n'}.items():
        (pkg / sub).parent.mkdir(parents=True, exist_ok=True)
        (pkg / sub).write_text(text)
    edges, known = graph(pkg)
    assert upward(edges) == [('formation_control.core.a', 'formation_control.ros.b')]
    assert circles(edges) == [['formation_control.core.a', 'formation_control.ros.b']]
    assert 'rclpy' in imports(known['formation_control.sim.c'], known)


def test_an_import_for_the_type_checker_alone_is_an_edge(tmp_path):
    pkg = tmp_path / 'formation_control'
    (pkg / 'core').mkdir(parents=True)
    (pkg / 'core' / 'a.py').write_text(
        'from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n'
        '    from formation_control.core import b\nelse:\n    import numpy\n')
    (pkg / 'core' / 'b.py').write_text('from formation_control.core import a\n')
    edges, known = graph(pkg)
    assert circles(edges) == [['formation_control.core.a', 'formation_control.core.b']]
    assert imports(known['formation_control.core.a'], known) == {
        'typing', 'numpy', 'formation_control.core.b'}


@pytest.mark.parametrize('name', FLOORS[:-2])
def test_a_floor_is_a_folder(name):
    assert (PACKAGE / name / '__init__.py').is_file()
