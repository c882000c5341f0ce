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

"""Fault scripts of ``swarm --fault``: parsing, checks against the scenario, the schedule."""
from formation_control.core import scenario
from formation_control.core.errors import UsageError
from formation_control.protocol import faults
from formation_control.protocol.faults import Fault
from formation_control.sim import simulator
import pytest

SC = scenario.resolve({'num_vehicles': 4, 'duration': 20.0})


def test_parse_every_kind():
    assert faults.parse('kill:3@8') == [Fault('kill', (3,), 8.0, 'kill:3@8')]
    assert faults.parse(' stop:2@.5 ') == [Fault('stop', (2,), 0.5, 'stop:2@.5')]
    text = 'cut:1-2@5..10.5'
    assert faults.parse(text) == [Fault('cut', (1, 2), 5.0, text),
                                  Fault('mend', (1, 2), 10.5, text)]
    assert faults.parse('cut:1-2@5..10')[1].describe() == 'mend link 1-2'


@pytest.mark.parametrize('text, reason', [
    ('kill:3', 'expected kill|restart'), ('freeze:3@1', 'expected'), ('kill:3@-1', 'expected'),
    ('cut:1-2@5..5', 'must end after it starts'), ('kill:5@1', '1..num_vehicles = 4'),
    ('kill:1@21', 'after the end of the run (duration 20 s)'),
    ('cut:2-2@1..2', 'not neighbours'), ('cont:1@3', 'vehicle 1 is running at 3 s'),
])
def test_bad_entries_are_refused_naming_the_reason(text, reason):
    with pytest.raises(UsageError, match=r'--fault .* is invalid: .*') as err:
        faults.schedule([text], SC)
    assert reason in str(err.value)


def test_a_script_must_make_sense_in_time_order():
    faults.schedule(['cont:1@3', 'stop:1@2', 'kill:1@4', 'restart:1@5', 'stop:1@6'], SC)
    with pytest.raises(UsageError, match='vehicle 2 is killed at 3 s'):
        faults.schedule(['kill:2@1', 'stop:2@3'], SC)
    with pytest.raises(UsageError, match='overlaps another cut of link 2-1'):
        faults.schedule(['cut:1-2@1..5', 'cut:2-1@4..6'], SC)
    ring = scenario.resolve({'num_vehicles': 6, 'graph': 'circulant'})
    with pytest.raises(UsageError, match='vehicles 1 and 3 are not neighbours'):
        faults.schedule(['cut:1-3@1..2'], ring)


def test_schedule_hands_out_faults_once_in_time_order_and_tracks_the_cut_links():
    s = faults.schedule(['cut:1-2@1..4', 'kill:3@2', 'cut:1-3@2..3'], SC)
    assert s.due(0.5) == []
    first = s.due(2.0)
    assert [(f.kind, f.vehicles) for f in first] == [
        ('cut', (1, 2)), ('kill', (3,)), ('cut', (1, 3))]
    assert s.due(2.0) == []
    assert s.cut_links(first[0]) == {1: (2,), 2: (1,)}
    assert s.cut_links(first[2]) == {1: (2, 3), 3: (1,)}
    mend_13, mend_12 = s.due(10.0)
    assert s.cut_links(mend_13) == {1: (2,), 3: ()}
    assert s.cut_links(mend_12) == {1: (), 2: ()} and not s


def test_survivors_converged_measures_the_members_alone():
    sc = scenario.resolve({'num_vehicles': 5, 'duration': 15.0, 'seed': 1})
    run = simulator.simulate(sc)
    assert simulator.summary(run)['converged']
    converged, since = faults.survivors_converged(run, [1, 2, 4])
    assert converged is True and 0 < since < 15.0
    start = simulator.Run(sc, run.t[:1], run.X[:1], run.U[:1])
    assert faults.survivors_converged(start, [1, 2, 4]) == (False, None)
    assert faults.survivors_converged(run, []) == (None, None)
