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

"""The healing rule (protocol/healing.py) and what the plant says it waits on (Plant.silent)."""
from formation_control.core import scenario
from formation_control.protocol.healing import Healer, Heard, Hearing
from formation_control.protocol.plant import Plant
import pytest

MEMBERS = [(), (1,), (2,), (3,), (4,), ()]          # plant, vehicles 1-4, monitor
RUNNING = range(1, 6)
W = dict.fromkeys                                   # ids -> the same seconds waited


def fresh(now, **awaiting):
    """Statuses of vehicles 1-4 heard at ``now``, with ``awaiting`` {'v3': (2,)}."""
    return {k: Heard(now, tuple(awaiting.get(f'v{k}', ()))) for k in range(1, 5)}


def test_nothing_is_restarted_before_the_deadline_or_with_healing_off():
    assert Healer(MEMBERS, after=10.0).due(0, W([2], 10.0), {}, RUNNING, 100.0) == []
    assert Healer(MEMBERS, after=0.0).due(0, W([2], 1e6), {}, RUNNING, 100.0) == []


def test_the_start_up_of_the_fleet_is_allowed_for_at_step_0_only():
    healer = Healer(MEMBERS, after=10.0, startup=6.0)
    assert healer.due(0, W([2], 15.9), {}, RUNNING, 100.0) == []
    assert healer.due(9, W([2], 10.5), {}, RUNNING, 100.0) == [
        (2, 'vehicles [2] stopped answering: silent 10.5 s at step 9')]
    assert [i for i, _ in Healer(MEMBERS, 10.0, startup=6.0).due(0, W([2], 16.1), {}, RUNNING,
                                                                 100.0)] == [2]


def test_a_member_never_heard_is_restarted_once_per_deadline_and_at_most_limit_times():
    healer = Healer(MEMBERS, after=10.0, limit=2)
    heard = {k: Heard(50.0) for k in (1, 3, 4)}       # vehicle 2 never spoke
    assert healer.due(0, W([2], 10.5), heard, RUNNING, 50.0) == [
        (2, 'vehicles [2] never joined: the plant waited 10.5 s on them')]
    assert healer.due(0, W([2], 15.0), heard, RUNNING, 55.0) == []      # within its grace
    assert [i for i, _ in healer.due(0, W([2], 21.0), heard, RUNNING, 61.0)] == [2]
    assert healer.due(0, W([2], 40.0), heard, RUNNING, 80.0) == [] and healer.given_up == {2}


def test_a_member_just_started_or_continued_has_the_deadline_before_it_is_judged():
    healer = Healer(MEMBERS, after=10.0)
    healer.resumed(2, 95.0)                            # e.g. SIGCONT of a scripted freeze
    assert healer.due(40, W([2], 30.0), {}, RUNNING, 100.0) == []
    assert [i for i, _ in healer.due(40, W([2], 30.0), {}, RUNNING, 105.5)] == [2]


def test_a_restarted_member_has_the_start_up_allowance_too():
    """A process started again on a loaded machine may take as long as the fleet's start."""
    healer = Healer(MEMBERS, after=4.0, startup=15.0)
    assert [i for i, _ in healer.due(200, W([3], 4.5), {}, RUNNING, 100.0)] == [3]
    assert healer.due(300, W([3], 30.0), {}, RUNNING, 118.9) == []      # not heard since
    assert [i for i, _ in healer.due(300, W([3], 30.0), {}, RUNNING, 119.1)] == [3]
    healer.resumed(3, 200.0)
    assert [i for i, _ in healer.due(400, W([3], 4.5), {}, RUNNING, 210.0)] == [3]  # it was


def test_a_member_that_answered_since_its_start_has_no_start_up_allowance():
    healer = Healer(MEMBERS, after=4.0, startup=15.0)
    healer.resumed(3, 100.0)
    assert [i for i, _ in healer.due(300, W([3], 4.5), {}, RUNNING, 106.0)] == [3]


def test_each_vehicle_is_judged_by_its_own_silence():
    """A step under way waits a moment on everyone: only the long-silent vehicle is late."""
    due = Healer(MEMBERS, after=10.0).due(9, {1: 0.01, 2: 0.01, 3: 12.0}, {}, RUNNING, 100.0)
    assert due == [(3, 'vehicles [3] stopped answering: silent 12.0 s at step 9')]


def test_a_wedged_vehicle_is_named_not_the_neighbours_that_wait_for_it():
    """All-to-all, every vehicle misses the step; the one whose status stopped is the cause."""
    heard = {**fresh(100.0, v1=(3,), v2=(3,), v4=(3,)), 3: Heard(80.0)}
    due = Healer(MEMBERS, after=10.0).due(120, W([1, 2, 3, 4], 12.0), heard, RUNNING, 100.0)
    assert due == [(3, 'vehicles [3] stopped answering: silent 12.0 s at step 120')]


def test_the_awaited_vehicle_is_named_when_every_status_comes():
    heard = fresh(100.0, v1=(4,), v2=(4,), v3=(4,))
    assert [i for i, _ in Healer(MEMBERS, after=10.0).due(
        7, W([1, 2, 3, 4], 11.0), heard, RUNNING, 100.0)] == [4]


