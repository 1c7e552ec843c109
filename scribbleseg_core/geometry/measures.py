"""Small vectorized geometry helpers on (V, F) arrays."""

from __future__ import annotations

import numpy as np


def face_areas(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Triangle areas.

    Parameters
    ----------
    V : (n, 3) float64 ndarray
    F : (m, 3) int64 ndarray

    Returns
    -------
    A : (m,) float64 ndarray
    """
    return 0.5 * np.linalg.norm(_cross(V, F), axis=1)


def face_normals(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Unit face normals; zero-area faces get (0, 0, 0).

    Returns
    -------
    N : (m, 3) float64 ndarray
    """
    c = _cross(V, F)
    norm = np.linalg.norm(c, axis=1, keepdims=True)
    return np.divide(c, norm, out=np.zeros_like(c), where=norm > 0)


def face_centroids(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Triangle centroids, (m, 3) float64."""
    return V[F].mean(axis=1)


def _cross(V, F):
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return np.cross(b - a, c - a)


def normalize(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Center on the area-weighted centroid and scale to unit surface area.

    Processing (features, patches) runs on the normalized copy; exports use the file's
    own coordinates.

    Returns
    -------
    V_unit : (n, 3) float64 ndarray
        ``(V - center) * scale``, with total area 1.
    center : (3,) float64 ndarray
    scale : float
    """
    A = face_areas(V, F)
    total = A.sum()
    if not np.isfinite(total) or total <= 0:
        raise ValueError("cannot normalize a mesh with zero surface area")
    center = (face_centroids(V, F) * A[:, None]).sum(axis=0) / total
    scale = 1.0 / np.sqrt(total)
    return (V - center) * scale, center, float(scale)
