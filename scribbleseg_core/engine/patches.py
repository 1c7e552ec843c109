"""Over-segmentation into primitive patches that follow concave creases."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, dijkstra

from scribbleseg_core.geometry.dual_graph import DualGraph
from scribbleseg_core.geometry.topology import label_components


def over_segment(
    graph: DualGraph,
    num_patches: int = 50,
    *,
    scribble_labels: np.ndarray | None = None,
) -> np.ndarray:
    """Split a mesh into about `num_patches` connected patches bounded by creases.

    Every connected component of the face graph gets at least one patch (so a mesh of
    more components than `num_patches`, such as a triangle soup, gets one patch per
    component); further seeds are placed by farthest-point sampling in the crease-aware
    dual metric
    (:meth:`DualGraph.crease_distance`, where crossing a concave crease is long), and
    every face joins its nearest seed. Boundaries thus settle on concave creases where
    seeds lie on both sides. A patch holding scribbles of two labels is split between
    them (each face to its nearest scribbled face), so no patch mixes scribble labels.

    Parameters
    ----------
    graph : DualGraph
    num_patches : int
    scribble_labels : (m,) int ndarray, optional
        Scribble label per face, -1 where unscribbled.

    Returns
    -------
    patch : (m,) int64 ndarray
        Patch id per face, ``0 .. p-1``; every patch is connected.
        p ≥ min(`num_patches`, m) and p ≥ the number of components.
    """
    m = graph.num_faces
    W = graph.crease_matrix
    seeds = _farthest_point_seeds(W, min(num_patches, m))
    _, _, source = dijkstra(W, directed=False, indices=seeds, min_only=True, return_predecessors=True)
    patch = _seed_index(seeds, source)
    if scribble_labels is not None:
        patch = _split_mixed(W, patch, np.asarray(scribble_labels))
    return label_components(graph.pairs, patch)  # renumbered 0 .. p-1, each patch connected


def _seed_index(seeds: np.ndarray, source: np.ndarray) -> np.ndarray:
    lookup = np.full(max(int(seeds.max()), int(source.max())) + 1, -1, np.int64)
    lookup[seeds] = np.arange(len(seeds))
    return lookup[source]


def _farthest_point_seeds(W, k: int) -> np.ndarray:
    """Seeds by farthest-point sampling: one in every connected component first, then more
    up to k in all (or as many as there are components, if more)."""
    m = W.shape[0]
    ncomp, comp = connected_components(W, directed=False)
    firsts = np.unique(comp, return_index=True)[1]
    seeds = list(firsts) if ncomp > 1 else [0]
    d = dijkstra(W, directed=False, indices=seeds, min_only=True)
    if ncomp == 1:  # restart from the face farthest from face 0 (an extremity)
        seeds = [int(np.argmax(d))]
        d = dijkstra(W, directed=False, indices=seeds[0])
    while len(seeds) < min(k, m):
        s = int(np.argmax(d))
        if d[s] <= 0:
            break
        seeds.append(s)
        d = np.minimum(d, dijkstra(W, directed=False, indices=s))
    return np.asarray(seeds, dtype=np.int64)


def _split_mixed(W, patch: np.ndarray, scribble: np.ndarray) -> np.ndarray:
    """Split every patch whose scribbled faces carry several labels."""
    scribbled = scribble >= 0
    pairs = np.unique(np.stack([patch[scribbled], scribble[scribbled]], axis=1), axis=0)
    patches_with = np.bincount(pairs[:, 0], minlength=patch.max() + 1)
    mixed = np.flatnonzero(patches_with > 1)
    if mixed.size == 0:
        return patch
    in_mixed = np.isin(patch, mixed)
    # keep only arcs inside one mixed patch; grow from its scribbled faces
    Wc = W.tocoo()
    keep = (patch[Wc.row] == patch[Wc.col]) & in_mixed[Wc.row]
    Wm = sp.csr_matrix((Wc.data[keep], (Wc.row[keep], Wc.col[keep])), shape=W.shape)
    sources = np.flatnonzero(in_mixed & scribbled)
    _, _, src = dijkstra(Wm, directed=False, indices=sources, min_only=True, return_predecessors=True)
    out = patch.copy()
    reached = in_mixed & (src >= 0)
    # new id per (old patch, label): offset past the existing ids
    new_ids = np.unique(np.stack([patch[reached], scribble[src[reached]]], axis=1), axis=0, return_inverse=True)[1]
    out[reached] = patch.max() + 1 + new_ids.ravel()
    return out


def patch_adjacency(graph: DualGraph, patch: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Adjacent patch pairs and the length of the boundary they share.

    Returns
    -------
    pairs : (r, 2) int64 ndarray
        ``pairs[:, 0] < pairs[:, 1]``.
    boundary : (r,) float64 ndarray
    """
    a, b = patch[graph.pairs[:, 0]], patch[graph.pairs[:, 1]]
    cross = a != b
    P = np.sort(np.stack([a[cross], b[cross]], axis=1), axis=1)
    if len(P) == 0:
        return np.zeros((0, 2), np.int64), np.zeros(0)
    uniq, inv = np.unique(P, axis=0, return_inverse=True)
    return uniq.astype(np.int64), np.bincount(inv.ravel(), graph.length[cross], minlength=len(uniq))


def nearest_scribble_labels(graph: DualGraph, scribble: np.ndarray) -> np.ndarray:
    """Label of each face's nearest scribbled face in the crease-aware dual metric.

    Parameters
    ----------
    graph : DualGraph
    scribble : (m,) int ndarray
        -1 where unscribbled.

    Returns
    -------
    labels : (m,) int64 ndarray
        -1 for faces no scribble can reach (components without scribbles).
    """
    sources = np.flatnonzero(scribble >= 0)
    if sources.size == 0:
        return np.full(graph.num_faces, -1, np.int64)
    W = graph.crease_matrix
    _, _, src = dijkstra(W, directed=False, indices=sources, min_only=True, return_predecessors=True)
    return np.where(src >= 0, np.asarray(scribble)[np.maximum(src, 0)], -1).astype(np.int64)
