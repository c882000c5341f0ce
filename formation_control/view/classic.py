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
The classic layout format of Foxglove Studio 1.x and Lichtblick, from a Foxglove layout.

The Foxglove app's layout (``foxglove.layouts``) is a tree of splits with any number of items,
each with a proportion, and panels that hold their type, title and settings. The classic format
(what Studio 1.x and Lichtblick import) keeps the settings of each panel in ``configById``
under an id ``<kind>!<name>`` (the kind names the panel type: ``3D``, ``Plot``,
``DiagnosticSummary``), the title as ``foxglovePanelTitle``, and the arrangement in ``layout``:
a binary mosaic tree of ``{direction, first, second, splitPercentage}`` whose leaves are panel
ids. :func:`classic` converts the one into the other; the panel settings are kept as they are.
"""
from collections.abc import Sequence
from typing import Any

Json = dict[str, Any]
"""A JSON object, as a dict."""

KINDS = {'ThreeDee': '3D', 'Plot': 'Plot', 'DiagnosticsSummary': 'DiagnosticSummary',
         'RawMessages': 'RawMessages', 'Table': 'Table'}
"""The classic panel kind of each Foxglove ``panelType``."""


def classic(layout: Json) -> Json:
    """
    Return the classic layout of a Foxglove layout (both as JSON-ready dicts).

    Raises
    ------
    ValueError
        For a panel type without a classic kind in :data:`KINDS`.

    """
    config_by_id: Json = {}
    return {'configById': config_by_id, 'globalVariables': {}, 'userNodes': {},
            'playbackConfig': {'speed': 1.0},
            'layout': _node(layout['content'], config_by_id)}


def _node(node: Json, config_by_id: Json) -> Json | str:
    if node['type'] == 'panel':
        return _panel(node, config_by_id)
    return _split(node['direction'], node['items'], config_by_id)


def _panel(panel: Json, config_by_id: Json) -> str:
    kind = KINDS.get(panel['panelType'])
    if kind is None:
        raise ValueError(f"panelType {panel['panelType']!r}: no classic panel kind (one of "
                         f"{', '.join(sorted(KINDS))})")
    ident = f'{kind}!panel{len(config_by_id) + 1}'
    config_by_id[ident] = {**panel.get('config', {}), 'foxglovePanelTitle': panel['title']}
    return ident


def _split(direction: str, items: Sequence[Json], config_by_id: Json) -> Json | str:
    """Nest the items of a split: the first, then the rest, by their proportions."""
    first = _node(items[0]['content'], config_by_id)
    if len(items) == 1:
        return first
    share = items[0]['proportion'] / sum(item['proportion'] for item in items)
    return {'direction': direction, 'first': first,
            'second': _split(direction, items[1:], config_by_id),
            'splitPercentage': round(100.0 * share, 3)}
