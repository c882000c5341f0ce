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

"""Communication graphs: construction, the default nu, connectivity, and refused input."""
from formation_control.core import graphs
from formation_control.core.graphs import GraphError
import numpy as np
import pytest


def test_ring_and_circulant_link_k_to_k_plus_and_minus_each_offset():
    ring = graphs.build(6, 'ring')
    assert ring.neighbours(1) == [2, 6] and ring.neighbours(4) == [3, 5]
    assert ring.degrees().tolist() == [2] * 6 and ring.nu == 3.0
    circ = graphs.build(8, 'circulant', offsets=[1, 3])
    assert circ.neighbours(1) == [2, 4, 6, 8]
    assert len(circ.edges) == 16 and not circ.complete


def test_complete_graph_has_nu_equal_to_n_and_every_pair():
    g = graphs.build(5)
    assert g.complete and g.nu == 5.0 and len(g.edges) == 10
    np.testing.assert_array_equal(g.laplacian(), 5 * np.eye(5) - np.ones((5, 5)))
    assert graphs.algebraic_connectivity(g.adjacency()) == pytest.approx(5.0)


def test_random_graph_is_connected_seeded_and_has_the_mean_degree():
    a = graphs.build(40, 'random', degree=4, seed=3)
    assert graphs.algebraic_connectivity(a.adjacency()) > 0
    assert a.degrees().mean() == pytest.approx(4.0)
    np.testing.assert_array_equal(a.edges, graphs.build(40, 'random', degree=4, seed=3).edges)
    assert not np.array_equal(a.edges, graphs.build(40, 'random', degree=4, seed=4).edges)


def test_ring_connectivity_is_the_known_eigenvalue():
    n = 12
    ring = graphs.build(n, 'ring')
    assert graphs.algebraic_connectivity(ring.adjacency()) == pytest.approx(
        2 - 2 * np.cos(2 * np.pi / n))


def test_explicit_edges_and_nu():
    g = graphs.build(4, 'explicit', edges=[1, 2, 2, 3, 3, 4], nu=2.5)
    assert g.edges.tolist() == [[0, 1], [1, 2], [2, 3]] and g.nu == 2.5
    assert g.neighbours(2) == [1, 3]


@pytest.mark.parametrize('kwargs, message', [
    ({'graph': 'star'}, r"'graph' = 'star' is invalid: allowed values: complete \| ring"),
    ({'graph': 'explicit', 'edges': [1, 2, 3, 4]},
     r"'graph_edges' = \[1, 2, 3, 4\] is invalid: the graph on 4 vehicles is not connected"),
    ({'graph': 'explicit', 'edges': [1, 2, 2, 1, 2, 3, 3, 4]},
     r"'graph_edges' = .* edges \[\(1, 2\)\] are given more than once \(edges are undirected"),
    ({'graph': 'explicit', 'edges': [1, 2, 2, 5]},
     r"'graph_edges' = \[1, 2, 2, 5\] is invalid: vehicle ids must lie in 1..num_vehicles = 4"),
    ({'graph': 'explicit', 'edges': [1, 1, 1, 2, 2, 3, 3, 4]},
     r"'graph_edges' = .* self edges \[\(1, 1\)\]"),
    ({'graph': 'explicit', 'edges': [1, 2, 3]},
     r"'graph_edges' = \[1, 2, 3\] is invalid: a flat list of 1-based id pairs"),
    ({'graph': 'circulant', 'offsets': [2]},
     r"'graph_offsets' = \[2\] is invalid: offsets must be integers with 1 <= d < "
     r'num_vehicles/2 = 2'),
    ({'graph': 'circulant', 'offsets': [1, 1]},
     r"'graph_offsets' = \[1, 1\] is invalid: offsets must be distinct"),
    ({'graph': 'random', 'degree': 1},
     r"'graph_degree' = 1 is invalid: a random connected graph needs a mean degree in "
     r'\[2, num_vehicles - 1 = 3\]'),
    ({'graph': 'complete', 'nu': -1.0}, r"'graph_nu' = -1.0 is invalid: must be >= 0"),
])
def test_bad_graphs_are_refused_naming_the_parameter(kwargs, message):
    with pytest.raises(GraphError, match=message):
        graphs.build(4, **kwargs)


def test_a_circulant_graph_that_is_not_connected_is_refused():
    with pytest.raises(GraphError, match=r"'graph_offsets' = \[2\] is invalid: the graph on 8 "
                                         r'vehicles is not connected'):
        graphs.build(8, 'circulant', offsets=[2])


def test_a_ring_needs_three_vehicles():
    with pytest.raises(GraphError, match=r'a ring needs num_vehicles >= 3'):
        graphs.build(2, 'ring')
