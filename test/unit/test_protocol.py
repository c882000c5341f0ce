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

"""The time protocol of the plant and the vehicles, with a fake clock (no ROS, no DDS)."""
from formation_control.core import scenario
from formation_control.core.control import Controller
from formation_control.core.laws import View
from formation_control.protocol import links, lockstep
from formation_control.protocol.fleet import FleetPlant
from formation_control.protocol.lockstep import FRESH, REPEATED, STALE
from formation_control.protocol.neighbours import NeighbourTable
from formation_control.protocol.onboard import Onboard
from formation_control.sim import simulator
import numpy as np
import pytest
from runs import CONFIG


class FakeClock:
    """Wall seconds that move only when the test says so."""

    def __init__(self, t=100.0):
        self.t = t

    def __call__(self):
        return self.t


@pytest.fixture
def clock():
    return FakeClock()


def test_a_step_waits_for_every_command_stamped_with_it(clock):
    gate = lockstep.CommandGate(3, command_timeout=2.0, clock=clock)
    assert gate.command(0, 0) == STALE                      # no step under way yet
    gate.begin(0)
    assert [gate.command(i, 0) for i in (0, 1)] == [FRESH, FRESH]
    assert not gate.ready(np.zeros(3, bool))
    assert gate.command(2, 20_000_000) == STALE             # another step's command
    assert not gate.ready(np.zeros(3, bool))
    assert gate.command(2, 0) == FRESH
    assert gate.ready(np.zeros(3, bool))
    gate.begin(20_000_000)
    assert not gate.ready(np.zeros(3, bool))


def test_a_second_answer_to_a_step_is_counted_apart_from_a_stale_command(clock):
    gate = lockstep.CommandGate(2, command_timeout=2.0, clock=clock)
    gate.begin(0)
    assert gate.command(0, 0) == FRESH
    assert gate.command(0, 0) == REPEATED
    assert gate.repeated == 1
    gate.close()
    assert gate.command(1, 0) == STALE                      # the run is over


def test_a_silent_vehicle_is_no_longer_waited_for_and_a_stopped_one_never(clock):
    gate = lockstep.CommandGate(3, command_timeout=2.0, clock=clock)
    gate.begin(0)
    for i in range(3):
        gate.command(i, 0)
    gate.begin(1)
    gate.command(0, 1)
    clock.t += 1.9
    assert not gate.ready(np.zeros(3, bool))
    clock.t += 0.2                                          # vehicles 2 and 3 silent for 2.1 s
    assert list(gate.gone()) == [False, True, True]
    assert gate.ready(np.zeros(3, bool))
    stopped = np.array([True, False, False])
    assert not gate.ready(stopped)                          # nobody is waited for: no step
    gate.begin(2)
    gate.command(1, 2)                                      # vehicle 2 speaks again
    assert list(gate.gone()) == [False, False, True]
    assert list(gate.missing(np.zeros(3, bool))) == [True, False, False]


def test_a_vehicle_never_heard_is_waited_for_and_one_that_answered_is_never_gone(clock):
    gate = lockstep.CommandGate(2, command_timeout=1.0, clock=clock)
    gate.begin(0)
    gate.command(0, 0)
    clock.t += 100.0                                        # a long step: vehicle 2 starts late
    assert not gate.gone().any()
    assert not gate.ready(np.zeros(2, bool))
    gate.command(1, 0)
    assert gate.ready(np.zeros(2, bool))


def test_a_vehicle_that_has_not_answered_is_asked_again_with_back_off(clock):
    gate = lockstep.CommandGate(2, command_timeout=60.0, clock=clock)
    none = np.zeros(2, bool)
    gate.begin(0)
    gate.command(0, 0)
    asked = []
    for _ in range(80):                                     # 8 s in steps of 0.1 s
        clock.t += 0.1
        again = gate.nudge(none)
        if again is not None:
            asked.append((round(clock.t - 100.0, 1), again.tolist()))
    assert asked == [(1.1, [True, True]), (3.2, [True, True]), (7.3, [True, True])]
    assert gate.nudges == 3


