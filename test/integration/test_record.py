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
The record survives, and nothing is left running (docs/reliability.md, "The record").

A swarm killed with SIGKILL (one of its vehicles frozen by a ``stop`` fault) leaves no process
behind and a bag that ``formation-control repair`` makes readable to ``report``, ``play`` and
an indexed MCAP reader, and the plant's ``.npz`` of the run so far; a recorder killed alone
likewise; a full disk and a read-only directory stop the swarm with a clear error, what was
recorded before kept.
"""
import contextlib
import os
from pathlib import Path
import re
import resource
import subprocess
import tempfile
import time

from formation_control.bags import reader as bagfile
from formation_control.bags.playback import Bag
from formation_control.ros.interface import LATCHED_QOS
from formation_control.sim import simulator
from mcap.reader import make_reader
import pytest
from rosgraph_msgs.msg import Clock
from rosutil import ament_prefix, BIN, CONFIG, output

ORPHAN_DEADLINE = 20.0
"""Seconds the fleet has to be gone once its starter is killed (SIGTERM, then GRACE 10 s)."""


def _stat(pid):
    """Return (state, ppid, pgrp) of ``pid``, or None once it is gone or a zombie."""
    try:
        fields = Path(f'/proc/{pid}/stat').read_text().rpartition(')')[2].split()
    except OSError:
        return None
    return None if fields[0] in 'ZX' else (fields[0], int(fields[1]), int(fields[2]))


def _children(parent):
    """Return the pids of the live processes whose parent is ``parent``."""
    pids = [int(p.name) for p in Path('/proc').iterdir() if p.name.isdigit()]
    return [pid for pid in pids if (_stat(pid) or (None, None))[1] == parent]


def _group(pgrp):
    pids = [int(p.name) for p in Path('/proc').iterdir() if p.name.isdigit()]
    return [pid for pid in pids if (_stat(pid) or (None, None, None))[2] == pgrp]


def _gone(pids, groups=(), deadline=ORPHAN_DEADLINE):
    """Wait until none of ``pids`` nor any member of ``groups`` lives; return those left."""
    end = time.monotonic() + deadline
    while True:
        left = [p for p in pids if _stat(p)] + [p for g in groups for p in _group(g)]
        if not left or time.monotonic() > end:
            return sorted(set(left))
        time.sleep(0.1)


def _described(pids):
    """Return what each of ``pids`` is: its state, command line and its threads' kernel waits."""
    out = {}
    for pid in pids:
        proc = Path(f'/proc/{pid}')
        try:
            cmd = (proc / 'cmdline').read_bytes().replace(b'\0', b' ').decode()[-160:]
            waits = sorted({(t / 'wchan').read_text() for t in (proc / 'task').iterdir()})
        except OSError:
            continue
        out[pid] = (_stat(pid), cmd, waits)
    return out


def _cli(ros, *args, timeout=120):
    return subprocess.run([str(BIN / 'formation-control'), *map(str, args)], env=ros.env,
                          capture_output=True, text=True, timeout=timeout)


def _swarm(ros, *args, preexec_fn=None):
    """Start a swarm of rigid_parallel; its output goes to ``proc.log`` (rosutil.output)."""
    log = tempfile.TemporaryFile('w+')
    proc = subprocess.Popen([str(BIN / 'formation-control'), 'swarm',
                             CONFIG / 'rigid_parallel.yaml', *map(str, args)], env=ros.env,
                            stdout=log, stderr=subprocess.STDOUT, text=True,
                            stdin=subprocess.DEVNULL, preexec_fn=preexec_fn)
    proc.log = log
    ros.procs.procs.append(proc)
    return proc


def _wait_for_fleet_time(ros, seconds, timeout=120):
    clock = ros.probe.collect(Clock, '/clock', LATCHED_QOS)
    assert ros.probe.spin_until(
        lambda: clock and clock[-1].clock.sec >= seconds, timeout=timeout), 'no fleet time'


