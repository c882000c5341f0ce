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
``plant``: integrates the N vehicles of a scenario and broadcasts their state.

The dynamics are the offline simulator's sampled-data loop (:class:`fleet.FleetPlant`), the
time protocol is :mod:`lockstep` (which commands a step waits for, real-time pacing): this node
converts messages and publishes.

Lockstep (default): the plant owns the fleet's ``clock``; it publishes step n (clock, every
odometry), waits for the command of every vehicle stamped with step n, records, integrates one
control period, and publishes step n + 1. Real time: simulated time starts once every vehicle
is up (a writer on each command topic; ``wait_for_fleet``); then a wall timer integrates the
steps the clock has reached with the last command of each vehicle held, and vehicle k's
odometry is sent at integration step (k - 1) mod substeps of each period.

The flow each vehicle meets is the plant's flowfield at its own place and time (the simulator's
:func:`models.integrate`), and its gust when gusts are on (:mod:`world`: the odometry's
ground velocity has it, the flow a vehicle is told has not). Known to the vehicles
(``flow_source: known``), it goes on ``/vehicle_k/flow``: latched once if uniform, else with
every odometry; for estimating rigid bodies each odometry comes with the through-water velocity
on ``/vehicle_k/water_velocity``.

An aircraft's command (``plant_backend: jsbsim``) is its autopilot demand on ``vehicle_k/cmd_vel``
(geometry_msgs/TwistStamped, its base frame: linear.x airspeed, angular.z turn rate), which the
autopilot flies as sent; the plant does not subscribe to its ``cmd``, which the vehicle still
publishes for the monitor, the bags and ``watch``. The lockstep gate and ``wait_for_fleet`` wait
for ``cmd_vel`` then.

A vehicle that was heard and then sends no command for ``command_timeout`` wall seconds is gone:
its command is zero, and lockstep stops waiting for it until it speaks again. A vehicle whose
state diverges (non-finite or exploding) is stopped with an error naming it and the likely
cause; once every vehicle is, the run ends (exit code 1). Counts and status:
``/diagnostics``, ``formation_control/plant``.

