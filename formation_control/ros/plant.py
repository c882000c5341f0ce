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
:func:`models.integrate`). Known to the vehicles (``flow_source: known``), it goes on
``/vehicle_k/flow``: latched once if uniform, else with every odometry; for estimating rigid
bodies each odometry comes with the through-water velocity on ``/vehicle_k/water_velocity``.

A vehicle that was heard and then sends no command for ``command_timeout`` wall seconds is gone:
its command is zero, and lockstep stops waiting for it until it speaks again. A vehicle whose
state diverges (non-finite or exploding) is stopped with an error naming it and the likely
cause; once every vehicle is, the run ends (exit code 1). Counts and status:
``/diagnostics``, ``formation_control/plant``.

Every scenario parameter is read-only here: the plant uses no gain, the vehicles hold them.
"""
import sys
import time

from diagnostic_msgs.msg import DiagnosticStatus
from formation_control.core import stability
from formation_control.protocol import links, lockstep, messages, names
from formation_control.protocol.fleet import FleetPlant
from formation_control.protocol.names import START_TOPIC
from formation_control.protocol.node_parameters import check_frames, PLANT
from formation_control.protocol.onboard import needs_second_sensor
from formation_control.ros import common, interface as itf, parameters
from geometry_msgs.msg import TwistStamped, Vector3Stamped, WrenchStamped
from nav_msgs.msg import Odometry
import numpy as np
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Empty, String

REJECTS = ('non_finite', 'wrong_frame', 'stale', 'malformed')


class PlantNode(Node):
    """Rigid-body and flowfield dynamics of the whole fleet."""

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
        self.gate = lockstep.CommandGate(sc.num_vehicles, timeout['command_timeout'], self.now,
                                         self.mode == 'lockstep')
        self.fleet = FleetPlant(sc)
        self.reject = common.Rejections(self.get_logger(), REJECTS)
        self.pacer = self.missing = self.wall_start = None
        self.t0_ns = 0
        self.started = self.finished = self.done = False
        self.exit_code = 0
        self._create_topics()
        self.get_logger().info(f'plant: {sc.num_vehicles} x {sc.model}, {sc.formation} '
                               f'({sc.controller}), {self.mode}, {sc.duration:g} s')
        self.create_timer(1.0, self._publish_diagnostics, clock=self.wall)
        if self.mode == 'lockstep':
            self.create_timer(min(0.05, self.gate.liveness.timeout / 4), self._try_advance,
                              clock=self.wall)
        if self.p['wait_for_start']:
            self.create_subscription(Empty, START_TOPIC, self._start, itf.LATCHED_QOS)
        else:
            self._start()

    def _create_topics(self):
        sc, ids = self.sc, range(1, self.sc.num_vehicles + 1)
        self.odom_pubs = [self.create_publisher(Odometry, names.topic(k, 'odom'),
                                                **itf.state_qos_kwargs()) for k in ids]
        self.odom_wires = [itf.odom_wire(k, self.frames) for k in ids]
        self.cmd_wires = [itf.cmd_wire(k, self.frames) for k in ids]
        self.cmd_subs = [self.create_subscription(WrenchStamped, names.topic(k, 'cmd'),
                                                  lambda data, k=k: self._on_cmd(k, data),
                                                  raw=True,
                                                  **itf.state_qos_kwargs()) for k in ids]
        if sc.flow_source == 'estimated':
            self.period_ns = round(sc.dt_control * 1e9)
            self.state_wires = [messages.StateWire(k, () if sc.all_to_all else
                                                   sc.comm_graph.neighbours(k), self.frames, True)
                                for k in ids]
            for k in ids:
                self.create_subscription(JointState, names.topic(k, 'formation_state'),
                                         lambda data, k=k: self._on_state(k, data), raw=True,
                                         **itf.state_qos_kwargs())
        self.flow_pubs = self.water_pubs = None
        second = needs_second_sensor(sc)
        if sc.flow_source == 'known':
            self.flow_pubs = [self.create_publisher(Vector3Stamped, names.topic(k, 'flow'),
                                                    itf.LATCHED_QOS) for k in ids]
            if second is None:
                for k, pub in zip(ids, self.flow_pubs):
                    pub.publish(itf.flow_msg(k, 0, sc.flow_c, self.frames))
                self.flow_pubs = None
        if second == 'water':
            self.water_pubs = [self.create_publisher(TwistStamped,
                                                     names.topic(k, 'water_velocity'),
                                                     **itf.state_qos_kwargs()) for k in ids]
        self.clock_pub = None
        if self.mode == 'lockstep':
            self.clock_pub = self.create_publisher(Clock, names.CLOCK_TOPIC, itf.LATCHED_QOS)
        self.scenario_pub = self.create_publisher(String, names.SCENARIO_TOPIC, itf.LATCHED_QOS)
        self.scenario_pub.publish(itf.scenario_msg(sc))
        self.diag_pub = common.diagnostics_publisher(self)

    def _start(self, _msg=None):
        if self.started:
            return
        self.started = True
        if self.mode == 'lockstep':
            self._publish_step()
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
        sc = self.sc
        self.t0_ns = self.get_clock().now().nanoseconds
        tick_rate = self.p['real_time_factor'] / sc.dt_integration
        self.pacer = lockstep.Pacer(tick_rate, sc.substeps, self.now())
        self.slot = lockstep.sample_slots(sc.num_vehicles, sc.substeps)
        self.create_timer(1.0 / tick_rate, self._on_tick, clock=self.wall)
        self._publish_odom(self.slot == 0, self.t0_ns)

    def _stamp_ns(self, t):
        """Return the stamp (ns) of simulated time ``t`` (s)."""
        return self.t0_ns + int(round(t * 1e9))

    def _publish_step(self):
        ns = self._stamp_ns(self.fleet.time)
        self.gate.begin(ns)
        msg = Clock()
        msg.clock.sec, msg.clock.nanosec = divmod(ns, 1_000_000_000)
        self.clock_pub.publish(msg)
        self._publish_odom(np.ones(self.sc.num_vehicles, bool), ns)

    def _publish_odom(self, which, ns):
        X, flow = self.fleet.X, self.fleet.stepper.local_flow()
        for i in np.flatnonzero(which & ~self.fleet.stopped):
            if self.flow_pubs is not None:
                self.flow_pubs[i].publish(itf.flow_msg(i + 1, ns, flow[i], self.frames))
            if self.water_pubs is not None:
                self.water_pubs[i].publish(itf.water_velocity_msg(i + 1, ns, X[:, i],
                                                                  self.frames))
            values = messages.odom_values(X[:, i], flow[i])
            self.odom_pubs[i].publish(self.odom_wires[i].encode(ns, values))

    def _on_state(self, k, data):
        """Keep the flow estimate an estimating vehicle sends, for the record (canonical bytes)."""
        got = self.state_wires[k - 1].decode(data)
        if got is None:
            return self.reject('malformed', f'a formation_state of vehicle {k} in another '
                               f'layout (its flow estimate is not recorded)')
        ns, values = got
        step = (ns - self.t0_ns) // self.period_ns
        self.fleet.estimate(k - 1, int(step), complex(*values[-2:]))

    def _on_cmd(self, k, data):
        """Take vehicle k's command bytes, read in place in the canonical layout."""
        got = self.cmd_wires[k - 1].decode(data)
        if got is None:
            try:
                msg = deserialize_message(data, WrenchStamped)
            except Exception:
                return self.reject('malformed', f'undecodable command bytes of vehicle {k}')
            if msg.header.frame_id != self.frames.base(k):
                return self.reject('wrong_frame', f"a command on vehicle {k}'s topic in frame "
                                   f'{msg.header.frame_id!r}')
            got = messages.stamp_ns(msg.header.stamp), messages.input_from_cmd(msg, self.sc.model)
        else:
            got = got[0], messages.input_from_cmd_values(got[1], self.sc.model)
        ns, u = got
        if not np.all(np.isfinite(u)):
            return self.reject('non_finite', f'a non-finite command of vehicle {k}')
        kind = self.gate.command(k - 1, ns)
        if kind == lockstep.REPEATED:
            return
        if kind == lockstep.STALE:
            return self.reject('stale', f'a command of vehicle {k} for another step')
        self.fleet.set_command(k - 1, u)
        self._try_advance()

    def _try_advance(self):
        """Lockstep: advance once every vehicle still waited for has commanded this step."""
        if self.mode != 'lockstep' or not self.started or self.finished:
            return
        if not self.gate.ready(self.fleet.stopped):
            again = self.gate.nudge(self.fleet.stopped)
            if again is not None:
                self._publish_odom(again, self.gate.step_ns)
            return
        if self._hold(self.gate.gone(), True):
            self._integrate()
            if self.finished:
                return
            self.fleet.n += 1
            self._publish_step()

    def _on_tick(self):
        """Real time: the integration steps the wall clock has reached, each with its samples."""
        for _ in range(self.pacer.due(self.now())):
            if self.finished or not self._hold(self.gate.gone(), self.pacer.boundary):
                return
            self._integrate(1)
            tick = self.pacer.advance()
            self.fleet.n = tick // self.sc.substeps
            self._publish_odom(self.slot == tick % self.sc.substeps,
                               self._stamp_ns(tick * self.sc.dt_integration))

    def _hold(self, gone, boundary):
        if self.wall_start is None:
            self.wall_start = time.perf_counter()
        if self.fleet.hold(gone, boundary):
            return True
        self._finish()
        return False

    def _integrate(self, steps=None):
        for i in self.fleet.integrate(steps):
            self.get_logger().error(
                f'vehicle {i + 1}: its state became non-finite or exploded after t = '
                f'{self.fleet.time:.3f} s (command {self.fleet.pending[:, i].tolist()}); '
                f'vehicle {i + 1} is stopped. Likely cause: {stability.likely_cause(self.sc)}')
        if self.fleet.stopped.all() and not self.finished:
            self.get_logger().error(f'every vehicle diverged by t = {self.fleet.time:.3f} s: '
                                    f'the run stops')
            self._finish()
            self.done, self.exit_code = True, 1

    def _publish_diagnostics(self):
        stopped_mask = self.fleet.stopped
        waited = self.gate.waiting_for()
        if self.mode == 'lockstep' and not self.finished and waited > itf.STALL:
            missing = np.flatnonzero(self.gate.missing(stopped_mask)) + 1
            self.get_logger().warn(f'step {self.fleet.n}: waiting {waited:.1f} s for the '
                                   f'commands of vehicles {missing.tolist()}',
                                   throttle_duration_sec=5.0)
        gone = (np.flatnonzero(self.gate.gone()) + 1).tolist()
        stopped = (np.flatnonzero(stopped_mask) + 1).tolist()
        level, text = DiagnosticStatus.OK, f'step {self.fleet.n}'
        if gone:
            level, text = DiagnosticStatus.WARN, f'vehicles {gone} gone (zero command)'
        if stopped:
            level, text = DiagnosticStatus.ERROR, f'vehicles {stopped} stopped: non-finite state'
        values = {'step': self.fleet.n, 'gone': gone, 'stopped': stopped,
                  **self.reject.counts, 'nudges': self.gate.nudges,
                  'repeated_commands': self.gate.repeated}
        common.publish_diagnostics(self, self.diag_pub, [
            common.status('formation_control/plant', level, text, values)])

    def _finish(self):
        wall = time.perf_counter() - self.wall_start
        simulated = self.fleet.time
        path = self.p['record_path']
        if path:
            meta = {'mode': self.mode, 'wall_time': wall, 'simulated_time': simulated}
            self.fleet.run(meta).save(path)
        self.get_logger().info(f'plant: {simulated:g} s simulated in {wall:.3g} s of wall time '
                               f'(real-time factor {simulated / max(wall, 1e-9):.3g})')
        self.finished = True
        self.gate.close()
        self.done = self.p['exit_when_done']


def main(args=None):
    """``plant``: the fleet's dynamics, ``--ros-args --params-file SCENARIO``."""
    from formation_control.ros.runner import run
    return run(lambda context: PlantNode(context=context), args)


if __name__ == '__main__':
    sys.exit(main())
