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
Thesis-style figures of a run.

Trajectories with heading (and ground-velocity) arrows; turning rate and speeds; crab angles;
the composite Lyapunov value on a log scale. They draw :func:`report.series`, so a run from the
simulator, the plant's ``.npz`` or a bag looks the same.
"""
from __future__ import annotations

from collections.abc import Sequence
from os import PathLike

from formation_control.core.flow import vehicle_speed
from formation_control.core.geometry import ComplexArray
from formation_control.core.parameters import Scenario
from formation_control.core.vehicles import vehicle_model
from formation_control.sim.report import Series, series
from formation_control.sim.simulator import Run
import matplotlib

matplotlib.use('Agg')
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def _arrows(ax: Axes, d: Series, flow: complex | ComplexArray, length: float,
            speed: float = 1.0) -> None:
    x, y, theta = d['x'][-1], d['y'][-1], d['theta'][-1]
    ax.quiver(x, y, np.cos(theta), np.sin(theta), color='k', angles='xy',
              scale_units='xy', scale=1.0 / length, width=0.005, label='heading')
    if flow != 0:
        ground = d['ground'][-1] / speed
        ax.quiver(x, y, ground.real, ground.imag, color='r', angles='xy', scale_units='xy',
                  scale=1.0 / length, width=0.005, label='ground velocity')


def _links(ax: Axes, d: Series, sc: Scenario) -> ComplexArray:
    """Draw the communication graph between the final positions; return its segments."""
    if sc.all_to_all:
        return np.zeros((0, 2), complex)
    r = d['x'][-1] + 1j * d['y'][-1]
    segments = r[sc.comm_graph.edges]
    ax.add_collection(LineCollection([[(z.real, z.imag) for z in s] for s in segments],
                                     colors='tab:purple', linewidths=1.2, alpha=0.8, zorder=3,
                                     label=f'{sc.graph} graph ({len(segments)} links)'))
    return segments


def _phases(ax: Axes, d: Series, sc: Scenario) -> ComplexArray:
    """Mark the final places on the common circle of a pattern; return them (N,) complex."""
    centre, radius = d['centre'][-1], 1.0 / abs(sc.omega0)
    ring = centre + radius * np.exp(1j * np.linspace(0.0, 2.0 * np.pi, 181))
    ax.plot(ring.real, ring.imag, ls='--', lw=0.8, color='0.3', label='common circle')
    r = d['x'][-1] + 1j * d['y'][-1]
    ax.plot(r.real, r.imag, 'o', ms=7, mfc='none', mec='tab:red', mew=1.5,
            label=f'final places ({sc.pattern})')
    for k, z in enumerate(r, start=1):
        out = centre + (z - centre) * 1.18
        ax.annotate(str(k), (out.real, out.imag), fontsize='x-small', ha='center',
                    va='center', color='tab:red')
    return r


def _trajectories(ax: Axes, d: Series, sc: Scenario) -> None:
    ax.plot(d['x'], d['y'], lw=0.8)
    ax.plot(d['x'][0], d['y'][0], 'o', color='0.5', ms=3, label='start')
    d['links'] = _links(ax, d, sc)
    if 'phase_orders' in d:
        d['places'] = _phases(ax, d, sc)
    span = np.ptp(d['x']) + np.ptp(d['y'])
    _arrows(ax, d, sc.flow_c, 0.04 * span, vehicle_speed(sc))
    ax.legend(loc='upper right', fontsize='small')
    ax.set(xlabel='x (m)', ylabel='y (m)', aspect='equal',
           title=f'{sc.model} {sc.formation}, {sc.controller}, N={sc.num_vehicles}')


def _rates(ax: Axes, d: Series, rigid: bool) -> None:
    ax.plot(d['t'], d['omega'], lw=0.8)
    ax.set(xlabel='t (s)', ylabel='turning rate omega (rad/s)', title='turning rate')
    if rigid:
        ax.plot(d['t'], d['speed'], lw=0.6, ls=':', color='0.4')
        ax.set(ylabel='omega (rad/s); ground speed (m/s, dotted)',
               title='turning rate and speed')


def _crab(ax: Axes, d: Series) -> None:
    ax.plot(d['t'], np.degrees(d['beta']), lw=0.8, color='tab:blue')
    ax.plot(d['t'], np.degrees(d['beta_hat']), lw=0.8, color='tab:red', ls='--')
    ax.set(xlabel='t (s)', ylabel='deg', title='crab angles beta (solid), beta_hat (dashed)')


def _lyapunov(ax: Axes, d: Series) -> None:
    ax.semilogy(d['t'], np.maximum(d['lyapunov'], 1e-300), lw=0.9, color='k')
    ax.set(xlabel='t (s)', ylabel='V_c', title='composite Lyapunov value (2.10)')


def _wind(ax: Axes, sc: Scenario) -> None:
    """Draw the background wind as an arrow in the upper left corner of the ground tracks."""
    if sc.flow_c == 0:
        return
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    size = 0.12 * max(x1 - x0, y1 - y0)
    unit = sc.flow_c / abs(sc.flow_c)
    ax.annotate('', xy=(x0 + 0.1 * (x1 - x0) + size * unit.real,
                        y1 - 0.1 * (y1 - y0) + size * unit.imag),
                xytext=(x0 + 0.1 * (x1 - x0), y1 - 0.1 * (y1 - y0)),
                arrowprops={'arrowstyle': '-|>', 'color': 'tab:blue', 'lw': 2})
    ax.text(x0 + 0.1 * (x1 - x0), y1 - 0.04 * (y1 - y0), f'wind {abs(sc.flow_c):.3g} m/s',
            color='tab:blue', fontsize='small')


def _flight(axes: Sequence[Axes], run: Run) -> None:
    """Draw each aircraft's altitude and bank over time (plant_backend: jsbsim)."""
    altitude, bank = run.channels['altitude'], run.channels['bank']
    axes[0].plot(run.t, altitude, lw=0.8)
    axes[0].set(xlabel='t (s)', ylabel='altitude above the ground (m)', title='altitude')
    axes[1].plot(run.t, np.degrees(bank), lw=0.8)
    limit = np.degrees(run.sc.bank_limit)
    for side in (-limit, limit):
        axes[1].axhline(side, ls='--', lw=0.8, color='0.4')
    axes[1].set(xlabel='t (s)', ylabel='bank (deg, right wing down +)',
                title=f'bank (limit +-{limit:.3g} deg dashed)')


