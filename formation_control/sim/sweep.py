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
Monte-Carlo studies: a grid of parameter values times seeds, run as batches of fleets.

A sweep is planned (every grid point validated) before anything runs, then its batches run in
local worker processes or on a Dask distributed cluster. Each batch is one grid point and a
range of seeds, simulated as one batch of independent fleets (:func:`simulator.simulate` with
(6, B, N) states); each run starts from :func:`scenario.initial_state` of its own seed, so a
run's result does not depend on the batch it is in, the batch size or the workers. Each
batch's rows are written to ``<out>.parts/`` as it completes, ``resume`` skips those already
there, and the parts are merged into one ``.npz`` at the end.
"""
from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
import itertools
import json
import math
import multiprocessing
from os import PathLike
from pathlib import Path
import shutil
import sys
import time
from typing import Any, TextIO, TypeAlias

from formation_control.core import parameters, scenario
from formation_control.core.models import ROW_THETA, ROW_X, ROW_Y
from formation_control.sim import simulator
import numpy as np
from numpy.typing import NDArray

FIXED = {'seed': 'the seeds are the runs: use --seeds',
         'duration': 'every run of a sweep has the same time axis: use --duration',
         'record_dt': 'every run of a sweep has the same time axis'}
"""Parameters that are not swept, and why."""
PAIRS = ('flow', 'c0')
SWEEPABLE = tuple(name for name in parameters.PARAMETER_NAMES if name not in FIXED and (
    name in PAIRS or not isinstance(getattr(parameters.Scenario(), name), tuple)))
"""Parameters a sweep may vary: every scalar one, and the pairs flow and c0."""
BATCH_VEHICLES = 2000
"""Vehicles simulated together by default (fleets per batch = this / N): past about a
thousand vehicles numpy's per-call overhead is small against the arithmetic (docs/benchmarks.md,
section 7)."""
Z95 = 1.959963984540054


Batch: TypeAlias = tuple[int, list[int]]
"""A batch of runs: its grid point and seeds."""
Rows: TypeAlias = dict[str, Any]
"""The rows of a batch, one per run (:func:`run_batch`)."""
Job: TypeAlias = tuple[int, tuple[Any, ...]]
"""A batch to run: its index and the arguments of the task."""
Task: TypeAlias = Callable[..., Rows]
Done: TypeAlias = Callable[[int, Rows], None]
Failed: TypeAlias = Callable[[int, str], None]


class SweepError(ValueError):
    """A sweep cannot be planned or resumed: the message says which option or grid point."""


def parse_grid(overrides: Iterable[str]) -> tuple[dict[str, Any], dict[str, list[Any]]]:
    """
    Split ``name:=value`` overrides into fixed values and grid axes.

    Parameters
    ----------
    overrides : iterable of str
        ``-p`` options: a list of values (``K:=[0.5, 1, 2]``; a list of pairs for flow and c0)
        makes an axis of the grid, anything else a fixed value.

    Returns
    -------
    fixed : dict
        Parameter name -> value, for every run.
    axes : dict
        Parameter name -> list of values, in the order given.

    Raises
    ------
    SweepError
        An empty list of values, or an axis of a parameter that cannot be swept.

    """
    fixed, axes = {}, {}
    for text in overrides:
        name, value = parameters.parse_override(text)
        pair = name in PAIRS
        is_axis = isinstance(value, list) and (
            not pair or (bool(value) and all(isinstance(v, list) for v in value)))
        if name in parameters.PARAMETERS and isinstance(value, list) and not value:
            raise SweepError(f"grid of '{name}' is empty: give at least one value, "
                             f'{name}:=[v1, v2, ...]')
        if not is_axis:
            fixed[name] = value
            continue
        if name not in SWEEPABLE:
            why = FIXED.get(name, 'it is a per-vehicle or per-edge list'
                            if name in parameters.PARAMETERS else 'not a scenario parameter')
            raise SweepError(f"parameter '{name}' cannot be swept ({why}); sweepable: "
                             f"{', '.join(SWEEPABLE)}")
        axes[name] = value
    return fixed, axes


@dataclass(frozen=True)
class Plan:
    """
    The runs of a sweep: grid points, seeds, and the batches they are cut into.

    Attributes
    ----------
    points : list of dict
        The parameters of each grid point (base scenario with fixed values and axis values).
    axes : dict
        Swept parameter -> values.
    seeds : list of int
        The seeds run at every grid point.
    batches : list of (int, list of int)
        (grid point, seeds) of each batch, in output order.

    """

    points: list[dict[str, Any]]
    axes: dict[str, list[Any]]
    seeds: list[int]
    batches: list[Batch]

    def manifest(self) -> dict[str, Any]:
        """Return the plan as JSON-able data: what ``--resume`` checks is the same sweep."""
        return {'points': self.points, 'axes': self.axes, 'seeds': self.seeds,
                'batches': self.batches}

    @property
    def runs(self) -> int:
        """Return the number of runs, grid points times seeds."""
        return len(self.points) * len(self.seeds)


def failure(err: BaseException) -> str:
    """Return the reason a batch failed with ``err``: an out-of-memory names what to lower."""
    if isinstance(err, MemoryError):
        return (f"out of memory ({str(err) or 'an allocation failed'}): lower --batch-size, "
                f'num_vehicles or --duration')
    return f'{type(err).__name__}: {err}'


def point_label(axes: Iterable[str], values: Iterable[Any]) -> str:
    """Return 'K=0.5, kappa=2' for one grid point, or 'all runs' without axes."""
    return ', '.join(f'{n}={v}' for n, v in zip(axes, values)) or 'all runs'


def plan(base: Mapping[str, Any], overrides: Iterable[str], seeds: Sequence[int],
         batch_size: int | None = None, workers: int = 1) -> Plan:
    """
    Plan a sweep and validate every grid point before anything runs.

    Parameters
    ----------
    base : dict
        The scenario's parameters (a parameter file's mapping, with --duration applied).
    overrides : iterable of str
        ``-p`` options (:func:`parse_grid`).
    seeds : sequence of int
        The seeds run at each grid point.
    batch_size : int, optional
        Runs per batch; by default ``BATCH_VEHICLES / N``, fewer so that every worker gets
        at least two batches.
    workers : int
        Workers the batches are spread over.

    Returns
    -------
    Plan

    Raises
    ------
    SweepError
        No seeds, a bad grid (:func:`parse_grid`), or a grid point that makes the scenario
        invalid, named with the reason :func:`scenario.resolve` gives.

    """
    seeds = [int(s) for s in seeds]
    if not seeds:
        raise SweepError('--seeds must be >= 1')
    fixed, axes = parse_grid(overrides)
    points, n = [], 1
    for values in itertools.product(*axes.values()):
        params = dict(base, **fixed, **dict(zip(axes, values)))
        try:
            n = max(n, scenario.resolve(params).num_vehicles)
        except scenario.ScenarioError as err:
            raise SweepError(f'grid point {point_label(axes, values)}: {err}') from None
        points.append(params)
    if batch_size is None:
        spread = math.ceil(len(seeds) * len(points) / (2 * max(1, workers)))
        batch_size = max(1, min(BATCH_VEHICLES // n, spread, len(seeds)))
    if batch_size < 1:
        raise SweepError(f'--batch-size = {batch_size} must be >= 1')
    batches = [(p, seeds[i:i + batch_size]) for p in range(len(points))
               for i in range(0, len(seeds), batch_size)]
    return Plan(points, axes, seeds, batches)


def run_batch(params: Mapping[str, Any], seeds: Sequence[int]) -> Rows:
    """
    Simulate one batch: a grid point's scenario from each seed, as one batch of fleets.

    Parameters
    ----------
    params : dict
        The scenario's parameters (:func:`scenario.resolve`).
    seeds : sequence of int
        One run per seed.

    Returns
    -------
    dict of str to ndarray
        One row per run: ``seed``, ``converged`` (:func:`metrics.verdict`, as
        :func:`simulator.summary`), ``convergence_time`` (s, NaN if not converged), ``held``
        (s, how long the test held to the end, :meth:`simulator.Outcome.held`), the final
        metrics by name (:meth:`metrics.Snapshot.values`), ``met_<condition>`` for each of
        :func:`metrics.conditions` (at the end; with the band test over the last window),
        with the band test ``ss_median_<error>`` and ``ss_p95_<error>`` of each
        :func:`metrics.steady_errors` over the last window, ``diverged`` (a fleet in the world
        whose state diverged, :meth:`simulator.Outcome.stop`), ``kept_apart`` (no pair ever
        too close, :class:`separation.Tracker`), ``separation_closest`` (m) and
        ``separation_time_too_close`` (s), and ``final_x``, ``final_y``, ``final_theta``
        (runs, N).

    """
    sc = scenario.resolve(params)
    out = simulator.simulate(sc, simulator.initial_states(sc, seeds), simulator.Outcome(sc),
                             seeds=seeds)
    rows = {'seed': np.array(seeds, dtype=np.int64), 'converged': out.converged(),
            'convergence_time': out.convergence_times(),
            'held': out.held(),
            'diverged': np.broadcast_to(out.diverged, (len(seeds),)).copy()}
    for name, ok in out.met_conditions().items():
        rows[f'met_{name}'] = np.broadcast_to(ok, (len(seeds),)).copy()
    rows.update(out.final.values())
    rows.update({f'separation_{k}' if k != 'kept_apart' else k: v
                 for k, v in out.apart.rows().items()})
    if scenario.practical(sc):
        for name, (median, p95) in out.steady_state().items():
            rows[f'ss_median_{name}'] = np.broadcast_to(median, (len(seeds),)).copy()
            rows[f'ss_p95_{name}'] = np.broadcast_to(p95, (len(seeds),)).copy()
    rows.update(final_x=out.X[ROW_X], final_y=out.X[ROW_Y], final_theta=out.X[ROW_THETA])
    return rows


class Progress:
    """
    A progress bar with the runs done, the elapsed time and an ETA, on stderr.

    Redrawn in place on a terminal; elsewhere (a log) one line per tenth of the runs.
    """

    def __init__(self, total: int, stream: TextIO | None = None) -> None:
        self.total, self.done, self.shown = total, 0, -1
        self.stream = sys.stderr if stream is None else stream
        self.start = time.monotonic()

    def advance(self, runs: int) -> None:
        """Count ``runs`` more runs done and redraw the bar."""
        self.done += runs
        elapsed = time.monotonic() - self.start
        frac = self.done / self.total
        tty = self.stream.isatty()
        if not tty and int(10 * frac) == self.shown:
            return
        self.shown = int(10 * frac)
        eta = elapsed * (1 - frac) / frac
        end = '\n' if self.done >= self.total or not tty else ''
        self.stream.write(f"\r[{'#' * int(30 * frac):30s}] {self.done}/{self.total} runs  "
                          f'{elapsed:.1f} s  ETA {eta:.1f} s{end}')
        self.stream.flush()


def part_name(batch: Batch) -> str:
    """Return the file name of a batch's rows: grid point and first seed."""
    point, seeds = batch
    return f'point{point:04d}_seed{seeds[0]:08d}.npz'


