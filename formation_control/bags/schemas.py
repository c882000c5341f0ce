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
The message types a bag is written and read with: Jazzy's and formation_control_msgs'.

The recorder registers formation_control_msgs from its ``.msg`` files (:func:`msg_files`), so
that each connection of the bag carries the definition (an MCAP schema that any reader
decodes); a reader registers the definitions the bag itself carries (:func:`bag_definitions`),
so that reading needs no formation_control_msgs installed.
"""
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from rosbags.interfaces import MessageDefinitionFormat
from rosbags.typesys import get_types_from_msg, get_typestore, Stores

MSGS = 'formation_control_msgs'


def typestore(definitions: Iterable[tuple[str, str]] = ()) -> Any:
    """Return Jazzy's typestore with ``definitions`` ((type name, ``.msg`` text)) added."""
    store = get_typestore(Stores.ROS2_JAZZY)
    types: dict[str, Any] = {}
    for name, text in definitions:
        if name not in store.types:
            types.update(get_types_from_msg(text, name))
    store.register({k: v for k, v in types.items() if k not in store.types})
    return store


def msg_files(share: str | Path) -> list[tuple[str, str]]:
    """Return (type name, text) of each ``.msg`` file of a package's share directory."""
    package = Path(share).name
    return [(f'{package}/msg/{path.stem}', path.read_text())
            for path in sorted(Path(share, 'msg').glob('*.msg'))]


def bag_definitions(connections: Iterable[Any]) -> list[tuple[str, str]]:
    """Return (type name, text) of each ``ros2msg`` definition the ``connections`` carry."""
    return [(c.msgtype, c.msgdef.data) for c in connections
            if c.msgdef is not None and c.msgdef.data
            and c.msgdef.format == MessageDefinitionFormat.MSG]
