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
``formation-control repair BAG``: a bag whose recorder did not close it, made whole again.

A recorder killed (SIGKILL, its swarm killed, a full disk) leaves its ``.mcap`` without the
summary and index an indexed MCAP reader needs, and the bag directory without
``metadata.yaml``: rosbags, ``ros2 bag`` and ``report`` refuse it. The records before the
failure are whole (the recorder writes finished chunks, :mod:`formation_control.ros.bag`);
this reads them in order (a streaming read), stops at the first record cut short or
malformed, and writes them to a new bag with its summary, index and ``metadata.yaml``: every
schema and channel as recorded, whatever the message types. It says what was kept: each
topic's message count, the time span, and the bytes dropped at the tail.
"""
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
import io
import os
from pathlib import Path
import shutil
import struct
import tempfile
from typing import Any, BinaryIO

from formation_control.core.errors import UsageError
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.rosbag2.storage_mcap import decompress, get_qos
from rosbags.typesys import get_types_from_idl, get_types_from_msg, get_typestore, Stores

MAGIC = b'\x89MCAP0\r\n'
SCHEMA, CHANNEL, MESSAGE, CHUNK, DATA_END, FOOTER = 0x03, 0x04, 0x05, 0x06, 0x0F, 0x02
IDL_SEPARATOR = '=' * 80 + '\n'


class Truncated(Exception):
    """A record cut short or malformed: the file ends before it."""


@dataclass
class Kept:
    """What a streaming read kept of an MCAP file."""

    size: int
    end: int = len(MAGIC)
    reason: str = 'the file ends cleanly'
    counts: dict[str, int] = field(default_factory=dict)
    first: int | None = None
    last: int | None = None

    @property
    def dropped(self) -> int:
        """Bytes after the last whole record (0 for a file that ends cleanly)."""
        return self.size - self.end

    def lines(self) -> list[str]:
        """Return the report: the topics and counts, the time span, the bytes dropped."""
        span = 0.0 if self.first is None or self.last is None else (
            (self.last - self.first) * 1e-9)
        out = [f'kept {sum(self.counts.values())} messages on {len(self.counts)} topics, '
               f'{span:.3f} s from the first to the last',
               *(f'  {topic}: {n}' for topic, n in sorted(self.counts.items()))]
        out.append(f'dropped {self.dropped} bytes at the tail ({self.reason})'
                   if self.dropped else 'dropped nothing: every record was whole')
        return out


def _string(rec: BinaryIO) -> str:
    (size,) = struct.unpack('<I', _exact(rec, 4))
    return _exact(rec, size).decode()


def _exact(rec: BinaryIO, size: int) -> bytes:
    data = rec.read(size)
    if len(data) != size:
        raise Truncated(f'a field of {size} bytes has {len(data)}')
    return data


def _records(bio: BinaryIO, end: int) -> Iterator[tuple[int, bytes]]:
    """Yield (opcode, body) of the records of ``bio`` up to ``end``; Truncated past it."""
    while bio.tell() < end:
        head = bio.read(9)
        if len(head) < 9:
            raise Truncated(f'a record header of {len(head)} of 9 bytes')
        op, length = struct.unpack('<BQ', head)
        if length > end - bio.tell():
            raise Truncated(f'a record (opcode {op:#04x}) of {length} bytes, '
                            f'{end - bio.tell()} left in the file')
        yield op, bio.read(length)


def _chunk_records(body: bytes) -> Iterator[tuple[int, bytes]]:
    rec = io.BytesIO(body)
    _, _, size, crc = struct.unpack('<QQQI', _exact(rec, 28))
    compression = _string(rec)
    (compressed,) = struct.unpack('<Q', _exact(rec, 8))
    try:
        data = decompress(_exact(rec, compressed), compression, size, crc)
    except Exception as err:
        raise Truncated(f'a chunk that does not decompress ({err})') from None
    return _records(io.BytesIO(data), len(data))


class Scan:
    """
    A streaming read of one MCAP file: its schemas, channels and messages, whole records only.

    Iterate :meth:`messages` once; :attr:`kept` then says how far it got.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.schemas: dict[int, tuple[str, str, str]] = {}
        self.channels: dict[int, tuple[str, int, str, bytes]] = {}
        self.kept = Kept(self.path.stat().st_size)

    def messages(self) -> Iterator[tuple[int, int, bytes]]:
        """Yield (channel id, log time ns, data) of every whole message record, in file order."""
        with open(self.path, 'rb') as bio:
            if bio.read(len(MAGIC)) != MAGIC:
                raise UsageError(f'{self.path}: not an MCAP file (no MCAP magic at its start)')
            try:
                for op, body in _records(bio, self.kept.size):
                    if op in (DATA_END, FOOTER):
                        self.kept.end = self.kept.size
                        return
                    inner: Iterable[tuple[int, bytes]] = (
                        _chunk_records(body) if op == CHUNK else [(op, body)])
                    yield from (m for o, b in list(inner) if (m := self._take(o, b)))
                    self.kept.end = bio.tell()
            except Truncated as cut:
                self.kept.reason = f'cut short: {cut}'

    def _take(self, op: int, body: bytes) -> tuple[int, int, bytes] | None:
        rec = io.BytesIO(body)
        if op == SCHEMA:
            (key,) = struct.unpack('<H', _exact(rec, 2))
            self.schemas[key] = (_string(rec), _string(rec), _string(rec))
        elif op == CHANNEL:
            key, schema = struct.unpack('<HH', _exact(rec, 4))
            topic, encoding = _string(rec), _string(rec)
            (size,) = struct.unpack('<I', _exact(rec, 4))
            self.channels[key] = (topic, schema, encoding, _exact(rec, size))
        elif op == MESSAGE:
            channel, _, stamp, _ = struct.unpack('<HIQQ', _exact(rec, 22))
            if channel not in self.channels:
                raise Truncated(f'a message of channel {channel}, never defined')
            return channel, stamp, rec.read()
        return None


