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

import subprocess
import sys

import pytest

RUN = 'import sys; from ament_flake8.main import main; sys.exit(main(argv=[]))'


@pytest.mark.flake8
@pytest.mark.linter
def test_flake8(request):
    """
    ament_flake8 on the repository (ament's config: max line 99, single quotes, import order).

    In a process of its own: flake8 forks its workers, and a fork of a pytest worker that holds
    DDS threads from earlier tests could deadlock in the child (the test once hung 600 s).
    """
    done = subprocess.run([sys.executable, '-c', RUN], cwd=request.config.rootpath,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout[-20000:] + done.stderr[-2000:]
