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
Little-endian CDR bytes of a message from its field list, without message objects.

A message definition here is the field list of its ``.msg`` file, in order: (name, type)
pairs whose type is a primitive of :data:`PRIMITIVES`, ``string``, a sequence ``T[]`` of a
primitive, or a nested definition (:data:`TIME`, :data:`HEADER`). A :class:`Layout` lays out
one message whose strings and sequences have known sizes as one ``struct.Struct``,
padding each primitive to its size from the start of the body (XCDR1, as Fast DDS writes it
after the 4-byte encapsulation header); a :class:`Codec` fixes some of its items (frames,
ids, sizes) and writes and reads the others. The definitions are checked against the ``.msg``
files of formation_control_msgs by test/unit/test_interface_definitions.py.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from operator import itemgetter
import struct
from typing import Any, Union

Definition = tuple[tuple[str, Union[str, 'Definition']], ...]

PRIMITIVES = {'bool': '?', 'uint8': 'B', 'int32': 'i', 'uint32': 'I', 'float64': 'd'}
"""The struct code of each primitive type the package's messages use."""

TIME: Definition = (('sec', 'int32'), ('nanosec', 'uint32'))
"""builtin_interfaces/Time."""

HEADER: Definition = (('stamp', TIME), ('frame_id', 'string'))
"""std_msgs/Header."""

ENCAPSULATION = b'\x00\x01\x00\x00'
"""CDR, little endian (what rclpy's serialize_message writes first)."""


class Layout:
    """
    One message of ``definition`` as a struct: its items and their paths.

    ``sizes`` gives, by path (``header.frame_id``, ``neighbour_ids``), the byte length of each
    string (its text, without the terminating NUL) and the length of each sequence. A string
    is two items, ``path.size`` (uint32, with the NUL) and ``path`` (bytes with the NUL); a
    sequence is ``path.size`` and ``path.0`` .. ``path.{n-1}``. :attr:`sizes` holds the value
    of every ``.size`` item.
    """

    def __init__(self, definition: Definition, sizes: Mapping[str, int]) -> None:
        self.paths: list[str] = []
        self.sizes: dict[str, int] = {}
        self._codes: list[str] = []
        self._at = 0
        self._walk(definition, '', sizes)
        self.struct = struct.Struct('<' + ''.join(self._codes))

    def _put(self, path: str, code: str, size: int) -> None:
        pad = -self._at % size
        self._codes.append(f'{pad}x{code}' if pad else code)
        self._at += pad + struct.calcsize('<' + code)
        self.paths.append(path)

    def _walk(self, definition: Definition, prefix: str, sizes: Mapping[str, int]) -> None:
        for name, kind in definition:
            path = prefix + name
            if not isinstance(kind, str):
                self._walk(kind, path + '.', sizes)
            elif kind == 'string':
                self.sizes[path + '.size'] = sizes[path] + 1
                self._put(path + '.size', 'I', 4)
                self._put(path, f'{sizes[path] + 1}s', 1)
            elif kind.endswith('[]'):
                code = PRIMITIVES[kind[:-2]]
                self.sizes[path + '.size'] = sizes[path]
                self._put(path + '.size', 'I', 4)
                for i in range(sizes[path]):
                    self._put(f'{path}.{i}', code, struct.calcsize(code))
            else:
                code = PRIMITIVES[kind]
                self._put(path, code, struct.calcsize(code))


class Codec:
    """
    The canonical bytes of a :class:`Layout` whose ``constants`` (by path) are fixed.

    A string constant is given as text. ``variables`` are the paths of the other items, in the
    order :meth:`encode` takes and :meth:`decode` returns their values. Raises ValueError
    unless every item is exactly one of the two.
    """

    def __init__(self, layout: Layout, constants: Mapping[str, Any],
                 variables: Sequence[str]) -> None:
        fixed = {**layout.sizes, **{path: value.encode() + b'\x00' if isinstance(value, str)
                                    else value for path, value in constants.items()}}
        both = set(fixed) & set(variables)
        missing = set(layout.paths) - set(fixed) - set(variables)
        if both or missing or len(fixed) + len(variables) != len(layout.paths):
            raise ValueError(f'not a partition of the items {layout.paths}: both {sorted(both)}, '
                             f'neither {sorted(missing)}')
        self.struct = layout.struct
        self.size = len(ENCAPSULATION) + layout.struct.size
        const_paths = [p for p in layout.paths if p in fixed]
        self.constants = tuple(fixed[p] for p in const_paths)
        order = {p: i for i, p in enumerate([*const_paths, *variables])}
        self._arrange = _picker([order[p] for p in layout.paths])
        self._const_of = _picker([layout.paths.index(p) for p in const_paths])
        self._vars_of = _picker([layout.paths.index(p) for p in variables])

    def encode(self, values: Sequence[Any]) -> bytes:
        """Return the bytes of the message with the ``variables``' values."""
        return ENCAPSULATION + self.struct.pack(*self._arrange(self.constants + tuple(values)))

    def decode(self, data: bytes) -> tuple[Any, ...] | None:
        """Return the ``variables``' values of canonical bytes, else None."""
        if len(data) != self.size or data[:4] != ENCAPSULATION:
            return None
        items = self.struct.unpack_from(data, 4)
        if self._const_of(items) != self.constants:
            return None
        return self._vars_of(items)


def _picker(indices: Sequence[int]) -> Callable[[Sequence[Any]], tuple[Any, ...]]:
    """Return a function of a sequence: the tuple of its items at ``indices``."""
    if len(indices) > 1:
        return itemgetter(*indices)
    return lambda items: tuple(items[i] for i in indices)
