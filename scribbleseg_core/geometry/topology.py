"""Edge and connectivity structure of triangle meshes, vectorized."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components


@dataclass(frozen=True)
class Edges:
    """Unique undirected edges of a triangle mesh.

    Attributes
    ----------
    E : (e, 2) int64 ndarray
        Vertex pairs, ``E[:, 0] < E[:, 1]``.
    count : (e,) int64 ndarray
        How many faces use each edge (1: boundary, 2: manifold interior, >2: non-manifold).
    face_edge : (m, 3) int64 ndarray
        Edge id of face corner-opposite side j (edge from ``F[:, j]`` to ``F[:, (j+1)%3]``).
    """

    E: np.ndarray
    count: np.ndarray
    face_edge: np.ndarray


def unique_rows(A: np.ndarray, **kwargs):
    """``np.unique(A, axis=0, ...)`` for small non-negative int rows, via scalar keys.

    Rows of c non-negative ints below ``base = A.max() + 1`` are encoded as one int64
    when ``base ** c`` fits; a 1-D unique is several times faster than ``axis=0``.
    """
    A = np.asarray(A, dtype=np.int64)
    base = int(A.max()) + 1 if A.size else 1
    if A.size == 0 or A.min() < 0 or base ** A.shape[1] >= 2**62:
        return np.unique(A, axis=0, **kwargs)
    key = np.zeros(A.shape[0], np.int64)
    for j in range(A.shape[1]):
        key = key * base + A[:, j]
    res = np.unique(key, **kwargs)
    res = res if isinstance(res, tuple) else (res,)
    uniq = res[0]
    rows = np.empty((uniq.size, A.shape[1]), np.int64)
    for j in range(A.shape[1] - 1, -1, -1):
        uniq, rows[:, j] = np.divmod(uniq, base)
    return (rows, *res[1:]) if len(res) > 1 else rows


def edges(F: np.ndarray) -> Edges:
    """Unique edges, their face counts and the face-to-edge map of `F` (m, 3)."""
    half = np.stack([F, np.roll(F, -1, axis=1)], axis=2).reshape(-1, 2)
    half = np.sort(half, axis=1)
    E, inverse, count = unique_rows(half, return_inverse=True, return_counts=True)
    return Edges(E, count.astype(np.int64), inverse.reshape(-1, 3).astype(np.int64))


def face_adjacency(F: np.ndarray, ed: Edges | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Pairs of faces that share an edge (every pair, also around non-manifold edges).

    Parameters
    ----------
    F : (m, 3) int64 ndarray
    ed : Edges, optional
        ``edges(F)``, if already computed.

    Returns
    -------
    pairs : (q, 2) int64 ndarray
        Face index pairs ``i < j``.
    edge_of_pair : (q,) int64 ndarray
        Id of the shared edge in ``edges(F).E``.
    """
    ed = edges(F) if ed is None else ed
    m = F.shape[0]
    edge_ids = ed.face_edge.ravel()
    face_ids = np.repeat(np.arange(m), 3)
    order = np.argsort(edge_ids, kind="stable")
    e_sorted, f_sorted = edge_ids[order], face_ids[order]
    # For every edge, pair each incident face with every later one.
    starts = np.r_[0, np.flatnonzero(np.diff(e_sorted)) + 1]
    counts = np.diff(np.r_[starts, e_sorted.size])
    pairs, eop = [], []
    for c in np.unique(counts[counts > 1]):
        sel = starts[counts == c]
        for a in range(c):
            for b in range(a + 1, c):
                pairs.append(np.stack([f_sorted[sel + a], f_sorted[sel + b]], axis=1))
                eop.append(e_sorted[sel])
    if not pairs:
        return np.zeros((0, 2), np.int64), np.zeros(0, np.int64)
    P = np.sort(np.concatenate(pairs), axis=1).astype(np.int64)
    return P, np.concatenate(eop).astype(np.int64)


def face_components(F: np.ndarray, ed: Edges | None = None) -> tuple[int, np.ndarray]:
    """Connected components of faces joined across shared edges.

    Parameters
    ----------
    F : (m, 3) int64 ndarray
    ed : Edges, optional
        ``edges(F)``, if already computed.

    Returns
    -------
    count : int
    comp : (m,) int64 ndarray
        Component id per face.
    """
    m = F.shape[0]
    P, _ = face_adjacency(F, ed)
    G = sp.coo_matrix((np.ones(len(P)), (P[:, 0], P[:, 1])), shape=(m, m))
    count, comp = connected_components(G, directed=False)
    return int(count), comp.astype(np.int64)


def label_components(pairs: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """Connected components of same-label faces.

    Parameters
    ----------
    pairs : (q, 2) int ndarray
        Adjacent faces (``face_adjacency`` or ``DualGraph.pairs``).
    labels : (m,) ndarray
        A label per face.

    Returns
    -------
    comp : (m,) int64 ndarray
        Component id per face, ``0 .. n-1``.
    """
    labels = np.asarray(labels)
    m = len(labels)
    same = labels[pairs[:, 0]] == labels[pairs[:, 1]]
    G = sp.coo_matrix((np.ones(int(same.sum())), (pairs[same, 0], pairs[same, 1])), shape=(m, m))
    return connected_components(G, directed=False)[1].astype(np.int64)


def boundary_loops(F: np.ndarray, ed: Edges | None = None) -> int:
    """Number of connected chains of boundary edges (holes)."""
    ed = edges(F) if ed is None else ed
    B = ed.E[ed.count == 1]
    if len(B) == 0:
        return 0
    verts, inv = np.unique(B.ravel(), return_inverse=True)
    inv = inv.reshape(-1, 2)
    G = sp.coo_matrix((np.ones(len(B)), (inv[:, 0], inv[:, 1])), shape=(verts.size,) * 2)
    return int(connected_components(G, directed=False)[0])
