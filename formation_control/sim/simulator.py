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
Offline simulator: the sampled-data loop the ROS plant runs too.

Each control period every vehicle's command is computed from the state at the start of the
period, predicted to the middle of the hold (``hold_prediction``), and held while RK4 integrates
the plant over ``dt_control / dt_integration`` steps. Each vehicle commands with the flow it has:
the local flow at its place (``flow_source: known``) or its estimate (``estimated``,
:mod:`estimation`), from what it measures at the period's start.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
import json
from os import PathLike
from typing import Any, cast, overload

from formation_control.core import formations, safety, sensors, stability
from formation_control.core.aircraft import CHANNELS
from formation_control.core.control import Controller
from formation_control.core.estimation import neighbour_mean
from formation_control.core.geometry import BoolArray, ComplexArray, RealArray
from formation_control.core.models import (ground_velocity, ROW_THETA, ROW_U, ROW_V, ROW_X,
                                           ROW_Y, STATE_NAMES)
from formation_control.core.parameters import Scenario
from formation_control.core.scenario import initial_state, practical, resolve
from formation_control.core.sensors import Sample, Sensors
from formation_control.core.separation import limits
from formation_control.core.vehicles import vehicle_model
from formation_control.core.world import GUST_CHANNELS, recorded_gust
from formation_control.sim import metrics, separation
from formation_control.sim.allocator import keep_freed_memory
from formation_control.sim.backends import backend_of
from formation_control.sim.onboard import OnboardStep
import numpy as np
from numpy.typing import ArrayLike

LARGE_FLEET = 10_000
"""From this many vehicles (all fleets of a batch) freed memory is kept (:mod:`allocator`)."""


@dataclass
class Run:
    """
    A recorded run.

    Attributes
    ----------
    sc : scenario.Scenario
        The scenario that ran.
    t : ndarray, shape (T,)
        Sample times (s) from the first step.
    X : ndarray, shape (T, 6, N)
        States at those times (rows of :mod:`models`).
    U : ndarray, shape (T, 2, N)
        Inputs held from those times on.
    meta : dict
        Where it came from (a bag's path, ...), saved as JSON.
    flow_hat : ndarray of complex, shape (T, N), or None
        The flow each vehicle commanded with (its known local flow or its estimate, m/s);
        None where the record does not hold it (the plant node's: the estimates are the
        vehicles').
    channels : dict of str to ndarray, shape (T, N)
        What a plant backend records beside the state (JSBSim: :data:`aircraft.CHANNELS`;
        the world in gusts: :data:`world.GUST_CHANNELS`).

    """

    sc: Scenario
    t: RealArray
    X: RealArray
    U: RealArray
    meta: dict[str, Any] = field(default_factory=dict)
    flow_hat: ComplexArray | None = None
    channels: dict[str, RealArray] = field(default_factory=dict)

    @property
    def gust(self) -> ComplexArray:
        """Return the gusts recorded, complex m/s, (T, N): :func:`world.recorded_gust`, or 0."""
        return np.broadcast_to(recorded_gust(self.channels), self.X[:, 0].shape)

    def arrays(self) -> dict[str, Any]:
        """
        Return the arrays of the ``.npz`` layout.

        Returns
        -------
        dict of str to ndarray
            t (T,); x, y, theta, omega, u, v (T, N); the held inputs, T and F (N) for rigid
            bodies, ``command`` for particles (rad/s^2, or rad/s for first order);
            ``flow_hat_x``, ``flow_hat_y`` (T, N) where recorded; the backend's channels
            (T, N) (altitude, bank, ...); ``params``, the scenario as JSON, and ``meta``.

        """
        out = {'t': self.t, 'params': np.array(self.sc.to_json()),
               'meta': np.array(json.dumps(self.meta))}
        out.update({name: self.X[:, row] for row, name in enumerate(STATE_NAMES)})
        if vehicle_model(self.sc.model).rigid:
            out['T'], out['F'] = self.U[:, 0], self.U[:, 1]
        else:
            out['command'] = self.U[:, 1]
        if self.flow_hat is not None:
            out['flow_hat_x'], out['flow_hat_y'] = self.flow_hat.real, self.flow_hat.imag
        out.update(self.channels)
        return out

    def save(self, path: str | PathLike[str]) -> None:
        """Write :meth:`arrays` to ``path`` (a compressed ``.npz``)."""
        np.savez_compressed(path, **self.arrays())


