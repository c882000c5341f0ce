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
The 3-D laws of core/spatial.py over seeds no test uses (docs/laws.md, "Three dimensions").

Each law from random fleets (N particles, positions N(0, spread^2) per axis, frames uniform on
SO(3)), stepped exactly with the controls held for dt until its potential V is below the tol
(parallel: 1 - |mean x| < tol; circular, helical: V < tol m^2, centres across b within about
sqrt(2 tol)) or the horizon: the share converged with its Wilson 95 % interval, the median
and the largest time to converge, and, over the converged runs, the largest radius error and
axis angle of a circle fitted to each particle's last orbit.

    .venv/bin/python bench/spatial.py [--seeds 30] [--first-seed 1000] [--n 8]
        [--horizon 200] [--dt 0.02] [--tol 1e-6]
"""
import argparse

from formation_control.core import graphs, spatial
from formation_control.sim.sweep import wilson
import numpy as np


def laws(n):
    """Return the laws measured, by name."""
    ring = graphs.build(n, 'ring').coupling()
    return {'parallel': spatial.Parallel(-1.0),
            'parallel, ring': spatial.Parallel(-1.0, ring),
            'circular': spatial.Circular(1.0, 1.0),
            'circular, ring': spatial.Circular(1.0, 1.0, coupling=ring),
            'circular, tilted b': spatial.Circular(0.6, -0.8, (1.0, -2.0, 0.5)),
            'helical, axial 0.4': spatial.Circular(1.0, 0.7, (0.0, 1.0, 1.0), axial=0.4)}


def fleet(seed, n, spread):
    """Return random positions (n, 3) and frames uniform on SO(3) (n, 3, 3)."""
    rng = np.random.default_rng(seed)
    Q, T = np.linalg.qr(rng.normal(size=(n, 3, 3)))
    Q = Q * np.sign(np.diagonal(T, axis1=1, axis2=2))[:, None, :]
    Q[:, :, 2] *= np.linalg.det(Q)[:, None]
    return spread * rng.normal(size=(n, 3)), Q


def error(law, r, R):
    """Return the convergence error: 1 - |mean x| (parallel) or V (m^2)."""
    if isinstance(law, spatial.Parallel):
        return 1.0 - np.linalg.norm(R[:, :, 0].mean(axis=0))
    return law.potential(r, R)


def orbit_errors(law, r, R, dt):
    """Return the largest radius error (relative) and axis angle (rad) over one more orbit."""
    steps = int(np.ceil(2 * np.pi / abs(law.omega0) / dt))
    rs = [r]
    for _ in range(steps):
        u, v, w = law.controls(r, R)
        r, R = spatial.step(r, R, u, v, dt, w)
        rs.append(r)
    b = np.asarray(law.b)
    radius = np.sqrt(1 - law.axial ** 2) / abs(law.omega0)
    p = np.array(rs)
    rad, ang = 0.0, 0.0
    for k in range(p.shape[1]):
        chord = p[1:, k] - p[:-1, k]
        n = np.linalg.svd(chord - chord.mean(axis=0))[2][-1]
        q = p[:, k] - np.outer(p[:, k] @ n, n)
        M = np.column_stack([2 * q, np.ones(len(q))])
        sol = np.linalg.lstsq(M, np.sum(q * q, 1), rcond=None)[0]
        o = sol[:3]
        rho = np.sqrt(sol[3] + o @ o - (o @ n) ** 2)
        rad = max(rad, abs(rho / radius - 1))
        ang = max(ang, float(np.arccos(min(1.0, abs(n @ b)))))
    return rad, ang


def run(law, seed, a):
    """Return the time to converge (NaN if not within the horizon) and the final state."""
    r, R = fleet(seed, a.n, a.spread)
    for i in range(int(a.horizon / a.dt) + 1):
        if error(law, r, R) < a.tol:
            return i * a.dt, r, R
        u, v, w = law.controls(r, R)
        r, R = spatial.step(r, R, u, v, a.dt, w)
    return float('nan'), r, R


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    p.add_argument('--seeds', type=int, default=30)
    p.add_argument('--first-seed', type=int, default=1000)
    p.add_argument('--n', type=int, default=8)
    p.add_argument('--spread', type=float, default=4.0)
    p.add_argument('--horizon', type=float, default=200.0)
    p.add_argument('--dt', type=float, default=0.02)
    p.add_argument('--tol', type=float, default=1e-6)
    a = p.parse_args()
    print('| law | converged | Wilson 95 % | median t (s) | max t (s) '
          '| radius error | axis angle (rad) |\n|---|---|---|---|---|---|---|')
    for name, law in laws(a.n).items():
        times, rad, ang = [], 0.0, 0.0
        for seed in range(a.first_seed, a.first_seed + a.seeds):
            t, r, R = run(law, seed, a)
            times.append(t)
            if np.isfinite(t) and isinstance(law, spatial.Circular):
                e = orbit_errors(law, r, R, a.dt)
                rad, ang = max(rad, e[0]), max(ang, e[1])
        t = np.array(times)
        ok = int(np.isfinite(t).sum())
        low, high = wilson(ok, len(t))
        fits = '- | -' if isinstance(law, spatial.Parallel) else f'{rad:.1e} | {ang:.1e}'
        print(f'| {name} | {ok}/{len(t)} | [{low:.2f}, {high:.2f}] '
              f'| {np.nanmedian(t):.1f} | {np.nanmax(t):.1f} | {fits} |', flush=True)


if __name__ == '__main__':
    main()
