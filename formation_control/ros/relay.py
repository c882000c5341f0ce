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
The live view's public port: both names of the Foxglove WebSocket protocol.

foxglove-sdk 0.30's server accepts only the subprotocols ``foxglove.sdk.v1`` and
``foxglove.sdk.v1.1`` (its handshake has no option for more); Foxglove Studio 1.x, Lichtblick
and other ws-protocol clients offer ``foxglove.websocket.v1``, the same protocol under its
older name. :class:`Relay` listens on the public address with the ``websockets`` server,
accepts any of :data:`SUBPROTOCOLS`, and forwards every frame unchanged, both ways, to the SDK
server on a loopback port (as ``foxglove.sdk.v1``, or ``foxglove.sdk.v1.1`` when the client chose
it). The protocol itself (server info, channels, subscriptions, backlog) stays foxglove-sdk's.
"""
import asyncio
import contextlib
import threading

from websockets.asyncio.client import connect
from websockets.asyncio.server import serve
from websockets.exceptions import ConnectionClosed

SDK_V1, SDK_V1_1, WEBSOCKET_V1 = 'foxglove.sdk.v1', 'foxglove.sdk.v1.1', 'foxglove.websocket.v1'
SUBPROTOCOLS = (SDK_V1_1, SDK_V1, WEBSOCKET_V1)
"""What the public port accepts, in the server's preference."""


def upstream_subprotocol(chosen):
    """Return the subprotocol to offer the SDK server for a client's ``chosen`` one."""
    return chosen if chosen in (SDK_V1, SDK_V1_1) else SDK_V1


async def _pipe(source, sink):
    with contextlib.suppress(ConnectionClosed):
        async for frame in source:
            await sink.send(frame)
    await sink.close()


class Relay:
    """
    A WebSocket front on ``host:port`` for the SDK server on ``127.0.0.1:upstream_port``.

    Parameters
    ----------
    host : str
        Address to listen on.
    port : int
        TCP port (0: any free one; :attr:`port` is the one bound).
    upstream_port : int
        The foxglove-sdk server's loopback port.

    Raises
    ------
    OSError
        When ``host:port`` cannot be bound.

    """

    def __init__(self, host, port, upstream_port):
        self.upstream = f'ws://127.0.0.1:{upstream_port}'
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, name='foxglove-relay',
                                       daemon=True)
        self.thread.start()
        try:
            self.server = self._call(self._serve(host, port))
        except BaseException:
            self._stop_loop()
            raise
        self.port = self.server.sockets[0].getsockname()[1]

    def _call(self, coroutine):
        return asyncio.run_coroutine_threadsafe(coroutine, self.loop).result()

    async def _serve(self, host, port):
        return await serve(self._client, host, port, subprotocols=SUBPROTOCOLS,
                           compression=None, max_size=None)

    async def _client(self, ws):
        async with connect(self.upstream, subprotocols=[upstream_subprotocol(ws.subprotocol)],
                           compression=None, max_size=None) as sdk:
            await asyncio.gather(_pipe(ws, sdk), _pipe(sdk, ws))

    def close(self):
        """Stop listening, close the connections and end the relay's thread."""
        self.server.close()
        self._call(self.server.wait_closed())
        self._stop_loop()

    def _stop_loop(self):
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join()
        self.loop.close()