def test_asking_again_skips_the_stopped_and_the_gone(clock):
    """The others are all asked: one may wait for a neighbour's lost state, not its odometry."""
    gate = lockstep.CommandGate(3, command_timeout=3.0, clock=clock)
    gate.begin(0)
    for i in range(3):
        gate.command(i, 0)
    clock.t += 0.1
    gate.begin(20)
    gate.command(1, 20)
    clock.t += 1.1
    assert gate.nudge(np.array([False, False, True])).tolist() == [True, True, False]
    clock.t += 3.0                                         # 1 and 3 silent past their timeout
    assert gate.gone().tolist() == [True, False, True]
    assert gate.nudge(np.zeros(3, bool)) is None           # none waited for is missing
    assert gate.nudges == 1


def test_the_wait_before_asking_again_scales_with_the_last_step(clock):
    gate = lockstep.CommandGate(1, command_timeout=60.0, clock=clock)
    gate.begin(0)
    clock.t += 0.5                                          # that step took 0.5 s
    gate.begin(1)
    clock.t += 1.9
    assert gate.nudge(np.zeros(1, bool)) is None            # waits NUDGE_AFTER * 0.5 = 2 s
    clock.t += 0.2
    assert gate.nudge(np.zeros(1, bool)).tolist() == [True]


def test_real_time_holds_the_latest_command_whatever_its_stamp(clock):
    gate = lockstep.CommandGate(2, command_timeout=2.0, clock=clock, lockstep=False)
    assert gate.command(0, 123) == FRESH and gate.command(0, 5) == FRESH
    clock.t += 2.5
    assert list(gate.gone()) == [True, False]


def test_pacer_takes_the_steps_the_clock_reached_and_slips_past_one_period():
    pacer = lockstep.Pacer(tick_rate=500.0, substeps=10, t0_wall=0.0)
    assert pacer.due(0.0011) == 0
    assert pacer.due(0.0041) == 2
    assert pacer.boundary
    for _ in range(2):
        pacer.advance()
    assert not pacer.boundary and pacer.tick == 2
    assert pacer.due(0.0041) == 0
    assert pacer.due(1.0) == 10                             # 498 steps late: one period only
    assert pacer.t0_wall == pytest.approx(0.976) and pacer.behind == pytest.approx(0.976)
    for _ in range(10):
        pacer.advance()
    assert pacer.tick == 12 and pacer.due(1.0) == 0


def test_each_vehicle_is_sampled_in_its_own_slot_of_the_period():
    assert lockstep.sample_slots(5, 10).tolist() == [0, 1, 2, 3, 4]
    assert lockstep.sample_slots(12, 10).tolist() == [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 0, 1]


def _row(x):
    return (complex(x, 0.0), 0.1 * x, 0.0, 1.0)


def test_vehicle_commands_once_it_holds_every_neighbours_state_of_the_step(clock):
    table = NeighbourTable(3, own=2, timeout=1.0, clock=clock)
    assert table.ready() is None                            # no odometry yet
    assert table.odometry(0) == FRESH
    table.store(2, 0, _row(2))
    assert table.ready() is None                            # 1 and 3 never heard: waited for
    assert table.hear(1, 0, _row(1))
    assert table.waiting().tolist() == [False, False, True]
    assert table.hear(3, 0, _row(3))
    assert table.ready().tolist() == [True, True, True]
    table.commanded()
    assert table.ready() is None                            # one command per step
    assert table.odometry(0) == REPEATED
    assert table.odometry(-5) == STALE


def test_vehicle_leaves_a_silent_neighbour_out_of_the_step_until_it_speaks(clock):
    table = NeighbourTable(3, own=1, timeout=1.0, clock=clock)
    table.odometry(0)
    table.store(1, 0, _row(1))
    table.hear(2, 0, _row(2))
    table.hear(3, 0, _row(3))
    table.commanded()
    clock.t += 0.5
    table.odometry(20)
    table.store(1, 20, _row(1))
    table.hear(2, 20, _row(2))
    clock.t += 1.01                                         # 3 silent for 1.01 s of this step
    assert table.ready().tolist() == [True, True, False]
    assert table.gone().tolist() == [False, False, True]
    assert not table.hear(2, 0, _row(2))                    # older than the last: stale
    table.hear(3, 20, _row(3))
    assert table.live().tolist() == [True, True, True]


