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
Whether CDR bytes can hold a message of a type: every string and sequence within the bytes.

rosidl's C type support, which :func:`rclpy.serialization.deserialize_message` runs, prints
"sequence size exceeds remaining buffer" on stderr for each sample whose sequence length field
runs past its end (a length of 2^31-1, a byte-swapped one): a line per malformed sample. The
byte subscribers (:mod:`formation_control.ros.common`) refuse such bytes before deserializing
them. The walk follows the type's fields (XCDR1 as Fast DDS writes it: each primitive aligned to
its size from the start of the body); it refuses only bytes no message of the type fits.
"""
import struct

from rosidl_parser.definition import (AbstractGenericString, AbstractSequence,
                                      AbstractWString, Array, BasicType, NamespacedType)

SIZES = {'boolean': 1, 'octet': 1, 'char': 1, 'uint8': 1, 'int8': 1, 'int16': 2, 'uint16': 2,
         'wchar': 2, 'int32': 4, 'uint32': 4, 'float': 4, 'int64': 8, 'uint64': 8, 'double': 8,
         'long double': 16}


class _Short(Exception):
    """The bytes end before the message does."""


class _Walk:
    def __init__(self, data):
        self.data, self.pos = data, 4
        self.order = '<' if data[1] & 1 else '>'

    def skip(self, size, count=1):
        if count == 0:
            return                            # an empty sequence is not aligned
        self.pos = 4 + -(-(self.pos - 4) // size) * size + size * count
        if self.pos > len(self.data):
            raise _Short

    def length(self):
        self.skip(4)
        return struct.unpack_from(self.order + 'I', self.data, self.pos - 4)[0]

    def fields(self, msg_type):
        if not msg_type.SLOT_TYPES:
            self.skip(1)                      # an empty message is one uint8
        for t in msg_type.SLOT_TYPES:
            self.field(t)

    def field(self, t):
        if isinstance(t, BasicType):
            self.skip(SIZES[t.typename])
        elif isinstance(t, AbstractWString):
            raise NotImplementedError
        elif isinstance(t, AbstractGenericString):
            self.skip(1, self.length())
        elif isinstance(t, NamespacedType):
            module = __import__('.'.join(t.namespaces), fromlist=[t.name])
            self.fields(getattr(module, t.name))
        elif isinstance(t, (Array, AbstractSequence)):
            count = t.size if isinstance(t, Array) else self.length()
            if isinstance(t.value_type, BasicType):
                self.skip(SIZES[t.value_type.typename], count)
            elif count > len(self.data) - self.pos:
                raise _Short
            else:
                for _ in range(count):
                    self.field(t.value_type)


def fits(data, msg_type):
    """
    Return False if no ``msg_type`` message fits CDR ``data``, else True.

    Bytes that are not plain CDR (an encapsulation other than CDR_BE / CDR_LE) are left to the
    deserializer, which refuses them without a word, as are wide strings.
    """
    if len(data) < 4 or data[0] != 0 or data[1] > 1:
        return True
    try:
        _Walk(data).fields(msg_type)
    except _Short:
        return False
    except NotImplementedError:
        return True
    return True
