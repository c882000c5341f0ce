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
The processes of a fleet and the parameters they are given (``swarm``, the launch files).

A :class:`FleetPlan` describes a fleet once: its plant, its vehicle processes (one vehicle
each, or groups of ``per_process`` in ``vehicles`` processes), its monitor and bag recorder,
which of them take the scenario's parameter file, which follow the fleet's ``/clock``
(``use_sim_time`` in lockstep) and the member of a TLS fleet each runs as. ``swarm`` turns it
into command lines, ``fleet.launch.py`` into launch Nodes.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
import math
import os
from os import PathLike
from pathlib import Path
from typing import Any, NamedTuple

from formation_control.core.errors import ScenarioError
from formation_control.core.parameters import Scenario
from formation_control.protocol import names
from formation_control.protocol.node_parameters import MODES
import yaml

RECORDED_DEPTH = 500
"""With a bag: the history of the odometry, state and command writers (samples; 10 s at
50 Hz). DDS matches a writer to the recorder's reader on each side in its own time; a writer
that matches after the first steps resends its transient-local history, which must still
hold step 0."""


RECORDED_TOPICS = ('odom', 'formation_state', 'cmd')
"""The per-vehicle topics whose writers keep :data:`RECORDED_DEPTH` samples under a bag."""


def write_params(sc: Scenario, path: str | PathLike[str], recorded: bool = False,
                 namespace: str = '/') -> str:
    """
    Write the resolved scenario as a ROS 2 parameter file at ``path``; return the path.

    Empty lists are left out: ROS types them. ``recorded``: the state writers keep
    :data:`RECORDED_DEPTH` samples (``qos_overrides`` of the topics in ``namespace``), so the
    bag misses no step.
    """
    values = {k: v for k, v in sc.to_dict().items() if v != []}
    prefix = names.namespace_prefix(namespace)
    if recorded:
        values['qos_overrides'] = {
            f'{prefix}vehicle_{k}/{name}': {'publisher': {'depth': RECORDED_DEPTH}}
            for k in range(1, sc.num_vehicles + 1) for name in RECORDED_TOPICS}
    Path(path).write_text(yaml.safe_dump({'/**': {'ros__parameters': values}}))
    return str(path)


SWARM_LABELS = ('--vehicles-per-process', '--secure')
"""How ``formation-control swarm`` spells ``per_process`` and ``secure`` (in errors)."""
LAUNCH_LABELS = ('vehicles_per_process', 'secure')
"""How ``fleet.launch.py`` spells them."""


class Process(NamedTuple):
    """
    One process of a fleet.

    Attributes
    ----------
    name : str
        ``plant``, ``vehicle_3``, ``vehicles_1-4``, ``monitor``, ``recorder`` or ``warden``:
        the name of its log and (:meth:`member`) of its member of a TLS fleet.
    executable : str
        The console script (``ros2 run formation_control <executable>``).
    vehicles : tuple of int
        The vehicles it runs.
    parameters : dict
        Its own parameters, given after the fleet's.
    fleet : bool
        It takes the scenario's parameter file and :attr:`FleetPlan.common`.
    clock : bool
        Its ``/clock`` is remapped to the fleet's (:attr:`FleetPlan.clock`).

    """

    name: str
    executable: str
    vehicles: tuple[int, ...] = ()
    parameters: dict[str, Any] = {}
    fleet: bool = True
    clock: bool = False

    @property
    def member(self) -> str:
        """
        Return the member of a TLS fleet the process runs as.

        The recorder is the swarm's; the warden, which only listens, is a client: the operator.
        """
        return {'recorder': 'swarm', 'warden': 'operator'}.get(self.name, self.name)


PROCESSES_PER_CORE = 1
"""``per_process='auto'``: about this many vehicle processes per core (measured: N = 16 on a
ring, 2 cores, lockstep: 2.28x, 2.48x, 2.40x real time with 8 per process against 1.68x, 1.58x,
1.92x with 4 and 2.03x with 16; real time at 50 Hz, odometry-to-command p99 2.44 ms against
4.6-5.5 ms with 4; docs/benchmarks.md section 6)."""


