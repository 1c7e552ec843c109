"""Potts energy and multi-label alpha-expansion on a general graph (PyMaxflow)."""

from __future__ import annotations

import numpy as np

from scribbleseg_core.geometry.dual_graph import pair_matrix

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


def graph_clusters(matrix, size: int, seed: int = 0) -> np.ndarray:
    """Partition a graph's nodes into connected clusters of about `size` nodes: the Voronoi
    cells, in the metric of `matrix`, of ``p / size`` nodes drawn at random.

    Parameters
    ----------
    matrix : (p, p) sparse matrix
        Symmetric arc lengths (e.g. :attr:`DualGraph.crease_matrix`: cells then avoid
        crossing creases).
    size : int
        Mean nodes per cluster; 1 or less puts each node in its own cluster.
    seed : int
        Seed of the random draw (the partition is deterministic).

    Returns
    -------
    (p,) int64 ndarray
        Cluster id per node, ``0 .. c−1``; every connected component holds at least one
        cluster (one of its nodes joins the draw).
    """
    from scipy.sparse.csgraph import connected_components, dijkstra

    p = matrix.shape[0]
    if size <= 1 or p == 0:
        return np.arange(p, dtype=np.int64)
    rng = np.random.default_rng(seed)
    _, comp = connected_components(matrix, directed=False)
    seeds = rng.choice(p, size=max(1, p // size), replace=False)
    seeds = np.unique(np.r_[seeds, np.unique(comp, return_index=True)[1]])  # one per component at least
    _, _, source = dijkstra(matrix, directed=False, indices=seeds, min_only=True, return_predecessors=True)
    return np.unique(source, return_inverse=True)[1].astype(np.int64)


def coarsen(clusters: np.ndarray, pinned: np.ndarray, edges: np.ndarray, weights: np.ndarray):
    """The coarse graph of a clustering: one node per (cluster, pinned label) pair, so that
    nodes pinned to different labels (strokes) never share a coarse node.

    Parameters
    ----------
    clusters : (p,) int ndarray
        Cluster id per node (:func:`graph_clusters`).
    pinned : (p,) int ndarray
        The label a node is pinned to, -1 where free.
    edges : (q, 2) int ndarray
    weights : (q,) float ndarray

    Returns
    -------
    coarse : (p,) int64 ndarray
        Coarse node per node, ``0 .. c−1``.
    coarse_edges : (r, 2) int64 ndarray
        Pairs of coarse nodes joined by an arc, each once.
    coarse_weights : (r,) float64 ndarray
        The summed weights of the arcs between them.
    """
    import scipy.sparse as sp

    clusters, pinned = np.asarray(clusters, dtype=np.int64), np.asarray(pinned, dtype=np.int64)
    k = int(pinned.max(initial=-1)) + 1
    coarse = np.unique(clusters * (k + 1) + (pinned + 1), return_inverse=True)[1].ravel().astype(np.int64)
    c = int(coarse.max()) + 1 if coarse.size else 0
    ci, cj = coarse[edges[:, 0]], coarse[edges[:, 1]]
    cross = ci != cj
    W = sp.coo_matrix((np.asarray(weights, dtype=np.float64)[cross], (np.minimum(ci, cj)[cross], np.maximum(ci, cj)[cross])),
                      shape=(c, c)).tocsr()
    W.sum_duplicates()
    W = W.tocoo()
    return coarse, np.c_[W.row, W.col].astype(np.int64), W.data


def multilevel_alpha_expansion(
    unary: np.ndarray,
    edges: np.ndarray,
    weights: np.ndarray,
    clusters: np.ndarray,
    init: np.ndarray | None = None,
    *,
    band: int = 3,
    max_sweeps: int = 10,
) -> np.ndarray:
    """:func:`alpha_expansion` on clusters of nodes, then on the nodes near its boundaries.

    First the labeling that is constant on every cluster and minimizes the Potts energy
    among those (each cluster split by the one label its hard-constrained nodes allow:
    nodes with a single finite label never share a coarse node with others). Then
    alpha-expansion on the nodes within `band` arcs of a label boundary, the others held
    fixed. Both levels minimize the same energy, so the result's energy is never above the
    coarse labeling's; it matches :func:`alpha_expansion` where the boundaries' errors at
    the coarse level are within `band` arcs, at a fraction of the cost on large graphs.

    Parameters
    ----------
    unary, edges, weights : as in :func:`alpha_expansion`
    clusters : (p,) int ndarray
        Cluster id per node (:func:`graph_clusters`).
    init : (p,) int ndarray, optional
        Start labeling (a previous result); at the coarse level each cluster starts from one
        of its nodes' labels.
    band : int
        Width, in arcs, of the refined band around the coarse labeling's boundaries.
    max_sweeps : int
        Per level.

    Returns
    -------
    labels : (p,) int64 ndarray
    """
    import scipy.sparse as sp

    unary = np.asarray(unary, dtype=np.float64)
    p = unary.shape[0]
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    weights = np.asarray(weights, dtype=np.float64).reshape(-1)
    clusters = np.asarray(clusters, dtype=np.int64)
    if clusters.shape != (p,):
        raise ValueError(f"clusters has shape {clusters.shape}, expected ({p},)")
    # coarse nodes: (cluster, the label a hard-constrained node must take, else -1)
    finite = unary < INF
    pinned = np.where(finite.sum(axis=1) == 1, finite.argmax(axis=1), -1)
    coarse, coarse_edges, coarse_weights = coarsen(clusters, pinned, edges, weights)
    c = int(coarse.max()) + 1 if p else 0
    S = sp.csr_matrix((np.ones(p), (coarse, np.arange(p))), shape=(c, p))
    Uc = S @ unary
    init_c = None
    if init is not None:
        first = np.full(c, -1, np.int64)
        first[coarse[::-1]] = np.arange(p)[::-1]  # one node per coarse node
        init_c = np.asarray(init, dtype=np.int64)[first]
        bad = Uc[np.arange(c), init_c] >= INF
        init_c[bad] = np.argmin(Uc[bad], axis=1)
    labels = alpha_expansion(Uc, coarse_edges, coarse_weights, init=init_c, max_sweeps=max_sweeps)[coarse]
    # refine a band around the coarse boundaries, the rest held fixed
    i, j = edges[:, 0], edges[:, 1]
    near = np.zeros(p, bool)
    differ = labels[i] != labels[j]
    near[i[differ]] = near[j[differ]] = True
    A = pair_matrix(edges, 1.0, p)
    for _ in range(band):
        near |= (A @ near.astype(np.float64)) > 0
    nodes = np.flatnonzero(near)
    if nodes.size == 0:
        return labels
    local = np.full(p, -1, np.int64)
    local[nodes] = np.arange(nodes.size)
    Ub = unary[nodes].copy()
    inside = near[i] & near[j]
    for a, b in ((i, j), (j, i)):  # an arc to a fixed node: its weight unless the label matches
        edge = near[a] & ~near[b]
        np.add.at(Ub, local[a[edge]], weights[edge, None])
        np.subtract.at(Ub, (local[a[edge]], labels[b[edge]]), weights[edge])
    Eb = np.c_[local[i[inside]], local[j[inside]]]
    out = labels.copy()
    out[nodes] = alpha_expansion(Ub, Eb, weights[inside], init=labels[nodes], max_sweeps=max_sweeps)
    return out
