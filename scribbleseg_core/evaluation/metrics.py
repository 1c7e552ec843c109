"""Segmentation metrics of the Princeton Segmentation Benchmark, vectorized.

All take two segmentations of the same faces as (m,) int arrays; segment ids are arbitrary
(renaming changes nothing) except in :func:`labeling_accuracy`. ``weights`` (m,) — face
areas for the area-weighted variants — default to 1 per face (face counts, as PSB's Rand
Index does).

References
----------
X. Chen, A. Golovinskiy, T. Funkhouser, "A benchmark for 3D mesh segmentation", ACM TOG
(SIGGRAPH) 2009.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def _contingency(a, b, weights=None):
    """Overlap table n_ij (weighted), its row and column sums, and per-face cell ids."""
    a = np.unique(np.asarray(a), return_inverse=True)[1].ravel()
    b = np.unique(np.asarray(b), return_inverse=True)[1].ravel()
    if len(a) != len(b):
        raise ValueError(f"segmentations differ in length: {len(a)} and {len(b)}")
    w = np.ones(len(a)) if weights is None else np.asarray(weights, dtype=np.float64)
    C = sp.coo_matrix((w, (a, b))).tocsr()
    C.sum_duplicates()
    return C, np.asarray(C.sum(axis=1)).ravel(), np.asarray(C.sum(axis=0)).ravel(), a, b, w


def _pairs(n) -> np.ndarray:
    n = np.asarray(n, dtype=np.float64)
    return n * (n - 1) / 2


def rand_index_error(a: np.ndarray, b: np.ndarray) -> float:
    """1 − Rand Index, over faces, as PSB computes it.

    ``[Σ C(a_i,2) + Σ C(b_j,2) − 2 Σ C(n_ij,2)] / C(N,2)`` with segment sizes a_i, b_j and
    overlaps n_ij.

    Returns
    -------
    float in [0, 1]
    """
    C, ra, cb, *_ = _contingency(a, b)
    N = ra.sum()
    if N < 2:
        return 0.0
    return float((_pairs(ra).sum() + _pairs(cb).sum() - 2 * _pairs(C.data).sum()) / _pairs(N))


def rand_index_error_area(a: np.ndarray, b: np.ndarray, area: np.ndarray) -> float:
    """Area-weighted 1 − Rand Index: a pair of faces counts with the product of their areas."""
    C, ra, cb, ia, ib, w = _contingency(a, b, area)
    sq = np.asarray(area, dtype=np.float64) ** 2

    def pairs(sums, sq_sums):  # Σ_{f<g in S} w_f w_g = (S² − Σ w²) / 2
        return (sums**2 - sq_sums) / 2

    sq_a = np.bincount(ia, sq, minlength=len(ra))
    sq_b = np.bincount(ib, sq, minlength=len(cb))
    Sq = sp.coo_matrix((sq, (ia, ib)), shape=C.shape).tocsr()
    Sq.sum_duplicates()
    total = pairs(w.sum(), sq.sum())
    if total <= 0:
        return 0.0
    cross = pairs(C.data, Sq.data).sum()  # C and Sq share their sparsity pattern
    return float((pairs(ra, sq_a).sum() + pairs(cb, sq_b).sum() - 2 * cross) / total)


def consistency_errors(a: np.ndarray, b: np.ndarray, weights: np.ndarray | None = None) -> tuple[float, float]:
    """Global and Local Consistency Error (Martin et al. 2001).

    With ``E(S1, S2, f) = |R(S1, f) \\ R(S2, f)| / |R(S1, f)|`` (R: the segment holding f):
    ``GCE = min(Σ_f E(a, b, f), Σ_f E(b, a, f)) / n`` and
    ``LCE = Σ_f min(E(a, b, f), E(b, a, f)) / n``; weighted by `weights` if given.

    Returns
    -------
    gce, lce : float in [0, 1]
    """
    C, ra, cb, _, _, w = _contingency(a, b, weights)
    C = C.tocoo()
    n_ij = C.data
    e_ab = (ra[C.row] - n_ij) / ra[C.row]
    e_ba = (cb[C.col] - n_ij) / cb[C.col]
    total = w.sum()
    gce = min((n_ij * e_ab).sum(), (n_ij * e_ba).sum()) / total
    lce = (n_ij * np.minimum(e_ab, e_ba)).sum() / total
    return float(gce), float(lce)


def hamming_distance(pred: np.ndarray, truth: np.ndarray, weights: np.ndarray | None = None) -> tuple[float, float, float]:
    """Hamming distance (Huang & Dom 1995): missing rate, false-alarm rate, their mean.

    Each truth segment is matched to the predicted segment overlapping it most; what of it
    lies outside is *missing*. Symmetrically, each predicted segment is matched to its best
    truth segment; what lies outside is a *false alarm*. Both as fractions of the total.

    Returns
    -------
    missing, false_alarm, mean : float in [0, 1]
    """
    C, rp, ct, _, _, w = _contingency(pred, truth, weights)
    total = w.sum()
    missing = (ct - np.asarray(C.max(axis=0).todense()).ravel()).sum() / total
    false_alarm = (rp - np.asarray(C.max(axis=1).todense()).ravel()).sum() / total
    return float(missing), float(false_alarm), float((missing + false_alarm) / 2)


def cut_discrepancy(V: np.ndarray, F: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Mean distance between the cut boundaries of two segmentations, over the average radius.

    Boundary points are the midpoints of edges whose two faces lie in different segments;
    the distance from each to the other segmentation's nearest boundary point is Euclidean
    (PSB uses geodesic distance; on the boundaries' scale they agree closely). The result
    is ``(mean d(Ca→Cb) + mean d(Cb→Ca)) / 2`` divided by the mean distance of the surface
    (face centroids, area-weighted) to its centroid. 0 when neither has a cut, NaN when
    only one has.
    """
    from scipy.spatial import cKDTree

    from scribbleseg_core.geometry.measures import face_areas, face_centroids
    from scribbleseg_core.geometry.topology import edges, face_adjacency

    ed = edges(F)
    pairs, edge_of_pair = face_adjacency(F, ed)
    mid = V[ed.E[edge_of_pair]].mean(axis=1)
    a, b = np.asarray(a), np.asarray(b)
    ca = mid[a[pairs[:, 0]] != a[pairs[:, 1]]]
    cb = mid[b[pairs[:, 0]] != b[pairs[:, 1]]]
    if len(ca) == 0 and len(cb) == 0:
        return 0.0
    if len(ca) == 0 or len(cb) == 0:
        return float("nan")
    d_ab = cKDTree(cb).query(ca)[0].mean()
    d_ba = cKDTree(ca).query(cb)[0].mean()
    A = face_areas(V, F)
    C = face_centroids(V, F)
    center = (C * A[:, None]).sum(0) / A.sum()
    radius = (np.linalg.norm(C - center, axis=1) * A).sum() / A.sum()
    return float((d_ab + d_ba) / 2 / radius)