def auto_per_process(num_vehicles: int, cores: int, one_each: bool = False) -> int:
    """
    Return the vehicle nodes per process ``per_process='auto'`` stands for.

    One each when ``one_each`` (a TLS fleet: one member is one process; scripted process
    faults: a fault acts on one vehicle's process); otherwise the fleet spread over
    :data:`PROCESSES_PER_CORE` processes per core, so that the nodes of a process share its
    executor instead of waking one process each per message.
    """
    if one_each:
        return 1
    return max(1, math.ceil(num_vehicles / (PROCESSES_PER_CORE * max(1, cores))))


LOCALHOST_PARTICIPANTS = 32
"""With ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` rmw_fastrtps announces each participant by
unicast to the first 32 participant ports of the host (its ``maxInitialPeersRange``), so two
participants of a higher index never meet: at most this many discover each other on a host."""


def check_discovery(participants: int, num_vehicles: int, per_process: int, label: str,
                    environ: Mapping[str, str]) -> None:
    """
    Refuse a fleet of more DDS participants on this host than localhost discovery reaches.

    Parameters
    ----------
    participants : int
        The fleet's participants on this host: its processes, the starter's own node too.
    num_vehicles, per_process : int
        The fleet, and its vehicle nodes per process.
    label : str
        How the caller spells the vehicles per process, for the error.
    environ : mapping
        The fleet's environment: the limit holds for rmw_fastrtps with
        ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and no ``ROS_DISCOVERY_SERVER``.

    Raises
    ------
    ScenarioError
        Over :data:`LOCALHOST_PARTICIPANTS`: the error names the grouping that fits.

    """
    if (environ.get('ROS_AUTOMATIC_DISCOVERY_RANGE', '').upper() != 'LOCALHOST'
            or environ.get('ROS_DISCOVERY_SERVER')
            or environ.get('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp') != 'rmw_fastrtps_cpp'
            or participants <= LOCALHOST_PARTICIPANTS):
        return
    others = participants - math.ceil(num_vehicles / per_process)
    fits = math.ceil(num_vehicles / max(1, LOCALHOST_PARTICIPANTS - others))
    raise ScenarioError(
        f'{label} {per_process} makes {participants} DDS participants on this host, but with '
        f'ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST rmw_fastrtps discovers at most '
        f'{LOCALHOST_PARTICIPANTS} (the rest would never match each other): use {label} '
        f'{fits} or more (or auto), or a discovery server (ROS_DISCOVERY_SERVER)')


def cores() -> int:
    """Return the number of cores this process may run on."""
    return len(os.sched_getaffinity(0))


def _count(value: int | str, label: str) -> int:
    """Return ``value`` (an int or its digits) as an int >= 1."""
    number = int(value) if isinstance(value, str) and value.isdigit() else value
    if isinstance(number, bool) or not isinstance(number, int) or number < 1:
        raise ScenarioError(f"{label} {value!r} is invalid: an integer >= 1 or 'auto'")
    return number


