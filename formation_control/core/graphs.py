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
Communication graphs: who hears whom, for the Laplacian formation laws.

A graph is undirected (a_kj = a_jk) and connected, with unit weights; the laws are gradients
of their potentials only then (Sepulchre, Paley and Leonard, "Stabilization of planar
collective motion with limited communication", IEEE TAC 53(3), 2008). A directed or
disconnected graph is refused before anything runs.

Kinds (scenario parameter ``graph``): ``complete`` (every vehicle hears every other: the
all-to-all laws), ``ring``, ``circulant`` (vehicle k hears k +- d for each d in
``graph_offsets``), ``random`` (connected, mean degree ``graph_degree``, seeded by
``graph_seed``) and ``explicit`` (``graph_edges``: 1-based id pairs).
"""
from __future__ import annotations

from collections.abc import Collection, Sequence
from functools import lru_cache
import math
from typing import NoReturn, TYPE_CHECKING

from formation_control.core.geometry import BoolArray, IntArray, RealArray
import numpy as np

if TYPE_CHECKING:
    from formation_control.core.laws import Coupling

GRAPHS = ('complete', 'ring', 'circulant', 'random', 'explicit')


class GraphError(ValueError):
    """A graph parameter is invalid: the message names the parameter and the reason."""


def _fail(name: str, value: object, reason: str) -> NoReturn:
    raise GraphError(f"parameter '{name}' = {value!r} is invalid: {reason}")


class Graph:
    """
    An undirected communication graph on vehicles 1..n.

    Parameters
    ----------
    n : int
        Number of vehicles.
    edges : (E, 2) int or None
        Each undirected edge once, as 0-based indices (i < j); None = the complete graph,
        whose edges are only listed when asked for.
    nu : float
        The fleet-wide normalising constant of the Laplacian laws (> 0).

    """

    def __init__(self, n: int, edges: IntArray | None, nu: float) -> None:
        self.n = n
        self.complete = edges is None or len(edges) == n * (n - 1) // 2
        self._edges = edges
        self.nu = nu

    @property
    def edges(self) -> IntArray:
        """(E, 2) int: each undirected edge once, as 0-based indices (i < j)."""
        if self._edges is None:
            i, j = np.triu_indices(self.n, 1)
            self._edges = np.stack([i, j], axis=1)
        return self._edges

    @property
    def arcs(self) -> tuple[IntArray, IntArray]:
        """(src, dst): every edge in both directions, (2E,) int each."""
        i, j = self.edges.T
        return np.concatenate([i, j]), np.concatenate([j, i])

    def degrees(self) -> IntArray:
        """(n,) int: the number of neighbours of each vehicle."""
        if self._edges is None:
            return np.full(self.n, self.n - 1)
        return np.bincount(self.edges.ravel(), minlength=self.n)

    def neighbours(self, k: int) -> list[int]:
        """Return the ids (1-based, sorted) vehicle ``k`` hears."""
        if self._edges is None:
            return [j for j in range(1, self.n + 1) if j != k]
        i, j = self.edges.T
        own = k - 1
        return sorted(int(x) + 1 for x in np.concatenate([j[i == own], i[j == own]]))

    def adjacency(self) -> RealArray:
        """(n, n) float: the weights a_kj (dense; for small fleets, tests and metrics)."""
        A = np.zeros((self.n, self.n))
        A[self.edges[:, 0], self.edges[:, 1]] = 1.0
        return A + A.T

    def laplacian(self) -> RealArray:
        """(n, n) float: L = D - A."""
        A = self.adjacency()
        return np.diag(A.sum(axis=1)) - A

    def coupling(self, members: BoolArray | None = None) -> Coupling:
        """
        Return the :class:`laws.Coupling` of the graph among the vehicles ``members``.

        Parameters
        ----------
        members : (n,) bool, optional
            The vehicles of a view (a vehicle and the neighbours it hears); all by default.

        Returns
        -------
        laws.Coupling
            The arcs between members, as indices into the members in fleet order, with this
            graph's nu and n.

        """
        from formation_control.core.laws import Coupling
        src, dst = self.arcs
        if members is not None:
            members = np.asarray(members, bool)
            keep = members[src] & members[dst]
            index = np.cumsum(members) - 1
            src, dst = index[src[keep]], index[dst[keep]]
        return Coupling(src, dst, self.nu, self.n)


def algebraic_connectivity(A: RealArray) -> float:
    """
    lambda_2 of the Laplacian of the symmetric weights ``A`` (n, n): > 0 iff connected.

    Returns 0 for fewer than two vehicles.
    """
    A = np.asarray(A, float)
    if A.shape[0] < 2:
        return 0.0
    L = np.diag(A.sum(axis=1)) - A
    return float(np.linalg.eigvalsh(L)[1])


def _components(n: int, edges: IntArray | Sequence[tuple[int, int]]) -> int:
    """Count the connected components of the graph on n vertices (union-find)."""
    parent = list(range(n))

    def root(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x
    for i, j in edges:
        parent[root(int(i))] = root(int(j))
    return len({root(x) for x in range(n)})


def _circulant(n: int, offsets: Sequence[int], name: str = 'graph_offsets') -> IntArray:
    offsets = list(offsets)
    if not offsets:
        _fail(name, offsets, 'give at least one offset d (vehicle k hears k +- d)')
    half = n / 2
    bad = [d for d in offsets if not (isinstance(d, int) and 1 <= d < half)]
    if bad:
        _fail(name, offsets, f'offsets must be integers with 1 <= d < num_vehicles/2 = {half:g} '
              f'(d and num_vehicles - d give the same links; for d = num_vehicles/2 list the '
              f'edges with graph: explicit)')
    if len(set(offsets)) != len(offsets):
        _fail(name, offsets, 'offsets must be distinct')
    k = np.arange(n)
    return np.concatenate([np.stack([k, (k + d) % n], axis=1) for d in offsets])


def _random(n: int, degree: float, seed: int) -> IntArray:
    """Draw a connected graph: a random spanning tree, then random edges up to the degree."""
    if n < 3:
        _fail('graph', 'random', f'a random connected graph needs num_vehicles >= 3 (got {n})')
    if not (isinstance(degree, (int, float)) and 2 <= degree <= n - 1):
        _fail('graph_degree', degree, f'a random connected graph needs a mean degree in '
              f'[2, num_vehicles - 1 = {n - 1}]')
    rng = np.random.default_rng(seed)
    order = rng.permutation(n)
    edges = {tuple(sorted((int(order[m]), int(order[rng.integers(m)])))) for m in range(1, n)}
    target = int(round(n * degree / 2))
    while len(edges) < target:
        i, j = rng.choice(n, 2, replace=False)
        edges.add((int(min(i, j)), int(max(i, j))))
    return np.array(sorted(edges))


def _explicit(n: int, flat: Sequence[int]) -> IntArray:
    flat = list(flat)
    name = 'graph_edges'
    if len(flat) % 2 or not flat:
        _fail(name, flat, 'a flat list of 1-based id pairs [i1, j1, i2, j2, ...]')
    bad = [k for k in flat if not (isinstance(k, int) and 1 <= k <= n)]
    if bad:
        _fail(name, flat, f'vehicle ids must lie in 1..num_vehicles = {n} (not {bad})')
    pairs = [(flat[m], flat[m + 1]) for m in range(0, len(flat), 2)]
    loops = [p for p in pairs if p[0] == p[1]]
    if loops:
        _fail(name, flat, f'self edges {loops}: a vehicle does not link to itself')
    seen = [tuple(sorted(p)) for p in pairs]
    twice = sorted({p for p in seen if seen.count(p) > 1})
    if twice:
        _fail(name, flat, f'edges {twice} are given more than once (edges are undirected: '
              '[1, 2] and [2, 1] are the same edge; a one-way link cannot be expressed, as the '
              "one-way Laplacian law is not a gradient and diverges at the thesis' gains)")
    return np.array(sorted(seen)) - 1


def _check_nu(nu: float, degree: float) -> None:
    """Refuse a given nu below the largest degree: the laws need every d_k / nu <= 1."""
    if 0 < nu < degree:
        _fail('graph_nu', nu, f'must be >= the largest degree {degree} of the graph (every '
              f'coupling d_k / nu <= 1, as in the all-to-all law; a smaller nu multiplies the '
              f'formation gains by d_k / nu and makes the laws stiff), or 0 for the default')


def build(n: int, graph: str = 'complete', offsets: Sequence[int] = (1,), degree: float = 4.0,
          seed: int = 0, edges: Sequence[int] = (), nu: float = 0.0) -> Graph:
    """
    Build and validate the communication graph a scenario names.

    Parameters
    ----------
    n : int
        Number of vehicles.
    graph : str
        One of ``GRAPHS``.
    offsets : sequence of int
        ``circulant``: vehicle k hears k +- d for each offset d (1 <= d < n/2).
    degree : float
        ``random``: the mean degree (2 <= degree <= n - 1).
    seed : int
        ``random``: the seed of the draw.
    edges : sequence of int
        ``explicit``: undirected edges as a flat list of 1-based id pairs.
    nu : float
        The normalising constant; 0 = the default, max degree + 1 (= n on the complete graph).

    Returns
    -------
    Graph

    Raises
    ------
    GraphError
        Naming the parameter: unknown kind, ids out of range, self or duplicate edges,
        offsets that repeat a link, a degree out of range, a disconnected graph, nu < 0 or
        below the largest degree.

    """
    if graph not in GRAPHS:
        _fail('graph', graph, f"allowed values: {' | '.join(GRAPHS)}")
    if not (math.isfinite(nu) and nu >= 0):
        _fail('graph_nu', nu, 'must be >= 0 (0 = max degree + 1)')
    if graph == 'complete':
        _check_nu(nu, n - 1)
        return Graph(n, None, float(nu) if nu > 0 else float(n))
    if graph == 'ring':
        if n < 3:
            _fail('graph', graph, f'a ring needs num_vehicles >= 3 (got {n})')
        pairs = _circulant(n, [1])
    elif graph == 'circulant':
        pairs = _circulant(n, offsets)
    elif graph == 'random':
        pairs = _random(n, degree, seed)
    else:
        pairs = _explicit(n, edges)
    pairs = np.sort(pairs.reshape(-1, 2), axis=1)
    if n > 1 and _components(n, pairs) > 1:
        where = {'explicit': 'graph_edges', 'circulant': 'graph_offsets'}.get(graph, 'graph')
        value = {'graph_edges': list(edges), 'graph_offsets': list(offsets)}.get(where, graph)
        _fail(where, value, f'the graph on {n} vehicles is not connected: the Laplacian laws '
              f'need every vehicle linked to every other through some path')
    degrees = np.bincount(pairs.ravel(), minlength=n)
    _check_nu(nu, int(degrees.max(initial=0)))
    nu = float(nu) if nu > 0 else float(degrees.max(initial=0) + 1)
    return Graph(n, pairs.astype(np.int64), nu)


def live_edges(graph: Graph, fresh: BoolArray,
               deaf: Collection[tuple[int, int]] = ()) -> IntArray:
    """
    Return the edges of ``graph`` that are live: both ends fresh and each hearing the other.

    Parameters
    ----------
    graph : Graph
        The communication graph.
    fresh : (n,) bool
        The vehicles whose state is recent.
    deaf : collection of (k, j)
        The pairs (0-based) where vehicle k's latest state says it does not hear j; O(pairs)
        memory, not a dense (n, n) table.

    Returns
    -------
    (L, 2) int
        The live edges, 0-based (i < j).

    """
    i, j = graph.edges.T
    live = fresh[i] & fresh[j]
    if deaf:
        pairs = np.array(list(deaf), dtype=np.int64)
        lo, hi = pairs.min(axis=1), pairs.max(axis=1)
        live &= ~np.isin(i.astype(np.int64) * graph.n + j, lo * graph.n + hi)
    return graph.edges[live]


CONNECTIVITY_DENSE_MAX = 1000
"""The most vehicles whose lambda_2 :func:`connectivity` computes (a dense eigenproblem)."""


def connectivity(members: BoolArray, edges: IntArray) -> float:
    """
    Return the algebraic connectivity of the graph of unit-weight ``edges`` among ``members``.

    Parameters
    ----------
    members : (n,) bool
        The vehicles of the graph (the live ones).
    edges : (L, 2) int
        Edges between members, 0-based fleet indices.

    Returns
    -------
    float
        lambda_2 of its Laplacian (:func:`algebraic_connectivity`): 0 when disconnected; the
        formation laws converge at a rate of about K lambda_2 / nu. Past
        ``CONNECTIVITY_DENSE_MAX`` members, where the dense Laplacian (m^2 floats) and its
        eigenvalues (m^3 work) cost too much each sample: 0 when disconnected (union-find,
        O(m + L)), else NaN (connected; lambda_2 not computed).

    """
    index = np.cumsum(members) - 1
    m = int(np.count_nonzero(members))
    if m > CONNECTIVITY_DENSE_MAX:
        return 0.0 if _components(m, index[edges]) > 1 else math.nan
    A = np.zeros((m, m))
    A[index[edges[:, 0]], index[edges[:, 1]]] = 1.0
    return algebraic_connectivity(A + A.T)


def twisted_states(n: int, offsets: Sequence[int]) -> list[int]:
    """
    Return the stable twisted states of the Laplacian phase potential of a circulant graph.

    Parameters
    ----------
    n : int
        Number of vehicles.
    offsets : sequence of int
        Vehicle k hears k +- d for each offset d (the ring: (1,)).

    Returns
    -------
    list of int
        The winding numbers q in 1..n//2 whose twisted state ``psi_k = 2 pi q k / n`` is a
        strict local minimum of ``sum_arcs (1 - cos(psi_j - psi_k))`` (docs/errata.md,
        "Twisted states"): its Hessian has the eigenvalues
        ``lambda_l = sum_d 2 cos(2 pi q d / n) (1 - cos(2 pi l d / n))``, l = 1..n-1, all > 0.
        On a ring: every q with ``|q| < n/4``.

    """
    d = np.asarray(offsets, float)[:, None]
    modes = np.arange(1, n)[None, :]
    out = []
    for q in range(1, n // 2 + 1):
        weight = np.cos(2.0 * np.pi * q * d / n)
        hessian = np.sum(2.0 * weight * (1.0 - np.cos(2.0 * np.pi * modes * d / n)), axis=0)
        if np.all(hessian > 1e-12):
            out.append(q)
    return out


TRAP_STARTS = 64
"""Random phase starts of :func:`slot_traps`."""


def _in_half_circle(x: RealArray) -> bool:
    """Return (S,) bool: whether the unit vectors x (S, n) lie in an open half circle."""
    ang = np.sort(np.angle(x), axis=1)
    gaps = np.diff(np.concatenate([ang, ang[:, :1] + 2.0 * np.pi], axis=1), axis=1)
    return gaps.max(axis=1) > np.pi


def slot_traps(graph: Graph, starts: int = TRAP_STARTS, seed: int = 0,
               max_steps: int = 20000) -> float:
    """
    Return the share of random phase starts that end away from synchrony on the graph.

    Parameters
    ----------
    graph : Graph
        The communication graph.
    starts : int
        Independent uniformly random starts of the phases.
    seed : int
        Seed of the starts (the census is reproducible).
    max_steps : int
        Euler steps at most (step ``0.5 / max degree``, inside the stability limit
        ``2 / lambda_max(L) >= 1 / max degree``).

    Returns
    -------
    float
        The fraction of starts whose gradient flow ``psi_k' = sum_j a_kj sin(psi_j - psi_k)``
        of the Laplacian phase potential comes to rest (every ``|psi_k'| < 1e-9``) outside
        every open half circle: a stable equilibrium that is not synchrony, where a slot
        pattern stops with its slots wrongly filled. A start whose phases enter an open half
        circle is counted as synchronising (on a connected graph the flow keeps such phases in
        a shrinking arc and converges to synchrony), which ends its integration.

    """
    return _slot_traps(graph.n, graph.edges.tobytes(), starts, seed, max_steps)


@lru_cache(maxsize=64)
def _slot_traps(n: int, edges: bytes, starts: int, seed: int, max_steps: int) -> float:
    pairs = np.frombuffer(edges, dtype=np.int64).reshape(-1, 2)
    A = np.zeros((n, n))
    A[pairs[:, 0], pairs[:, 1]] = 1.0
    A = A + A.T
    dt = 0.5 / max(1.0, A.sum(axis=1).max())
    rng = np.random.default_rng(seed)
    x = np.exp(2j * np.pi * rng.random((starts, n)))
    trapped = np.zeros(starts, bool)
    for step in range(max_steps):
        rate = (np.conj(x) * (x @ A)).imag
        if step % 20 == 0:
            synced = _in_half_circle(x)
            trapped = ~synced & np.all(abs(rate) < 1e-9, axis=1)
            live = ~synced & ~trapped
            if not live.any():
                break
            x, rate = x[live | trapped], rate[live | trapped]
            trapped = trapped[live | trapped]
        x = x * np.exp(1j * dt * rate * ~trapped[:, None])
    return float(np.count_nonzero(trapped) / starts)
