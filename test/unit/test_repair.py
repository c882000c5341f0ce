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

"""``formation-control repair``: bags left unclosed, cut anywhere, of any message type."""
from pathlib import Path
import shutil

from formation_control.bags.repair import finish_chunk, repair, unclosed
from formation_control.core.errors import UsageError
import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import get_types_from_msg, get_typestore, Stores

mcap_reader = pytest.importorskip('mcap.reader', reason='pip mcap (the test extra)')

SAMPLE = 'float64 x\nstring label\nint32[] ids\n'
"""A message type no typestore knows: repair must carry its recorded definition."""


def _store():
    store = get_typestore(Stores.ROS2_JAZZY)
    store.register(get_types_from_msg(SAMPLE, 'repair_test_msgs/msg/Sample'))
    return store


class Recording:
    """A bag written as the recorder writes it, copied aside at any moment (a kill)."""

    def __init__(self, tmp_path):
        self.tmp_path, self.store = tmp_path, _store()
        self.writer = Writer(tmp_path / 'live', version=9, storage_plugin=StoragePlugin.MCAP)
        self.writer.open()
        self.sample = self.writer.add_connection('/sample', 'repair_test_msgs/msg/Sample',
                                                 typestore=self.store)
        self.text = self.writer.add_connection('/text', 'std_msgs/msg/String',
                                               typestore=self.store)
        self.n = 0

    def write(self, count):
        Sample = self.store.types['repair_test_msgs/msg/Sample']
        String = self.store.types['std_msgs/msg/String']
        for _ in range(count):
            self.n += 1
            msg = Sample(x=float(self.n), label=f'sample {self.n}',
                         ids=np.full(3, self.n, np.int32))
            self.writer.write(self.sample, self.n * 1_000_000,
                              self.store.serialize_cdr(msg, 'repair_test_msgs/msg/Sample'))
            self.writer.write(self.text, self.n * 1_000_000 + 1,
                              self.store.serialize_cdr(String(data=str(self.n)),
                                                       'std_msgs/msg/String'))

    def killed(self, name, cut=None):
        """Return a bag directory holding the file as it is on disk now, cut at ``cut``."""
        bag = self.tmp_path / name
        bag.mkdir()
        data = (self.tmp_path / 'live' / 'live.mcap').read_bytes()
        (bag / f'{name}.mcap').write_bytes(data if cut is None else data[:cut])
        return bag


@pytest.fixture
def rec(tmp_path):
    """Give a :class:`Recording` in ``tmp_path``, its writer closed at the end of the test."""
    made = Recording(tmp_path)
    yield made
    if made.writer.storage is not None:
        made.writer.close()


def _read(bag):
    """Return the (topic, x or data) of every message, read by rosbags and mcap's reader."""
    with AnyReader([Path(bag)]) as reader:
        got = [(c.topic, getattr(msg, 'x', None) or msg.data) for c, _, raw in reader.messages()
               for msg in [reader.deserialize(raw, c.msgtype)]]
    with open(next(Path(bag).glob('*.mcap')), 'rb') as f:
        indexed = mcap_reader.make_reader(f)
        assert indexed.get_summary().statistics.message_count == len(got)
        assert sum(1 for _ in indexed.iter_messages()) == len(got)
    return got


def test_a_killed_recorder_loses_nothing_before_its_last_finished_chunk(rec, tmp_path):
    rec.write(300)
    finish_chunk(rec.writer)
    rec.write(7)                                   # pending in memory: lost with the process
    bag = rec.killed('B')
    assert 'formation-control repair' in unclosed(bag)
    kept = repair(bag)
    assert kept.counts == {'/sample': 300, '/text': 300}
    assert kept.dropped == 0 and kept.first == 1_000_000 and kept.last == 300_000_001
    got = _read(bag)
    assert [x for t, x in got if t == '/sample'] == [float(k) for k in range(1, 301)]
    assert [x for t, x in got if t == '/text'] == [str(k) for k in range(1, 301)]
    assert (tmp_path / 'B.unrepaired' / 'B.mcap').is_file()
    assert unclosed(bag) is None


def test_a_file_cut_anywhere_keeps_every_whole_record_before_the_cut(rec, tmp_path):
    for _ in range(6):
        rec.write(40)
        finish_chunk(rec.writer)
    size = (tmp_path / 'live' / 'live.mcap').stat().st_size
    kept_before = -1
    for i, cut in enumerate(range(0, size + 1, max(1, size // 37))):
        if cut < 8:
            with pytest.raises(UsageError, match='not an MCAP file'):
                repair(rec.killed(f'c{i}', cut), tmp_path / f'r{i}')
            continue
        kept = repair(rec.killed(f'c{i}', cut), tmp_path / f'r{i}')
        total = sum(kept.counts.values())
        assert total >= kept_before and total % 80 == 0        # whole chunks of 40 + 40
        assert kept.dropped == cut - kept.end >= 0
        assert len(_read(tmp_path / f'r{i}')) == total
        kept_before = total
    assert kept_before == 480


def test_a_closed_bag_is_rebuilt_whole_and_out_leaves_it_as_it_is(rec, tmp_path):
    rec.write(50)
    rec.writer.close()
    kept = repair(tmp_path / 'live', tmp_path / 'copy')
    assert sum(kept.counts.values()) == 100 and kept.dropped == 0
    assert 'dropped nothing' in kept.lines()[-1]
    assert _read(tmp_path / 'copy') == _read(tmp_path / 'live')
    with pytest.raises(UsageError, match='exists already'):
        repair(tmp_path / 'live', tmp_path / 'copy')


def test_repair_names_what_it_needs(rec, tmp_path):
    with pytest.raises(UsageError, match='a bag directory holding one .mcap file'):
        repair(tmp_path / 'nothing')
    rec.write(5)
    finish_chunk(rec.writer)
    bag = rec.killed('B')
    shutil.copy(bag / 'B.mcap', bag / 'other.mcap')
    with pytest.raises(UsageError, match=r'\(2 found\)'):
        repair(bag)
