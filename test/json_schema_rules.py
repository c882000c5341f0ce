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
The strict JSON-schema rules of Foxglove Studio 1.x and Lichtblick, for the tests.

Their channel-schema parser (``parseJsonSchema`` of ``@foxglove/mcap-support``) turns a JSON
schema into message definitions and rejects the whole channel ("Failed to parse channel
schema") when a field does not fit: the root and every nested message is ``"type": "object"``;
each property has one ``"type"`` string (``boolean``, ``string``, ``number``, ``integer``,
``object``, ``array``) or a ``oneOf`` of numeric ``const`` values (an enum); a type array such as
``["number", "null"]`` is refused; strings take no ``contentEncoding`` but ``base64``; an array's
``items`` follow the same rules. :func:`check` raises :class:`SchemaRejected` with the field's
path, as the app does.
"""

PRIMITIVES = {'boolean', 'number', 'integer', 'string'}


class SchemaRejected(ValueError):
    """The schema would be refused by the app."""


def check(schema, name='schema'):
    """Raise :class:`SchemaRejected` unless the object schema parses under the app's rules."""
    if schema.get('type') != 'object':
        raise SchemaRejected(f'Expected "type": "object" for schema {name}')
    for field, spec in schema.get('properties', {}).items():
        _field(spec, f'{name}.{field}')


def _field(spec, path):
    if 'oneOf' in spec:
        if not all(isinstance(alt.get('const'), (int, float)) for alt in spec['oneOf']):
            raise SchemaRejected(f'Unsupported type for {path}: oneOf alternatives must have '
                                 'number values')
        return
    kind = spec.get('type')
    if not isinstance(kind, str):
        raise SchemaRejected(f'Unsupported or missing type for {path}: {kind!r}')
    if kind == 'object':
        check(spec, path)
    elif kind == 'array':
        _field(spec.get('items', {}), f'{path}[]')
    elif kind == 'string' and spec.get('contentEncoding') not in (None, 'base64'):
        raise SchemaRejected(f'Unsupported contentEncoding for {path}')
    elif kind not in PRIMITIVES | {'string'}:
        raise SchemaRejected(f'Unsupported or missing type for {path}: {kind!r}')
