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

"""Processes tied to their starter die with it, by SIGKILL too, frozen or not (no DDS here)."""
import os
from pathlib import Path
import signal
import subprocess
import sys
import time

from formation_control.ops import lifetime
import pytest

CHILD = """
import signal, sys, time
from formation_control.ops import lifetime
if sys.argv[1] == 'watch_only':
    lifetime.parent_death_signal = lambda sig=None: False
if sys.argv[1] == 'signal_only':
    lifetime.Tie.watch = lambda self: None
lifetime.GRACE = 1.0
signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
if sys.argv[1] == 'deaf':
    signal.signal(signal.SIGTERM, lambda *_: None)
if sys.argv[1] == 'hangs_holding_the_lock':
    lifetime.Tie.watch = lambda self: None
    signal.signal(signal.SIGTERM, lambda *_: (lifetime.end_within(1), sum(range(10 ** 15))))
signal.signal(signal.SIGHUP, lambda *_: sys.exit(0))
assert lifetime.die_with_parent()
print('ready', flush=True)
while True:
    time.sleep(1)
"""
STARTER = """
import os, subprocess, sys
from formation_control.ops import lifetime
env = lifetime.tied_env(os.environ, group=True)
group = 0
for how in sys.argv[1:]:
    child = subprocess.Popen([sys.executable, '-c', sys.argv[0], how], env=env,
                             process_group=group, stdout=subprocess.PIPE, text=True)
    group = group or child.pid
    assert child.stdout.readline() == 'ready\\n'
    print(child.pid, flush=True)
signal_wait = os.read(0, 1)
"""


def _alive(pid):
    try:
        state = Path(f'/proc/{pid}/stat').read_text().rpartition(')')[2].split()[0]
    except OSError:
        return False
    return state not in 'ZX'


def _gone_within(pids, seconds):
    end = time.monotonic() + seconds
    while any(_alive(p) for p in pids):
        if time.monotonic() > end:
            return False
        time.sleep(0.05)
    return True


def _start(*hows):
    """Start a starter of one tied child per ``how``; return it and the children's pids."""
    starter = subprocess.Popen(
        [sys.executable, '-c', STARTER.replace('sys.argv[0]', repr(CHILD)), *hows],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
        env={**os.environ, 'PYTHONPATH': str(Path(__file__).resolve().parents[2])})
    pids = [int(starter.stdout.readline()) for _ in hows]
    return starter, pids


@pytest.fixture
def started():
    made = []
    yield lambda *hows: made.append(_start(*hows)) or made[-1]
    for starter, pids in made:
        for pid in [starter.pid, *pids]:
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)
        starter.wait()
        starter.stdin.close()
        starter.stdout.close()


@pytest.mark.skipif(not sys.platform.startswith('linux'), reason='PR_SET_PDEATHSIG is Linux')
def test_the_kernel_stops_a_tied_process_when_its_starter_is_killed(started):
    starter, pids = started('signal_only')
    starter.kill()
    assert _gone_within(pids, 5.0)


def test_without_a_parent_death_signal_the_watch_stops_an_orphan(started):
    starter, pids = started('watch_only')
    starter.kill()
    assert _gone_within(pids, 10 * lifetime.WATCH_PERIOD + 2.0)


def test_a_frozen_member_of_the_fleet_group_is_continued_and_stops(started):
    starter, (running, frozen) = started('watch_only', 'watch_only')
    os.kill(frozen, signal.SIGSTOP)
    starter.kill()
    assert _gone_within([running, frozen], 10 * lifetime.WATCH_PERIOD + 2.0)


def test_an_orphan_deaf_to_its_sigterm_ends_after_its_grace(started):
    starter, pids = started('deaf')
    starter.kill()
    assert _gone_within(pids, 10 * lifetime.WATCH_PERIOD + 1.0 + 2.0)


def test_a_stop_hung_holding_the_interpreter_lock_still_ends_on_time(started):
    """The node's own stop arms the deadline before a shutdown that may hang in DDS."""
    starter, pids = started('hangs_holding_the_lock')
    starter.kill()
    assert _gone_within(pids, 1.0 + 2.0)


def test_an_untied_process_is_left_alone():
    assert lifetime.die_with_parent({}) is None
    env = lifetime.tied_env({'A': '1', lifetime.GROUP_ENV: '1'})
    assert env == {'A': '1', lifetime.PARENT_ENV: str(os.getpid())}


def test_the_members_of_a_starter_are_found_by_their_environment():
    base = {**os.environ, lifetime.PARENT_ENV: str(os.getpid())}
    envs = {'vehicle_2': {**base, lifetime.MEMBER_ENV: 'vehicle_2'},
            'vehicles_3-4': {**base, lifetime.MEMBER_ENV: 'vehicles_3-4'},
            'none': base,                                                 # no member name
            'other': {**base, lifetime.PARENT_ENV: '1', lifetime.MEMBER_ENV: 'vehicle_1'}}
    procs = {name: subprocess.Popen(['sleep', '30'], env=env) for name, env in envs.items()}
    try:
        assert lifetime.members(os.getpid()) == {
            'vehicle_2': procs['vehicle_2'].pid, 'vehicles_3-4': procs['vehicles_3-4'].pid}
    finally:
        for proc in procs.values():
            proc.kill()
            proc.wait()
    assert lifetime.members(os.getpid()) == {}