def parts_dir(out: str | PathLike[str]) -> Path:
    """Return the directory next to ``out`` that holds the rows of completed batches."""
    out = Path(out)
    return out.with_name(out.name + '.parts')


def stored_batches(out: str | PathLike[str]) -> list[Batch]:
    """Return the batches of the sweep whose parts are next to ``out`` (its manifest)."""
    stored = json.loads((parts_dir(out) / 'manifest.json').read_text())
    return [(point, seeds) for point, seeds in stored['batches']]


def open_parts(out: str | PathLike[str], the_plan: Plan,
               resume: bool) -> tuple[list[Batch], set[int]]:
    """
    Prepare the directory of parts; return the batches, and those already done (resume).

    A resumed sweep keeps the batches it started with (another ``--workers`` or
    ``--batch-size`` does not change them).

    Raises
    ------
    SweepError
        The directory holds another sweep (resume), or exists without ``resume``.

    """
    where = parts_dir(out)
    manifest = where / 'manifest.json'
    wanted = json.loads(json.dumps(the_plan.manifest()))
    if where.exists() and not resume:
        raise SweepError(f'{where} holds the batches of an unfinished sweep: continue it with '
                         f'--resume, or remove the directory')
    if resume and manifest.exists():
        stored = json.loads(manifest.read_text())
        if any(stored[k] != wanted[k] for k in ('points', 'axes', 'seeds')):
            raise SweepError(f'--resume: {where} holds another sweep (scenario, grid or seeds '
                             f'differ); run the same command, or remove it')
        batches = stored_batches(out)
        return batches, {i for i, b in enumerate(batches) if (where / part_name(b)).exists()}
    where.mkdir(parents=True, exist_ok=True)
    manifest.write_text(json.dumps(wanted))
    return the_plan.batches, set()


