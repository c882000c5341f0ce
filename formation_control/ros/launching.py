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
The actions of ``fleet.launch.py`` and ``vehicle.launch.py`` (share/formation_control/launch).

The scenario is read and validated when the launch starts (a bad one stops it with the
reason, before any node runs), written resolved to one parameter file that every node of the
fleet takes, and the nodes are those ``formation-control swarm`` starts: the plant, one
``vehicle`` node per vehicle (or ``vehicles`` processes of several nodes), the monitor and,
with ``record``, the bag ``recorder``, all in the ``namespace``.
"""
import os
from pathlib import Path
import tempfile

from formation_control.core import parameters, scenario
from formation_control.core.errors import UsageError
from formation_control.ops import dds_profile, lifetime, security
from formation_control.protocol.fleet_plan import (check_discovery, FleetPlan, LAUNCH_LABELS,
                                                   write_params)
from formation_control.protocol.healing import HEAL_AFTER, HEAL_LIMIT
from formation_control.protocol.onboard import vehicle_topics
from launch.actions import DeclareLaunchArgument, OpaqueFunction, Shutdown
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

PACKAGE = 'formation_control'
FLEET_ARGUMENTS = {
    'scenario': ('rigid_circular', 'a scenario of config/ (name) or the path of one'),
    'namespace': ('', 'ROS namespace of the fleet (e.g. fleet_a); empty = /'),
    'mode': ('lockstep', 'lockstep | realtime'),
    'num_vehicles': ('', "override the scenario's number of vehicles; empty = the scenario's"),
    'duration': ('', "override the scenario's duration (s); empty = the scenario's"),
    'vehicles_per_process': ('auto', 'vehicle nodes per process (vehicles executable); auto: 1 '
                             'with secure, else the fleet over one process per core'),
    'monitor': ('true', 'start the monitor (metrics, diagnostics, markers)'),
    'record': ('', 'record the fleet into this new bag directory (MCAP); empty = none'),
    'record_path': ('', "the plant's record of the run (.npz) when it ends; empty = none"),
    'params_file': ('', 'a ROS parameter file of node parameters (links, faults, timeouts, QoS) '
                    'for the plant and the vehicles, after the scenario; empty = none'),
    'world_frame': ('map', 'world frame (REP-105)'),
    'base_frame': ('vehicle_{id}/base_link', "each vehicle's base frame; {id} = its id"),
    'secure': ('', 'run each node as its member of the TLS fleet in this directory '
               '(formation-control secure; docs/security.md); empty = the default transports'),
    'heal_after': (str(HEAL_AFTER), 'wall seconds the fleet waits on a live vehicle process '
                   'before the warden restarts it (at most 3 times); 0 = no warden'),
}
VEHICLE_ARGUMENTS = {
    'scenario': FLEET_ARGUMENTS['scenario'],
    'namespace': FLEET_ARGUMENTS['namespace'],
    'vehicle_id': ('1', "this vehicle's id k"),
    'mode': FLEET_ARGUMENTS['mode'],
    'params_file': FLEET_ARGUMENTS['params_file'],
    'world_frame': FLEET_ARGUMENTS['world_frame'],
    'base_frame': FLEET_ARGUMENTS['base_frame'],
    'secure': FLEET_ARGUMENTS['secure'],
}


def arguments(table):
    """Return the DeclareLaunchArgument of each entry of ``table`` (name -> (default, text))."""
    return [DeclareLaunchArgument(name, default_value=default, description=text)
            for name, (default, text) in table.items()]


def _values(context, table):
    return {name: LaunchConfiguration(name).perform(context) for name in table}


def _true(text):
    return text.strip().lower() in ('1', 'true', 'yes', 'on')


def _scenario(a, recorded=False):
    """
    Validate the scenario of the arguments ``a``; return it and its parameter files.

    Without ``secure``, ``a['profile']`` becomes the variables of the fleet's Fast DDS profile
    (:func:`~formation_control.ops.dds_profile.fleet_env`), written beside the parameters.
    """
    overrides = [f'{name}:={a[name]}' for name in ('num_vehicles', 'duration') if a.get(name)]
    sc = scenario.load(parameters.find(a['scenario']), overrides)
    folder = Path(tempfile.mkdtemp(prefix='formation_launch_'))
    files = [write_params(sc, folder / 'scenario.yaml', recorded, a['namespace'] or '/')]
    a['profile'] = {} if a['secure'] else dds_profile.fleet_env(os.environ, folder)
    if a['params_file']:
        if not Path(a['params_file']).is_file():
            raise UsageError(f"params_file {a['params_file']!r} not found")
        files.append(a['params_file'])
    return sc, files


def _node(executable, a, params, member, name=None, **kwargs):
    """
    Return the Node of ``executable``; with a ``secure`` fleet it runs as ``member``.

    The node stops when the launch dies, even by SIGKILL
    (:func:`~formation_control.ops.lifetime.die_with_parent`); the warden finds it by ``name``.
    """
    env = security.environment(a['secure'], member) if a['secure'] else dict(a['profile'])
    env[lifetime.PARENT_ENV] = str(os.getpid())
    if name:
        env[lifetime.MEMBER_ENV] = name
    return Node(package=PACKAGE, executable=executable, namespace=a['namespace'] or None,
                parameters=params, output='screen', emulate_tty=True, additional_env=env,
                **kwargs)


def _fleet(context):
    a = _values(context, FLEET_ARGUMENTS)
    record = a['record']
    if record and Path(record).exists():
        raise UsageError(f'record {record!r} exists already: give a new bag directory')
    sc, files = _scenario(a, recorded=bool(record))
    plan = FleetPlan(sc.num_vehicles, a['mode'], a['vehicles_per_process'],
                     a['namespace'] or '/', bool(a['secure']), bool(record), LAUNCH_LABELS,
                     {'world_frame': a['world_frame'], 'base_frame': a['base_frame']})
    processes = [plan.plant(record_path=a['record_path']), *plan.vehicles()]
    if _true(a['monitor']):
        processes.append(plan.monitor())
    if record:
        processes.append(plan.recorder(record, _true(a['monitor']), vehicle_topics(sc)))
    heal_after = _heal_after(a['heal_after'])
    if heal_after:
        processes.append(plan.warden(heal_after))
    check_discovery(len(processes) + 1, sc.num_vehicles, plan.per_process, LAUNCH_LABELS[0],
                    os.environ)
    return [_process_node(p, a, plan, files, bool(heal_after)) for p in processes]


def _heal_after(text):
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not (value == 0 or 0.5 <= value <= 3600):
        raise UsageError(f'heal_after {text!r} is invalid: seconds in [0.5, 3600], or 0 (no '
                         f'warden)')
    return value


def _process_node(process, a, plan, files, healed):
    """
    Return the launch Node of a :class:`~formation_control.protocol.fleet_plan.Process`.

    With the warden (``healed``), a vehicle process that ends is started again, at most
    :data:`~formation_control.protocol.healing.HEAL_LIMIT` times.
    """
    params = [*files, {**plan.common, **process.parameters}] if process.fleet else [
        process.parameters]
    extra = {'remappings': [plan.clock]} if process.clock else {}
    if process.name == 'plant':
        extra['on_exit'] = Shutdown(reason='the plant has finished the run')
    if process.vehicles and healed:
        extra.update(respawn=True, respawn_max_retries=HEAL_LIMIT)
    member = None if process.executable == 'vehicles' else process.member
    return _node(process.executable, a, params, member, process.name, **extra)


def _vehicle(context):
    a = _values(context, VEHICLE_ARGUMENTS)
    _, files = _scenario(a)
    k = int(a['vehicle_id'])
    return [_node('vehicle', a, [*files, {'mode': a['mode'], 'vehicle_id': k,
                                          'world_frame': a['world_frame'],
                                          'base_frame': a['base_frame']}],
                  f'vehicle_{k}', on_exit=Shutdown(reason='the vehicle node exited'))]


def fleet_actions():
    """Return the actions of ``fleet.launch.py``: its arguments, then the fleet."""
    return [*arguments(FLEET_ARGUMENTS), OpaqueFunction(function=_fleet)]


def vehicle_actions():
    """Return the actions of ``vehicle.launch.py``: one vehicle node (one per computer)."""
    return [*arguments(VEHICLE_ARGUMENTS), OpaqueFunction(function=_vehicle)]
