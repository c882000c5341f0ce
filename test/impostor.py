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
A member posing as another (test helper, run as a script): vehicle_2's key, vehicle K's topics.

``impostor.py MEMBER_DIR K MODEL [STATUS ...]`` runs with a TLS profile of its own and the key
of the member in MEMBER_DIR. At 50 Hz it publishes on ``vehicle_K/formation_state`` and
``vehicle_K/cmd`` (plain, in the canonical layout, full-scale values), their envelopes signed
with its key (``wrong_signer``) and envelopes that claim to be vehicle K's (``bad_signature``);
it replays the envelopes vehicle K sends on them half a second later (``replay``). Given STATUS
names, it publishes ``formation/start`` (the fleet's plant waits for it) once each of those
``/diagnostics`` statuses counts more than ``START_AFTER`` wrong-signer and bad-signature
drops: the run starts once every receiver hears it, however long TLS discovery took. It prints
``probing`` once started and, on SIGINT or SIGTERM, one JSON line: what it sent, and the last
``/diagnostics`` values of each status.
"""
import collections
import json
from pathlib import Path
import signal
import sys
import time

from diagnostic_msgs.msg import DiagnosticArray
from formation_control.ops import signing
from formation_control.protocol.messages import CommandWire, FormationState, StateWire
from formation_control.protocol.names import START_TOPIC
from formation_control.ros.interface import LATCHED_QOS
from formation_control_msgs.msg import FormationState as StateMsg, VehicleCommand
import rclpy
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Empty, UInt8MultiArray

QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                 durability=DurabilityPolicy.TRANSIENT_LOCAL)
"""The fleet's state QoS (a volatile writer would match none of its readers)."""
START_AFTER = 50
"""Drops of each kind every named receiver counts before the impostor starts the run."""
KINDS = (signing.WRONG_SIGNER, signing.BAD_SIGNATURE)


def main():
    home, k, model, awaited = Path(sys.argv[1]), int(sys.argv[2]), sys.argv[3], sys.argv[4:]
    me = signing.load_member(home)
    own, forged = me.signer, signing.Signer(f'vehicle_{k}', me.signer.sign)
    rclpy.init(signal_handler_options=rclpy.SignalHandlerOptions.NO)
    node = rclpy.create_node('impostor')
    topics = {'formation_state': (StateMsg, StateWire(k).encode(FormationState(
        0, 50.0, 50.0, 1.0, 5.0, 1.0, 5.0, 9.0))),
        'cmd': (VehicleCommand, CommandWire(k, model).encode(0, (50.0, 50.0, 0.0, 0.0)))}
    sent = collections.Counter()
    heard = collections.deque()
    pubs = {}

    def genuine(name, topic, data):
        if isinstance(me.verifier.unseal(topic, data), bytes):
            heard.append((time.monotonic(), name, data))

    for name, (kind, payload) in topics.items():
        topic = f'/vehicle_{k}/{name}'
        pubs[name] = (node.create_publisher(kind, topic, QOS),
                      node.create_publisher(UInt8MultiArray, topic + signing.SUFFIX, QOS))
        node.create_subscription(UInt8MultiArray, topic + signing.SUFFIX,
                                 lambda data, name=name, topic=topic: genuine(name, topic, data),
                                 QOS, raw=True)
    status = {}
    start = node.create_publisher(Empty, '/' + START_TOPIC, LATCHED_QOS)

    def diagnostics(msg):
        status.update({s.name: {v.key: v.value for v in s.values} for s in msg.status})
        if awaited and all(int(status.get(name, {}).get(kind, 0)) > START_AFTER
                           for name in awaited for kind in KINDS):
            start.publish(Empty())
            awaited.clear()
    node.create_subscription(DiagnosticArray, '/diagnostics', diagnostics, 10)

    def inject():
        for name, (_kind, payload) in topics.items():
            plain, envelopes = pubs[name]
            topic = f'/vehicle_{k}/{name}'
            plain.publish(payload)
            envelopes.publish(own.seal(topic, payload))
            envelopes.publish(forged.seal(topic, payload))
            sent.update((f'{name}_plain', f'{name}_wrong_signer', f'{name}_forged'))
        while heard and heard[0][0] < time.monotonic() - 0.5:
            _, name, data = heard.popleft()
            pubs[name][1].publish(data)
            sent[f'{name}_replayed'] += 1
    node.create_timer(0.02, inject)
    stop = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.append(1))
    print('probing', flush=True)
    while not stop:
        rclpy.spin_once(node, timeout_sec=0.1)
    print(json.dumps({'sent': sent, 'status': status}), flush=True)
    node.destroy_node()
    rclpy.try_shutdown()


if __name__ == '__main__':
    main()