class FleetPlan:
    """
    The processes of a fleet of ``num_vehicles`` in ``namespace``, checked.

    Parameters
    ----------
    num_vehicles : int
        Number of vehicles.
    mode : str
        ``lockstep`` or ``realtime``: in lockstep the monitor and the recorder take the fleet's
        time (``use_sim_time``).
    per_process : int or str
        Vehicle nodes per process, >= 1 (1: a ``vehicle`` process each), or ``'auto'``
        (:func:`auto_per_process` for the machine's cores).
    namespace : str
        The fleet's namespace.
    secure : bool
        Each process runs as its member of a TLS fleet: one vehicle per process.
    recorded : bool
        A bag records the fleet: the plant waits for the recorder (``wait_for_start``).
    labels : (str, str)
        How the caller spells ``per_process`` and ``secure``, for the errors
        (:data:`SWARM_LABELS`, :data:`LAUNCH_LABELS`).
    frames : dict, optional
        ``world_frame`` and ``base_frame`` of every node that takes them (empty: the defaults).
    process_faults : bool
        Scripted faults act on vehicles' processes (kill, restart, stop, cont).
    held : bool
        The plant holds step 0 until the starter says go (``wait_for_start``): a bag's
        recorder, or the swarm of a fault script, which acts on the fleet's time.

    Raises
    ------
    ScenarioError
        ``mode`` is not one of :data:`MODES`; ``per_process`` is not an integer >= 1 or
        ``'auto'``, or not 1 with ``secure`` or ``process_faults``.

    """

    def __init__(self, num_vehicles: int, mode: str = 'lockstep', per_process: int | str = 1,
                 namespace: str = '/', secure: bool = False, recorded: bool = False,
                 labels: tuple[str, str] = SWARM_LABELS,
                 frames: Mapping[str, str] | None = None, process_faults: bool = False,
                 held: bool = False) -> None:
        if mode not in MODES:
            raise ScenarioError(f"mode {mode!r} is invalid: {' or '.join(MODES)}")
        self.per_process = (auto_per_process(num_vehicles, cores(), secure or process_faults)
                            if per_process == 'auto' else _count(per_process, labels[0]))
        if secure and self.per_process != 1:
            raise ScenarioError(f'{labels[0]} {self.per_process} with {labels[1]}: a member of a '
                                f'TLS fleet is one process, 1 only')
        if process_faults and self.per_process != 1:
            raise ScenarioError(f'{labels[0]} {self.per_process} with a process fault (kill, '
                                f'restart, stop, cont): a fault acts on the process of one '
                                f'vehicle, 1 only')
        self.num_vehicles, self.mode, self.recorded = num_vehicles, mode, recorded
        self.held = recorded or held
        self.prefix = names.namespace_prefix(namespace)
        self.clock = ('/clock', self.prefix + 'clock')
        """The remapping of the fleet's clock: ``/clock`` to the namespace's."""
        self.frames = dict(frames or {})
        self.common = {'mode': mode, **self.frames}
        """The parameters of every process that takes the fleet's file, after it."""
        self.sim_time = {'use_sim_time': mode == 'lockstep'}

    def groups(self) -> list[tuple[int, ...]]:
        """Return the vehicle ids of each vehicle process."""
        ids = list(range(1, self.num_vehicles + 1))
        return [tuple(ids[i:i + self.per_process]) for i in range(0, len(ids), self.per_process)]

    def plant(self, **parameters: Any) -> Process:
        """Return the plant process; ``parameters`` come before ``wait_for_start``."""
        return Process('plant', 'plant', (), {**parameters, 'wait_for_start': self.held})

    def vehicles(self) -> list[Process]:
        """Return the vehicle processes."""
        if self.per_process == 1:
            return [Process(f'vehicle_{k}', 'vehicle', (k,), {'vehicle_id': k})
                    for (k,) in self.groups()]
        return [Process(f'vehicles_{g[0]}-{g[-1]}', 'vehicles', g, {'vehicle_ids': list(g)})
                for g in self.groups()]

    def monitor(self, **parameters: Any) -> Process:
        """Return the monitor: the frames and the fleet's time, not the fleet's file."""
        return Process('monitor', 'monitor', (), {**self.frames, **parameters, **self.sim_time},
                       fleet=False, clock=True)

    def warden(self, heal_after: float) -> Process:
        """Return the warden of a launched fleet (``formation_control.ros.warden``)."""
        return Process('warden', 'warden', (), {
            'num_vehicles': self.num_vehicles, 'vehicles_per_process': self.per_process,
            'heal_after': float(heal_after)}, fleet=False)

    def recorder(self, bag: str, monitor: bool, vehicle_topics: Sequence[str]) -> Process:
        """
        Return the bag recorder of ``bag`` (recording the monitor's topics if ``monitor``).

        ``vehicle_topics``: each vehicle's topics the fleet publishes
        (:func:`~formation_control.protocol.onboard.vehicle_topics`).
        """
        return Process('recorder', 'recorder', (), {
            'bag': bag, 'num_vehicles': self.num_vehicles, 'monitor': monitor,
            'vehicle_topics': list(vehicle_topics), **self.sim_time}, fleet=False, clock=True)


def ros_arguments(parameters: Mapping[str, Any]) -> list[str]:
    """Return ``parameters`` as ``-p NAME:=VALUE`` arguments (booleans ``true``/``false``)."""
    return [a for name, value in parameters.items() for a in (
        '-p', f'{name}:={str(value).lower() if isinstance(value, bool) else value}')]
