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
``warden``: heals a launched fleet, as ``formation-control swarm`` heals its own.

``fleet.launch.py`` starts it beside the fleet. It hears on ``/diagnostics`` whom the plant
waits on and whom each vehicle awaits (:class:`~formation_control.protocol.healing.Hearing`),
and a vehicle process that holds the fleet past ``heal_after`` (one that never joined, or that
stopped answering while alive: :class:`~formation_control.protocol.healing.Healer`) is
stopped with SIGKILL; the launch starts it again (its ``respawn``, at most
:data:`~formation_control.protocol.healing.HEAL_LIMIT` times). It finds the process by the
member name the launch gave it (:func:`~formation_control.ops.lifetime.members`), and says
what it did in its log and in its ``/diagnostics`` status ``formation_control/warden``
(``healed``: each restart with its reason).
"""
import json
import os
import signal
import sys
import time

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from formation_control.core.errors import ScenarioError
from formation_control.ops import lifetime
from formation_control.protocol import names
from formation_control.protocol.fleet_plan import FleetPlan
from formation_control.protocol.healing import Healer, Hearing, STARTUP
from formation_control.protocol.node_parameters import WARDEN
from formation_control.ros import common, interface as itf, parameters
from rclpy.node import Node


class WardenNode(Node):
    """The warden of the fleet of its namespace, started by the launch named in its environment."""

    def __init__(self, **kwargs):
        super().__init__('formation_warden', **kwargs)
        values = parameters.declare_node(self, WARDEN)
        starter = os.environ.get(lifetime.PARENT_ENV, '')
        if not starter.isdigit():
            raise ScenarioError(f'the warden heals the members of a launch: start it from '
                                f'fleet.launch.py ({lifetime.PARENT_ENV} is not set)')
        self.starter = int(starter)
        plan = FleetPlan(values['num_vehicles'], per_process=values['vehicles_per_process'])
        processes = plan.vehicles()
        self.names = [p.name for p in processes]
        self.healer = Healer([p.vehicles for p in processes], values['heal_after'],
                             startup=STARTUP * (len(processes) + 2))
        now = time.monotonic()
        for i in range(len(processes)):
            self.healer.resumed(i, now)
        self.hearing = Hearing(self.get_namespace())
        self.healed = []
        self.diagnostics = common.diagnostics_publisher(self)
        reject = common.Rejections(self.get_logger(), ['malformed'])
        common.subscribe_messages(self, DiagnosticArray, names.DIAGNOSTICS_TOPIC, self._on_status,
                                  reject, qos_profile=itf.STREAM_QOS)

    def _on_status(self, msg):
        now = time.monotonic()
        for s in msg.status:
            self.hearing.hear(s.name, {kv.key: kv.value for kv in s.values}, now)
        status = self.hearing.take_plant_status()
        if status is None:
            return
        pids = lifetime.members(self.starter)
        running = [i for i, name in enumerate(self.names) if name in pids]
        due = self.healer.due(*status, self.hearing.heard, running, now)
        for i, reason in due:
            self._restart(self.names[i], pids[self.names[i]], reason)
        if due:
            self._publish()

    def _restart(self, name, pid, reason):
        self.get_logger().warning(f'healing {name}: {reason}: restarted (pid {pid} stopped; '
                                  f'the launch starts it again)')
        self.healed.append({'process': name, 'reason': reason, 'wall': time.time()})
        for sig in (signal.SIGCONT, signal.SIGKILL):
            try:
                os.kill(pid, sig)
            except ProcessLookupError:
                break

    def _publish(self):
        level = DiagnosticStatus.WARN if self.healed else DiagnosticStatus.OK
        text = f'{len(self.healed)} restarts' if self.healed else 'nothing to heal'
        common.publish_diagnostics(self, self.diagnostics, [common.status(
            'formation_control/warden', level, text, {'healed': json.dumps(self.healed)})])


def main(args=None):
    from formation_control.ros.runner import run
    return run(lambda context: WardenNode(context=context), args)


if __name__ == '__main__':
    sys.exit(main())
