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
A flood of bad samples (test helper, run as a script): ``flooder.py PLAN.json``.

The plan lists topics, each with its ROS message type (``pkg/msg/Name``), its QoS
(``reliability``, ``durability``, ``depth``), the subscriptions to wait for and its samples
(hex). Once every topic has its subscriptions matched it prints ``matched``, then publishes the
samples as they are (serialized bytes), one of each topic per round, and prints one JSON line:
the indices of the samples sent, per topic (the middleware refuses to send some: a payload
shorter than its encapsulation header).
"""
import json
import sys
import time

import rclpy
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

ROUND = 0.02
"""Wall seconds between two rounds: the receivers keep up, no sample is overwritten."""


def _qos(spec):
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=spec['depth'],
                      reliability=ReliabilityPolicy[spec['reliability']],
                      durability=DurabilityPolicy[spec['durability']])


def _msg_type(name):
    package, _, cls = name.split('/')
    return getattr(__import__(f'{package}.msg', fromlist=[cls]), cls)


def _publish(pub, data):
    try:
        pub.publish(data)
    except RuntimeError:
        return False
    return True


def main():
    with open(sys.argv[1]) as f:
        plan = json.load(f)
    rclpy.init(signal_handler_options=rclpy.SignalHandlerOptions.NO)
    node = rclpy.create_node('flooder')
    pubs = [(t, node.create_publisher(_msg_type(t['type']), t['topic'], _qos(t)),
             [bytes.fromhex(s) for s in t['samples']]) for t in plan]
    end = time.monotonic() + 60.0
    while any(pub.get_subscription_count() < t['matches'] for t, pub, _ in pubs):
        if time.monotonic() > end:
            print(json.dumps({'unmatched': [t['topic'] for t, pub, _ in pubs
                                            if pub.get_subscription_count() < t['matches']]}))
            return 1
        time.sleep(0.02)
    print('matched', flush=True)
    sent = {t['topic']: [] for t, _, _ in pubs}
    for i in range(max(len(samples) for _, _, samples in pubs)):
        for t, pub, samples in pubs:
            if i < len(samples) and _publish(pub, samples[i]):
                sent[t['topic']].append(i)
        time.sleep(ROUND)
    time.sleep(1.0)                     # reliable samples still in flight reach their readers
    print(json.dumps(sent), flush=True)
    node.destroy_node()
    rclpy.shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