Every scenario parameter is read-only here: the plant uses no gain, the vehicles hold them.
"""
import os
from pathlib import Path
import sys
import time

from diagnostic_msgs.msg import DiagnosticStatus
from formation_control.core.sensors import covariances
from formation_control.protocol import intake, links, messages, names
from formation_control.protocol.names import START_TOPIC
from formation_control.protocol.node_parameters import check_frames, PLANT
from formation_control.protocol.onboard import needs_second_sensor
from formation_control.protocol.plant import Plant
from formation_control.ros import common, interface as itf, parameters, signed, tracing
from formation_control.sim.backends import backend_of
from formation_control_msgs.msg import FormationState, VehicleCommand
from geometry_msgs.msg import TwistStamped, Vector3Stamped
from nav_msgs.msg import Odometry
import numpy as np
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Empty, String

REJECTS = ('non_finite', 'wrong_frame', 'stale', 'malformed', 'foreign_id', 'wrong_kind',
           'interface_version')
SNAPSHOT_PERIOD = 2.0
"""Wall seconds between two snapshots of the record (at least; see :meth:`PlantNode._snapshot`)."""
BEHIND = 0.5
"""Wall seconds the real-time plant may slip more between two warnings."""
LEVELS = {'ok': DiagnosticStatus.OK, 'warn': DiagnosticStatus.WARN,
          'error': DiagnosticStatus.ERROR}


class PlantNode(Node):
    """Rigid-body and flowfield dynamics of the whole fleet: messages in and out of a Plant."""

    def __init__(self, **kwargs):
        super().__init__('plant', **kwargs)
        self.p = parameters.declare_node(self, PLANT)
        parameters.declare(self, runtime=False)
        parameters.reject_unknown(self, PLANT)
        check_frames(self.p)
        self.frames = names.Frames(self.p['world_frame'], self.p['base_frame'])
        self.sc = sc = parameters.current(self)
        for note in sc.warnings:
            self.get_logger().warn(note)
        self.mode = parameters.choice(self, 'mode', parameters.MODES)
        timeout = links.check({'command_timeout': self.p['command_timeout']}, sc.num_vehicles, 0)
        self.wall, self.now = common.wall_clock()
        self.plant = Plant(sc, self.mode == 'lockstep', timeout['command_timeout'], self.now)
        self.fleet = self.plant.fleet
        self.reject = common.Rejections(self.get_logger(), REJECTS)
        self.signed = signed.of_node(self, self.reject, 'plant')
        self.trace = tracing.of_node('plant')
        common.clock_bytes(self, self.reject, self.signed)
        self.missing = self.fleet_timer = None
        self.done = self.ended = False
        self.behind = 0.0
        self.run_id = os.urandom(4).hex()
        """This run's identity in the plant's status (``run``): two in one namespace are two
        fleets on the same topics (the swarm refuses to go on)."""
        self.exit_code = 0
        self._create_topics()
        self.get_logger().info(f'plant: {sc.num_vehicles} x {sc.model}, {sc.formation} '
                               f'({sc.controller}), {self.mode}, {sc.duration:g} s')
        self.create_timer(1.0, self._publish_diagnostics, clock=self.wall)
        if self.mode == 'lockstep':
            self.create_timer(min(0.05, self.plant.gate.liveness.timeout / 4), self._advance,
                              clock=self.wall)
        self.snapshot_timer = None
        if self.p['record_path']:
            self.snapshot_timer = self.create_timer(SNAPSHOT_PERIOD, self._snapshot,
                                                    clock=self.wall)
        if self.p['wait_for_start']:
            common.subscribe_messages(self, Empty, START_TOPIC, self._start, self.reject,
                                      qos_profile=itf.LATCHED_READER_QOS)
        else:
            self._start()

    def destroy_node(self):
        """Keep the record so far when stopped before the end (Ctrl-C, SIGTERM, the swarm gone)."""
        if self.p['record_path'] and not self.ended:
            self._save({**self.plant.progress(), 'complete': False})
        self.trace.save()
        return super().destroy_node()

    def _create_topics(self):
        sc, ids, qos = self.sc, range(1, self.sc.num_vehicles + 1), itf.state_qos_kwargs
        self.odom_pubs = self._per_vehicle(Odometry, 'odom', signed=self.signed, **qos())
        self.odom_wires = [itf.odom_wire(k, self.frames, covariances(sc)) for k in ids]
        if backend_of(sc).takes_demand:
            self.cmd_subs = [self._subscribe(TwistStamped, k, 'cmd_vel', intake.autopilot_demand(
                itf.cmd_vel_wire(k, self.frames), k, self.frames.base(k)), self._on_demand)
                for k in ids]
        else:
            self.cmd_subs = [self._subscribe(VehicleCommand, k, 'cmd', intake.command(
                itf.cmd_wire(k, sc.model, self.frames), self.frames.base(k)), self._on_cmd)
                for k in ids]
        if sc.flow_source == 'estimated':
            for k in ids:
                self._subscribe(FormationState, k, 'formation_state', intake.formation_state(
                    messages.StateWire.of(sc, k, self.frames), self.frames),
                    lambda k, state: self.plant.estimate(k, state))
        self.flow_pubs = self.water_pubs = self.clock_pub = None
        second = needs_second_sensor(sc)
        if sc.flow_source == 'known':
            self.flow_pubs = self._per_vehicle(Vector3Stamped, 'flow', qos_profile=itf.LATCHED_QOS)
            if second is None:
                for k, pub in zip(ids, self.flow_pubs):
                    pub.publish(itf.flow_msg(k, 0, sc.flow_c, self.frames))
                self.flow_pubs = None
        if second == 'water':
            self.water_pubs = self._per_vehicle(TwistStamped, 'water_velocity', **qos())
        if self.mode == 'lockstep':
            self.clock_pub = (self.create_publisher if self.signed is None else
                              self.signed.publisher)(Clock, names.CLOCK_TOPIC,
                                                     qos_profile=itf.LATCHED_QOS)
        self.scenario_pub = self.create_publisher(String, names.SCENARIO_TOPIC, itf.LATCHED_QOS)
        self.scenario_pub.publish(itf.scenario_msg(sc))
        self.diag_pub = common.diagnostics_publisher(self)

    def _per_vehicle(self, msg_type, name, signed=None, **qos):
        publisher = self.create_publisher if signed is None else signed.publisher
        return [publisher(msg_type, names.topic(k, name), **qos)
                for k in range(1, self.sc.num_vehicles + 1)]

    def _subscribe(self, msg_type, k, name, rule, take):
        return common.subscribe(self, msg_type, names.topic(k, name), rule, self.reject,
                                lambda got: take(k, got), self.signed)

    def _start(self, _msg=None):
        if self.plant.started or self.fleet_timer is not None:
            return
        if self.mode == 'lockstep':
            self._send((np.ones(self.sc.num_vehicles, bool), self.plant.begin(), True))
        elif self.p['wait_for_fleet']:
            self.fleet_timer = self.create_timer(0.05, self._start_when_fleet_is_up,
                                                 clock=self.wall)
        else:
            self._start_clock()

    def _start_when_fleet_is_up(self):
        missing = [k for k, sub in enumerate(self.cmd_subs, start=1)
                   if sub.get_publisher_count() == 0]
        if missing != self.missing:
            self.missing = missing
            self.get_logger().info(f'real time starts once vehicles {missing} are up'
                                   if missing else 'every vehicle is up: real time starts')
        if not missing:
            self.destroy_timer(self.fleet_timer)
            self._start_clock()

    def _start_clock(self):
        """Real time: t = 0 now; the first integration step is one tick away."""
        t0_ns = self.get_clock().now().nanoseconds
        period = self.plant.start_clock(t0_ns, self.p['real_time_factor'])
        self.create_timer(period, self._on_tick, clock=self.wall)
        self._publish_odom(self.plant.slot == 0, t0_ns)

    def _publish_odom(self, which, ns):
        flow, sent = self.fleet.local_flow(), np.flatnonzero(which & ~self.fleet.stopped)
        for i, (values, water) in zip(sent, self.fleet.odometry(sent)):
            if self.flow_pubs is not None:
                self.flow_pubs[i].publish(itf.flow_msg(i + 1, ns, flow[i], self.frames))
            if self.water_pubs is not None:
                self.water_pubs[i].publish(itf.water_velocity_msg(i + 1, ns, water,
                                                                  self.frames))
            data = self.odom_wires[i].encode(ns, values)
            self.trace.indexed('odom_pub', i, ns)
            self.odom_pubs[i].publish(data)
            self.trace.indexed('odom_sent', i, ns)

    def _on_cmd(self, k, got):
        self.trace.note('cmd_in', k, got[0])
        self._held(self.plant.command(k, *got))

    def _on_demand(self, k, got):
        self._held(self.plant.demand(k, *got))

    def _held(self, held):
        if isinstance(held, intake.Rejection):
            return self.reject(held.kind, held.what)
        if held:
            self._advance()

    def _advance(self):
        """Lockstep: the next step once every vehicle waited for has commanded this one."""
        self._send(self.plant.advance())

    def _on_tick(self):
        """Real time: the integration steps the wall clock has reached, each with its samples."""
        for due in self.plant.ticks():
            self._send(due)
        self._send(None)

    def _send(self, due):
        """Log what went wrong, end a finished run, send the odometry (and clock) ``due``."""
        for text in self.plant.errors:
            self.get_logger().error(text)
        self.plant.errors.clear()
        if self.plant.finished and not self.ended:
            self._finish()
        if due is not None:
            which, ns, step = due
            if step:
                self.trace.note('step', 0, ns)
                msg = Clock()
                messages.set_time(msg.clock, ns)
                self.clock_pub.publish(msg)
            self._publish_odom(which, ns)

    def _publish_diagnostics(self):
        stalled = self.plant.stalled(itf.STALL)
        if stalled is not None:
            self.get_logger().warn(f'step {self.fleet.n}: waiting {stalled[0]:.1f} s for the '
                                   f'commands of vehicles {stalled[1]}',
                                   throttle_duration_sec=5.0)
        level, text, values = self.plant.status(self.reject.counts, self.missing or ())
        values['run'] = self.run_id
        if values['behind'] > self.behind + BEHIND:
            self.behind = values['behind']
            self.get_logger().warn(f'real time: {self.behind:.1f} s behind the wall clock so far, '
                                   f'the machine does not keep the pace: lower num_vehicles or '
                                   f'the real_time_factor, or run in lockstep',
                                   throttle_duration_sec=10.0)
        common.publish_diagnostics(self, self.diag_pub, [
            common.status('formation_control/plant', LEVELS[level], text, values)])

    def _snapshot(self):
        """Write the record so far (``complete: false``); the next one after 20 times as long."""
        start = time.monotonic()
        self._save({**self.plant.progress(), 'complete': False})
        took = time.monotonic() - start
        self.destroy_timer(self.snapshot_timer)
        self.snapshot_timer = self.create_timer(max(SNAPSHOT_PERIOD, 20 * took), self._snapshot,
                                                clock=self.wall)

    def _save(self, meta):
        """Write the record to ``record_path`` atomically: a kill leaves the last one whole."""
        if not self.fleet.recorder.count:
            return
        path = Path(self.p['record_path'])
        part = path.with_name(path.name + '.part')
        with open(part, 'wb') as out:
            self.fleet.run({'mode': self.mode, **meta}).save(out)
        os.replace(part, path)

    def _finish(self):
        self.ended = True
        meta, summary = self.plant.summary()
        if self.p['record_path']:
            self._save({**meta, 'complete': True})
        self.get_logger().info(summary)
        self.done, self.exit_code = (True, 1) if self.plant.failed else (
            self.p['exit_when_done'], 0)


def main(args=None):
    """``plant``: the fleet's dynamics, ``--ros-args --params-file SCENARIO``."""
    from formation_control.ros.runner import run
    return run(lambda context: PlantNode(context=context), args)


if __name__ == '__main__':
    sys.exit(main())
