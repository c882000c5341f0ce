"""
Thesis-style figures of a run: trajectories with heading (and ground-velocity) arrows, turning
rate over time, and for rigid bodies speeds and crab angles.
"""
import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from formation_control.core.metrics import crab_angles  # noqa: E402
from formation_control.core.models import RIGID_MODELS  # noqa: E402


def _arrows(ax, X, flow, length):
    ax.quiver(X[0], X[1], np.cos(X[2]), np.sin(X[2]), color='k', angles='xy',
              scale_units='xy', scale=1.0 / length, width=0.005, label='heading')
    if flow != 0:
        vel = (X[4] + 1j * X[5]) * np.exp(1j * X[2]) + flow
        ax.quiver(X[0], X[1], vel.real, vel.imag, color='r', angles='xy', scale_units='xy',
                  scale=1.0 / length, width=0.005, label='ground velocity')


def plot_run(run, path):
    """Write the figure of ``run`` (a :class:`simulator.Run`) to ``path`` (PNG)."""
    sc = run.sc
    rigid = sc.model in RIGID_MODELS
    fig, axes = plt.subplots(1, 3 if rigid else 2, figsize=(16 if rigid else 11, 5))
    ax = axes[0]
    ax.plot(run.X[:, 0], run.X[:, 1], lw=0.8)
    ax.plot(run.X[0, 0], run.X[0, 1], 'o', color='0.5', ms=3, label='start')
    span = np.ptp(run.X[:, 0]) + np.ptp(run.X[:, 1])
    _arrows(ax, run.X[-1], sc.flow_c, 0.04 * span)
    ax.legend(loc='upper right', fontsize='small')
    ax.set(xlabel='x (m)', ylabel='y (m)', aspect='equal',
           title=f'{sc.model} {sc.formation}, {sc.controller}, N={sc.num_vehicles}')
    axes[1].plot(run.t, run.X[:, 3], lw=0.8)
    axes[1].set(xlabel='t (s)', ylabel='turning rate omega (rad/s)', title='turning rate')
    if rigid:
        speed = np.hypot(run.X[:, 4], run.X[:, 5])
        axes[1].plot(run.t, speed, lw=0.6, ls=':', color='0.4')
        axes[1].set(ylabel='omega (rad/s); speed s (m/s, dotted)')
        beta, beta_hat = crab_angles(run.X.transpose(1, 0, 2), sc.flow_c)
        axes[2].plot(run.t, np.degrees(beta), lw=0.8, color='tab:blue')
        axes[2].plot(run.t, np.degrees(beta_hat), lw=0.8, color='tab:red', ls='--')
        axes[2].set(xlabel='t (s)', ylabel='deg',
                    title='crab angles beta (solid), beta_hat (dashed)')
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
