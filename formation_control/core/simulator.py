"""
Offline simulator: the sampled-data loop the ROS plant runs too.

Each control period every vehicle's command is computed from the state at the start of the
period and held while RK4 integrates the plant over ``dt_control / dt_integration`` steps.
"""
from dataclasses import dataclass, field
import json

import numpy as np

from formation_control.core import metrics
from formation_control.core.control import Controller
from formation_control.core.models import (integrate, RIGID_MODELS, ROW_OMEGA, ROW_U, ROW_V,
                                           STATE_NAMES)
from formation_control.core.scenario import initial_state, resolve


@dataclass
class Run:
    """A recorded run: times (T,), states (T, 6, N), commands (T, 2, N) and the scenario."""

    sc: object
    t: np.ndarray
    X: np.ndarray
    U: np.ndarray
    meta: dict = field(default_factory=dict)

    def arrays(self):
        """
        The ``.npz`` layout: t (T,); x, y, theta, omega, u, v (T, N); the held commands, T and F
        (N) for rigid bodies, ``command`` for particles (rad/s^2, or rad/s for first order).
        """
        out = {'t': self.t, 'params': np.array(self.sc.to_json()),
               'meta': np.array(json.dumps(self.meta))}
        out.update({name: self.X[:, row] for row, name in enumerate(STATE_NAMES)})
        if self.sc.model in RIGID_MODELS:
            out['T'], out['F'] = self.U[:, 0], self.U[:, 1]
        else:
            out['command'] = self.U[:, 1]
        return out

    def save(self, path):
        np.savez_compressed(path, **self.arrays())


def load_run(path):
    """Read a run written by :meth:`Run.save` (the simulator or the plant node)."""
    with np.load(path) as d:
        sc = resolve(json.loads(str(d['params'])))
        X = np.stack([d[name] for name in STATE_NAMES], axis=1)
        U = np.zeros((X.shape[0], 2, X.shape[2]))
        if 'T' in d:
            U[:, 0], U[:, 1] = d['T'], d['F']
        else:
            U[:, 1] = d['command']
        meta = json.loads(str(d['meta'])) if 'meta' in d else {}
        return Run(sc, d['t'].copy(), X, U, meta)


class Stepper:
    """One sampled-data period at a time: ``command`` (or ``hold``) then ``advance``."""

    def __init__(self, sc, X0=None):
        self.sc = sc
        self.ctrl = Controller(sc)
        self.X = initial_state(sc) if X0 is None else np.array(X0, float)
        self.U = np.zeros((2, self.X.shape[1]))

    def hold(self, U):
        """Hold ``U`` over the next period (the first-order turn rate is the state omega)."""
        self.U = np.array(U, float)
        if self.sc.model == 'first_order':
            self.X[ROW_OMEGA] = self.U[1]
        return self.U

    def command(self):
        """Compute and hold every vehicle's command from the current state."""
        return self.hold(self.ctrl.command(self.ctrl.view(self.X, self.U[1]), self.X))

    def advance(self, steps=None):
        """Integrate one control period (or ``steps`` integration steps) with the held command."""
        sc = self.sc
        self.X = integrate(self.X, self.U, sc.dt_integration, steps or sc.substeps,
                           self.ctrl.plant)
        return self.X


class Recorder:
    """Keeps the state and held command every ``record_dt`` (the simulator and the plant)."""

    def __init__(self, sc):
        self.sc = sc
        self.steps = sc.periods
        self.t, self.X, self.U = [], [], []

    def record(self, n, X, U):
        if n % self.sc.record_every == 0 or n == self.steps:
            self.t.append(n * self.sc.dt_control)
            self.X.append(X.copy())
            self.U.append(U.copy())

    def run(self):
        return Run(self.sc, np.array(self.t), np.array(self.X), np.array(self.U))


def simulate(sc, X0=None):
    """Run the scenario for ``sc.duration`` seconds and record every ``record_dt``."""
    stepper = Stepper(sc, X0)
    rec = Recorder(sc)
    for n in range(rec.steps + 1):
        rec.record(n, stepper.X, stepper.command())
        if n < rec.steps:
            stepper.advance()
    return rec.run()


def summary(run):
    """Convergence figures of a run: final metrics, convergence flag and time."""
    sc = run.sc
    ctrl = Controller(sc)
    snaps = [metrics.snapshot(ctrl, X, U) for X, U in zip(run.X, run.U)]
    flags = [metrics.converged(sc, s) for s in snaps]
    final = snaps[-1]
    out = {'num_vehicles': sc.num_vehicles, 'duration': float(run.t[-1]),
           'converged': bool(flags[-1]), 'convergence_time': metrics.convergence_time(run.t, flags),
           'order_parameter': final.order, 'lyapunov': final.lyapunov,
           'max_turn_rate': final.max_rate}
    if sc.formation == 'circular':
        out.update(centre_spread=final.spread, radius=final.radius,
                   radius_target=1.0 / abs(sc.omega0))
    if sc.model in RIGID_MODELS:
        X = run.X[-1]
        out.update(mean_u=float(X[ROW_U].mean()), mean_v=float(X[ROW_V].mean()))
    return out
