"""Alpha-expansion against brute force, energy monotonicity, and the multilevel cut."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from scribbleseg_core.engine.graphcut import (
    INF,
    alpha_expansion,
    graph_clusters,
    multilevel_alpha_expansion,
    potts_energy,
)


def _random_problem(rng, p, k, q):
    unary = rng.random((p, k)) * 3
    pairs = np.array(list(itertools.combinations(range(p), 2)))
    edges = pairs[rng.choice(len(pairs), size=min(q, len(pairs)), replace=False)]
    weights = rng.random(len(edges)) * 2
    return unary, edges, weights


def _brute_force(unary, edges, weights):
    p, k = unary.shape
    best = min(itertools.product(range(k), repeat=p), key=lambda y: potts_energy(np.array(y), unary, edges, weights))
    return potts_energy(np.array(best), unary, edges, weights)


@pytest.mark.parametrize("seed", range(12))
def test_binary_expansion_is_exact(seed):
    rng = np.random.default_rng(seed)  # seeds 0..11: varied random graphs
    unary, edges, weights = _random_problem(rng, 8, 2, 14)
    y = alpha_expansion(unary, edges, weights)
    assert np.isclose(potts_energy(y, unary, edges, weights), _brute_force(unary, edges, weights))


@pytest.mark.parametrize("seed", range(12))
def test_multilabel_expansion_matches_brute_force_within_the_bound(seed):
    rng = np.random.default_rng(100 + seed)
    unary, edges, weights = _random_problem(rng, 7, 3, 12)
    y = alpha_expansion(unary, edges, weights)
    e, opt = potts_energy(y, unary, edges, weights), _brute_force(unary, edges, weights)
    assert opt - 1e-9 <= e <= 2 * opt + 1e-9  # Potts: expansion is within a factor 2


def test_multilabel_usually_optimal():
    hits = 0
    for seed in range(20):
        rng = np.random.default_rng(200 + seed)
        unary, edges, weights = _random_problem(rng, 7, 3, 10)
        y = alpha_expansion(unary, edges, weights)
        hits += np.isclose(potts_energy(y, unary, edges, weights), _brute_force(unary, edges, weights))
    assert hits >= 17


def test_no_move_increases_the_energy():
    rng = np.random.default_rng(5)
    unary, edges, weights = _random_problem(rng, 30, 4, 80)
    init = rng.integers(0, 4, 30)
    e_init = potts_energy(init, unary, edges, weights)
    energies = [e_init]
    for sweeps in range(1, 5):
        energies.append(potts_energy(alpha_expansion(unary, edges, weights, init, max_sweeps=sweeps), unary, edges, weights))
    assert all(b <= a + 1e-9 for a, b in zip(energies, energies[1:]))


def test_forbidden_labels_are_never_chosen():
    rng = np.random.default_rng(9)
    unary, edges, weights = _random_problem(rng, 20, 3, 40)
    unary[:10, 2] = INF
    unary[0, :] = [INF, 0.0, INF]  # node 0 fixed to label 1
    y = alpha_expansion(unary, edges, weights * 50, init=np.ones(20, int))
    assert (y[:10] != 2).all() and y[0] == 1


def test_chain_propagates_from_fixed_ends():
    """Two fixed ends, uniform unaries: the cut falls on the weakest edge."""
    p = 10
    unary = np.zeros((p, 2))
    unary[0] = [0, INF]
    unary[-1] = [INF, 0]
    edges = np.stack([np.arange(p - 1), np.arange(1, p)], axis=1)
    weights = np.ones(p - 1)
    weights[6] = 0.1
    y = alpha_expansion(unary, edges, weights, init=np.zeros(p, int))
    np.testing.assert_array_equal(y, [0] * 7 + [1] * 3)


def _grid(nx, ny):
    idx = np.arange(nx * ny).reshape(ny, nx)
    edges = np.r_[np.c_[idx[:, :-1].ravel(), idx[:, 1:].ravel()], np.c_[idx[:-1].ravel(), idx[1:].ravel()]]
    A = sp.coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(nx * ny,) * 2)
    return idx, edges, (A + A.T).tocsr()


def test_graph_clusters_are_connected_cells_of_about_the_size_asked():
    idx, edges, A = _grid(40, 30)
    clusters = graph_clusters(A, 8)
    np.testing.assert_array_equal(clusters, graph_clusters(A, 8))  # deterministic
    c = clusters.max() + 1
    assert 1200 / 8 * 0.9 <= c <= 1200 / 8 + 1 and set(np.unique(clusters)) == set(range(c))
    for cell in range(c):  # every cell is one connected piece of the grid
        nodes = np.flatnonzero(clusters == cell)
        assert connected_components(A[nodes][:, nodes], directed=False)[0] == 1
    np.testing.assert_array_equal(graph_clusters(A, 1), np.arange(1200))


def test_multilevel_expansion_finds_the_cut_and_keeps_hard_constraints():
    # three labels on a 60x20 grid: noisy unaries whose truth is three vertical bands, and
    # side by side in the middle band, pairs of nodes forced to labels 0 and 2
    rng = np.random.default_rng(0)
    idx, edges, A = _grid(60, 20)
    truth = np.minimum(np.tile(np.arange(60) // 20, 20), 2)
    unary = rng.random((1200, 3)) * 3  # alone, half the nodes would take a wrong label
    unary[np.arange(1200), truth] -= 0.6
    weights = np.full(len(edges), 1.0)
    pinned, pin = idx[2::4, 28:30].ravel(), np.tile([0, 2], 5)
    unary[pinned] = INF
    unary[pinned, pin] = 0.0
    truth[pinned] = pin
    clusters = graph_clusters(A, 6)
    full = alpha_expansion(unary, edges, weights)
    multi = multilevel_alpha_expansion(unary, edges, weights, clusters)
    np.testing.assert_array_equal(multi[pinned], pin)
    assert (multi == truth).mean() >= 0.97
    e_full, e_multi = potts_energy(full, unary, edges, weights), potts_energy(multi, unary, edges, weights)
    assert e_multi <= e_full + 0.005 * abs(e_full)
    again = multilevel_alpha_expansion(unary, edges, weights, clusters, init=multi)
    assert potts_energy(again, unary, edges, weights) <= e_multi + 1e-9  # from a start, never worse
    with pytest.raises(ValueError, match="clusters"):
        multilevel_alpha_expansion(unary, edges, weights, clusters[:-1])
