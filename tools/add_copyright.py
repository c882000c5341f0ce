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
Add the project's Apache-2.0 copyright header to the Python files missing it.

Writes exactly what ``ament_copyright --add-missing "formation_control developers" apache2``
writes (ament_copyright is not on PyPI): below an optional shebang / coding line, the header
as ``#`` comments, then one empty line; a file that already starts with a copyright notice,
and an empty file, is left alone. test/test_copyright.py checks the result.

Usage: python tools/add_copyright.py [--check] [PATH ...]
(default paths: formation_control test bench tools setup.py, from the repository root)
"""

import argparse
from pathlib import Path
import re
import sys
import time

ROOT = Path(__file__).resolve().parents[1]
HOLDER = 'formation_control developers'
DEFAULT_PATHS = ('formation_control', 'test', 'bench', 'tools', 'setup.py')

NOTICE = """\
Licensed under the Apache License, Version 2.0 (the "License");
you may not use this file except in compliance with the License.
You may obtain a copy of the License at

    http://www.apache.org/licenses/LICENSE-2.0

Unless required by applicable law or agreed to in writing, software
distributed under the License is distributed on an "AS IS" BASIS,
WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
See the License for the specific language governing permissions and
limitations under the License."""

# The header's first line; ament_copyright accepts a year or a year range.
COPYRIGHT_LINE = re.compile(r'# Copyright \d{4}(?:-\d{4})? ' + re.escape(HOLDER) + r'\n')
# ament_copyright's test for "already has a copyright notice" (its first comment block).
ANY_COPYRIGHT = re.compile(r'^#\s*copyright(?:\s+\(c\))?\s+\d{4}', re.IGNORECASE)


def comment(text):
    """Return text as ``#`` comment lines, ``#`` alone on an empty line (as ament writes it)."""
    return ''.join(('# ' + line if line else '#') + '\n' for line in text.split('\n'))


def header(year=None):
    """Return the header ament_copyright would add in ``year`` (default: this year)."""
    year = time.strftime('%Y') if year is None else year
    return comment(f'Copyright {year} {HOLDER}\n\n{NOTICE}')


NOTICE_LINES = comment('\n' + NOTICE)  # the header after its copyright line


def header_start(content):
    """Return the index past the optional shebang and coding lines (where a header goes)."""
    index = 0
    lines = content.splitlines(keepends=True)
    for line in lines:
        if line.startswith('#!') or (line.startswith('#') and re.search('coding[:=]', line)):
            index += len(line)
        else:
            break
    return index


def has_header(content):
    """Whether content starts (after shebang, coding and empty lines) with our header."""
    rest = content[header_start(content):].lstrip('\n')
    match = COPYRIGHT_LINE.match(rest)
    return bool(match) and rest[match.end():].startswith(NOTICE_LINES)


def has_any_copyright(content):
    """Whether content's first comment already holds a copyright notice (anyone's)."""
    rest = content[header_start(content):].lstrip('\n')
    for line in rest.splitlines():
        if not line.startswith('#'):
            return False
        if ANY_COPYRIGHT.match(line):
            return True
    return False


def with_header(content, year=None):
    """Return content with the header inserted, as ament_copyright --add-missing does."""
    begin = header_start(content)
    end = begin
    while content.startswith('\n', end):
        end += 1
    block = header(year) + '\n'
    if begin > 0:
        block = '\n' + block
    return content[:begin] + block + content[end:]


def python_files(paths, root=ROOT):
    """Yield the .py files under paths (relative to root), skipping . and _ folders."""
    for name in paths:
        path = root / name
        if path.is_file():
            yield path
        elif path.is_dir():
            for file in sorted(path.rglob('*.py')):
                parts = file.relative_to(root).parts[:-1]
                if not any(part[0] in '._' for part in parts):
                    yield file


def missing(paths=DEFAULT_PATHS, root=ROOT):
    """Return the non-empty .py files under paths that do not start with the header."""
    return [f for f in python_files(paths, root)
            if f.read_text(encoding='utf-8') and not has_header(f.read_text(encoding='utf-8'))]


def main(argv=sys.argv[1:]):
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('paths', nargs='*', default=DEFAULT_PATHS,
                        help='files or folders, relative to the repository root')
    parser.add_argument('--check', action='store_true',
                        help='only list the files missing the header; exit 1 if any')
    args = parser.parse_args(argv)
    todo = missing(args.paths)
    status = 0
    for path in todo:
        rel = path.relative_to(ROOT)
        content = path.read_text(encoding='utf-8')
        if args.check:
            print(f'missing: {rel}')
            status = 1
        elif has_any_copyright(content):
            print(f'skipped (another copyright notice): {rel}', file=sys.stderr)
            status = 1
        else:
            path.write_text(with_header(content), encoding='utf-8')
            print(f'* {rel}')
    return status


if __name__ == '__main__':
    sys.exit(main())
