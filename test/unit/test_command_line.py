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

"""``-p NAME:=VALUE`` on a node's command line, as the node declares it (checked_overrides)."""
import re

from formation_control.core.errors import ScenarioError
from formation_control.protocol.node_parameters import checked_overrides
import pytest


def test_command_line_values_are_taken_in_the_declared_type_or_refused():
    argv = ['vehicle', '--ros-args', '--params-file', 'f.yaml', '-p', 'kappa:=3', '-p',
            'flow:=[0, 1]', '-p', 'vehicle_id:=2', '-p', 'K_f:=1e-5', '-p', 'K:=-2', '-p',
            'vehicle_1:omega0:=2', '--param', 'model:=rigid', '-p', 'vehicle_ids:=[1, 2, 3]', '--',
            '-p', 'kappa:=abc']
    assert checked_overrides(argv) == [
        'vehicle', '--ros-args', '--params-file', 'f.yaml', '-p', 'kappa:=3.0', '-p',
        'flow:=[0.0, 1.0]', '-p', 'vehicle_id:=2', '-p', 'K_f:=1e-5', '-p', 'K:=-2.0', '-p',
        'vehicle_1:omega0:=2.0', '--param', 'model:=rigid', '-p', 'vehicle_ids:=[1, 2, 3]',
        '--', '-p', 'kappa:=abc']
    for bad, text in (('kappa:=abc', "'kappa' = 'abc' is invalid: a number"),
                      ('kappa:=true', "'kappa' = True is invalid: a number"),
                      ('flow:=1.0', "'flow' = 1.0 is invalid: a list of numbers")):
        with pytest.raises(ScenarioError, match=re.escape(f'parameter {text}')):
            checked_overrides(['--ros-args', '-p', bad])
