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
Known non-uniform flows: the laws with df/dt and grad f against the uniform-flow laws.

Runs particle_circular (16 particles, backstepping) in the shear and the vortex of
test_flow.py (seeds 101-105, 100 s, one batch each), and 6 particles in the turning flow of
the same file (seeds 1-3, 150 s), once with the laws as they are and once with the laws that
take the known flow as uniform and steady (``Controller.rates = False``, the laws before
issue 28, item 4). Prints the steady-state figures (the last 20 s; the turning flow's last
60 s) and draws docs/flow_rates.png.

    PYTHONPATH=. MPLBACKEND=Agg python tools/flow_rates.py [docs/flow_rates.png]
"""
from pathlib import Path
import sys

from formation_control.core import scenario
from formation_control.core.control import Controller
from formation_control.sim.simulator import initial_states, Stepper
import matplotlib.pyplot as plt
import numpy as np

CONFIG = Path(__file__).resolve().parents[1] / 'config'
CASES = {
    'shear': ('particle_circular', ('flow_model:=shear', 'flow_shear:=0.05',
                                    'flow_shear_width:=5.0'), range(101, 106), 100.0),
    'vortex': ('particle_circular', ('flow_model:=vortex', 'flow_circulation:=1.0',
                                     'flow_radius:=2.0', 'flow_center:=[3.0, 0.0]'),
               range(101, 106), 100.0),
    'turning': ('particle_circular_flow', ('flow_model:=time_varying', 'flow_amplitude:=0.2',
                                           'flow_period:=60.0', 'flow:=[0.3, 0.0]',
                                           'num_vehicles:=6'), range(1, 4), 150.0),
}


def run_case(name, rates):
    """Return the sample times (T,), true circle centres (T, B, N), course-rate errors (T, B)."""
    config, overrides, seeds, duration = CASES[name]
    sc = scenario.load(CONFIG / f'{config}.yaml', overrides, seed=seeds[0], duration=duration)
    st, truth = Stepper(sc, initial_states(sc, seeds)), Controller(sc)
    st.ctrl.rates = rates
    times, out, errors = [], [], []
    for n in range(sc.periods + 1):
        U = st.command()
        if n % sc.record_every == 0:
            view = truth.view(st.X, U[1], truth.plant.flow(st.t, st.X[0], st.X[1]))
            times.append(st.t)
            out.append(truth.formation.centres(view))
            errors.append(np.max(abs(view.rate - sc.omega0 * view.speed), axis=-1))
        if n < sc.periods:
            st.advance()
    return np.array(times), np.array(out), np.array(errors)


def figures(t, c, errors, window):
    """Return each fleet's centre spread (m), centre loop (m), course-rate error (rad/s)."""
    late = t >= t[-1] - window
    spread = np.max(abs(c[late] - c[late].mean(axis=-1, keepdims=True)), axis=(0, 2))
    mean = c[late].mean(axis=-1)
    return spread, np.max(abs(mean - mean.mean(axis=0)), axis=0), np.max(errors[late], axis=0)


def main(path='docs/flow_rates.png'):
    """Print the table and draw the figure at ``path``."""
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8), sharey=True)
    print('| flow | law | centre spread (m) | centre loop (m) | course-rate error (rad/s) |')
    print('|---|---|---|---|---|')
    for ax, name in zip(axes, CASES):
        window = 60.0 if name == 'turning' else 20.0
        for rates, label, colour in ((False, 'uniform-flow law', 'tab:red'),
                                     (True, 'with df/dt, grad f', 'tab:blue')):
            t, c, errors = run_case(name, rates)
            values = figures(t, c, errors, window)
            cells = ' | '.join(f'{v.min():.2g}-{v.max():.2g}' for v in values)
            print(f'| {name} | {label} | {cells} |', flush=True)
            curves = np.max(abs(c - c.mean(axis=-1, keepdims=True)), axis=-1)
            for b in range(curves.shape[1]):
                ax.semilogy(t, curves[:, b], color=colour, lw=0.8,
                            label=label if b == 0 else None)
        ax.axhline(0.01, color='k', ls=':', lw=0.8)
        ax.set_title(f'{name} (known flow)')
        ax.set_xlabel('t (s)')
    axes[0].set_ylabel('max |c_k - mean c| (m)')
    axes[0].legend(loc='lower left', fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == '__main__':
    main(*sys.argv[1:])
