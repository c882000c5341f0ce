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
A headless Foxglove WebSocket client for the tests.

It offers one or both subprotocols ``foxglove.sdk.v1`` (the Foxglove app's) and
``foxglove.websocket.v1`` (the ws-protocol spec's name, same messages: Foxglove Studio 1.x,
Lichtblick), checks the server chose one of them, reads the server's
``advertise``, subscribes to channels by topic and decodes the binary ``messageData`` frames
(opcode 1: subscription id u32, log time u64 ns, payload) as the Foxglove app does: JSON,
protobuf from the advertised FileDescriptorSet, CDR bytes as they are.
"""
import base64
import contextlib
import json
import struct
import time

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from websockets.sync.client import connect

SUBPROTOCOLS = ['foxglove.sdk.v1', 'foxglove.websocket.v1']
MESSAGE_DATA = 0x01


def protobuf_class(schema_name, file_descriptor_set):
    """Return the protobuf message class ``schema_name`` of a serialized FileDescriptorSet."""
    files = descriptor_pb2.FileDescriptorSet.FromString(file_descriptor_set)
    pool = descriptor_pool.DescriptorPool()
    for proto in files.file:
        pool.Add(proto)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(schema_name))


@contextlib.contextmanager
def client(port, host='127.0.0.1', timeout=10.0, subprotocols=SUBPROTOCOLS):
    """Yield a :class:`Client` connected to ``ws://host:port`` (retried until ``timeout``)."""
    end = time.monotonic() + timeout
    while True:
        try:
            ws = connect(f'ws://{host}:{port}', subprotocols=subprotocols, open_timeout=timeout)
            break
        except OSError:
            if time.monotonic() > end:
                raise
            time.sleep(0.05)
    with ws:
        assert ws.subprotocol in subprotocols
        yield Client(ws)


class Client:
    """An open connection; ``channels`` maps topic -> advertised channel."""

    def __init__(self, ws):
        self.ws = ws
        self.channels = {}
        self.subscribed = {}
        self.info = None

    def _handle_text(self, text):
        msg = json.loads(text)
        if msg['op'] == 'serverInfo':
            self.info = msg
        elif msg['op'] == 'advertise':
            self.channels.update({c['topic']: c for c in msg['channels']})

    def poll(self, timeout=0.05):
        """Read one frame (None on timeout); text frames update the state, data is returned."""
        try:
            frame = self.ws.recv(timeout=timeout)
        except TimeoutError:
            return None
        if isinstance(frame, str):
            self._handle_text(frame)
            return None
        assert frame[0] == MESSAGE_DATA
        sub, log_time = struct.unpack_from('<IQ', frame, 1)
        return self.subscribed[sub], log_time, self._decode(self.subscribed[sub], frame[13:])

    def wait_advertised(self, topics, spin, timeout=10.0):
        """Read frames (calling ``spin()`` between them) until every topic is advertised."""
        end = time.monotonic() + timeout
        while not set(topics) <= set(self.channels):
            assert time.monotonic() < end, f'not advertised: {set(topics) - set(self.channels)}'
            spin()
            self.poll()

    def subscribe(self, topics):
        subs = []
        for topic in topics:
            sub = len(self.subscribed) + 1
            self.subscribed[sub] = self.channels[topic]
            subs.append({'id': sub, 'channelId': self.channels[topic]['id']})
        self.ws.send(json.dumps({'op': 'subscribe', 'subscriptions': subs}))

    @staticmethod
    def _decode(channel, payload):
        if channel['encoding'] == 'json':
            return json.loads(payload)
        if channel['encoding'] == 'protobuf':
            cls = protobuf_class(channel['schemaName'], base64.b64decode(channel['schema']))
            return cls.FromString(payload)
        return payload
