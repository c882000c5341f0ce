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

"""ros/tracing.py: off unless asked; asked, the events a node notes are the ones it writes."""
import os

from formation_control.ros import tracing
import numpy as np


def test_a_node_traces_nothing_unless_asked(monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv(tracing.ENV, raising=False)
    assert tracing.of_node('vehicle_1') is tracing.NULL
    monkeypatch.setenv(tracing.ENV, '')
    trace = tracing.of_node('vehicle_1')
    assert trace is tracing.NULL
    trace.note('odom_in', 1, 20)
    trace.indexed('odom_pub', 0, 20)
    trace.since('odom_in', 1, 20, tracing.time.perf_counter_ns())
    assert trace.clock() == 0 and trace.save() is None
    assert list(tmp_path.iterdir()) == []


def test_the_null_trace_has_the_interface_of_a_trace():
    public = {name for name in vars(tracing.Trace) if not name.startswith('_')}
    assert public | {'clock'} <= set(dir(tracing.NullTrace))


def test_the_events_noted_are_written_in_order_on_one_clock(monkeypatch, tmp_path):
    monkeypatch.setenv(tracing.ENV, str(tmp_path / 'trace'))
    trace = tracing.of_node('vehicle_3')
    before = tracing.time.monotonic_ns()
    for event in ('law_start', 'law_end', 'cmd_sent'):
        trace.note(event, 3, 20_000_000)
    trace.indexed('state_in', 2, 20_000_000)
    trace.since('odom_in', 3, 20_000_000, tracing.time.perf_counter_ns())
    trace.save()
    saved = np.load(tmp_path / 'trace' / f'vehicle_3_{os.getpid()}.npz')
    rows = saved['rows']
    assert [saved['events'][code] for code in rows[:, 0]] == \
        ['law_start', 'law_end', 'cmd_sent', 'state_in', 'odom_in']
    assert rows[:, 1].tolist() == [3, 3, 3, 3, 3] and np.all(rows[:, 2] == 20_000_000)
    assert np.all(np.diff(rows[:4, 3]) >= 0) and rows[0, 3] >= before
    assert before <= rows[4, 3] <= tracing.time.monotonic_ns()
    assert saved['cpu'].shape == (2,) and saved['switches'].shape == (2,)
    assert saved['traced'][0] >= 0 and saved['schedstat'].shape == (2, 3)
