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

"""The layout in the Foxglove app's format and the classic one of Studio 1.x and Lichtblick."""
import json
from pathlib import Path

from formation_control import cli
from formation_control.core.errors import UsageError
from formation_control.view import classic, layout
import pytest

ROOT = Path(__file__).resolve().parents[2]


def _leaves(node):
    if isinstance(node, str):
        return [node]
    assert set(node) == {'direction', 'first', 'second', 'splitPercentage'}
    assert 0 < node['splitPercentage'] < 100
    return _leaves(node['first']) + _leaves(node['second'])


def _panels(node):
    if node['type'] == 'panel':
        return [node]
    return [panel for item in node['items'] for panel in _panels(item['content'])]


@pytest.mark.parametrize('fmt', sorted(layout.FILES))
def test_installed_layouts_are_the_generated_ones(fmt):
    installed = ROOT / 'foxglove' / layout.FILES[fmt]
    assert installed.read_text() == layout.layout_json(fmt=fmt)
    setup = (ROOT / 'setup.py').read_text()
    assert "glob('foxglove/*.json')" in setup


def test_classic_layout_holds_each_panel_with_its_settings_and_title_in_a_mosaic():
    new = json.loads(layout.layout_json('fleet_a', 'odom'))
    old = json.loads(layout.layout_json('fleet_a', 'odom', 'classic'))
    panels = _panels(new['content'])
    ids = _leaves(old['layout'])
    assert sorted(ids) == sorted(old['configById'])
    assert [i.split('!')[0] for i in ids] == [classic.KINDS[p['panelType']] for p in panels]
    assert [i.split('!')[0] for i in ids] == ['3D'] + ['Plot'] * 4 + ['DiagnosticSummary']
    for ident, panel in zip(ids, panels):
        assert old['configById'][ident] == {**panel['config'],
                                            'foxglovePanelTitle': panel['title']}
    assert old['layout']['direction'] == 'row'
    assert old['layout']['splitPercentage'] == pytest.approx(60.0)    # proportions 3 : 2
    column = old['layout']['second']
    shares = []
    while isinstance(column, dict):
        shares.append(column['splitPercentage'])
        column = column['second']
    assert shares == pytest.approx([100 / 5, 100 / 4, 100 / 3, 100 / 2], abs=1e-3)


def test_classic_refuses_a_panel_it_has_no_kind_for():
    with pytest.raises(ValueError, match="panelType 'Gauge'"):
        classic.classic({'content': {'type': 'panel', 'panelType': 'Gauge', 'title': 'g'}})


def test_layout_command_writes_either_format(tmp_path, capsys):
    out = tmp_path / 'classic.json'
    assert cli.main(['layout', '--format', 'classic', '--out', str(out)]) == 0
    assert json.loads(out.read_text()) == json.loads(layout.layout_json(fmt='classic'))
    with pytest.raises(UsageError, match="layout format 'xml'"):
        layout.layout_json(fmt='xml')
