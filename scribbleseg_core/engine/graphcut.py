"""Potts energy and multi-label alpha-expansion on a general graph (PyMaxflow)."""

from __future__ import annotations

import numpy as np

#: Stand-in for an infinite unary cost (a forbidden label). Large, but far from
#: float64 overflow when summed over many nodes.
INF = 1e9


def potts_energy(labels: np.ndarray, unary: np.ndarray, edges: np.ndarray, weights: np.ndarray) -> float:
    """``Σ_i unary[i, y_i] + Σ_(i,j) w_ij [y_i ≠ y_j]``.

    Parameters
    ----------
    labels : (p,) int ndarray
    unary : (p, k) float64 ndarray
    edges : (q, 2) int ndarray
    weights : (q,) float64 ndarray, non-negative

    Returns
    -------
    float
    """
    labels = np.asarray(labels)
    data = unary[np.arange(len(labels)), labels].sum()
    if len(edges) == 0:
        return float(data)
    cut = labels[edges[:, 0]] != labels[edges[:, 1]]
    return float(data + weights[cut].sum())


def alpha_expansion(
    unary: np.ndarray,
    edges: np.ndarray,
    weights: np.ndarray,
    init: np.ndarray | None = None,
    *,
    max_sweeps: int = 10,
) -> np.ndarray:
    """Minimize a Potts energy by alpha-expansion moves (Boykov, Veksler, Zabih 2001).

    Each move lets any node switch to label α and is solved exactly as one min cut; a
    move is kept only if it lowers :func:`potts_energy`, so the energy never increases.
    Sweeps over all labels repeat until none helps; a label is not tried again while the
    labeling is the one it was last tried on (the move would be the same).

    Parameters
    ----------
    unary : (p, k) float64 ndarray
        Cost of each label per node; use :data:`INF` for forbidden labels.
    edges : (q, 2) int ndarray
    weights : (q,) float64 ndarray, non-negative
    init : (p,) int ndarray, optional
        Start labeling; default the unary argmin.
    max_sweeps : int

    Returns
    -------
    labels : (p,) int64 ndarray

    References
    ----------
    Y. Boykov, O. Veksler, R. Zabih, "Fast approximate energy minimization via graph
    cuts", IEEE TPAMI 2001. V. Kolmogorov, R. Zabih, "What energy functions can be
    minimized via graph cuts?", IEEE TPAMI 2004.
    """
    unary = np.asarray(unary, dtype=np.float64)
    p, k = unary.shape
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    weights = np.asarray(weights, dtype=np.float64).reshape(-1)
    if (weights < 0).any():
        raise ValueError("pairwise weights must be non-negative")
    labels = np.argmin(unary, axis=1) if init is None else np.asarray(init, dtype=np.int64).copy()
    energy = potts_energy(labels, unary, edges, weights)
    allowed = [alpha for alpha in range(k) if not np.all(unary[:, alpha] >= INF)]
    changes, tried = 0, {}  # labelings kept so far; label -> `changes` when it was last tried
    for _ in range(max_sweeps):
        improved = False
        for alpha in allowed:
            if tried.get(alpha) == changes:
                continue
            tried[alpha] = changes
            proposal = _expansion_move(labels, alpha, unary, edges, weights)
            e = potts_energy(proposal, unary, edges, weights)
            if e < energy - 1e-9 * max(1.0, abs(energy)):
                labels, energy, improved = proposal, e, True
                changes += 1
        if not improved:
            break
    return labels


def _expansion_move(labels, alpha, unary, edges, weights) -> np.ndarray:
    """One alpha-expansion: x_i = 1 switches node i to `alpha` (sink side of the cut)."""
    import maxflow

    p = len(labels)
    idx = np.arange(p)
    e0 = unary[idx, labels].copy()  # cost if the node keeps its label
    e1 = unary[idx, alpha].copy()   # cost if it switches to alpha
    e1[labels == alpha] = e0[labels == alpha]
    g = maxflow.Graph[float](p, len(edges))
    g.add_nodes(p)
    if len(edges):
        i, j = edges[:, 0], edges[:, 1]
        yi, yj = labels[i], labels[j]
        A = weights * (yi != yj)      # E(0, 0)
        B = weights * (yi != alpha)   # E(0, 1)
        C = weights * (alpha != yj)   # E(1, 0)
        # E(1, 1) = 0. E = A + (C - A) x_i + (0 - C) x_j + (B + C - A) (1 - x_i) x_j;
        # the constant A does not move the cut.
        np.add.at(e1, i, C - A)
        np.add.at(e1, j, -C)
        g.add_edges(i, j, np.maximum(B + C - A, 0.0), np.zeros(len(i)))
    shift = np.minimum(e0, e1)
    # a node on the sink side (x=1) pays the source capacity, and vice versa
    g.add_grid_tedges(idx, e1 - shift, e0 - shift)
    g.maxflow()
    switch = g.get_grid_segments(idx)
    out = labels.copy()
    out[switch] = alpha
    return out