def test_silent_vehicles_that_speak_and_await_nobody_are_all_restarted():
    """Their links to the plant are the broken ones: a TLS pair plant-vehicle never formed."""
    assert [i for i, _ in Healer(MEMBERS, after=10.0).due(
        0, W([2, 4], 11.0), fresh(100.0), RUNNING, 100.0)] == [2, 4]


def test_a_process_not_running_is_left_to_the_script_and_a_process_of_many_is_named_once():
    heard = {}
    assert Healer(MEMBERS, after=10.0).due(0, W([2], 11.0), heard, [1, 3, 4], 100.0) == []
    grouped = Healer([(), (1, 2), (3, 4)], after=10.0)
    assert grouped.due(0, W([1, 2], 11.0), heard, [1, 2], 100.0) == [
        (1, 'vehicles [1, 2] never joined: the plant waited 11.0 s on them')]


class Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


def _plant(lockstep, clock):
    sc = scenario.resolve({'num_vehicles': 3, 'formation': 'parallel', 'duration': 1.0})
    return Plant(sc, lockstep, 2.0, clock)


def test_lockstep_plant_is_silent_on_the_vehicles_the_step_waits_for_and_the_gone():
    clock = Clock()
    plant = _plant(True, clock)
    assert plant.silent() == {}                          # no step yet
    ns = plant.begin()
    clock.t = 1.0
    plant.command(1, ns, [0.0] * 4)
    clock.t = 5.0
    assert plant.silent() == {2: 5.0, 3: 5.0}
    assert plant.status({})[2]['silent'] == [2, 3]
    assert plant.status({})[2]['silent_for'] == [5.0, 5.0]


def test_real_time_plant_is_silent_on_the_unmatched_before_it_starts_then_on_the_gone():
    clock = Clock()
    plant = _plant(False, clock)
    clock.t = 7.0
    assert plant.silent([3]) == {3: 7.0} and plant.silent() == {}
    plant.start_clock(0, 1.0)
    for k in (1, 2, 3):
        plant.command(k, 0, [0.0] * 4)
    clock.t = 8.0
    plant.command(1, 0, [0.0] * 4)
    plant.command(2, 0, [0.0] * 4)
    clock.t = 8.5
    assert plant.silent() == {}                          # within the command timeout
    clock.t = 9.5
    plant.command(1, 0, [0.0] * 4)
    plant.command(2, 0, [0.0] * 4)
    clock.t = 10.5
    assert plant.silent() == pytest.approx({3: 3.5})


def test_a_real_time_plant_that_falls_behind_the_wall_clock_says_so():
    clock = Clock()
    plant = _plant(False, clock)
    plant.start_clock(0, 2.0)
    assert plant.status({})[:2] == ('ok', 'step 0') and plant.status({})[2]['behind'] == 0.0
    clock.t = 3.0                                        # 3 s without a tick: one period kept
    for _ in plant.ticks():
        pass
    slipped = 3.0 - plant.sc.dt_control / 2.0
    level, text, values = plant.status({})
    assert values['behind'] == pytest.approx(slipped, abs=0.01) and level == 'warn'
    assert text == (f'{values["behind"]:.1f} s behind the wall clock: the machine does not keep '
                    f'the pace asked (real_time_factor 2)')


def test_the_hearing_keeps_the_plant_and_the_vehicles_of_its_namespace_only():
    hearing = Hearing('/fleet_a')
    plant = {'step': '12', 'silent': '[2, 3]', 'silent_for': '[4.5, 0.5]'}
    hearing.hear('formation_control/plant', plant, 1.0)               # another fleet's
    hearing.hear('fleet_a/formation_control/vehicle_3/links', {'awaiting': '[2]'}, 2.0)
    hearing.hear('fleet_a/formation_control/vehicle_4', {'awaiting': '[1]'}, 2.0)  # no links
    assert hearing.take_plant_status() is None
    hearing.hear('fleet_a/formation_control/plant', plant, 3.0)
    assert hearing.take_plant_status() == (12, {2: 4.5, 3: 0.5})
    assert hearing.take_plant_status() is None                          # judged once
    assert hearing.heard == {3: Heard(2.0, (2,))}


@pytest.mark.parametrize('values', [{}, {'step': 'x', 'silent': '[]', 'silent_for': '[]'},
                                    {'step': '1', 'silent': '[1', 'silent_for': '[]'}])
def test_a_status_that_does_not_parse_is_passed_over(values):
    hearing = Hearing()
    hearing.hear('formation_control/plant', values, 1.0)
    hearing.hear('formation_control/vehicle_2/links', {'awaiting': 'nope'}, 1.0)
    assert hearing.take_plant_status() is None and hearing.heard == {}


def test_the_hearing_tells_two_plants_of_one_namespace_apart_by_their_run():
    hearing = Hearing()
    status = {'step': '1', 'silent': '[]', 'silent_for': '[]'}
    hearing.hear('formation_control/plant', {**status, 'run': 'a'}, 10.0)
    hearing.hear('formation_control/plant', {**status, 'run': 'a'}, 11.0)
    assert hearing.plants_within(3.0, 11.5) == ['a']
    hearing.hear('formation_control/plant', {**status, 'run': 'b'}, 12.0)
    assert hearing.plants_within(3.0, 12.5) == ['a', 'b']
    assert hearing.plants_within(3.0, 14.5) == ['b']          # a's last status is 3.5 s old
