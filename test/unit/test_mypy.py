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

"""mypy over the pure floors (core, protocol, sim), with the [mypy] section of setup.cfg."""
import pytest

api = pytest.importorskip('mypy.api')


@pytest.mark.linter
def test_mypy(request, monkeypatch):
    monkeypatch.chdir(request.config.rootpath)
    out, err, rc = api.run(['--config-file', 'setup.cfg'])
    assert rc == 0, f'mypy found errors:\n{out}{err}'
