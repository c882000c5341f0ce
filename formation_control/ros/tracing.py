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
Timestamps of the hot path, for the latency breakdown of a fleet (off unless asked).

With ``FORMATION_CONTROL_TRACE=DIR`` in its environment, a plant or vehicle node notes
(event, vehicle, stamp ns, :func:`time.monotonic_ns`) at each point of a step's path (the
plant's publish of an odometry, a vehicle's callback entry, its law, its publishes, a state's
arrival at a neighbour, a command's arrival at the plant) and writes them to
``DIR/<node>_<pid>.npz`` when it is destroyed, with the process's CPU time, context switches
(also between its first and last event: CPU s, voluntary and involuntary switches, wall s)
and time spent runnable but waiting for a core (``/proc/self/schedstat``: the main
thread, and the sum over its threads). CLOCK_MONOTONIC is
one clock for every process of a host, so the times of two processes subtract:
``bench/fleet_trace.py`` reads them. Unset (the default), a node's trace is :data:`NULL`, a
:class:`NullTrace`: the node notes each event all the same, at the cost of one method call
that does nothing (no allocation).
"""
import os
import resource
import time

import numpy as np

ENV = 'FORMATION_CONTROL_TRACE'
EVENTS = ('odom_pub', 'odom_sent', 'cmd_in', 'step', 'odom_in', 'state_sent', 'state_in',
          'law_start', 'law_end', 'cmd_sent')
"""Plant: before and after publishing vehicle k's odometry of stamp ns, a command's arrival
(decoded), a lockstep step sent. Vehicle k: its odometry's callback entry, its state sent, a
neighbour's state arrived (decoded; the vehicle is the neighbour's id), its law begun and
done, its command sent."""
CODE = {name: i for i, name in enumerate(EVENTS)}


class Trace:
    """The events of one node, kept in memory and written once (:meth:`save`)."""

    def __init__(self, directory, name):
        self.path = os.path.join(directory, f'{name}_{os.getpid()}.npz')
        self.rows = []
        self.clock = time.monotonic_ns
        self.first = self.last = None

    def _snapshot(self):
        usage = resource.getrusage(resource.RUSAGE_SELF)
        return np.array([usage.ru_utime + usage.ru_stime, usage.ru_nvcsw, usage.ru_nivcsw,
                         time.monotonic()])

    def note(self, event, vehicle, ns, at=None):
        """
        Note ``event`` (a name of :data:`EVENTS`) of ``vehicle`` for the step stamped ns.

        ``at``: when it happened (monotonic ns), for an event noted after the fact; now if None.
        """
        self.last = self._snapshot()
        if self.first is None:
            self.first = self.last
        self.rows.append((CODE[event], vehicle, ns, self.clock() if at is None else at))

    def indexed(self, event, i, ns):
        """Note ``event`` of the vehicle of index i (0-based: vehicle i + 1)."""
        self.note(event, i + 1, ns)

    def since(self, event, vehicle, ns, perf_ns):
        """Note ``event``, which happened at :func:`time.perf_counter_ns` ``perf_ns``."""
        self.note(event, vehicle, ns, at=self.clock() - (time.perf_counter_ns() - perf_ns))

    def save(self):
        """Write the events and the process's CPU and scheduling figures."""
        usage = resource.getrusage(resource.RUSAGE_SELF)
        rows = np.array(self.rows, np.int64).reshape(-1, 4)
        np.savez(self.path, rows=rows, events=np.array(EVENTS),
                 traced=np.zeros(4) if self.first is None else self.last - self.first,
                 cpu=np.array([usage.ru_utime, usage.ru_stime]),
                 switches=np.array([usage.ru_nvcsw, usage.ru_nivcsw]),
                 schedstat=np.array([_schedstat('/proc/self/schedstat'), sum(
                     (_schedstat(f'/proc/self/task/{t}/schedstat')
                      for t in os.listdir('/proc/self/task')), np.zeros(3, np.int64))]))


class NullTrace:
    """A :class:`Trace` that notes nothing and writes nothing: tracing is off."""

    def clock(self):
        return 0

    def note(self, event, vehicle, ns, at=None):
        pass

    def indexed(self, event, i, ns):
        pass

    def since(self, event, vehicle, ns, perf_ns):
        pass

    def save(self):
        pass


NULL = NullTrace()
"""The trace of a node when ``FORMATION_CONTROL_TRACE`` is unset."""


def _schedstat(path):
    """Return ns on a core, ns runnable waiting for one, time slices, of a task; -1 unknown."""
    try:
        with open(path) as f:
            return np.array([int(v) for v in f.read().split()[:3]], np.int64)
    except (OSError, ValueError):
        return np.full(3, -1, np.int64)


def of_node(name):
    """Return the :class:`Trace` of node ``name`` if ``FORMATION_CONTROL_TRACE`` is set; NULL."""
    directory = os.environ.get(ENV)
    if not directory:
        return NULL
    os.makedirs(directory, exist_ok=True)
    return Trace(directory, name)
