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
Benchmark the canonical-bytes wires against rclpy's (de)serialization, per message.

A vehicle's formation_control_msgs/FormationState (vehicle 3 of a ring: two neighbours; and of
the complete graph) and its VehicleCommand: ``StateWire`` / ``CommandWire`` encode and decode,
and rclpy's deserialize_message of the same bytes plus reading them into the record (what the
intake does for bytes in another layout). Best of ``--repeat`` timings of ``--number`` calls.

    .venv/bin/python bench/wire.py [--number 20000] [--repeat 5]
"""
import argparse
import timeit

from formation_control.protocol import messages
from formation_control.protocol.messages import FormationState, StateWire
from formation_control.ros import interface as itf
import formation_control_msgs.msg as fcm
import numpy as np
from rclpy.serialization import deserialize_message

X = np.array([1.5, -2.0, 0.3, -0.2, 1.1, 0.05])
ROW = (1.5 - 2.0j, 0.7, -0.1, 1.1)
NS = 1_795_000_123_456_789_012


def cases():
    """Yield (name, function) of each timed call."""
    for label, hears in (('ring', (2, 4)), ('complete', ())):
        wire = StateWire(3, hears)
        state = FormationState.of_vehicle(NS, X, ROW, dict.fromkeys(hears, True), ahead=10**7)
        data = wire.encode(state)
        yield f'state ({label}) encode', lambda w=wire, s=state: w.encode(s)
        yield f'state ({label}) decode', lambda w=wire, d=data: w.decode(d)
        yield f'state ({label}) deserialize + read', lambda d=data: FormationState.of_message(
            deserialize_message(d, fcm.FormationState))
    cmd = itf.cmd_wire(3, 'rigid')
    values = messages.cmd_values((0.8, -0.02), 'rigid')
    data = cmd.encode(NS, values)
    yield 'command encode', lambda: cmd.encode(NS, values)
    yield 'command decode', lambda: cmd.decode(data)
    yield 'command deserialize', lambda: deserialize_message(data, fcm.VehicleCommand)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--number', type=int, default=20000)
    parser.add_argument('--repeat', type=int, default=5)
    args = parser.parse_args()
    print(f'# us per call, best of {args.repeat} x {args.number}')
    for name, call in cases():
        best = min(timeit.repeat(call, number=args.number, repeat=args.repeat))
        print(f'{name:>40s} {1e6 * best / args.number:8.2f}')


if __name__ == '__main__':
    main()
