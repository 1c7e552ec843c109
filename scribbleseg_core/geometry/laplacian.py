"""The Laplace–Beltrami operator and its low spectrum, on any triangle mesh."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla


def laplacian(V: np.ndarray, F: np.ndarray) -> tuple[sp.csc_matrix, sp.csc_matrix]:
    """Intrinsic-Delaunay cotangent Laplacian and lumped mass (Sharp & Crane 2020).

    Equals the cotangent Laplacian on well-shaped manifold meshes and stays positive
    semi-definite on non-manifold, skinny or zero-area input, so one code path serves all.

    Returns
    -------
    L : (n, n) sparse, positive semi-definite (weak form)
    M : (n, n) sparse diagonal, vertex areas
    """
    import robust_laplacian

    L, M = robust_laplacian.mesh_laplacian(np.ascontiguousarray(V, dtype=np.float64), np.ascontiguousarray(F, dtype=np.int64))
    return sp.csc_matrix(L), sp.csc_matrix(M)


def eigenpairs(L: sp.spmatrix, M: sp.spmatrix, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The `k` smallest generalized eigenpairs ``L φ = λ M φ``, deterministic.

    Shift-invert around a small negative shift with a fixed start vector, so the same
    mesh always gives the same basis (up to the solver's tolerance).

    Returns
    -------
    evals : (k,) float64 ndarray, ascending, clipped at 0
    evecs : (n, k) float64 ndarray, M-orthonormal
    """
    n = L.shape[0]
    k = int(min(k, n - 2))
    if k < 1:
        raise ValueError(f"mesh too small for a spectrum ({n} vertices)")
    v0 = np.ones(n) / np.sqrt(n)
    scale = float(M.diagonal().mean()) or 1.0
    evals, evecs = sla.eigsh(L, k=k, M=M, sigma=-1e-3 / scale * 1e-3, which="LM", v0=v0, tol=1e-8)
    order = np.argsort(evals)
    return np.clip(evals[order], 0.0, None), evecs[:, order]
