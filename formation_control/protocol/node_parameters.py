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
The parameters of the nodes themselves, beside the scenario's: one table per node.

Each entry is ``name -> (default, parameters.Spec)``; the same table declares the node's ROS
parameters (descriptor with unit and range, read-only) and writes the node section of
``docs/parameters.md`` (:func:`markdown`). The offline simulator has none of these.
"""
from __future__ import annotations

from collections.abc import Mapping
import json
import re
from typing import Any

from formation_control.core import parameters, scenario
from formation_control.core.errors import ScenarioError
from formation_control.core.parameters import markdown_table, Scenario, Spec
from formation_control.protocol.healing import HEAL_AFTER
from formation_control.protocol.links import PARAMETERS as LINKS
from formation_control.protocol.names import BASE_FRAME, base_frame, WORLD_FRAME

MODES = ('lockstep', 'realtime')
"""Time modes of the plant and the vehicles."""
_FRAME = re.compile(r'[A-Za-z0-9_][A-Za-z0-9_/{}.-]*')

FRAMES = {
    'world_frame': (WORLD_FRAME, Spec('', 'frame of the poses, flows and markers (REP-105): '
                                      'map, or e.g. odom from a navigation stack')),
    'base_frame': (BASE_FRAME, Spec('', "each vehicle's body frame (odometry twist, commands, "
                                    'formation states); {id} = the vehicle id',
                                    rule='contains {id} on the plant')),
}
"""The frames every node of a fleet is given alike."""


def check_frames(values: Mapping[str, Any], per_vehicle: bool = True) -> None:
    """
    Refuse frame parameters that are not tf2 frame ids or that would be shared.

    Parameters
    ----------
    values : dict
        ``world_frame`` and ``base_frame`` (the :data:`FRAMES` entries).
    per_vehicle : bool
        The node handles several vehicles (the plant): ``base_frame`` must name each vehicle
        with ``{id}``.

    Raises
    ------
    ScenarioError
        Naming the parameter and what it must be.

    """
    for name in FRAMES:
        value = values[name]
        if not isinstance(value, str) or not _FRAME.fullmatch(value):
            raise ScenarioError(f'parameter {name!r} = {value!r} is invalid: a frame id '
                                f'(letters, digits, _ - . /; no leading /)')
    if per_vehicle and '{id}' not in values['base_frame']:
        raise ScenarioError(f"parameter 'base_frame' = {values['base_frame']!r} is invalid: "
                            f'must contain {{id}}, one frame per vehicle')
    if base_frame(values['base_frame'], 1) == values['world_frame']:
        raise ScenarioError(f"parameter 'base_frame' = {values['base_frame']!r} is invalid: "
                            f"must differ from world_frame {values['world_frame']!r}")


def plant_differences(sc: Scenario, text: str) -> str:
    """
    Return how a vehicle's scenario ``sc`` differs from the plant's (JSON ``text``), or ''.

    ``name = mine here, theirs at the plant`` for each parameter of
    :func:`parameters.differences`, joined by a semicolon. Raises ScenarioError for an unreadable
    plant scenario.
    """
    try:
        theirs = scenario.resolve(json.loads(text))
    except (ValueError, TypeError) as err:
        raise ScenarioError(str(err)) from None
    return '; '.join(f'{name} = {mine!r} here, {plant!r} at the plant'
                     for name, mine, plant in parameters.differences(sc, theirs))


def check_vehicle(sc: Scenario, vehicle_id: int) -> None:
    """
    Refuse a vehicle node of id ``vehicle_id`` in scenario ``sc``.

    Raises
    ------
    ScenarioError
        The id is not in 1..num_vehicles, or the scenario runs flow consensus (the
        formation_state does not carry the flow estimates).

    """
    if not 1 <= vehicle_id <= sc.num_vehicles:
        raise ScenarioError(f"parameter 'vehicle_id' = {vehicle_id} is invalid: must lie in "
                            f'1..num_vehicles = {sc.num_vehicles}')
    if sc.flow_consensus > 0:
        raise ScenarioError(f"parameter 'flow_consensus' = {sc.flow_consensus} is invalid "
                            f'for a vehicle node: the formation_state does not carry the '
                            f'flow estimates; use 0 (the offline simulator runs consensus)')


_MODE = Spec('', 'time mode: lockstep (the plant owns /clock and waits for every command) or '
             'realtime (wall-clock steps, the latest command held)', choices=MODES)

PLANT = {
    'mode': ('lockstep', _MODE),
    'real_time_factor': (1.0, Spec('', 'realtime mode: simulated seconds per wall second',
                                   low=0.01, high=1000.0)),
    'record_path': ('', Spec('', 'write the run here as .npz (simulator layout) when it ends, '
                             'and the run so far every few seconds and when stopped early '
                             '(meta complete: false); empty = no record')),
    'exit_when_done': (True, Spec('', 'exit once duration is simulated')),
    'wait_for_start': (False, Spec('', 'hold step 0 until a std_msgs/Empty on '
                                   '/formation/start (lets a recorder discover every topic '
                                   'first)')),
    'wait_for_fleet': (True, Spec('', 'realtime mode: hold t = 0 until every vehicle has a '
                                  'writer on its command topic')),
    'command_timeout': LINKS['command_timeout'],
    **FRAMES,
}
"""``plant``."""

VEHICLE = {
    'vehicle_id': (0, Spec('', "this vehicle's id k (vehicle executable)",
                           rule='1..num_vehicles')),
    'vehicle_ids': ((), Spec('', 'the ids of the vehicle nodes of one process (vehicles '
                             'executable)', rule='distinct ids in 1..num_vehicles')),
    'mode': ('lockstep', _MODE),
    **{name: LINKS[name] for name in LINKS if name != 'command_timeout'},
    **FRAMES,
}
"""``vehicle`` and ``vehicles``; the link parameters are :data:`links.PARAMETERS`."""

MONITOR = {
    'period': (0.1, Spec('s', 'fleet time between metrics samples', low=0.0, high=3600.0)),
    'stale_timeout': (2.0, Spec('s', 'wall seconds of silence before a stream is stale',
                                low=0.01, high=3600.0)),
    'converge_within': (60.0, Spec('s', 'fleet seconds after which a formation or vehicle that '
                                   'has not converged is reported', low=0.0, high=1e6)),
    'diagnostics_period': (1.0, Spec('s', 'wall seconds between /diagnostics', low=0.01,
                                     high=60.0)),
    'markers_period': (0.2, Spec('s', 'wall seconds between /formation/markers', low=0.01,
                                 high=60.0)),
    'trail_length': (300, Spec('', "points of each vehicle's trail marker", low=2,
                               high=100_000)),
    'foxglove_port': (0, Spec('', 'TCP port of the Foxglove live view (a Foxglove WebSocket '
                              'server: scene, metrics, diagnostics); 0 = off', low=0,
                              high=65535)),
    'foxglove_host': ('127.0.0.1', Spec('', 'address the Foxglove live view listens on '
                                        '(0.0.0.0: every interface)')),
    'world_frame': FRAMES['world_frame'],
    'base_frame': FRAMES['base_frame'],
}
"""``monitor``."""

WARDEN: dict[str, tuple[Any, Spec]] = {
    'num_vehicles': (1, Spec('', 'the vehicles of the fleet it heals', low=1, high=10_000)),
    'vehicles_per_process': (1, Spec('', "the launch's vehicle nodes per process", low=1,
                                     high=10_000)),
    'heal_after': (HEAL_AFTER, Spec('s', 'wall seconds the fleet waits on a live vehicle '
                                    'process before it is restarted (plus 2.5 s per process at '
                                    'step 0)', low=0.5, high=3600.0)),
}
"""``warden`` (``fleet.launch.py`` sets them: ``formation_control.ros.warden``)."""

NODES: dict[str, dict[str, tuple[Any, Spec]]] = {
    'plant': PLANT, 'vehicle': VEHICLE, 'monitor': MONITOR, 'warden': WARDEN}


def _number(x: float) -> str:
    return str(x) if isinstance(x, int) else f'{x:g}'


def _range(spec: Spec) -> str:
    parts = [' | '.join(spec.choices)] if spec.choices else []
    if spec.low is not None:
        parts.append(f'[{_number(spec.low)}, {_number(spec.high)}]' if spec.high is not None
                     else f'>= {_number(spec.low)}')
    if spec.rule:
        parts.append(spec.rule)
    return '; '.join(parts)


def _shown(value: object) -> str:
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, str):
        return f'`{value}`' if value else "''"
    return str(list(value)) if isinstance(value, tuple) else str(value)


def markdown() -> str:
    """
    Return the node section of docs/parameters.md: one table per node.

    Returns
    -------
    str
        Markdown, as ``formation-control params`` prints it after the scenario table.

    """
    out = ['', '# Node parameters', '',
           'Set per node (`--ros-args -p name:=value`, or `swarm ... -p name:=value`), not in '
           'the scenario;', 'all but `cut_links` are read-only once the node runs.', '']
    for node, table in NODES.items():
        rows = [(f'`{name}`', _shown(default), spec.unit, _range(spec), spec.text)
                for name, (default, spec) in table.items()]
        out += [f'## `{node}`', '', *markdown_table(
            ('name', 'default', 'unit', 'allowed', 'meaning'), rows), '']
    return '\n'.join(out)


def _float_of(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ScenarioError(f'parameter {name!r} = {value!r} is invalid: a number')
    return float(value)


def as_declared(name: str, value: Any) -> Any:
    """
    Return ``value`` of scenario parameter ``name`` in the type the node declares it with.

    An integer for a floating-point parameter (``kappa:=3``) is that float, as the simulator
    and the launch files take it; an integer array for a floating-point one likewise. Anything
    else that is not a number where one is declared is refused (ScenarioError, naming it);
    other parameters are returned as they are.
    """
    default = getattr(Scenario(), name, None) if name in parameters.PARAMETERS else None
    if isinstance(default, float):
        return _float_of(name, value)
    if isinstance(default, tuple) and default and isinstance(default[0], float):
        if not isinstance(value, (list, tuple)):
            raise ScenarioError(f'parameter {name!r} = {value!r} is invalid: a list of numbers')
        return [_float_of(name, v) for v in value]
    return value


def _scalar(text: str) -> int | float | str:
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            continue
    return text


def _yaml(value: Any) -> str:
    if isinstance(value, list):
        return '[' + ', '.join(map(_yaml, value)) + ']'
    text = repr(float(value))
    return text if '.' in text or 'e' not in text else text.replace('e', '.0e', 1)


def checked_overrides(argv: list[str]) -> list[str]:
    """
    Return the command line with each ``-p NAME:=VALUE`` of a scenario parameter as declared.

    rcl takes ``-p kappa:=3`` as an integer, which a double parameter refuses, and drops
    ``-p kappa:=abc`` in silence when a parameter file sets kappa: each value is read as YAML
    and rewritten by :func:`as_declared`, or refused (ScenarioError).
    """
    import yaml
    out, ros, take = [], False, False
    for arg in argv:
        if take and ':=' in arg:
            left, text = arg.split(':=', 1)
            name = left.rsplit(':', 1)[-1]
            value = _scalar(text)
            if isinstance(value, str):
                try:
                    value = yaml.safe_load(text)
                except yaml.YAMLError:
                    pass
            fixed = as_declared(name, value)
            if fixed is not value:
                arg = f'{left}:={_yaml(fixed)}'
        take = ros and arg in ('-p', '--param')
        ros = (ros or arg == '--ros-args') and arg != '--'
        out.append(arg)
    return out