def load_run(path: str | PathLike[str]) -> Run:
    """
    Read a run written by :meth:`Run.save` (the simulator or the plant node).

    Parameters
    ----------
    path : str or path-like
        The ``.npz`` file.

    Returns
    -------
    Run
        With its scenario validated again by :func:`scenario.resolve`.

    """
    with np.load(path) as d:
        sc = resolve(json.loads(str(d['params'])))
        X = np.stack([d[name] for name in STATE_NAMES], axis=1)
        U = np.zeros((X.shape[0], 2, X.shape[2]))
        if 'T' in d:
            U[:, 0], U[:, 1] = d['T'], d['F']
        else:
            U[:, 1] = d['command']
        meta = json.loads(str(d['meta'])) if 'meta' in d else {}
        flow_hat = d['flow_hat_x'] + 1j * d['flow_hat_y'] if 'flow_hat_x' in d else None
        channels = {name: d[name].copy() for name in CHANNELS + GUST_CHANNELS if name in d}
        return Run(sc, d['t'].copy(), X, U, meta, flow_hat, channels)


class Stepper:
    """
    The sampled-data loop, one control period at a time: ``command`` (or ``hold``), ``advance``.

    Parameters
    ----------
    sc : scenario.Scenario
        The scenario.
    X0 : array_like, shape (6, N), optional
        Initial state; :func:`scenario.initial_state` by default.
    seeds : sequence of int, optional
        The seed of each fleet of a batch X0 (6, B, N), for the world's draws
        (:class:`world.World`); ``sc.seed`` by default.

    Attributes
    ----------
    X : ndarray, shape (6, N)
        The fleet's current state.
    backend : backends.PlantBackend
        What integrates it (:func:`backends.backend_of`): the nominal model, the world (true
        vehicles, actuators, gusts) or JSBSim aircraft.
    vehicles : onboard.OnboardStep
        The vehicles' controllers, all at once.
    U : ndarray, shape (2, N)
        The inputs held over the current period.
    flow_hat : complex or ndarray of complex, shape (N,)
        The flow each vehicle commanded with at the last :meth:`command` (m/s).
    steps : int
        Integration steps taken: the state is at ``t = steps * dt_integration``.
    safety : safety.Tally
        What the safety layer did over the periods commanded (``safety: on``).

    """

    def __init__(self, sc: Scenario, X0: ArrayLike | None = None,
                 seeds: Sequence[int] | None = None) -> None:
        self.sc = sc
        X = initial_state(sc) if X0 is None else np.array(X0, float)
        if X.size >= 6 * LARGE_FLEET:
            keep_freed_memory()
        self.vehicles = OnboardStep(sc, X.shape[1:])
        self.backend = backend_of(sc)(sc, X, self.ctrl.plant, seeds)
        self.X = self.backend.X0
        self.U = self.vehicles.U
        self.steps = 0
        self.sensors = Sensors(sc, X.shape[1:], seeds) if sensors.active(sc) else None
        self.flow_hat: complex | ComplexArray = self.local_flow()
        self.safety = safety.Tally()

    @property
    def ctrl(self) -> Controller:
        """Return the vehicles' controller (that of ``vehicles``, the onboard step)."""
        return self.vehicles.ctrl

    @property
    def t(self) -> float:
        """Return the time of the current state (s)."""
        return self.steps * self.sc.dt_integration

    def local_flow(self) -> ComplexArray:
        """Return the flowfield (N,) complex at each vehicle's place now (m/s): what it is told."""
        return self.ctrl.plant.flow(self.t, self.X[ROW_X], self.X[ROW_Y])

    def true_flow(self) -> ComplexArray:
        """Return the flow (N,) complex each vehicle moves in now: the flowfield and its gust."""
        return self.backend.true_flow(self.local_flow())

    def sample(self) -> Sample:
        """Return what the vehicles measure now (:meth:`sensors.Sensors.sample`, with sensors)."""
        if self.sensors is None:
            raise RuntimeError('no sensors: the vehicles measure their state')
        told = self.local_flow() if self.sc.flow_source == 'known' else None
        return self.sensors.sample(self.steps // self.sc.substeps, self.X,
                                   ground_velocity(self.X, self.true_flow()), told)

    def observed(self) -> RealArray:
        """
        Return the states (6, N) as the vehicles measure them.

        With sensors, their sample (:meth:`sample`). A rigid body told the flow reads its
        velocity through the water from its ground velocity less the flow it is told, as a
        vehicle node does from its odometry (:func:`messages.state_from_odom_values`): a gust
        it is not told shifts u, v by the gust in its body frame. Otherwise the state itself.
        """
        if self.sensors is not None:
            return self.sample().X
        if not self.backend.gusts or not vehicle_model(self.sc.model).rigid \
                or self.sc.flow_source != 'known':
            return self.X
        X = self.X.copy()
        turn = np.exp(-1j * X[ROW_THETA])
        rel = ground_velocity(X, self.true_flow()) * turn - self.local_flow() * turn
        X[ROW_U], X[ROW_V] = rel.real, rel.imag
        return X

    def vehicles_flow(self) -> complex | ComplexArray:
        """
        Return the flow (N,) complex each vehicle uses now: known, or its updated estimate.

        An estimating vehicle measures its ground velocity in the local flow and its own
        velocity through it (:meth:`estimation.FlowEstimator.update`); with the position filter
        its estimator takes the filter's velocities (:func:`navigation.flow_input`). A known
        uniform flow is the complex number itself (the same for all, and cheapest).
        """
        field, est = self.ctrl.plant.flow, self.vehicles.estimator
        if est is None and field.uniform:
            return field.value
        if est is None:
            return self.local_flow()
        near = neighbour_mean(self.sc.comm_graph, est.fhat) if self.sc.flow_consensus else None
        if self.sensors is not None:
            seen = self.sample()
            return self.vehicles.estimate(seen.X, seen.v_ground, near)
        return self.vehicles.estimate(self.X, ground_velocity(self.X, self.true_flow()), near)

    def hold(self, U: ArrayLike, demand: ArrayLike | None = None) -> RealArray:
        """
        Hold the inputs ``U`` (2, N) over the next period; return them as held.

        The vehicles hold them too. The backend holds them from the state now
        (:meth:`backends.PlantBackend.hold`): the native first-order turn rate is the state
        omega, so it is written into ``X`` too; aircraft hold the autopilot ``demand`` (2, N),
        where NaN or not given that of ``U`` (:func:`aircraft.turn_demand`).
        """
        self.U = self.vehicles.U = np.array(U, float)
        self.backend.hold(self.X, self.U, None if demand is None else np.asarray(demand, float))
        return self.U

    @property
    def channels(self) -> dict[str, RealArray]:
        """Return what the backend records beside the state now ({} for the native plant)."""
        return self.backend.channels

    def command(self) -> RealArray:
        """
        Compute every vehicle's command, hold and return it (2, N).

        It is computed for the state :meth:`control.Controller.predict` gives from the current
        state, the inputs held so far and the flow each vehicle has (carried to the predicted
        state, :meth:`control.Controller.flow_ahead`), as each vehicle node computes its own.
        """
        self.flow_hat = flow = self.vehicles_flow()
        U = self.hold(self.vehicles.command(self.vehicles.observe(self.observed(), flow)))
        if self.ctrl.filtered is not None:
            self.safety.add(self.t, self.ctrl.filtered)
        return U

    def advance(self, steps: int | None = None) -> RealArray:
        """
        Integrate one control period with the held inputs; return the new state (6, N).

        ``steps`` integration steps of ``dt_integration`` instead of a whole period, if given
        (the real-time plant advances one step per tick), by the backend
        (:meth:`backends.PlantBackend.advance`). :func:`models.integrate` takes each vehicle on
        its own numbers, so a fleet of a batch (6, B, N) equals its run alone, bit for bit.
        """
        steps = steps or self.sc.substeps
        self.X = self.backend.advance(self.X, self.U, self.steps, steps)
        self.steps += steps
        return self.X


