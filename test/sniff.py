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
A wire tap (test helper, run as root in a host's namespace): what TCP carries in the clear.

``sniff.py IFACE`` reads every IPv4 TCP segment on IFACE (an AF_PACKET socket) until SIGINT or
SIGTERM, then prints one JSON line: the segments and payload bytes seen, and how often each
marker of plaintext DDS (the RTPS and RTCP headers, a topic name) occurs in the payloads.

A header is matched with the fields that follow its four letters: any four bytes occur by
chance about once in 4 GiB of ciphertext (the 7 MB of one TLS fleet test showed an ``RTPS``
once), a marker of 6-7 fixed bytes once in 2^48.
"""
import json
import re
import signal
import socket
import sys

MARKERS = {'RTPS': re.compile(rb'RTPS\x02.\x01\x0f', re.S),    # RTPS 2.x, vendor eProsima
           'RTCP': re.compile(rb'RTCP..\x00\x00', re.S),        # a TCP frame below 64 KiB
           'formation_state': re.compile(rb'formation_state')}
ETH_P_ALL = 0x0003


def tcp_payload(frame):
    """Return the TCP payload of an Ethernet frame, or None if it is no IPv4 TCP segment."""
    if len(frame) < 34 or frame[12:14] != b'\x08\x00' or frame[23] != 6:
        return None
    ip = 14 + 4 * (frame[14] & 0x0F)
    total = int.from_bytes(frame[16:18], 'big')
    return frame[ip + 4 * (frame[ip + 12] >> 4):14 + total]


def main():
    tap = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ETH_P_ALL))
    tap.bind((sys.argv[1], 0))
    tap.settimeout(0.2)
    stop, seen = [], {'segments': 0, 'bytes': 0, **dict.fromkeys(MARKERS, 0)}
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.append(1))
    print('tapping', flush=True)
    while not stop:
        try:
            payload = tcp_payload(tap.recv(65536))
        except socket.timeout:
            continue
        if payload:
            seen['segments'] += 1
            seen['bytes'] += len(payload)
            for name, marker in MARKERS.items():
                seen[name] += len(marker.findall(payload))
    print(json.dumps(seen), flush=True)


if __name__ == '__main__':
    main()