def write_part(out: str | PathLike[str], batch: Batch, point: int, rows: Rows) -> None:
    """Write a batch's rows, with its grid point index, atomically (a complete file or none)."""
    path = parts_dir(out) / part_name(batch)
    tmp = path.with_suffix('.tmp.npz')
    np.savez(tmp, grid_point=np.full(len(batch[1]), point), **rows)
    tmp.replace(path)


class _Local:
    """Run tasks in local worker processes; a task whose worker died is run once more, alone."""

    def __init__(self, workers: int) -> None:
        self.workers = workers
        self.tries: dict[int, int] = {}

    def run(self, task: Task, jobs: Iterable[Job], done: Done, failed: Failed) -> None:
        """Run ``task(*args)`` of each (key, args) in ``jobs``; report to ``done``/``failed``."""
        if self.workers == 0:
            for key, args in jobs:
                self._inline(task, key, args, done, failed)
            return
        pending, suspects = list(jobs), []
        while pending:
            died, pending = self._pool(task, pending, self.workers, done, failed)
            suspects += died
        for job in suspects:
            died, _ = self._pool(task, [job], 1, done, failed)
            for key, _ in died:
                failed(key, 'its worker process died, twice')

    def _failed(self, key: int, args: tuple[Any, ...], err: Exception, pending: list[Job],
                failed: Failed) -> None:
        """Queue a task whose code raised for a second try, or report it."""
        self.tries[key] = self.tries.get(key, 0) + 1
        if self.tries[key] < 2:
            pending.insert(0, (key, args))
        else:
            failed(key, failure(err))

    def _inline(self, task: Task, key: int, args: tuple[Any, ...], done: Done,
                failed: Failed) -> None:
        pending = [(key, args)]
        while pending:
            pending.pop()
            try:
                done(key, task(*args))
            except Exception as err:                   # noqa: B902 (retried, then reported)
                self._failed(key, args, err, pending, failed)

    def _pool(self, task: Task, jobs: Iterable[Job], workers: int, done: Done,
              failed: Failed) -> tuple[list[Job], list[Job]]:
        """
        Run jobs, ``workers`` at a time, until done or a worker dies.

        Returns the jobs that were running when the pool broke and those not started.
        """
        pending, died = list(jobs), list[Job]()
        running: dict[Future[Rows], Job] = {}
        with ProcessPoolExecutor(workers, mp_context=_workers_context()) as pool:
            while pending or running:
                while pending and len(running) < workers and not died:
                    key, args = pending.pop(0)
                    running[pool.submit(task, *args)] = (key, args)
                if not running:
                    break
                finished, _ = wait(running, return_when=FIRST_COMPLETED)
                for fut in finished:
                    key, args = running.pop(fut)
                    try:
                        rows = fut.result()
                    except BrokenProcessPool:
                        died.append((key, args))
                    except Exception as err:           # noqa: B902 (retried, then reported)
                        self._failed(key, args, err, pending, failed)
                    else:
                        done(key, rows)
        return died, pending


