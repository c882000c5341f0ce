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
``formation-control doctor``: what breaks fleets in practice, found in facts of the domain.

Pure checks over :class:`Facts` (what :mod:`formation_control.ros.doctor` gathers from a
running domain): the environment, the plant and the vehicle ids, each vehicle's scenario
parameters against the plant's latched scenario, the QoS of every publisher / subscription
pair, the streams each vehicle sends and hears, the clocks of the hosts. Each check returns
:class:`Finding` s; :func:`exit_status` is non-zero when one is a warning or an error.
"""
from dataclasses import dataclass, field
import math
import re

from formation_control.core.errors import ScenarioError

from formation_control.core.parameters import PLANT_ONLY, RUNTIME

from formation_control.core.scenario import resolve
from formation_control.ops.security import check_environment as check_security
from formation_control.protocol.names import namespace_prefix, SCENARIO_TOPIC, status_prefix

ERROR, WARNING, NOTE = 'error', 'warning', 'note'
DISCOVERY_RANGES = ('OFF', 'LOCALHOST', 'SUBNET', 'SYSTEM_DEFAULT')
SKEW_TOLERANCE = 0.05
"""Real time: |arrival - stamp| (s) of a node's /diagnostics above this is clock skew."""
VEHICLE = re.compile(r'vehicle_(\d+)$')
CLOCKED = re.compile(r'formation_control/(plant|vehicle_\d+)(/links)?$')
"""The /diagnostics statuses stamped with their node's own clock: the plant's, the vehicles'."""


def clocked_node(status_name, namespace):
    """
    Return who stamps a /diagnostics status with its own clock: ``plant``, ``vehicle_k``.

    None for a status of another kind or of a fleet in another namespace (in a namespace, a
    status name starts with it: ``fleet_a/formation_control/plant``).
    """
    prefix = status_prefix(namespace)
    if not status_name.startswith(prefix):
        return None
    match = CLOCKED.match(status_name[len(prefix):])
    return match[1] if match else None


@dataclass(frozen=True)
class Finding:
    """One thing the doctor found: its level, who it concerns (a node, a topic), the text."""

    level: str
    subject: str
    text: str


@dataclass(frozen=True)
class Endpoint:
    """A publisher or a subscription: topic, node (fully qualified), 'pub' or 'sub', its QoS."""

    topic: str
    node: str
    kind: str
    qos: object


@dataclass
class Stream:
    """
    What the doctor heard on one topic: the count of messages it read, the last hears flags.

    ``hears`` is {j: bool}; ``refused`` the text of the last message it could not read
    (another interface version, malformed), ``''`` if none.
    """

    count: int = 0
    hears: dict = field(default_factory=dict)
    refused: str = ''


@dataclass
class Facts:
    """
    What the doctor gathered from a domain.

    Attributes
    ----------
    namespace : str
        The fleet's namespace ('' or '/': none).
    env : dict
        ROS_DOMAIN_ID, ROS_AUTOMATIC_DISCOVERY_RANGE, ROS_LOCALHOST_ONLY, and the TLS fleet's
        FASTRTPS_DEFAULT_PROFILES_FILE and OPENSSL_CONF (absent: unset).
    scenario : dict or None
        The plant's latched scenario (JSON of ``<namespace>/formation/scenario``).
    scenario_publishers : list of str
        The nodes publishing it.
    nodes : list of str
        Every node's fully qualified name, as often as it is on the domain.
    parameters : dict
        Vehicle node -> its scenario parameters ({name: value}), None: they could not be read.
    mode : str or None
        The plant's time mode (``lockstep`` / ``realtime``).
    endpoints : list of Endpoint
        The publishers and subscriptions of the fleet's topics (absolute names).
    streams : dict
        Topic (absolute) -> :class:`Stream` heard on it (formation states and odometry).
    state_topics : dict
        Vehicle id -> its formation_state topic (resolved).
    clock_lags : dict
        ``plant`` / ``vehicle_k`` -> [arrival time on the doctor's clock - stamp (s)] of its
        /diagnostics, which a node stamps with its own clock.

    """

    namespace: str = ''
    env: dict = field(default_factory=dict)
    scenario: dict = None
    scenario_publishers: list = field(default_factory=list)
    nodes: list = field(default_factory=list)
    parameters: dict = field(default_factory=dict)
    mode: str = None
    endpoints: list = field(default_factory=list)
    streams: dict = field(default_factory=dict)
    state_topics: dict = field(default_factory=dict)
    clock_lags: dict = field(default_factory=dict)