def _flushed_twice(path, timeout=30):
    """Wait until ``path`` has grown twice (two chunks flushed); return whether it did."""
    sizes, end = [path.stat().st_size], time.monotonic() + timeout
    while len(set(sizes)) < 3 and time.monotonic() < end:
        time.sleep(0.05)
        sizes.append(path.stat().st_size)
    return len(set(sizes)) >= 3


def _assert_readable(bag, kept_total):
    """Read the whole bag with the package's report and play, and an indexed MCAP reader."""
    run = bagfile.read_run(bag)
    assert run.t[-1] > 0
    assert sum(1 for _ in Bag(bag).messages()) == kept_total
    mcap_file = next(Path(bag).glob('*.mcap'))
    with open(mcap_file, 'rb') as f:
        reader = make_reader(f)
        assert reader.get_summary().statistics.message_count == kept_total
        assert sum(1 for _ in reader.iter_messages()) == kept_total
    return run


def _kept(output):
    found = re.search(r'kept (\d+) messages on (\d+) topics', output)
    assert found, output
    return int(found[1])


def test_swarm_killed_leaves_no_process_and_a_bag_repair_makes_readable(ros, tmp_path):
    bag = tmp_path / 'B'
    swarm = _swarm(ros, '--duration', '60', '--bag', bag, '--fault', 'stop:2@2')
    _wait_for_fleet_time(ros, 5)
    fleet = _children(swarm.pid)
    assert len(fleet) == 7, fleet                       # plant, 5 vehicles, monitor
    groups = {_stat(p)[2] for p in fleet}
    assert len(groups) == 1 and groups != {os.getpgrp()}    # one group, the swarm's own
    assert any(_stat(p)[0] == 'T' for p in fleet)       # vehicle 2 frozen
    swarm.kill()
    swarm.wait()
    left = _gone(fleet, groups)
    assert left == [], _described(left)

    refused = _cli(ros, 'report', bag)
    assert refused.returncode == 2 and 'formation-control repair' in refused.stderr
    repaired = _cli(ros, 'repair', bag)
    assert repaired.returncode == 0, repaired.stderr
    assert '/vehicle_5/odom' in repaired.stdout and 'dropped' in repaired.stdout
    assert (tmp_path / 'B.unrepaired').is_dir()
    run = _assert_readable(bag, _kept(repaired.stdout))
    assert run.t[-1] > 2.0                              # past the fault; FLUSH_PERIOD lost at most

    out = output(swarm)
    record = Path(re.search(r"the plant's record (\S+) in", out)[1])
    partial = simulator.load_run(record)
    assert partial.meta['complete'] is False
    assert partial.t[-1] >= run.t[-1]                   # written on its SIGTERM, at the kill


@pytest.mark.skipif(not (BIN / 'ros2').exists(), reason='the ros2 command line is not in the '
                    'venv (make setup installs it from ../shared/ros2-tools)')
def test_a_launch_killed_leaves_no_process_and_its_bag_repairs(ros, tmp_path):
    env = {**ros.env, 'AMENT_PREFIX_PATH': str(ament_prefix(tmp_path / 'prefix'))}
    bag = tmp_path / 'B'
    launch_file = Path(__file__).resolve().parents[2] / 'launch' / 'fleet.launch.py'
    log = tempfile.TemporaryFile('w+')
    launch = subprocess.Popen([str(BIN / 'ros2'), 'launch', str(launch_file),
                               'scenario:=rigid_parallel', 'duration:=60', f'record:={bag}',
                               'vehicles_per_process:=1'],
                              env=env, stdout=log, stderr=subprocess.STDOUT,
                              stdin=subprocess.DEVNULL)
    launch.log = log
    ros.procs.procs.append(launch)
    _wait_for_fleet_time(ros, 4)
    fleet = _children(launch.pid)
    assert len(fleet) == 9, (fleet, output(launch)[-2000:])   # the recorder, the warden
    launch.kill()
    launch.wait()
    left = _gone(fleet)
    assert left == [], _described(left)
    repaired = _cli(ros, 'repair', bag)
    assert repaired.returncode == 0, repaired.stderr
    _assert_readable(bag, _kept(repaired.stdout))


