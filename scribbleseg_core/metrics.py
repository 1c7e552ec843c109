"""Segmentation metrics, vectorized."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def _pairs(n: np.ndarray) -> np.ndarray:
    n = np.asarray(n, dtype=np.float64)
    return n * (n - 1) / 2


def rand_index_error(a: np.ndarray, b: np.ndarray) -> float:
    """1 − Rand Index between two segmentations of the same faces, as PSB computes it.

    ``[Σ C(a_i,2) + Σ C(b_j,2) − 2 Σ C(n_ij,2)] / C(N,2)`` with segment sizes a_i, b_j
    and overlaps n_ij (face counts). Segment ids are arbitrary; renaming changes nothing.

    Parameters
    ----------
    a, b : (m,) int ndarray

    Returns
    -------
    float in [0, 1]
    """
    a = np.unique(np.asarray(a), return_inverse=True)[1].ravel()
    b = np.unique(np.asarray(b), return_inverse=True)[1].ravel()
    N = len(a)
    if N != len(b):
        raise ValueError(f"segmentations differ in length: {N} and {len(b)}")
    if N < 2:
        return 0.0
    C = sp.coo_matrix((np.ones(N), (a, b))).tocsr()
    C.sum_duplicates()
    sum_a = _pairs(np.asarray(C.sum(axis=1)).ravel()).sum()
    sum_b = _pairs(np.asarray(C.sum(axis=0)).ravel()).sum()
    sum_ab = _pairs(C.data).sum()
    return float((sum_a + sum_b - 2 * sum_ab) / _pairs(N))