def check_environment(env):
    """Check ROS_DOMAIN_ID, the discovery range and a TLS profile: unset, invalid or unsafe."""
    unsafe = check_security(env)
    out = [Finding(ERROR, 'FASTRTPS_DEFAULT_PROFILES_FILE', unsafe)] if unsafe else []
    domain = env.get('ROS_DOMAIN_ID')
    if domain in (None, ''):
        out.append(Finding(WARNING, 'ROS_DOMAIN_ID', 'unset: domain 0, which every ROS 2 '
                           'system shares by default; give the fleet its own id'))
    elif not domain.isdigit() or int(domain) > 232:
        out.append(Finding(ERROR, 'ROS_DOMAIN_ID', f'{domain!r} is invalid: an integer in '
                           f'0..232 (0..101 on Linux)'))
    elif 101 < int(domain) < 215:
        out.append(Finding(WARNING, 'ROS_DOMAIN_ID', f'{domain}: its DDS ports may collide with '
                           f"Linux's ephemeral ports; use 0..101"))
    scope = env.get('ROS_AUTOMATIC_DISCOVERY_RANGE')
    if scope in (None, ''):
        out.append(Finding(NOTE, 'ROS_AUTOMATIC_DISCOVERY_RANGE', 'unset: SUBNET, every host '
                           'of the subnet is discovered'))
    elif scope not in DISCOVERY_RANGES:
        out.append(Finding(ERROR, 'ROS_AUTOMATIC_DISCOVERY_RANGE', f'{scope!r} is invalid: one '
                           f'of {", ".join(DISCOVERY_RANGES)}'))
    elif scope == 'OFF':
        out.append(Finding(ERROR, 'ROS_AUTOMATIC_DISCOVERY_RANGE', 'OFF: no node is discovered, '
                           'not even on this host'))
    elif scope == 'LOCALHOST':
        out.append(Finding(NOTE, 'ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST: only the nodes '
                           'of this host are seen (a fleet across computers needs SUBNET)'))
    if env.get('ROS_LOCALHOST_ONLY') == '1':
        out.append(Finding(WARNING, 'ROS_LOCALHOST_ONLY', '1 is deprecated in Jazzy: use '
                           'ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST'))
    return out


def _short(name, namespace):
    prefix = namespace_prefix(namespace)
    return name[len(prefix):] if name.startswith(prefix) else None


def vehicle_ids(facts):
    """Return {vehicle id: [fully qualified node names]} of the vehicle nodes in the namespace."""
    ids = {}
    for name in facts.nodes:
        short = _short(name, facts.namespace)
        match = VEHICLE.match(short or '')
        if match:
            ids.setdefault(int(match[1]), []).append(name)
    return ids


def check_fleet(facts):
    """Check for the plant's scenario and one vehicle node per id 1..N, no other, none twice."""
    where = namespace_prefix(facts.namespace) + SCENARIO_TOPIC
    if facts.scenario is None:
        return [Finding(ERROR, 'fleet', f'no scenario on {where}: no plant runs in this '
                        f'namespace on ROS_DOMAIN_ID={facts.env.get("ROS_DOMAIN_ID", "0")}, or '
                        f'it is not discovered (ROS_AUTOMATIC_DISCOVERY_RANGE)')]
    out = []
    if len(set(facts.scenario_publishers)) > 1:
        out.append(Finding(ERROR, 'fleet', f'{where} has several publishers: '
                           f'{", ".join(sorted(set(facts.scenario_publishers)))}; one plant '
                           f'per fleet (namespace or domain)'))
    n = facts.scenario['num_vehicles']
    ids = vehicle_ids(facts)
    missing = [k for k in range(1, n + 1) if k not in ids]
    if missing:
        out.append(Finding(ERROR, 'fleet', f'vehicles {missing} of the {n} are missing (no node '
                           f'vehicle_k)'))
    for k, names in sorted(ids.items()):
        if k > n:
            out.append(Finding(ERROR, names[0], f'vehicle {k} is not in the scenario '
                               f'(num_vehicles = {n})'))
        if len(names) > 1:
            out.append(Finding(ERROR, names[0], f'{len(names)} nodes have this name: two '
                               f'vehicles were started with vehicle_id {k}'))
    return out


def _same(a, b):
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, float) or isinstance(b, float):
        try:
            return math.isclose(float(a), float(b), rel_tol=1e-12, abs_tol=1e-15)
        except (TypeError, ValueError):
            return False
    return a == b


def check_parameters(facts):
    """
    Check each vehicle's scenario parameters: the fixed ones against the plant's scenario.

    A run-time parameter (``formation-control set``) is the vehicles' to change: they must
    agree with each other; where they all differ from the plant's scenario, one note says so.
    """
    if facts.scenario is None:
        return []
    plant = resolve(facts.scenario).to_dict()
    out, mine = [], {}
    for node, values in sorted(facts.parameters.items()):
        if values is None:
            out.append(Finding(WARNING, node, 'its parameters could not be read (no parameter '
                               'service answered)'))
            continue
        try:
            mine[node] = resolve(values).to_dict()
        except ScenarioError as err:
            out.append(Finding(ERROR, node, f'its scenario parameters do not resolve: {err}'))
    for node, values in mine.items():
        for name in plant:
            if name not in RUNTIME and not _same(values[name], plant[name]):
                level = NOTE if name in PLANT_ONLY else ERROR
                out.append(Finding(level, node, f'{name} = {values[name]!r}, the plant has '
                                   f'{plant[name]!r}'))
    return out + _runtime_findings(mine, plant)


