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
Check that everything the package needs is installed at its pinned version.

Walks the installed requirements of the package with every extra of ``EXTRAS`` (msgs-build:
what building formation_control_msgs takes; bench: the tracked benchmarks; aircraft: JSBSim)
and of the build tools pip, setuptools, wheel, and fails, naming them, when one of them has no
exact pin in constraints.txt or is installed at another version: a dependency added to
setup.py without ``make upgrade`` would otherwise be installed at whatever version is newest
that day.

Usage: python tools/check_pins.py [constraints.txt]
"""

from importlib import metadata
from pathlib import Path
import sys

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

ROOT = Path(__file__).resolve().parents[1]
PROJECT = 'formation_control'
EXTRAS = ('ros', 'view', 'cluster', 'test', 'docs', 'msgs-build', 'bench', 'aircraft')
BUILD_TOOLS = ('pip', 'setuptools', 'wheel')


def read_pins(path):
    """Return {canonical name: version} of the ``name==version`` lines of a constraints file."""
    pins = {}
    for line in Path(path).read_text().splitlines():
        line = line.split('#', 1)[0].strip()
        if not line:
            continue
        name, sep, version = line.partition('==')
        if not sep:
            raise SystemExit(f'{path}: not an exact pin: {line!r}')
        pins[canonicalize_name(name)] = version.strip()
    return pins


def closure():
    """Return the canonical names of the project's installed dependency closure."""
    seen = set()
    todo = [(PROJECT, EXTRAS)] + [(name, ()) for name in BUILD_TOOLS]
    while todo:
        name, extras = todo.pop()
        key = (canonicalize_name(name), tuple(sorted(extras)))
        if key in seen:
            continue
        seen.add(key)
        for text in metadata.requires(name) or []:
            req = Requirement(text)
            if req.marker is not None and not any(
                    req.marker.evaluate({'extra': extra}) for extra in (extras or ('',))):
                continue
            todo.append((req.name, tuple(req.extras)))
    return sorted({name for name, _ in seen} - {canonicalize_name(PROJECT)})


def main(argv=sys.argv[1:]):
    path = Path(argv[0]) if argv else ROOT / 'constraints.txt'
    pins = read_pins(path)
    problems = []
    for name in closure():
        try:
            installed = metadata.version(name)
        except metadata.PackageNotFoundError:
            problems.append(f'{name}: required but not installed')
            continue
        pinned = pins.get(name)
        if pinned is None:
            problems.append(f'{name}=={installed}: not pinned in {path.name}')
        elif pinned != installed:
            problems.append(f'{name}: {installed} installed, {pinned} pinned')
    if problems:
        print(f'{len(problems)} dependencies are not at their pins '
              f'(run `make upgrade` to refresh {path.name} on purpose):', file=sys.stderr)
        print('\n'.join('  ' + p for p in problems), file=sys.stderr)
        return 1
    print(f'every dependency of {PROJECT}[{",".join(EXTRAS)}] is at its pin in {path.name}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