def plot_run(run: Run, path: str | PathLike[str]) -> Series:
    """
    Write the figure of a run to a PNG file.

    Parameters
    ----------
    run : simulator.Run
        The run.
    path : str or path-like
        The PNG file.

    Returns
    -------
    dict
        The data drawn, :func:`report.series`, and ``links``: the communication graph's
        links between the final positions, (L, 2) complex (none on the all-to-all graph);
        with a symmetric pattern ``places``, the final positions marked on the common circle.

    """
    sc = run.sc
    d = series(run)
    rigid = vehicle_model(sc.model).rigid
    flight = 'altitude' in run.channels
    fig, axes = plt.subplots(2, 3 if flight else 2, figsize=(19 if flight else 13, 10))
    _trajectories(axes[0, 0], d, sc)
    if flight:
        axes[0, 0].set_title(f'ground tracks: {sc.jsbsim_aircraft} {sc.formation}, '
                             f'N={sc.num_vehicles}')
        _wind(axes[0, 0], sc)
        _flight(axes[:, 2], run)
    _rates(axes[0, 1], d, rigid)
    if rigid:
        _crab(axes[1, 0], d)
    elif 'phase_orders' in d:
        for m, pm in enumerate(d['phase_orders'].T, start=1):
            axes[1, 0].plot(d['t'], pm, lw=0.9, label=f'|p_{m}|')
        axes[1, 0].legend(loc='upper right', fontsize='small', ncol=2)
        axes[1, 0].set(xlabel='t (s)', ylabel='|p_m|', title='phase moments |p_m| (pattern)')
    else:
        axes[1, 0].plot(d['t'], d['order'], lw=0.9, color='k')
        axes[1, 0].set(xlabel='t (s)', ylabel='|p|', title='order parameter |p| (1.10)')
    _lyapunov(axes[1, 1], d)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return d
