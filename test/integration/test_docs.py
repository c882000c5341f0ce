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
The docs site builds with warnings as errors, as ``make docs`` builds it.

A broken cross-reference (a page, a Python object) or a docstring that does not parse is a
warning, so it fails the build: checked on the real site, and on a small site that has one of
each, which must fail naming them.
"""
from pathlib import Path
import shutil
import subprocess
import sys

import pytest

pytest.importorskip('sphinx', reason='Sphinx is not installed (the docs extra of setup.py)')
pytest.importorskip('myst_parser', reason='myst-parser is not installed (the docs extra)')
pytest.importorskip('numpydoc', reason='numpydoc is not installed (the docs extra)')

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / 'docs'
FLAGS = ['-W', '--keep-going', '-n', '-q', '-b', 'html']


def build(source, out):
    return subprocess.run([sys.executable, '-m', 'sphinx', *FLAGS, str(source), str(out)],
                          capture_output=True, text=True, timeout=600, cwd=ROOT)


def test_make_docs_builds_with_the_same_flags():
    recipe = next(line for line in (ROOT / 'Makefile').read_text().splitlines()
                  if '-m sphinx' in line)
    assert recipe.split('-m sphinx', 1)[1].split()[:len(FLAGS)] == FLAGS, recipe
    assert recipe.split()[-2:] == ['docs', 'docs/_build/html'], recipe


def test_the_site_builds_without_a_warning(tmp_path):
    done = build(DOCS, tmp_path)
    assert done.returncode == 0, done.stderr
    front = (tmp_path / 'index.html').read_text()
    assert 'A 5-minute tour' in front                 # the README is the front page
    assert 'href="laws.html"' in front                # its docs/ links point into the site
    for page in ('usage', 'live_view', 'reliability', 'laws', 'studies', 'architecture',
                 'parameters', 'errata', 'deployment', 'security', 'benchmarks'):
        assert (tmp_path / f'{page}.html').is_file(), page
    api = tmp_path / 'api' / 'generated'
    laws = (api / 'formation_control.core.laws.html').read_text()
    assert 'id="formation_control.core.laws.backstepping"' in laws
    for module in ('core.scenario', 'protocol.lockstep', 'sim.simulator'):
        assert (api / f'formation_control.{module}.html').is_file(), module


def test_a_broken_reference_or_docstring_fails_the_build(tmp_path):
    site = tmp_path / 'site'
    site.mkdir()
    shutil.copy(DOCS / 'conf.py', site / 'conf.py')
    (tmp_path / 'brokendoc.py').write_text(
        'def order(p):\n'
        '    """\n'
        '    Return |p| of the fleet, as :func:`laws.no_such_law` does.\n'
        '\n'
        '    Parameters\n'
        '    ----------\n'
        '    p : complex\n'
        '        The order parameter.\n'
        '    """\n')
    (site / 'index.md').write_text(
        '# A site with faults\n\n'
        'See [the missing page](missing.md).\n\n'
        '```{eval-rst}\n.. autofunction:: brokendoc.order\n```\n')
    done = build(site, tmp_path / 'html')
    assert done.returncode != 0
    assert 'missing.md' in done.stderr
    assert 'Undefined substitution referenced: "p"' in done.stderr
    assert 'laws.no_such_law' in done.stderr