class Recorder:
    """
    Keep the state and held inputs every ``record_dt``, and at the last step.

    The simulator and the plant node record with it; step n is at ``n dt_control``, and a run
    has ``sc.periods`` steps after step 0. The arrays of the whole run are reserved at the first
    sample and filled in place: a long run's memory does not grow as it records (the plant of a
    30-minute fleet), and a record too large for memory fails at its start.

    Attributes
    ----------
    size : int
        Number of samples of the whole run.
    count : int
        Samples recorded so far.

    """

    def __init__(self, sc: Scenario) -> None:
        self.sc = sc
        self.steps = sc.periods
        self.size = self.index(self.steps) + 1
        self.count = 0
        self._t = np.minimum(np.arange(self.size) * sc.record_every, self.steps) * sc.dt_control
        self._arrays: dict[str, Any] = {}
        self._channels: dict[str, RealArray] = {}

    def keeps(self, n: int) -> bool:
        """Return whether step n is a recorded step."""
        return 0 <= n <= self.steps and (n % self.sc.record_every == 0 or n == self.steps)

    def index(self, n: int) -> int:
        """Return the sample index of recorded step n."""
        return -(-n // self.sc.record_every)

    def record(self, n: int, X: RealArray, U: RealArray,
               flow_hat: complex | ComplexArray | None = None,
               channels: dict[str, RealArray] | None = None) -> None:
        """Record the state X (6, N), inputs U (2, N), flows used and channels of step n."""
        if not self.keeps(n):
            return
        i = self.index(n)
        self._put(self._arrays, 'X', i, X)
        self._put(self._arrays, 'U', i, U)
        if flow_hat is not None:
            self._put(self._arrays, 'flow_hat', i, np.broadcast_to(flow_hat, X.shape[1:]))
        for name, value in (channels or {}).items():
            self._put(self._channels, name, i, np.asarray(value, float))
        self.count = i + 1

    def _put(self, arrays: dict[str, Any], name: str, i: int, value: Any) -> None:
        if name not in arrays:
            blank = complex(np.nan, np.nan) if np.iscomplexobj(value) else np.nan
            arrays[name] = np.full((self.size, *np.shape(value)), blank,
                                   np.result_type(value, float))
        arrays[name][i] = value

    @property
    def t(self) -> RealArray:
        """(count,) sample times so far (s)."""
        return self._t[:self.count]

    def run(self) -> Run:
        """Return what was recorded as a :class:`Run` (views of the reserved arrays)."""
        n, got = self.count, self._arrays
        flow_hat = got['flow_hat'][:n] if 'flow_hat' in got else None
        return Run(self.sc, self.t, got['X'][:n] if 'X' in got else np.empty((0,)),
                   got['U'][:n] if 'U' in got else np.empty((0,)), flow_hat=flow_hat,
                   channels={name: v[:n] for name, v in self._channels.items()})


class Outcome:
    """
    Record only what a study keeps of each run of a batch: convergence and the final state.

    Every ``record_dt`` and at the last step (the samples of :class:`Recorder`) it evaluates
    :func:`metrics.converged` on :func:`metrics.snapshot` of each fleet, which are computed
    per fleet (the minimum separation at the last step only), and follows each fleet's
    separation (:class:`separation.Tracker`, ``apart``); the states are not kept.

    Attributes
    ----------
    t : ndarray, shape (T,)
        Sample times (s).
    flags : ndarray of bool, shape (T, B)
        The convergence test of each fleet at each sample.
    X, U : ndarray, shapes (6, B, N), (2, B, N)
        The state and held inputs at the last step.
    diverged : ndarray of bool, shape (B,) (or () while none has)
        The fleets whose state diverged in the world (:meth:`stop`), held since.
    final : metrics.Snapshot
        The metrics at the last step, arrays of shape (B,).
    apart : separation.Tracker
        Each fleet's separation over the run, between samples too.
    safety : safety.Tally
        What each fleet's safety layer did (``safety: on``).

    """

    def __init__(self, sc: Scenario) -> None:
        self.sc = sc
        self.steps = sc.periods
        self.ctrl = Controller(sc)
        self.times: list[float] = []
        self.samples: list[BoolArray] = []
        self.met: list[dict[str, Any]] = []
        self.errors: list[dict[str, Any]] = []
        self.diverged: BoolArray = np.zeros((), bool)
        self.flown: list[tuple[RealArray, RealArray]] = []
        lim = limits(sc)
        self.apart = separation.Tracker(lim.d_min, lim.d_min_vertical)
        self.safety = safety.Tally()

    def record(self, n: int, X: RealArray, U: RealArray,
               flow_hat: complex | ComplexArray | None = None,
               channels: dict[str, RealArray] | None = None) -> None:
        """Evaluate the convergence test of step n (X (6, B, N), U (2, B, N)) if recorded."""
        if n % self.sc.record_every == 0 or n == self.steps:
            t = n * self.sc.dt_control
            every = n == self.steps or metrics.needs_separation(self.sc)
            self.final = metrics.snapshot(self.ctrl, X, U, t, separation=every,
                                          gust=recorded_gust(channels or {}))
            self.times.append(t)
            self.samples.append(np.asarray(metrics.converged(self.sc, self.final)))
            self.met.append(metrics.conditions(self.sc, self.final))
            self.errors.append(metrics.steady_errors(self.sc, self.final))
            self.X, self.U = X.copy(), U.copy()
            P = separation.positions(X, (channels or {}).get('altitude'))
            self.apart.add(t, P.reshape(-1, *P.shape[-2:]))
            if channels and 'altitude' in channels:
                self.flown.append((self.X, channels['altitude'].copy()))

    def run(self) -> Outcome:
        """Return itself, with ``t`` and ``flags`` as arrays."""
        self.t, self.flags = np.array(self.times), np.array(self.samples)
        return self

    def stop(self, fleets: BoolArray, before: RealArray, stepper: Stepper) -> None:
        """
        Freeze the ``fleets`` (B,) of a batch in the world whose state diverged.

        A vehicle unlike its model may run away (docs/errata.md, "Model mismatch"): in a
        study that is an outcome, not an error. Such a fleet is held at its state ``before``
        the period, never counts as converged, and is counted in :attr:`diverged`.
        """
        if not fleets.any():
            return
        self.diverged = self.diverged | fleets
        stepper.X[:, fleets] = before[:, fleets]

    def converged(self) -> BoolArray:
        """
        Return each fleet's :func:`metrics.verdict` (B,); never one that diverged.

        Nor one whose vehicles left what they hold (aircraft: airspeed and altitude,
        :meth:`backends.PlantBackend.held`).
        """
        ok = np.asarray(metrics.verdict(self.sc, self.t, self.flags)) & ~self.diverged
        if self.flown:
            X, altitude = (np.array(rows) for rows in zip(*self.flown))
            ok = ok & backend_of(self.sc).held(self.sc, self.t, X, {'altitude': altitude})['holds']
        return ok

    def met_conditions(self) -> dict[str, BoolArray]:
        """Return whether each fleet meets each condition: at the end, or over the window."""
        keep = metrics.window(self.sc, self.t) if practical(self.sc) else self.t == self.t[-1]
        return {name: np.all([np.broadcast_to(m[name], self.flags.shape[1:])
                              for m, k in zip(self.met, keep) if k], axis=0)
                for name in self.met[-1]}

    def steady_state(self) -> dict[str, tuple[Any, Any]]:
        """Return :func:`metrics.steady_state` of each fleet: (median, p95) arrays (B,)."""
        return metrics.steady_state(self.sc, self.t, {name: [e[name] for e in self.errors]
                                                      for name in self.errors[-1]})

    def held(self) -> RealArray:
        """Return how long each fleet's test held to the end, :func:`metrics.held` (s), (B,)."""
        return np.where(self.diverged, 0.0, metrics.held(self.t, self.flags))

    def convergence_times(self) -> RealArray:
        """Return each fleet's :func:`metrics.convergence_times` (s; NaN: not converged), (B,)."""
        return np.where(self.converged(), metrics.convergence_times(self.t, self.flags), np.nan)


def initial_states(sc: Scenario, seeds: Sequence[int]) -> RealArray:
    """
    Return the initial states of a batch of fleets, one per seed.

    Parameters
    ----------
    sc : scenario.Scenario
        The scenario.
    seeds : sequence of int
        The seed of each fleet.

    Returns
    -------
    ndarray, shape (6, B, N)
        Fleet b is :func:`scenario.initial_state` of ``sc`` with seed ``seeds[b]``: a run's
        start does not depend on the batch it is in.

    """
    return np.stack([initial_state(replace(sc, seed=int(s))) for s in seeds], axis=1)


@overload
def simulate(sc: Scenario, X0: ArrayLike | None = None,
             recorder: Recorder | None = None, seeds: Sequence[int] | None = None) -> Run: ...


@overload
def simulate(sc: Scenario, X0: ArrayLike | None, recorder: Outcome,
             seeds: Sequence[int] | None = None) -> Outcome: ...


def simulate(sc: Scenario, X0: ArrayLike | None = None,
             recorder: Recorder | Outcome | None = None,
             seeds: Sequence[int] | None = None) -> Run | Outcome:
    """
    Run a scenario in the offline simulator.

    Parameters
    ----------
    sc : scenario.Scenario
        The scenario: ``duration`` seconds of control periods ``dt_control``, each integrated
        by RK4 with ``dt_integration`` steps and the commands held.
    X0 : array_like, shape (6, N), optional
        Initial state; :func:`scenario.initial_state` by default. (6, B, N): a batch of B
        independent fleets (:func:`initial_states`), each under its own means and sums
        (:mod:`laws`), integrated together.
    recorder : Recorder or Outcome, optional
        What to keep; a :class:`Recorder` of ``sc`` by default.
    seeds : sequence of int, optional
        The seed of each fleet of a batch, for the world's draws (:class:`Stepper`).

    Returns
    -------
    Run or Outcome
        Samples every ``record_dt`` and at the end (a Run's X is (T, 6, B, N) for a batch).

    Raises
    ------
    stability.DivergenceError
        Once a vehicle's state diverges (:func:`stability.diverging`), naming the time, the
        vehicle and the likely cause.

    """
    stepper = Stepper(sc, X0, seeds)
    rec = Recorder(sc) if recorder is None else recorder
    held = isinstance(rec, Outcome) and stepper.X.ndim > 2 and stepper.backend.mismatched
    for n in range(rec.steps + 1):
        with np.errstate(over='ignore' if held else 'warn', invalid='ignore' if held else 'warn'):
            U = stepper.command()                  # held: a stopped fleet may run away again
        rec.record(n, stepper.X, U, stepper.flow_hat, stepper.channels)
        if n < rec.steps:
            before = stepper.X
            with np.errstate(over='ignore', invalid='ignore'):
                stepper.advance()
            bad = stability.diverging(stepper.X)
            if held and isinstance(rec, Outcome):
                rec.stop(np.any(bad, axis=-1), before, stepper)
            elif bad.any():
                flat = stepper.X.reshape(6, -1)
                raise stability.divergence(sc, (n + 1) * sc.dt_control,
                                           int(np.flatnonzero(bad)[0]), flat)
    out = rec.run()
    if sc.safety == 'on':
        if isinstance(out, Run):
            out.meta['safety'] = stepper.safety.values()
        else:
            out.safety = stepper.safety
    return out


def flow_estimate_errors(sc: Scenario, after: float) -> ComplexArray:
    """
    Return the errors of the vehicles' flow estimates, shape (T, N) complex (m/s), of a run.

    Each control period from ``after`` (s) on: the estimate each vehicle commands with minus
    the flow it moves in (:meth:`Stepper.true_flow`, the gust included).
    """
    stepper, errors = Stepper(sc), []
    for n in range(sc.periods):
        stepper.command()
        if n * sc.dt_control >= after:
            errors.append(np.asarray(stepper.flow_hat) - stepper.true_flow())
        stepper.advance()
    return np.array(errors)


def rms_flow_error(sc: Scenario, after: float) -> float:
    """Return the rms flow-estimate error per map axis (m/s) from ``after`` (s) on."""
    return float(np.sqrt(0.5 * np.mean(abs(flow_estimate_errors(sc, after)) ** 2)))


def aircraft_circle_errors(run: Run, last: float) -> tuple[float, float, float]:
    """
    Return an aircraft circle's worst errors over the last ``last`` seconds of ``run``.

    The centre spread (m), the radius error as a share of the radius ``1 / |omega0|`` and the
    altitude error (m) against ``altitude`` (docs/aircraft.md, "Steady states").
    """
    ctrl = Controller(run.sc)
    keep = run.t >= run.t[-1] - last
    snaps = [metrics.snapshot(ctrl, run.X[i], run.U[i], run.t[i], gust=run.gust[i])
             for i in np.flatnonzero(keep)]
    radius = 1.0 / abs(run.sc.omega0)
    return (max(float(s.spread) for s in snaps),
            max(abs(float(s.radius) - radius) for s in snaps) / radius,
            float(np.max(abs(run.channels['altitude'][keep] - run.sc.altitude))))


def summary(run: Run) -> dict[str, Any]:
    """
    Return the convergence figures of a run.

    Parameters
    ----------
    run : Run
        A recorded run.

    Returns
    -------
    dict
        ``num_vehicles``, ``duration`` (s), ``converged`` (:func:`metrics.verdict`: every
        :func:`metrics.converged` held at every sample over at least the last
        :func:`metrics.hold_window`, evaluated sample by sample: a fleet's views stay in cache),
        ``unmet`` (the names of the :func:`metrics.conditions` it fails at the end),
        ``convergence_time`` (s, from which they held; None unless converged), ``held`` (s,
        how long they held to the end; None if the last sample fails), ``hold_window`` (s), the
        final ``order_parameter``, ``lyapunov`` and ``max_turn_rate``. With the band test
        (:func:`scenario.practical`): the test is every band, ``unmet`` the bands left in the
        last ``settle_window``, ``steady_state`` the median, 95th percentile
        and band of each :func:`metrics.steady_errors` over it, and ``settle_window`` (s).
        Circular: ``centre_spread``, ``radius``, ``radius_target``; rigid bodies: ``mean_u``,
        ``mean_v`` (m/s). Aircraft: :func:`aircraft.held`; a run that left its airspeed or
        altitude band is not converged, and ``unmet`` names it. ``separation``: how close the
        vehicles came and whether they kept apart (:func:`separation.of_run`, its values).
        ``safety`` (``safety: on``): the layer's :meth:`safety.Tally.values` (its active share
        of the vehicle-periods), where the run recorded them (``meta``).

    """
    sc = run.sc
    ctrl = Controller(sc)
    flags: list[Any] = []
    met: list[dict[str, Any]] = []
    errors: list[dict[str, Any]] = []
    every, last = metrics.needs_separation(sc), len(run.t) - 1
    for i, (t, X, U) in enumerate(zip(run.t, run.X, run.U)):
        final = metrics.snapshot(ctrl, X, U, t, every or i == last, run.gust[i])
        flags.append(metrics.converged(sc, final))
        met.append(metrics.conditions(sc, final))
        errors.append(metrics.steady_errors(sc, final))
    verdict = metrics.settling(sc, run.t, flags)
    out = {'num_vehicles': sc.num_vehicles, 'duration': float(run.t[-1]),
           'converged': verdict.converged,
           'unmet': metrics.unmet(sc, final),
           'convergence_time': verdict.since if verdict.converged else None,
           'held': verdict.held, 'hold_window': verdict.hold,
           'order_parameter': final.order, 'lyapunov': final.lyapunov,
           'max_turn_rate': final.max_rate,
           'separation': separation.of_run(run).values()}
    if sc.safety == 'on':
        out['safety'] = run.meta.get('safety', {})
    if practical(sc):
        keep = metrics.window(sc, run.t)
        out['unmet'] = [name for name in met[-1] if not all(
            bool(m[name]) for m, k in zip(met, keep) if k)]
        ss = metrics.steady_state(sc, run.t, {name: [e[name] for e in errors]
                                              for name in errors[-1]})
        out['steady_state'] = {name: {'median': float(m), 'p95': float(q),
                                      'band': getattr(sc, metrics.BANDS[name])}
                               for name, (m, q) in ss.items()}
        out['settle_window'] = float(min(sc.settle_window, run.t[-1] - run.t[0]))
    flight = backend_of(sc).held(sc, run.t, run.X, run.channels)
    if flight.get('flight_unmet'):
        flight.update(converged=False, convergence_time=None,
                      unmet=cast('list[str]', out['unmet']) + flight['flight_unmet'])
    out.update(flight)
    radius = formations.of(sc).radius(sc)
    if radius is not None:
        out.update(centre_spread=final.spread, radius=final.radius, radius_target=radius)
    if vehicle_model(sc.model).rigid:
        X = run.X[-1]
        out.update(mean_u=float(X[ROW_U].mean()), mean_v=float(X[ROW_V].mean()))
    return out
