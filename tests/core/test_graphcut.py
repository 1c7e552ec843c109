"""Alpha-expansion against brute force, and energy monotonicity."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from scribbleseg_core.engine.graphcut import INF, alpha_expansion, potts_energy


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
