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
The copyright check of every ament_python package, without ament_copyright (not on PyPI).

Every non-empty .py file of the package, the tests, bench/, tools/ and setup.py starts (after
an optional shebang or coding line) with the header that
``ament_copyright --add-missing "formation_control developers" apache2`` writes, and LICENSE
is the Apache License 2.0. ``make copyright`` (tools/add_copyright.py) adds missing headers.
"""

import hashlib
import importlib.util
from pathlib import Path
import re

import pytest

ROOT = Path(__file__).resolve().parents[2]
CHECKED = ('formation_control', 'test', 'bench', 'tools', 'setup.py')

HEADER = re.compile(r"""# Copyright \d{4}(?:-\d{4})? formation_control developers
#
# Licensed under the Apache License, Version 2\.0 \(the "License"\);
# you may not use this file except in compliance with the License\.
# You may obtain a copy of the License at
#
#     http://www\.apache\.org/licenses/LICENSE-2\.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied\.
# See the License for the specific language governing permissions and
# limitations under the License\.
""")
PREAMBLE = re.compile(r'(?:#!.*\n|#.*coding[:=].*\n)*\n*')  # shebang / coding, empty lines
# sha256 of https://www.apache.org/licenses/LICENSE-2.0.txt
APACHE_2_0_SHA256 = 'cfc7749b96f63bd31c3c42b5c471bf756814053e847c10f3eb003417bc523d30'


def has_header(text):
    return HEADER.match(text, PREAMBLE.match(text).end()) is not None


def python_files(root=ROOT):
    for name in CHECKED:
        path = root / name
        if path.is_file():
            yield path
        for file in sorted(path.rglob('*.py')) if path.is_dir() else ():
            if not any(part[0] in '._' for part in file.relative_to(root).parts[:-1]):
                yield file


@pytest.mark.copyright
@pytest.mark.linter
def test_copyright():
    files = list(python_files())
    assert len(files) > 20
    missing = [str(f.relative_to(ROOT)) for f in files
               if f.read_text(encoding='utf-8') and not has_header(f.read_text(encoding='utf-8'))]
    assert not missing, (
        f'{len(missing)} of {len(files)} files lack the Apache-2.0 copyright header '
        '(`make copyright` adds it):\n' + '\n'.join(missing))


@pytest.mark.copyright
@pytest.mark.linter
def test_license_file_is_the_apache_license():
    assert hashlib.sha256((ROOT / 'LICENSE').read_bytes()).hexdigest() == APACHE_2_0_SHA256
    assert '<license>Apache-2.0</license>' in (ROOT / 'package.xml').read_text()


def load_tool():
    path = ROOT / 'tools' / 'add_copyright.py'
    spec = importlib.util.spec_from_file_location('add_copyright', path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_add_copyright_writes_the_header_this_check_accepts(tmp_path):
    tool = load_tool()
    cases = {
        'plain.py': '"""Doc."""\n\nimport os\n',
        'blank_lines.py': '\n\n"""Doc."""\n',
        'script.py': '#!/usr/bin/env python3\n"""Doc."""\n',
        'coded.py': '#!/usr/bin/env python3\n# -*- coding: utf-8 -*-\n\nx = 1\n',
        'comment.py': '# a comment, not a notice\nx = 1\n',
        'empty.py': '',
    }
    for name, text in cases.items():
        (tmp_path / name).write_text(text)
    headed = tool.with_header(cases['plain.py'], year='2026')
    (tmp_path / 'headed.py').write_text(headed)
    assert headed.startswith('# Copyright 2026 formation_control developers\n#\n# Licensed')
    assert headed.endswith('# limitations under the License.\n\n"""Doc."""\n\nimport os\n')

    missing = {f.name for f in tool.missing(['.'], root=tmp_path)}
    assert missing == set(cases) - {'empty.py'}
    for name in missing:
        text = (tmp_path / name).read_text()
        assert not has_header(text)
        fixed = tool.with_header(text)
        assert has_header(fixed) and tool.has_header(fixed), name
        assert fixed.replace(tool.header(), '').replace('\n', '') == text.replace('\n', '')
        (tmp_path / name).write_text(fixed)
    assert tool.missing(['.'], root=tmp_path) == []
    script = tool.with_header(cases['script.py'], year='2026')
    assert script.startswith('#!/usr/bin/env python3\n\n# Copyright 2026 ')
    assert script.endswith('License.\n\n"""Doc."""\n')
    assert tool.has_any_copyright('# Copyright 2019 Someone Else\n#\n# MIT\nx = 1\n')
    assert not tool.has_any_copyright(cases['comment.py'])
