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
Read a rosbag2 bag written by ``swarm --bag`` with the ``rosbags`` library.

(Or by ``ros2 bag record`` of the same topics.) The run it holds, as the simulator's
:class:`simulator.Run`, and the series of ``/formation/metrics`` and ``/diagnostics``. The
formation_control_msgs types are decoded by the definitions the bag carries
(:mod:`formation_control.bags.schemas`). A bag of another interface version is refused with the
version that wrote it: those of formation_control before formation_control_msgs (JointState
formation states and metrics, WrenchStamped commands) are interface version 0.

A bag holds what its recorder received, a flood's bytes too: a sample no message of its type
fits is left out, and so is an odometry or command with a non-finite value (what the nodes
refuse, :mod:`formation_control.protocol.intake`); :func:`read_run` counts them.
"""
from collections import Counter, defaultdict
from collections.abc import Collection, Iterator
import json
from pathlib import Path
from typing import Any, NoReturn

from formation_control.bags import schemas
from formation_control.core.errors import UsageError
from formation_control.core.flowfields import Flowfield
from formation_control.core.geometry import RealArray
from formation_control.core.models import ground_velocity, ROW_OMEGA
from formation_control.core.scenario import resolve, Scenario
from formation_control.core.vehicles import vehicle_model
from formation_control.core.world import GUST_CHANNELS
from formation_control.protocol import names
from formation_control.protocol.messages import (ground_velocity_of, input_from_cmd,
                                                 INTERFACE_VERSION, METRIC_DOC, odom_values_of,
                                                 stamp_ns, state_from_odom)
from formation_control.sim.simulator import Run
import numpy as np
from rosbags.rosbag2 import Reader

LEGACY = {'sensor_msgs/msg/JointState', 'geometry_msgs/msg/WrenchStamped'}
"""The stand-ins of interface version 0 for the formation states, commands and metrics."""


def messages(path: str | Path, topics: Collection[str],
             skipped: Counter[str] | None = None) -> Iterator[tuple[str, Any]]:
    """
    Yield (topic, message) for ``topics`` in a bag, in recorded order.

    A sample no message of its topic's type fits is left out, counted in ``skipped`` (a
    :class:`collections.Counter` by topic) when given.

    Raises
    ------
    UsageError
        A formation_control_msgs message, or a topic's type, of another interface version.

    """
    with Reader(path) as reader:
        conns = [c for c in reader.connections if c.topic in topics]
        if not conns:                                    # rosbags reads every topic then
            return
        store = schemas.typestore(schemas.bag_definitions(conns))
        for conn in conns:
            if conn.msgtype in LEGACY and not conn.topic.endswith('/diagnostics'):
                _refuse(path, conn.topic, 0, f'its type {conn.msgtype}')
        for conn, _, data in reader.messages(connections=conns):
            try:
                msg = store.deserialize_cdr(data, conn.msgtype)
            except Exception:           # what the bytes make rosbags raise: struct, index, ...
                if skipped is not None:
                    skipped[conn.topic] += 1
                continue
            version = getattr(msg, 'interface_version', INTERFACE_VERSION)
            if version != INTERFACE_VERSION:
                _refuse(path, conn.topic, version, 'its interface_version')
            yield conn.topic, msg


def _refuse(path: str | Path, topic: str, version: int, why: str) -> NoReturn:
    raise UsageError(f'{path}: written by formation_control of interface version {version} '
                     f'({topic}: {why}); this formation_control reads formation_control_msgs '
                     f'interface version {INTERFACE_VERSION} (version 0: before '
                     f'formation_control_msgs, JointState and WrenchStamped stand-ins): read it '
                     f'with the formation_control that wrote it')


def _stamp(msg: Any) -> int:
    return stamp_ns(msg.header.stamp)


def fleet_prefix(path: str | Path) -> str:
    """Return the namespace of the fleet a bag holds, as a topic prefix ('/', '/fleet_a/')."""
    with Reader(path) as reader:
        for conn in reader.connections:
            if conn.topic.endswith('/' + names.SCENARIO_TOPIC):
                return conn.topic[:-len(names.SCENARIO_TOPIC)]
    raise UsageError(f'{path}: the bag has no {names.SCENARIO_TOPIC} topic (the plant '
                     f'publishes it; record that topic)')


def _scenario(path: str | Path, prefix: str) -> Scenario:
    for _, msg in messages(path, [prefix + names.SCENARIO_TOPIC]):
        return resolve(json.loads(msg.data))
    raise UsageError(f'{path}: the bag has no {names.SCENARIO_TOPIC} message (the plant '
                     f'publishes it; record that topic)')


def read_run(path: str | Path) -> Run:
    """
    Return the run a bag holds, sampled like the plant's record.

    Parameters
    ----------
    path : str or path-like
        The bag directory; it must hold ``/formation/scenario``.

    Returns
    -------
    simulator.Run
        Every ``record_dt`` (and the last) of the control periods in which every vehicle's
        odometry is present (:func:`_periods`: a real-time plant samples the vehicles at
        staggered steps of each period; the run's time is the period's start), with each
        vehicle's latest command at its sample; its ``meta['skipped']`` is {topic: samples
        left out} (undecodable, or an odometry or command not finite). In gusts
        (``gust_intensity``) its channels hold each vehicle's gust (:data:`world.GUST_CHANNELS`):
        the odometry's ground velocity less that of the state in the flowfield, which the
        metrics read (a particle's state has no place for it).

    Raises
    ------
    UsageError
        No scenario, or no control period with the odometry of every vehicle.

    """
    prefix = fleet_prefix(path)
    sc = _scenario(path, prefix)
    n = sc.num_vehicles
    index = {prefix + names.topic(k, 'odom'): k - 1 for k in range(1, n + 1)}
    cmd_index = {prefix + names.topic(k, 'cmd'): k - 1 for k in range(1, n + 1)}
    samples: list[tuple[int, int, Any, str]] = []
    cmds: list[list[tuple[int, tuple[float, float]]]] = [[] for _ in range(n)]
    skipped: Counter[str] = Counter()
    for topic, msg in messages(path, set(index) | set(cmd_index), skipped):
        if topic in index:
            samples.append((_stamp(msg), index[topic], msg, topic))
        else:
            u = input_from_cmd(msg, sc.model)
            if _finite(u, topic, skipped):
                cmds[cmd_index[topic]].append((_stamp(msg), u))
    periods = _periods(sc, samples, skipped, path)
    whole = np.array(sorted(p for p, cols in periods.items() if len(cols) == n), int)
    if whole.size == 0:
        raise UsageError(f'{path}: no control period with the odometry of all {n} vehicles')
    steps = whole - whole[0]
    keep = (steps % sc.record_every == 0) | (steps == steps[-1])
    chosen = [periods[p] for p in whole[keep]]
    steps = steps[keep]
    X = np.array([np.column_stack([cols[k][1] for k in range(n)]) for cols in chosen])
    U = np.zeros((len(chosen), 2, n))
    for k, seq in enumerate(cmds):
        seq.sort(key=lambda item: item[0])
        times = np.array([s for s, _ in seq], np.int64)
        values = np.array([u for _, u in seq]).reshape(-1, 2)
        at = np.searchsorted(times, [cols[k][0] for cols in chosen], side='right') - 1
        U[at >= 0, :, k] = values[at[at >= 0]]
    if vehicle_model(sc.model).first_order:
        X[:, ROW_OMEGA] = U[:, 1]
    gust = np.array([[cols[k][2] for k in range(n)] for cols in chosen])
    channels = dict(zip(GUST_CHANNELS, (gust.real, gust.imag))) if sc.gust_intensity else {}
    return Run(sc, steps * sc.dt_control, X, U, {'source': str(path), 'skipped': dict(skipped)},
               channels=channels)


def _periods(sc: Scenario, samples: list[tuple[int, int, Any, str]], skipped: Counter[str],
             path: str | Path) -> dict[int, dict[int, tuple[int, RealArray, complex]]]:
    """
    Return {control period: {vehicle index: (odometry stamp, state, gust)}} of the odometry.

    In lockstep every vehicle's sample of a period is stamped with its start; in real time
    the plant samples vehicle k at integration step (k - 1) mod substeps of each period
    (:func:`~formation_control.protocol.lockstep.sample_slots`): the period is the one the
    stamp falls in, counted from the first sample (t = 0). The flow a state is taken relative
    to is the flowfield's at the sample's own time; the gust is what of the odometry's ground
    velocity the state in it does not explain.
    """
    if not samples:
        raise UsageError(f'{path}: the bag has no odometry of the fleet')
    t0 = min(stamp for stamp, _, _, _ in samples)
    period_ns, half_step = round(sc.dt_control * 1e9), round(sc.dt_integration * 5e8)
    field = Flowfield(sc)
    out: defaultdict[int, dict[int, tuple[int, RealArray, complex]]] = defaultdict(dict)
    for stamp, k, msg, topic in samples:
        pos = msg.pose.pose.position
        with np.errstate(invalid='ignore'):
            flow = complex(field((stamp - t0) * 1e-9, pos.x, pos.y))
        x = state_from_odom(msg, flow, sc.model)
        if _finite(x, topic, skipped):
            gust = ground_velocity_of(odom_values_of(msg)) - complex(ground_velocity(x, flow))
            out[(stamp - t0 + half_step) // period_ns].setdefault(k, (stamp, x, gust))
    return out


def _finite(value: Any, topic: str, skipped: Counter[str]) -> bool:
    """Return whether ``value`` is finite; count it in ``skipped`` under ``topic`` if not."""
    if np.all(np.isfinite(value)):
        return True
    skipped[topic] += 1
    return False


def metrics(path: str | Path) -> tuple[RealArray, dict[str, RealArray]]:
    """
    ``formation/metrics`` of a bag: (t (M,) s from the first step, {name: (M,) array}).

    The names are those of :data:`~formation_control.protocol.messages.METRIC_DOC` that apply
    (not NaN in every sample).
    """
    rows = [(_stamp(msg), [float(getattr(msg, name)) for name in METRIC_DOC])
            for _, msg in messages(path, [fleet_prefix(path) + names.METRICS_TOPIC])]
    t = np.array([s for s, _ in rows], np.int64) * 1e-9
    values = np.array([r for _, r in rows]).reshape(len(rows), len(METRIC_DOC))
    return t, {name: values[:, i] for i, name in enumerate(METRIC_DOC)
               if rows and not np.all(np.isnan(values[:, i]))}


def diagnostics(path: str | Path) -> list[
        tuple[float, list[tuple[str, int, str, dict[str, str]]]]]:
    """``/diagnostics`` of a bag: a list of (stamp s, [(name, level, message, {key: value})])."""
    out = []
    for _, msg in messages(path, ['/diagnostics']):
        out.append((_stamp(msg) * 1e-9,
                    [(s.name, int(s.level), s.message, {v.key: v.value for v in s.values})
                     for s in msg.status]))
    return out