def finish_chunk(writer: Any) -> None:
    """
    Write the pending messages of a rosbags MCAP ``writer`` out as a finished chunk.

    The recorder's side of the contract: after this, a kill loses nothing written so far (the
    chunk and its message index are whole on disk); :func:`repair` reads them back.
    """
    storage = writer.storage
    if storage is None:
        return
    if storage.chunk.bio.tell():
        storage.close_chunk()
    storage.bio.flush()


def _digest(store: Any, msgtype: str, msgdef: str, encoding: str) -> str:
    """Return the RIHS01 type hash of ``msgtype`` from its recorded definition."""
    if msgtype not in store.fielddefs:
        if encoding == 'ros2idl':
            types: dict[str, Any] = {}
            for part in msgdef.split(IDL_SEPARATOR)[1:]:
                types.update(get_types_from_idl(part.split('\n', 1)[1]))
        else:
            types = get_types_from_msg(msgdef, msgtype)
        store.register(types)
    return store.hash_rihs01(msgtype)


def _copy(scan: Scan, out: Path) -> Kept:
    """Write the messages of ``scan`` to a new bag at ``out``; return what was kept."""
    store = get_typestore(Stores.ROS2_JAZZY)
    writer = Writer(out, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    conns: dict[int, Any] = {}
    kept = scan.kept
    try:
        for channel, stamp, data in scan.messages():
            if channel not in conns:
                topic, schema, encoding, metadata = scan.channels[channel]
                msgtype, fmt, msgdef = scan.schemas[schema]
                conns[channel] = writer.add_connection(
                    topic, msgtype, msgdef=msgdef, rihs01=_digest(store, msgtype, msgdef, fmt),
                    serialization_format=encoding, offered_qos_profiles=get_qos(metadata))
            writer.write(conns[channel], stamp, data)
            topic = scan.channels[channel][0]
            kept.counts[topic] = kept.counts.get(topic, 0) + 1
            kept.first = stamp if kept.first is None else min(kept.first, stamp)
            kept.last = stamp if kept.last is None else max(kept.last, stamp)
    finally:
        writer.close()
    return kept


def repair(bag: str | Path, out: str | Path | None = None) -> Kept:
    """
    Rebuild bag ``bag`` (a directory holding one ``.mcap``) from a streaming read.

    Parameters
    ----------
    bag : str or path-like
        The bag directory, with or without ``metadata.yaml``.
    out : str or path-like, optional
        Write the repaired bag here (a new directory), leaving ``bag`` as it is; by default
        the repaired bag takes the place of ``bag``, and the original is kept beside it as
        ``BAG.unrepaired``.

    Returns
    -------
    Kept
        The topics and counts, the time span, the bytes dropped.

    Raises
    ------
    UsageError
        No bag directory, not exactly one ``.mcap`` in it, ``out`` (or ``BAG.unrepaired``)
        exists.

    """
    bag = Path(bag)
    files = sorted(bag.glob('*.mcap')) if bag.is_dir() else []
    if len(files) != 1:
        raise UsageError(f'BAG {str(bag)!r}: a bag directory holding one .mcap file is '
                         f'needed ({len(files)} found)')
    if out is not None:
        if Path(out).exists():
            raise UsageError(f'--out {str(out)!r} exists already: give a new directory')
        return _copy(Scan(files[0]), Path(out))
    old = bag.with_name(bag.name + '.unrepaired')
    if old.exists():
        raise UsageError(f'{old} exists already: move it away, or give --out DIR')
    work = Path(tempfile.mkdtemp(prefix='.repair_', dir=bag.parent))
    try:
        kept = _copy(Scan(files[0]), work / bag.name)
        os.replace(bag, old)
        os.replace(work / bag.name, bag)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return kept


def unclosed(path: str | Path) -> str | None:
    """Return why ``path`` is a bag its recorder did not close, and the remedy; else None."""
    path = Path(path)
    if path.is_dir() and not (path / 'metadata.yaml').exists() and any(path.glob('*.mcap')):
        return (f'{path}: a bag its recorder did not close (no metadata.yaml: killed, or its '
                f'disk full?): `formation-control repair {path}` makes it readable')
    return None
