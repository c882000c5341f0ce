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
The fleet's processes die with the process that started them, however it dies.

The starter (``formation-control swarm``, ``ros2 launch ... fleet.launch.py``) puts its pid in
:data:`PARENT_ENV` of each process it starts (:func:`tied_env`); the swarm also puts its
processes in one process group of their own, and says so in :data:`GROUP_ENV`. Each node process
calls :func:`die_with_parent` first thing:

- on Linux, ``prctl(PR_SET_PDEATHSIG, SIGTERM)``: the kernel sends SIGTERM the moment the
  parent dies, even by SIGKILL, and the node stops as on Ctrl-C (the plant writes its record);
- everywhere, a thread watches the parent and the starter (they differ when a wrapper that
  forks, such as ``sudo``, stands between them), every :data:`WATCH_PERIOD` s; when either is
  gone,
  the thread sends SIGCONT to the fleet's group (a member frozen by a ``stop`` fault handles
  no SIGTERM until continued), SIGTERM to its own process, and asks the kernel to end the
  process :data:`GRACE` s later if it still lives (:func:`end_within`: SIGALRM, whose default
  action needs nothing of the process, not even Python's lock of the interpreter; a shutdown
  hung in the middleware cannot keep it alive). The node's own stop arms the same deadline: a
  tied process that has left its loop ends within :data:`GRACE` s, even if its starter is
  killed while the shutdown hangs (the watch thread may then never run again).

A process started without :data:`PARENT_ENV` (``ros2 run`` from a shell) is not tied.
"""
import ctypes
import math
import os
import signal
import sys
import threading
import time

PARENT_ENV = 'FORMATION_CONTROL_PARENT'
"""The environment variable holding the starter's pid."""
GROUP_ENV = 'FORMATION_CONTROL_GROUP'
MEMBER_ENV = 'FORMATION_CONTROL_MEMBER'
"""The environment variable naming a launched process's member of the fleet (``vehicle_3``)."""
"""The environment variable saying (``1``) that this process's group is the fleet's own."""
PR_SET_PDEATHSIG = 1
"""prctl option: the signal sent to this process when its parent dies (linux/prctl.h)."""
WATCH_PERIOD = 0.25
"""Seconds between two looks at the parent."""
GRACE = 10.0
"""Seconds an orphaned process has to stop by itself after its SIGTERM."""


def tied_env(env, group=False):
    """Return a copy of ``env`` naming this process the parent (``group``: in its own group)."""
    out = dict(env)
    out[PARENT_ENV] = str(os.getpid())
    if group:
        out[GROUP_ENV] = '1'
    else:
        out.pop(GROUP_ENV, None)
    return out


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def parent_death_signal(sig=signal.SIGTERM):
    """Ask the kernel for ``sig`` when the parent dies (Linux); return whether it was set."""
    if not sys.platform.startswith('linux'):
        return False
    libc = ctypes.CDLL(None, use_errno=True)           # the process's own symbols: libc's
    return libc.prctl(PR_SET_PDEATHSIG, int(sig), 0, 0, 0) == 0


class Tie:
    """
    What ties this process to its starter: the pids it watches, the group it wakes.

    Parameters
    ----------
    starter : int
        The pid of the swarm or launch (:data:`PARENT_ENV`).
    group : bool
        Whether this process's group is the fleet's own (:data:`GROUP_ENV`): then it is
        continued when the starter is gone.

    """

    def __init__(self, starter, group=False):
        self.starter, self.group = starter, group
        self.parent = os.getppid()

    def orphaned(self):
        """Return whether the parent or the starter is gone."""
        return os.getppid() != self.parent or not _alive(self.starter)

    def release(self):
        """Continue the fleet's group, then stop this process: SIGTERM, after GRACE its end."""
        if self.group:
            os.killpg(os.getpgrp(), signal.SIGCONT)
        end_within(GRACE)
        os.kill(os.getpid(), signal.SIGTERM)

    def watch(self):
        """Look every WATCH_PERIOD s; once the starter is gone, :meth:`release`."""
        while not self.orphaned():
            time.sleep(WATCH_PERIOD)
        self.release()


def end_within(seconds):
    """
    Have the kernel end this process in ``seconds`` (whole, at least 1), whatever it does then.

    SIGALRM with its default action, which Python leaves in place: no handler runs, so neither
    a thread holding the interpreter's lock nor a wait in the middleware delays it.
    """
    signal.alarm(max(1, math.ceil(seconds)))


def members(starter, proc='/proc'):
    """
    Return ``{member: pid}`` of the live processes a starter (its pid) started as members.

    A process counts when its environment holds :data:`PARENT_ENV` = ``starter`` and a
    :data:`MEMBER_ENV` (Linux: ``/proc/<pid>/environ``); others' processes, and those that
    end while read, are passed over.
    """
    out = {}
    for entry in os.scandir(proc):
        if not entry.name.isdigit():
            continue
        try:
            with open(os.path.join(entry.path, 'environ'), 'rb') as f:
                env = dict(v.split(b'=', 1) for v in f.read().split(b'\0') if b'=' in v)
        except OSError:
            continue
        if env.get(PARENT_ENV.encode()) == str(starter).encode() and MEMBER_ENV.encode() in env:
            out[env[MEMBER_ENV.encode()].decode(errors='replace')] = int(entry.name)
    return out


def die_with_parent(environ=None):
    """Tie this process to its starter, if :data:`PARENT_ENV` names one; return the Tie."""
    environ = os.environ if environ is None else environ
    if not environ.get(PARENT_ENV, '').isdigit():
        return None
    tie = Tie(int(environ[PARENT_ENV]), environ.get(GROUP_ENV) == '1')
    parent_death_signal()
    threading.Thread(target=tie.watch, daemon=True, name='die_with_parent').start()
    return tie
