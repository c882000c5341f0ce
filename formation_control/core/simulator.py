"""
Offline simulator: the sampled-data loop the ROS plant runs too.

Each control period every vehicle's command is computed from the state at the start of the
period and held while RK4 integrates the plant over ``dt_control / dt_integration`` steps.
"""
from dataclasses import dataclass

import numpy as np

from formation_control.core import metrics
from formation_control.core.control import Controller
from formation_control.core.models import integrate, OMEGA, RIGID_MODELS, STATE_NAMES
from formation_control.core.scenario import initial_state


@dataclass
class Run:
    """A recorded run: times (T,), states (T, 6, N), commands (T, 2, N) and the scenario."""

    sc: object
    t: np.ndarray
    X: np.ndarray
    U: np.ndarray

    def arrays(self):
        """The ``.npz`` layout: t, x, y, theta, omega, u, v (T, N), T and F for rigid bodies."""
        out = {'t': self.t, 'params': np.array(self.sc.to_json())}
        out.update({name: self.X[:, row] for row, name in enumerate(STATE_NAMES)})
        if self.sc.model in RIGID_MODELS:
            out['T'], out['F'] = self.U[:, 0], self.U[:, 1]
        return out

    def save(self, path):
        np.savez_compressed(path, **self.arrays())


class Stepper:
    """One sampled-data period at a time: ``command`` then ``advance`` (shared with the plant)."""

    def __init__(self, sc, X0=None):
        self.sc = sc
        self.ctrl = Controller(sc)
        self.X = initial_state(sc) if X0 is None else np.array(X0, float)
        self.U = np.zeros((2, self.X.shape[1]))

    def command(self):
        """Compute and hold every vehicle's command from the current state."""
        view = self.ctrl.view(self.X, self.U[1])
        self.U = self.ctrl.command(view, self.X)
        if self.sc.model == 'first_order':
            self.X[OMEGA] = self.U[1]
        return self.U

    def advance(self, U=None):
        """Integrate one control period with ``U`` (default: the held command) held."""
        sc = self.sc
        held = self.U if U is None else U
        self.X = integrate(self.X, held, sc.dt_integration, sc.substeps, self.ctrl.plant)
        return self.X


def simulate(sc, X0=None):
    """Run the scenario for ``sc.duration`` seconds and record every ``record_dt``."""
    stepper = Stepper(sc, X0)
    steps = int(round(sc.duration / sc.dt_control))
    every = max(1, int(round(sc.record_dt / sc.dt_control)))
    t, Xs, Us = [], [], []
    for n in range(steps + 1):
        U = stepper.command()
        if n % every == 0 or n == steps:
            t.append(n * sc.dt_control)
            Xs.append(stepper.X.copy())
            Us.append(U.copy())
        if n < steps:
            stepper.advance()
    return Run(sc, np.array(t), np.array(Xs), np.array(Us))


def summary(run):
    """Convergence figures of a run: final metrics, convergence flag and time."""
    sc = run.sc
    ctrl = Controller(sc)
    snaps = [metrics.snapshot(ctrl, ctrl.view(X, U[1])) for X, U in zip(run.X, run.U)]
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
        out.update(mean_u=float(X[4].mean()), mean_v=float(X[5].mean()))
    return out
