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
Register the editable formation_control in the venv's ament index, as colcon would install it.

``pip install -e`` installs the console scripts but not setup.py's ``data_files``, so
``ros2 launch formation_control ...`` and ``ros2 run formation_control vehicle`` from the venv
would not find the package. This links, in the venv prefix, the package marker of the ament
index, each file of ``share/formation_control/`` (package.xml, config, launch, foxglove, rviz:
links to the repository's files, so edits show at once; launch does not follow a linked
directory) and ``lib/formation_control/<node>`` (the venv's
console scripts).

Usage: python tools/ament_register.py VENV
"""

from importlib.metadata import entry_points
from pathlib import Path
import sys

PACKAGE = 'formation_control'
SHARED = ('package.xml', 'config', 'launch', 'foxglove', 'rviz')


def link(path, target):
    """Make ``path`` a symlink to ``target``, replacing what was there."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.is_symlink() or path.is_file():
        path.unlink()
    path.symlink_to(target)


def register(prefix, root):
    """Register the package of the repository ``root`` in the ament prefix ``prefix``."""
    index = prefix / 'share' / 'ament_index' / 'resource_index' / 'packages' / PACKAGE
    index.parent.mkdir(parents=True, exist_ok=True)
    index.touch()
    for name in SHARED:
        found = root / name
        for path in sorted(found.rglob('*')) if found.is_dir() else [found]:
            if path.is_file():
                link(prefix / 'share' / PACKAGE / path.relative_to(root), path)
    for script in entry_points(group='console_scripts'):
        if script.value.startswith(f'{PACKAGE}.'):
            link(prefix / 'lib' / PACKAGE / script.name, prefix / 'bin' / script.name)


if __name__ == '__main__':
    register(Path(sys.argv[1]).absolute(), Path(__file__).resolve().parents[1])