def test_recorder_killed_alone_leaves_a_bag_repair_makes_readable(ros, tmp_path):
    bag = tmp_path / 'B'
    recorder = ros.procs.start('recorder', '--ros-args', '-p', f'bag:={bag}',
                               '-p', 'num_vehicles:=5', '-p', 'use_sim_time:=true')
    names = ros.probe.node.get_node_names
    assert ros.probe.spin_until(lambda: 'formation_bag_recorder' in names(), timeout=60), \
        output(recorder)
    swarm = _swarm(ros, '--duration', '60')
    _wait_for_fleet_time(ros, 4)
    mcap_file = bag / 'B.mcap'
    assert _flushed_twice(mcap_file), output(recorder)     # what came before 4 s is written
    recorder.kill()
    recorder.wait()
    assert swarm.poll() is None                         # the fleet carries on without it
    out = tmp_path / 'R'
    repaired = _cli(ros, 'repair', bag, '--out', out)
    assert repaired.returncode == 0, repaired.stderr
    assert not (bag / 'metadata.yaml').exists()         # --out leaves the original as it is
    _assert_readable(out, _kept(repaired.stdout))


@contextlib.contextmanager
def _tmpfs(path, size):
    path.mkdir()
    mounted = subprocess.run(['mount', '-t', 'tmpfs', '-o', f'size={size}', 'tmpfs', str(path)],
                             capture_output=True, text=True)
    if mounted.returncode != 0:
        pytest.skip(f'cannot mount a tmpfs here: {mounted.stderr.strip()}')
    try:
        yield path
    finally:
        subprocess.run(['umount', '-l', str(path)], check=True)


def _file_size_limit(limit):
    """Let the swarm and its fleet write no file past ``limit`` bytes: a full disk, no root."""
    def set_limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return set_limit


@pytest.mark.parametrize('full', ['tmpfs', 'file_size_limit'])
def test_a_full_disk_stops_the_swarm_with_a_clear_error_and_keeps_the_bag(ros, tmp_path, full):
    if full == 'tmpfs' and os.geteuid() != 0:
        pytest.skip('mounting a tmpfs needs root; file_size_limit is the same case without')
    with contextlib.ExitStack() as stack:
        preexec = None
        if full == 'tmpfs':
            disk = stack.enter_context(_tmpfs(tmp_path / 'disk', '1m'))
        else:
            disk, preexec = tmp_path, _file_size_limit(1 << 20)
        bag = disk / 'B'
        swarm = _swarm(ros, '--duration', '60', '--bag', bag, preexec_fn=preexec)
        swarm.wait(timeout=300)
        out = output(swarm)
        assert swarm.returncode == 1, out
        assert re.search(r'error: bag .*B: writing failed after \d+ messages \((No space left '
                         r'on device|File too large)\); recording stopped', out), out
        assert 'formation-control repair' in out
        repaired = _cli(ros, 'repair', bag, '--out', tmp_path / 'R')
        assert repaired.returncode == 0, repaired.stderr
    kept = _kept(repaired.stdout)
    assert kept > 100
    _assert_readable(tmp_path / 'R', kept)


def test_a_read_only_bag_directory_is_a_clear_error_before_any_process_starts(ros, tmp_path):
    if os.geteuid() != 0:
        pytest.skip('root ignores permission bits: a read-only mount is the case; needs root')
    with _tmpfs(tmp_path / 'ro', '1m') as ro:
        subprocess.run(['mount', '-o', 'remount,ro', str(ro)], check=True)
        swarm = _swarm(ros, '--duration', '60', '--bag', ro / 'B')
        swarm.wait(timeout=120)
    out = output(swarm)
    assert swarm.returncode == 1, out
    assert re.search(r'error: bag .*B: cannot be created \(Read-only file system\)', out), out
    logs = Path(re.search(r'in (\S+)\n', out)[1])
    assert not list(logs.glob('*.log'))                 # no process was started
