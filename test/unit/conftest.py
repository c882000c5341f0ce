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
The unit tests: pure, no DDS.

They run in a plain numpy venv; those needing a tool that is not installed there (the ament
linters, mypy, rosidl's parser) are left out with the reason.
"""
import importlib.util

NEEDS = {'test_flake8.py': 'ament_flake8', 'test_pep257.py': 'ament_pep257',
         'test_mypy.py': 'mypy', 'test_interface_definitions.py': 'rosidl_adapter'}
collect_ignore = [name for name, module in NEEDS.items()
                  if importlib.util.find_spec(module) is None]
for name in collect_ignore:
    print(f'test/unit/{name} left out: {NEEDS[name]} is not installed')