def _workers_context() -> multiprocessing.context.BaseContext:
    """
    Return the start method of the local workers: new interpreters, not forks of the caller.

    A pool forked from a process with threads (a ROS node, a Dask client, a test runner) can
    deadlock in a child on a lock another thread held at the fork; a spawned worker starts
    clean, with the caller's environment of the moment.
    """
    return multiprocessing.get_context('spawn')


class _Dask:
    """Run tasks on a Dask distributed cluster; a failed task is resubmitted once."""

    def __init__(self, address: str) -> None:
        try:
            from distributed import Client
        except ImportError:
            raise SweepError('--scheduler needs Dask distributed: pip install '
                             "'formation_control[cluster]' (make setup installs it)") from None
        try:
            self.client = Client(address, timeout=10)
        except (OSError, TimeoutError) as err:
            raise SweepError(f'--scheduler {address}: cannot connect ({err})') from None

    def run(self, task: Task, jobs: Iterable[Job], done: Done, failed: Failed) -> None:
        """Run ``task(*args)`` of each (key, args) in ``jobs``; report to ``done``/``failed``."""
        from distributed import as_completed
        futures = {self.client.submit(task, *args, pure=False): (key, args, 0)
                   for key, args in jobs}
        queue = as_completed(futures)
        for fut in queue:
            key, args, attempt = futures.pop(fut)
            try:
                done(key, fut.result())
            except Exception as err:                   # noqa: B902 (KilledWorker, the task's)
                if attempt:
                    failed(key, failure(err))
                else:
                    again = self.client.submit(task, *args, pure=False)
                    futures[again] = (key, args, 1)
                    queue.add(again)
        self.client.close()