def labeling_accuracy(pred: np.ndarray, truth: np.ndarray, area: np.ndarray | None = None) -> float:
    """Fraction of the surface (or of faces) whose predicted label id equals the truth's."""
    w = np.ones(len(pred)) if area is None else np.asarray(area, dtype=np.float64)
    return float(w[np.asarray(pred) == np.asarray(truth)].sum() / w.sum())


def split_components(F: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """Relabel so every segment is one connected component of same-label faces, (m,) int64."""
    from scribbleseg_core.geometry.topology import face_adjacency, label_components

    return label_components(face_adjacency(F)[0], labels)


def error_anatomy(F: np.ndarray, pred: np.ndarray, truth: np.ndarray) -> dict[str, float]:
    """Split a predicted labeling's Rand Index error into wrong names and misplaced boundaries.

    Two repairs of `pred`, each perfect in one respect and unchanged in the other:

    * ``names_right``: every connected region of `pred` takes the true label that covers most
      of its faces. Its boundaries stay where they were; what error is left comes from where
      they run (and from true parts merged into one region).
    * ``boundaries_right``: every connected region of `truth` takes the predicted label that
      covers most of its faces. The boundaries are then the true ones; what error is left
      comes from naming whole parts wrongly.

    Parameters
    ----------
    F : (m, 3) int ndarray
        The faces the labelings are of.
    pred, truth : (m,) int ndarray
        Label per face (ids as in the label map; -1 counts as a label of its own).

    Returns
    -------
    dict
        ``error`` (of `pred` as it is), ``names_right`` and ``boundaries_right``, Rand Index
        errors (:func:`rand_index_error`).
    """
    from scribbleseg_core.geometry.topology import face_adjacency, label_components

    pred, truth = np.asarray(pred), np.asarray(truth)
    if pred.shape != truth.shape or pred.shape != (len(F),):
        raise ValueError(f"labelings of shape {pred.shape} and {truth.shape} for {len(F)} faces")
    pairs = face_adjacency(F)[0]

    def majority(regions: np.ndarray, values: np.ndarray) -> np.ndarray:
        """Per face, the value most faces of its region have."""
        ids, v = np.unique(values, return_inverse=True)
        counts = sp.coo_matrix((np.ones(len(v)), (regions, v))).toarray()
        return ids[counts.argmax(axis=1)][regions]

    return {
        "error": rand_index_error(pred, truth),
        "names_right": rand_index_error(majority(label_components(pairs, pred), truth), truth),
        "boundaries_right": rand_index_error(majority(label_components(pairs, truth), pred), truth),
    }