def test_real_time_vehicle_commands_from_the_live_neighbours_it_has_heard(clock):
    table = NeighbourTable(3, own=3, timeout=1.0, clock=clock, lockstep=False)
    table.odometry(0)
    assert table.odometry(0) == FRESH                       # no repeats in real time
    table.store(3, 0, _row(3))
    assert table.ready().tolist() == [False, False, True]
    table.hear(1, 0, _row(1))
    assert table.ready().tolist() == [True, False, True]
    clock.t += 1.5
    assert table.ready().tolist() == [False, False, True]


def test_view_of_the_members_is_the_controllers_view_of_that_subfleet(clock):
    sc = scenario.load(CONFIG / 'particle_circular_flow.yaml', ['num_vehicles:=5'])
    ctrl = Controller(sc)
    X = scenario.initial_state(sc)
    full = ctrl.view(X)
    table = NeighbourTable(5, own=4, timeout=1.0, clock=clock)
    table.odometry(0)
    for j in range(1, 6):
        i = j - 1
        table.store(j, 0, (full.r[i], full.phase[i], full.rate[i], full.speed[i]))
    members = np.array([True, False, True, True, False])
    view, own = table.view(members, full.speed_dot[3])
    assert own == 2
    sub = ctrl.view(X[:, members])
    for name in ('r', 'phase', 'rate', 'speed'):
        np.testing.assert_array_equal(getattr(view, name), getattr(sub, name))
    assert view.speed_dot[own] == sub.speed_dot[own]
    np.testing.assert_array_equal(ctrl.command(view, X[:, [3]], [own], members=members),
                                  ctrl.command(sub, X[:, [3]], [own], members=members))


def test_real_time_neighbour_sampled_earlier_is_carried_along_its_arc_to_the_own_stamp(clock):
    table = NeighbourTable(2, own=2, timeout=1.0, clock=clock, lockstep=False)
    speed, rate, tau = 1.2, 0.8, 0.015                     # a circle of radius 1.5 m
    centre, phase = 1.0 + 2.0j, 0.3
    on_circle = centre - 1j * speed / rate * np.exp(1j * phase)
    table.odometry(15_000_000)
    table.store(2, 15_000_000, (0j, 0.0, 0.0, 1.0))
    table.hear(1, 0, (on_circle, phase, rate, speed))
    view, own = table.view(np.array([True, True]), 0.0)
    later = centre - 1j * speed / rate * np.exp(1j * (phase + rate * tau))
    assert abs(view.r[0] - later) < 1e-12
    assert view.phase[0] == pytest.approx(phase + rate * tau, abs=1e-15)
    assert (view.r[1], view.phase[1]) == (0j, 0.0)          # its own, at the stamp already


def test_inbox_drops_delays_and_limits_range_and_counts_each(clock):
    inbox = links.Inbox(links.Faults(delay=0.05, delay_jitter=0.1, vehicle_id=1), clock)
    outcomes = [inbox.receive(2, n, 0j, 1 + 0j) for n in range(100)]
    assert set(outcomes) == {links.DELAYED}
    assert inbox.due() == []
    clock.t += 0.0999
    early = [m for _, m in inbox.due()]
    clock.t += 0.06
    late = [m for _, m in inbox.due()]
    assert sorted(early + late) == list(range(100)) and 0 < len(early) < 100
    assert inbox.delay_total / 100 == pytest.approx(0.1, abs=0.01)
    lossy = links.Inbox(links.Faults(drop_probability=0.25, comm_range=5.0, vehicle_id=1), clock)
    far = [lossy.receive(2, 0, 0j, 6 + 0j) for _ in range(10)]
    near = [lossy.receive(2, 0, 0j, 1 + 0j) for _ in range(4000)]
    assert far == [links.OUT_OF_RANGE] * 10
    assert lossy.counts[links.DROPPED] == near.count(links.DROPPED)
    assert lossy.counts[links.DROPPED] / 4000 == pytest.approx(0.25, abs=0.03)
    assert set(near) == {links.DROPPED, links.NOW}
    clean = links.Inbox(links.Faults(vehicle_id=1), clock)
    assert clean.receive(2, 0, 0j, 1e6 + 0j) == links.NOW


@pytest.mark.parametrize('name', ['rigid_circular_flow_center', 'particle_parallel_flow',
                                  'first_order_circular', 'vessel_circular'])
