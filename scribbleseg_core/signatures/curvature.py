"""Gaussian curvature as angle defect over mixed (Voronoi) area."""

from __future__ import annotations

import numpy as np

from scribbleseg_core.geometry.topology import edges


def corner_angles(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Interior angle at each corner, (m, 3) float64 (0 for zero-length edges)."""
    P = V[F]
    out = np.zeros(F.shape)
    for j in range(3):
        a = P[:, (j + 1) % 3] - P[:, j]
        b = P[:, (j + 2) % 3] - P[:, j]
        cross = np.linalg.norm(np.cross(a, b), axis=1)
        out[:, j] = np.arctan2(cross, np.einsum("ij,ij->i", a, b))
    return out


def angle_defect(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Discrete Gaussian curvature integrated over each vertex's area.

    ``2π − Σθ`` at interior vertices, so Gauss–Bonnet reads ``Σ = 2π χ`` on closed
    meshes. Boundary vertices get 0: there ``π − Σθ`` is the turning of the boundary
    (geodesic curvature), not Gaussian curvature, and would make every hole's rim look
    like a sharp tip.

    Returns
    -------
    K_int : (n,) float64 ndarray
    """
    n = V.shape[0]
    theta = np.bincount(F.ravel(), corner_angles(V, F).ravel(), minlength=n)
    ed = edges(F)
    on_boundary = np.zeros(n, bool)
    on_boundary[ed.E[ed.count == 1].ravel()] = True
    return np.where(on_boundary, 0.0, 2 * np.pi - theta)


def mixed_area(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Mixed Voronoi vertex areas (Meyer et al. 2003), (n,) float64; sum = surface area."""
    import igl

    M = igl.massmatrix(V, F, igl.MASSMATRIX_TYPE_VORONOI)
    return np.asarray(M.diagonal()).ravel()


def gaussian_curvature(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pointwise Gaussian curvature per vertex and the areas it is taken over.

    Returns
    -------
    K : (n,) float64 ndarray
        Angle defect over mixed area (0 where a vertex has no area).
    A : (n,) float64 ndarray
        Mixed areas; ``(K * A).sum()`` is the total curvature.
    """
    K_int = angle_defect(V, F)
    A = mixed_area(V, F)
    K = np.divide(K_int, A, out=np.zeros_like(K_int), where=A > 0)
    return K, A


def face_gaussian_curvature(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Gaussian curvature per face, tail compressed: ``asinh(K)`` of the vertex mean.

    Meant for the unit-area mesh, where a sphere has K = 4π; asinh is linear near 0 and
    logarithmic in the tails, so a few needle vertices do not dominate the feature.

    Returns
    -------
    k : (m,) float64 ndarray
    """
    K, _ = gaussian_curvature(V, F)
    return np.arcsinh(K[F].mean(axis=1))