def execute(the_plan: Plan, out: str | PathLike[str], workers: int = 1,
            scheduler: str | None = None, resume: bool = False, task: Task = run_batch,
            progress: Progress | None = None) -> dict[int, str]:
    """
    Run the batches of a plan not done yet, writing each one's rows as it completes.

    Parameters
    ----------
    the_plan : Plan
        The sweep.
    out : str or path-like
        The merged ``.npz``; the parts go to ``<out>.parts/``.
    workers : int
        Local worker processes (0: in this process).
    scheduler : str, optional
        A Dask scheduler address (``tcp://HOST:PORT``): run the batches there instead.
    resume : bool
        Continue a sweep whose parts are in ``<out>.parts/``.
    task : callable
        ``task(params, seeds) -> rows``; :func:`run_batch`.
    progress : Progress, optional
        Advanced as batches complete.

    Returns
    -------
    dict
        Batch index -> what failed twice and why ('grid point 1, seeds 0-249: ...'); empty
        when all ran.

    """
    batches, finished = open_parts(out, the_plan, resume)
    if progress is not None and finished:
        progress.advance(sum(len(batches[i][1]) for i in finished))
    jobs = [(i, (the_plan.points[p], seeds)) for i, (p, seeds) in enumerate(batches)
            if i not in finished]
    failures: dict[int, str] = {}

    def done(i: int, rows: Rows) -> None:
        write_part(out, batches[i], batches[i][0], rows)
        if progress is not None:
            progress.advance(len(batches[i][1]))

    def failed(i: int, reason: str) -> None:
        point, seeds = batches[i]
        failures[i] = f'grid point {point}, seeds {seeds[0]}-{seeds[-1]}: {reason}'
    engine = _Dask(scheduler) if scheduler else _Local(workers)
    engine.run(task, jobs, done, failed)
    return failures


