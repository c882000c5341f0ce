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

"""The live view's JSON channels parse under the strict rules of Studio 1.x and Lichtblick."""
import math

from formation_control.protocol import messages
from formation_control.view import scene
from json_schema_rules import check, SchemaRejected
import pytest


def test_metrics_schema_parses_strictly_and_keeps_each_description():
    schema = scene.metrics_schema(messages.METRIC_DOC)
    check(schema)
    for name, text in messages.METRIC_DOC.items():
        assert schema['properties'][name] == {'type': 'number', 'description': text}


@pytest.mark.parametrize('field', [
    {'type': ['number', 'null']}, {}, {'type': 'null'},
    {'type': 'string', 'contentEncoding': 'hex'},
    {'oneOf': [{'const': 'a'}]}, {'type': 'array', 'items': {'type': ['integer', 'null']}},
    {'type': 'object', 'properties': {'x': {'type': ['number', 'null']}}}])
def test_the_rules_reject_what_the_app_rejects(field):
    with pytest.raises(SchemaRejected, match='x'):
        check({'type': 'object', 'properties': {'x': field}})


def test_metrics_message_leaves_absent_values_out():
    msg = scene.metrics_message(3_000_000_007, {'order_parameter': 0.5, 'radius': math.nan,
                                                'lyapunov': math.inf})
    assert msg == {'timestamp': {'sec': 3, 'nsec': 7}, 'order_parameter': 0.5}
    schema = scene.metrics_schema(messages.METRIC_DOC)
    assert all(schema['properties'][k]['type'] == 'number' for k in msg if k != 'timestamp')
