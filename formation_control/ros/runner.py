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

"""The main loop every node shares: spin_once until done or asked to stop, exit 0 on SIGINT."""
import contextlib
import fcntl
import gc
import os
import re
import signal
import sys
import tempfile

from formation_control.core.errors import ScenarioError, UsageError
from formation_control.ops.lifetime import die_with_parent, end_within, GRACE
from formation_control.ops.security import check_environment
from formation_control.ops.signing import check_member
from formation_control.protocol.node_parameters import checked_overrides
from formation_control.ros.common import probe_node
import rclpy
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.executors import ExternalShutdownException
from rclpy.experimental import EventsExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation

WHERE = re.compile(r', at /\S+:\d+')
"""rcl's source locations in its error text, left out of the one line the user reads."""


class _StopFlag:
    """
    SIGINT / SIGTERM / SIGHUP set a flag the loop checks: a signal at any moment stops the node.

    SIGHUP too: the kernel sends it to a process group left orphaned with a frozen member (a
    swarm killed during a ``stop`` fault), and the node stops as cleanly as on Ctrl-C.
    """

    def __init__(self):
        self.raised = False
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            signal.signal(sig, self._raise)

    def _raise(self, *_):
        self.raised = True


@contextlib.contextmanager
def one_participant_at_a_time():
    """
    Hold a lock file while this process creates its DDS participant.

    Fast DDS participants created at the same instant on one host race for shared-memory ports
    (2.14.5 here), and a reader can be left matched but never handed a sample
    (docs/benchmarks.md, section 3); the lock lets fleets of processes start together, in any
    order, from any launcher.
    """
    path = os.path.join(tempfile.gettempdir(), f'formation_control_participant_{os.getuid()}.lock')
    with open(path, 'a') as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def _participant(context):
    """
    Return a hidden node that creates the context's DDS participant.

    rmw_fastrtps creates the participant with the first node and destroys it with the last;
    this node is kept until the real nodes exist.
    """
    return probe_node(f'_participant_{os.getpid()}', context)


def run(make_node, args=None):
    """
    Create the node (or list of nodes) with ``make_node(context)`` and spin them.

    The nodes share one events executor until one is done, SIGINT or SIGTERM arrives or the
    context shuts down (exit code 0, or the ``exit_code`` of a node that is done); a bad
    scenario or command line (a ``-p`` value of the wrong type, :func:`checked_overrides`; a
    parameter file rcl cannot read), or an environment that would open a TLS fleet to anyone
    (:func:`~formation_control.ops.security.check_environment`) or a member a signing fleet
    refuses (:func:`~formation_control.ops.signing.check_member`), exits 2 with the reason. A
    process started by a swarm or a launch stops when its starter dies
    (:func:`~formation_control.ops.lifetime.die_with_parent`).
    """
    stop = _StopFlag()
    tie = die_with_parent()
    unsafe = check_environment(os.environ) or check_member(os.environ)
    if unsafe:
        print(f'error: {unsafe}', file=sys.stderr)
        return 2
    nodes, code = [], 0
    try:
        argv = checked_overrides(list(sys.argv if args is None else args))
        with one_participant_at_a_time():
            rclpy.init(args=argv, signal_handler_options=rclpy.SignalHandlerOptions.NO)
            context = rclpy.get_default_context()
            anchor = _participant(context)
        try:
            made = make_node(context)
        finally:
            anchor.destroy_node()
        nodes = made if isinstance(made, list) else [made]
        executor = EventsExecutor(context=context)
        for node in nodes:
            executor.add_node(node)
        gc.collect()
        gc.freeze()                   # what start-up built is never collected again: short pauses
        while (not stop.raised and context.ok()
               and not any(getattr(node, 'done', False) for node in nodes)):
            executor.spin_once(timeout_sec=0.1)
        code = max(getattr(node, 'exit_code', 0) for node in nodes)
    except (ScenarioError, UsageError, InvalidParameterTypeException,
            InvalidParameterValueException) as err:
        print(f'error: {err}', file=sys.stderr)
        return 2
    except rclpy_implementation.RCLError as err:      # a parameter file missing or broken
        print(f'error: {WHERE.sub("", str(err))}', file=sys.stderr)
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if tie is not None:
            end_within(GRACE)
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
    return code
