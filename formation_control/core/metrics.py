"""
Formation metrics of the thesis' analysis: order parameter |p|, circle centres, potentials,
composite Lyapunov values, centre spread, radius, crab angles and the convergence test.
"""
from dataclasses import dataclass

import numpy as np

from formation_control.core import laws
from formation_control.core.models import THETA, U, V

ORDER_TOL = 0.999        # parallel: |p| above this
RATE_TOL = 1e-2          # parallel: |turning rate| below this (rad/s)
SPREAD_TOL = 1e-2        # circular: max |c_k - mean(c)| below this (m)
RADIUS_TOL = 1e-2        # circular: relative error of the mean radius


@dataclass(frozen=True)
class Snapshot:
    """Formation quantities at one instant."""

    order: float           # |p| of the steered phase (1.10)
    potential: float       # V of the formation (1.11), (1.14), (7.18)
    lyapunov: float        # V_c = V + sum z^2 / 2 (2.10)
    spread: float          # max_k |c_k - mean(c)| (m)
    radius: float          # mean_k |r_k - mean(c)| (m)
    max_rate: float        # max_k |phase rate| (rad/s)


def snapshot(ctrl, view):
    """Metrics of one view under the controller's formation law."""
    f = ctrl.formation
    order = float(abs(view.e.mean()))
    spread = radius = float('nan')
    if isinstance(f, laws.Circular):
        c = f.centres(view)
        spread = float(np.max(abs(c - c.mean())))
        radius = float(np.mean(abs(view.r - c.mean())))
    return Snapshot(order, float(f.potential(view)), float(laws.composite_lyapunov(f, view)),
                    spread, radius, float(np.max(abs(view.rate))))


def converged(sc, snap):
    """The scenario's convergence test: parallel or circular formation reached."""
    if sc.formation == 'parallel':
        return snap.order > ORDER_TOL and snap.max_rate < RATE_TOL
    radius_error = abs(snap.radius * abs(sc.omega0) - 1.0)
    return snap.spread < SPREAD_TOL and radius_error < RADIUS_TOL


def convergence_time(t, flags):
    """First time from which ``flags`` holds to the end, or None."""
    flags = np.asarray(flags, bool)
    if flags.size == 0 or not flags[-1]:
        return None
    bad = np.flatnonzero(~flags)
    return float(t[0] if bad.size == 0 else t[bad[-1] + 1])


def crab_angles(X, flow):
    """(beta, beta_hat): flow-relative crab angle atan2(v, u) and inertial one gamma - theta (8.1)."""
    heading = np.exp(1j * X[THETA])
    rel = X[U] + 1j * X[V]
    beta = np.angle(rel)
    beta_hat = np.angle((rel * heading + flow) / heading)
    return beta, beta_hat


def steady_turn(sc):
    """
    Steady turn of a rigid body on radius 1/|omega0| (7.9)-(7.10), corrected (errata).

    Returns (v0, s0, beta0, yaw_rate): ``v0 = -m0 u0 omega0 / h_eff`` (skids outward),
    ``s0 = u0 sqrt(1 + (m0 omega0 / h_eff)^2)``, ``beta0 = atan2(v0, u0)``, yaw rate
    ``omega0 s0``. ``h_eff = h``, except for the centre-of-pressure model with its drag moment
    cancelled (A.20): there the steady force ``F = -(l1/l) h s v`` adds to the drag,
    ``h_eff = h (1 + l1/l)``.
    """
    h_eff = sc.h
    if sc.model == 'rigid_cop' and sc.cancel_drag_moment:
        h_eff = sc.h * (1.0 + sc.l1 / sc.l)
    v0 = -sc.m0 * sc.u0 * sc.omega0 / h_eff
    s0 = float(np.hypot(sc.u0, v0))
    return v0, s0, float(np.arctan2(v0, sc.u0)), sc.omega0 * s0


def parallel_flow_crab(sc, theta):
    """Steady inertial crab angle and speed in flow (8.17): atan2(<f, y>, u0 + <f, x>), |u0 e + f|."""
    heading = np.exp(1j * np.asarray(theta))
    f_body = sc.flow_c / heading
    return np.arctan2(f_body.imag, sc.u0 + f_body.real), abs(sc.u0 * heading + sc.flow_c)