def test_the_plants_fleet_loop_is_the_offline_simulator(name):
    """Commands computed one vehicle at a time and held by FleetPlant equal ``simulate``."""
    sc = scenario.load(CONFIG / f'{name}.yaml', ['num_vehicles:=4', 'duration:=1.0',
                                                 'informed:=[1, 3]'], seed=3)
    fleet = FleetPlant(sc)
    onboards = [Onboard(sc) for _ in range(4)]
    everyone = np.ones(4, bool)
    while True:
        rows = [onboard.observe(fleet.X[:, i]) for i, onboard in enumerate(onboards)]
        r, phase, rate, speed = map(np.array, zip(*rows))
        for i, onboard in enumerate(onboards):
            s_dot = np.where(np.arange(4) == i, onboard.speed_dot, 0.0)
            view = View(r, phase, rate, speed, s_dot)
            fleet.set_command(i, onboard.command(view, i, everyone)[0])
        if not fleet.hold(np.zeros(4, bool), True):
            break
        assert fleet.integrate().size == 0
        fleet.next_period()
    run, ref = fleet.run({}), simulator.simulate(sc)
    np.testing.assert_allclose(run.X, ref.X, rtol=0, atol=1e-12)
    np.testing.assert_allclose(run.U, ref.U, rtol=0, atol=1e-12)


def test_a_vehicle_whose_state_turns_non_finite_is_stopped_and_the_others_go_on():
    sc = scenario.load(CONFIG / 'rigid_parallel.yaml', ['num_vehicles:=3'])
    fleet = FleetPlant(sc)
    before = fleet.X.copy()
    fleet.set_command(1, (np.inf, 0.0))
    fleet.hold(np.zeros(3, bool), True)
    assert fleet.integrate().tolist() == [1]
    np.testing.assert_array_equal(fleet.X[:, 1], before[:, 1])
    assert np.any(fleet.X[:, [0, 2]] != before[:, [0, 2]], axis=0).all()
    fleet.set_command(1, (1.0, 0.0))
    fleet.hold(np.zeros(3, bool), True)
    assert fleet.pending[:, 1].tolist() == [0.0, 0.0]       # a stopped vehicle holds zero
    assert fleet.integrate().size == 0 and np.all(np.isfinite(fleet.X))


def test_the_fleet_run_ends_after_its_last_period():
    sc = scenario.load(CONFIG / 'particle_parallel.yaml', ['duration:=0.1'])
    fleet = FleetPlant(sc)
    periods = 0
    while fleet.hold(np.zeros(sc.num_vehicles, bool), True):
        fleet.integrate()
        fleet.next_period()
        periods += 1
    assert periods == 5 and fleet.time == pytest.approx(0.1)
    assert fleet.run({'mode': 'x'}).t.tolist() == pytest.approx([0.0, 0.1])


@pytest.mark.parametrize('name', ['rigid_circular_flow_center', 'rigid_circular',
                                  'vessel_circular'])
def test_onboard_controller_commands_as_the_fleet_controller_does(name, clock):
    """A vehicle's Onboard, fed its own state and its neighbours' rows, equals the simulator."""
    sc = scenario.load(CONFIG / f'{name}.yaml', ['num_vehicles:=4', 'informed:=[2]'], seed=5)
    stepper = simulator.Stepper(sc)
    X = stepper.X.copy()
    expected = stepper.command()
    table = NeighbourTable(4, own=3, timeout=1.0, clock=clock)
    onboards = [Onboard(sc) for _ in range(4)]
    for j, onboard in enumerate(onboards, start=1):
        table.store(j, 0, onboard.observe(X[:, j - 1]))
    table.odometry(0)
    members = table.ready()
    view, own = table.view(members, onboards[2].speed_dot)
    u, saturated = onboards[2].command(view, own, members)
    np.testing.assert_allclose(u, expected[:, 2], rtol=0, atol=1e-12)
    assert not saturated
    if sc.controller == 'pi':
        integral = onboards[2].ctrl.integral.copy()
        onboards[2].retune(scenario.resolve({**sc.to_dict(), 'K_P': 12.0}))
        assert onboards[2].ctrl.sc.K_P == 12.0
        np.testing.assert_array_equal(onboards[2].ctrl.integral, integral)