def merge(the_plan: Plan, out: str | PathLike[str]) -> dict[str, NDArray[Any]]:
    """
    Merge the parts of a finished sweep into ``out`` and remove them.

    Returns
    -------
    dict of str to ndarray
        What was written: one row per run, in grid-point then seed order; ``grid_point``
        (index), one column per swept parameter, rows padded with NaN to the largest N and
        metrics NaN where a grid point has none; ``params`` (the grid points) and ``axes`` as
        JSON.

    """
    where = parts_dir(out)
    parts = []
    for batch in stored_batches(out):
        with np.load(where / part_name(batch)) as d:
            parts.append({k: d[k] for k in d.files})
    width = max(p['final_x'].shape[1] for p in parts)
    names = list(dict.fromkeys(k for p in parts for k in p))
    merged: dict[str, Any] = {}
    for name in names:
        cols = []
        for p in parts:
            rows = len(p['seed'])
            col = p.get(name, np.full(rows, np.nan))
            if name.startswith('final_'):
                col = np.pad(col, ((0, 0), (0, width - col.shape[1])), constant_values=np.nan)
            cols.append(col)
        merged[name] = np.concatenate(cols)
    resolved = [scenario.resolve(p) for p in the_plan.points]
    for name in the_plan.axes:
        merged[name] = np.array([getattr(resolved[g], name) for g in merged['grid_point']])
    merged['params'] = np.array(json.dumps(the_plan.points))
    merged['axes'] = np.array(json.dumps(the_plan.axes))
    np.savez_compressed(out, **merged)
    shutil.rmtree(where)
    return merged


