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
A probe of a fleet (test helper, run as a script): listens to it and, with --inject, commands it.

``intruder.py N [--inject]`` subscribes to every ``vehicle_k/formation_state`` and
``vehicle_k/odom`` of a fleet of N and, with --inject, publishes a full-scale command on every
``vehicle_k/cmd`` at 50 Hz. On SIGINT or SIGTERM it prints one JSON line: the samples it
received per topic, the subscribers its command publishers matched, the commands it sent.
"""
import json
import signal
import sys

from formation_control_msgs.msg import FormationState, VehicleCommand
from nav_msgs.msg import Odometry
import rclpy
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                 durability=DurabilityPolicy.TRANSIENT_LOCAL)


def main():
    n, inject = int(sys.argv[1]), '--inject' in sys.argv
    rclpy.init(signal_handler_options=rclpy.SignalHandlerOptions.NO)
    node = rclpy.create_node('intruder')
    got = {}

    def count(topic):
        got[topic] = 0
        return lambda _msg: got.__setitem__(topic, got[topic] + 1)

    for k in range(1, n + 1):
        for name, kind in (('formation_state', FormationState), ('odom', Odometry)):
            topic = f'/vehicle_{k}/{name}'
            node.create_subscription(kind, topic, count(topic), QOS)
    pubs = [node.create_publisher(VehicleCommand, f'/vehicle_{k}/cmd', QOS)
            for k in range(1, n + 1)] if inject else []
    sent = [0]

    def command():
        msg = VehicleCommand(kind=VehicleCommand.SECOND_ORDER, thrust=50.0,
                             angular_acceleration=5.0)
        for pub in pubs:
            pub.publish(msg)
            sent[0] += 1

    if inject:
        node.create_timer(0.02, command)
    stop = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.append(1))
    print('probing', flush=True)
    while not stop:
        rclpy.spin_once(node, timeout_sec=0.05)
    print(json.dumps({'received': got, 'sent': sent[0],
                      'matched': sum(p.get_subscription_count() for p in pubs)}), flush=True)
    node.destroy_node()
    rclpy.try_shutdown()


if __name__ == '__main__':
    main()