def _runtime_findings(mine, plant):
    """Return the findings on run-time parameters: vehicles that disagree, or one note."""
    out = []
    for name in RUNTIME:
        values = [(node, v[name]) for node, v in mine.items()]
        if not values:
            continue
        first_node, first = values[0]
        others = [(node, v) for node, v in values[1:] if not _same(v, first)]
        out += [Finding(ERROR, node, f'{name} = {v!r}, {first_node} has {first!r}: the fleet '
                        f'runs two gains (formation-control set {name}:=... sets every one)')
                for node, v in others]
        if not others and not _same(first, plant[name]):
            out.append(Finding(NOTE, 'fleet', f'{name} = {first!r} on every vehicle (set at run '
                               f'time); the scenario of the plant says {plant[name]!r}'))
    return out


def check_qos(endpoints, compatible):
    """
    Check every publisher / subscription pair of a topic for QoS that do not match.

    Parameters
    ----------
    endpoints : list of Endpoint
        Every publisher and subscription of the fleet's topics.
    compatible : callable
        ``(publisher QoS, subscription QoS) -> (compatibility, reason)``, as
        ``rclpy.qos.qos_check_compatible``; ``compatibility.name`` is OK, WARNING (a policy
        is the system default: it cannot tell, noted) or ERROR.

    """
    out = []
    by_topic = {}
    for e in endpoints:
        by_topic.setdefault(e.topic, []).append(e)
    for topic, ends in sorted(by_topic.items()):
        for pub in (e for e in ends if e.kind == 'pub'):
            for sub in (e for e in ends if e.kind == 'sub'):
                verdict, reason = compatible(pub.qos, sub.qos)
                if verdict.name == 'OK':
                    continue
                level = ERROR if verdict.name == 'ERROR' else NOTE    # WARNING: cannot tell
                out.append(Finding(level, topic, f'{pub.node} -> {sub.node}: {reason.strip()}'))
    return out


def check_streams(facts):
    """Find the vehicles that send no formation_state, or hear none of their neighbours."""
    if facts.scenario is None:
        return []
    out = []
    subs = {(e.node, e.topic) for e in facts.endpoints if e.kind == 'sub'}
    pubs = {e.topic for e in facts.endpoints if e.kind == 'pub'}
    by_topic = {topic: k for k, topic in facts.state_topics.items()}
    for k, names in sorted(vehicle_ids(facts).items()):
        topic = facts.state_topics.get(k)
        stream = facts.streams.get(topic, Stream())
        if stream.count == 0:
            why = f' the doctor can read: {stream.refused}' if stream.refused else ''
            out.append(Finding(ERROR, names[0], f'publishes no formation_state on {topic}{why}'))
        heard = {by_topic[t] for node, t in subs if node in names and t in by_topic
                 and t != topic}
        if heard and not heard & {by_topic[t] for t in pubs if t in by_topic}:
            out.append(Finding(ERROR, names[0], f'hears no neighbour: no vehicle of '
                               f'{sorted(heard)} publishes its formation_state'))
        elif stream.hears and not any(stream.hears.values()):
            out.append(Finding(ERROR, names[0], 'hears no neighbour: every hears flag of its '
                               'formation_state is false'))
    return out


def check_clocks(facts):
    """Find, in real time, the nodes whose clock leads or lags the doctor's (/diagnostics)."""
    if facts.mode != 'realtime':
        return []
    out = []
    for who, lags in sorted(facts.clock_lags.items()):
        median = sorted(lags)[len(lags) // 2]
        if abs(median) > SKEW_TOLERANCE:
            side = 'behind' if median > 0 else 'ahead of'
            out.append(Finding(WARNING, who, f'its clock is {abs(median):.3f} s {side} this '
                               f"host's (arrival - stamp of its /diagnostics): sync the hosts' "
                               f'clocks (chrony, docs/deployment.md)'))
    return out


def diagnose(facts, compatible):
    """Return every :class:`Finding` of the facts (``compatible``: :func:`check_qos`)."""
    return (check_environment(facts.env) + check_fleet(facts) + check_parameters(facts)
            + check_qos(facts.endpoints, compatible) + check_streams(facts)
            + check_clocks(facts))


def exit_status(findings):
    """Return 1 if a finding is a warning or an error, else 0."""
    return int(any(f.level in (ERROR, WARNING) for f in findings))


def format_report(facts, findings):
    """Return the text ``formation-control doctor`` prints: findings by subject, then a verdict."""
    lines = []
    if facts.scenario is not None:
        sc = facts.scenario
        lines.append(f"fleet: {sc['num_vehicles']} x {sc['model']} {sc['formation']} "
                     f"({facts.mode or 'mode unknown'}), {len(vehicle_ids(facts))} vehicle nodes")
    for f in findings:
        lines.append(f'{f.level:8s} {f.subject}: {f.text}')
    problems = sum(f.level in (ERROR, WARNING) for f in findings)
    lines.append('no problem found' if not problems else f'{problems} problems found')
    return '\n'.join(lines) + '\n'