def wilson(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """
    Return the Wilson score interval of a binomial proportion.

    Parameters
    ----------
    successes, n : int
        Runs that converged, and all runs (n >= 1).
    z : float
        Normal quantile; 1.96 for 95 %.

    Returns
    -------
    low, high : float
        ``(p + z^2/(2n) -+ z sqrt(p (1 - p)/n + z^2/(4 n^2))) / (1 + z^2/n)``, with
        ``p = successes / n``: it stays in [0, 1] and is not empty at p = 0 or 1.

    """
    p = successes / n
    centre = p + z * z / (2 * n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    scale = 1 + z * z / n
    low = 0.0 if successes == 0 else (centre - half) / scale
    high = 1.0 if successes == n else (centre + half) / scale
    return low, high


def table(data: Mapping[str, NDArray[Any]]) -> list[dict[str, Any]]:
    """
    Return the per-grid-point figures of a merged sweep.

    Parameters
    ----------
    data : dict of str to ndarray
        :func:`merge`'s arrays (or a loaded sweep ``.npz``).

    Returns
    -------
    list of dict
        Per grid point: ``label``, ``runs``, ``converged`` (count), ``fraction`` and its 95 %
        Wilson interval ``low``, ``high``; ``t10``, ``t50``, ``t90``, the convergence-time
        quantiles (s) of the runs that converged (NaN if none); ``failed``, the number of
        runs that fail each convergence condition (``met_<condition>`` false; NaN where a
        grid point has no such condition), by name; ``steady``, with the band test, the
        median and 95th percentile over the runs of each run's steady-state error (its 95th
        percentile over the last window, ``ss_p95_<error>``), by name; ``kept_apart``, the
        runs that kept apart, with ``apart_low``, ``apart_high`` the Wilson interval of their
        share (absent from a sweep that has no such column).

    """
    axes = json.loads(str(data['axes']))
    points = json.loads(str(data['params']))
    rows = []
    for g, params in enumerate(points):
        mine = data['grid_point'] == g
        ok = data['converged'][mine]
        times = data['convergence_time'][mine][ok]
        low, high = wilson(int(ok.sum()), int(ok.size))
        q = np.quantile(times, (0.1, 0.5, 0.9)) if times.size else (np.nan,) * 3
        failed = {key[4:]: int(np.count_nonzero(data[key][mine] == 0)) for key in sorted(data)
                  if key.startswith('met_')}
        steady = {key[7:]: (float(np.nanmedian(data[key][mine])),
                            float(np.nanquantile(data[key][mine], 0.95)))
                  for key in sorted(data) if key.startswith('ss_p95_')
                  and np.any(np.isfinite(data[key][mine]))}
        rows.append({'label': point_label(axes, [params[n] for n in axes]),
                     'runs': int(ok.size), 'converged': int(ok.sum()),
                     'fraction': float(ok.mean()), 'low': low, 'high': high,
                     't10': float(q[0]), 't50': float(q[1]), 't90': float(q[2]),
                     'failed': {k: v for k, v in failed.items() if v}, 'steady': steady})
        if 'kept_apart' in data:
            apart = data['kept_apart'][mine] == 1
            rows[-1].update(zip(('kept_apart', 'apart_low', 'apart_high'),
                                (int(apart.sum()), *wilson(int(apart.sum()), int(apart.size)))))
    return rows


def format_table(rows: Sequence[Mapping[str, Any]]) -> str:
    """Return the table of :func:`table` as text, one line per grid point."""
    width = max(len('grid point'), *(len(r['label']) for r in rows))
    apart = all('kept_apart' in r for r in rows)
    lines = [f"{'grid point':{width}s}  {'runs':>5s}  {'converged':>9s}  {'95% CI':>13s}  "
             f"{'t10 (s)':>8s}  {'median':>8s}  {'t90 (s)':>8s}  "
             + (f"{'kept apart':>10s}  {'95% CI':>13s}  " if apart else '') + 'failed on']
    for r in rows:
        failed = ', '.join(f'{k} {v}' for k, v in r.get('failed', {}).items())
        steady = ', '.join(f'{k} {m:.3g}/{q:.3g}' for k, (m, q) in r.get('steady', {}).items())
        kept = (f"{r['kept_apart'] / r['runs']:10.3f}  [{r['apart_low']:.3f}, "
                f"{r['apart_high']:.3f}]  " if apart else '')
        lines.append(f"{r['label']:{width}s}  {r['runs']:5d}  {r['fraction']:9.3f}  "
                     f"[{r['low']:.3f}, {r['high']:.3f}]  {r['t10']:8.2f}  {r['t50']:8.2f}  "
                     f"{r['t90']:8.2f}  {kept}{failed}".rstrip()
                     + (f'  steady-state p95 median/p95: {steady}' if steady else ''))
    return '\n'.join(lines)


def plot(data: Mapping[str, NDArray[Any]], path: str | PathLike[str], title: str = '') -> None:
    """
    Draw a sweep: fraction converged with its 95 % interval, convergence-time distributions.

    Parameters
    ----------
    data : dict of str to ndarray
        A merged sweep.
    path : str or path-like
        PNG file to write.
    title : str
        The figure's title.

    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    rows = table(data)
    x = np.arange(len(rows))
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(max(6, 0.9 * len(rows) + 3), 7),
                                      sharex=True)
    frac = np.array([r['fraction'] for r in rows])
    err = np.array([[r['fraction'] - r['low'] for r in rows],
                    [r['high'] - r['fraction'] for r in rows]])
    top.errorbar(x, frac, yerr=err, fmt='o', capsize=4)
    top.set_ylim(-0.05, 1.05)
    top.set_ylabel('fraction converged\n(95% Wilson interval)')
    top.grid(alpha=0.3)
    times = [data['convergence_time'][(data['grid_point'] == g) & data['converged']]
             for g in range(len(rows))]
    shown = [i for i, t in enumerate(times) if t.size]
    if shown:
        bottom.boxplot([times[i] for i in shown], positions=x[shown], widths=0.5,
                       whis=(5, 95), showfliers=True)
    bottom.set_ylabel('convergence time (s)\n(box 25-75 %, whiskers 5-95 %)')
    bottom.set_xticks(x, [r['label'] for r in rows], rotation=30, ha='right')
    bottom.grid(alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
