"""Multi-scale context for the face classifier: features diffused over the surface, and
the local extrinsic shape around each face."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from scribbleseg_core.geometry.dual_graph import DualGraph
from scribbleseg_core.geometry.measures import face_areas, face_centroids, face_normals

#: Diffusion times on the unit-area mesh; the smoothing length is about sqrt(4 t):
#: 0.09, 0.2 and 0.45 of the square root of the surface area.
DEFAULT_SCALES = (0.002, 0.01, 0.05)


def diffuse_face_values(graph: DualGraph, area: np.ndarray, X: np.ndarray, scales=DEFAULT_SCALES) -> np.ndarray:
    """Implicit heat diffusion of per-face values at several times.

    Solves ``(M + t L) Y = M X`` on the face graph, with M the face areas and L the graph
    Laplacian weighted by ``shared edge length / centroid distance`` (a finite-volume
    Laplacian), once per time t. Mass is conserved, so diffused features keep their units.

    Parameters
    ----------
    graph : DualGraph
    area : (m,) float64 ndarray
        Face areas of the unit-area mesh.
    X : (m, d) float64 ndarray
    scales : sequence of float
        Diffusion times.

    Returns
    -------
    Y : (m, d · len(scales)) float64 ndarray
    """
    m = graph.num_faces
    L = graph.laplacian()
    a = np.maximum(area, 1e-12 * max(area.mean(), 1e-300))
    M = sp.diags(a)
    out = []
    for t in scales:
        lu = sla.splu((M + t * L).tocsc())
        out.append(lu.solve(a[:, None] * X))
    return np.hstack(out) if out else np.zeros((m, 0))


#: Values per diffusion scale in :func:`local_shape`.
LOCAL_SHAPE_PER_SCALE = 5


def local_shape(V: np.ndarray, F: np.ndarray, graph: DualGraph, area: np.ndarray, scales=DEFAULT_SCALES) -> np.ndarray:
    """The extrinsic shape of the surface around each face, at each diffusion time.

    The 22 signatures are intrinsic or volumetric; these say how the surface sits in
    space. The heat diffusion of :func:`diffuse_face_values` (positive weights summing to
    one) averages, around each face, the face centroids p, their products p pᵀ and the
    unit normals n; at time t, with μ the weighted mean centroid, Σ the weighted
    covariance of the centroids and n̄ the weighted mean normal, the face gets

    * the square roots of Σ's eigenvalues over sqrt(t), ascending (3 values): how flat,
      elongated or round the surface around the face is (local PCA, as in Kalogerakis et
      al. 2010, with heat weights instead of a geodesic ball);
    * ‖n̄‖: how much the normals around it agree (1 on a plane);
    * (μ − p)·n / sqrt(t), p and n the face's own centroid and normal: a signed,
      multi-scale mean curvature, negative on convex bulges, positive in concave valleys
      (meshes oriented with outward normals, as the SDF assumes too).

    All are invariant to rotation and translation, and to scale on the unit-area mesh.

    Parameters
    ----------
    V : (n, 3) float64 ndarray
        Vertices of the unit-area mesh.
    F : (m, 3) int64 ndarray
    graph : DualGraph
        Its face graph.
    area : (m,) float64 ndarray
        Its face areas.
    scales : sequence of float
        Diffusion times.

    Returns
    -------
    (m, 5 · len(scales)) float64 ndarray
        Per scale: the 3 eigenvalue terms, ‖n̄‖, the normal offset.
    """
    P, N = face_centroids(V, F), face_normals(V, F)
    i, j = np.triu_indices(3)
    columns = np.hstack([P, P[:, i] * P[:, j], N])  # 3 + 6 + 3
    D = diffuse_face_values(graph, area, columns, scales)
    out = []
    for s, t in enumerate(scales):
        mu, second, mean_normal = np.split(D[:, 12 * s : 12 * (s + 1)], [3, 9], axis=1)
        cov = np.empty((len(P), 3, 3))
        cov[:, i, j] = second - mu[:, i] * mu[:, j]
        cov[:, j, i] = cov[:, i, j]
        spread = np.sqrt(np.clip(np.linalg.eigvalsh(cov), 0.0, None) / t)
        offset = np.einsum("ij,ij->i", mu - P, N) / np.sqrt(t)
        out += [spread, np.linalg.norm(mean_normal, axis=1)[:, None], offset[:, None]]
    return np.hstack(out) if out else np.zeros((len(P), 0))


def tangent_gradients(V: np.ndarray, F: np.ndarray, graph: DualGraph, Y: np.ndarray) -> np.ndarray:
    """The gradient of each column of the per-face values `Y` in each face's tangent plane.

    Least squares over the directional differences to the adjacent faces' centroids, each
    divided by the centroids' distance (projected on the face's plane), so every neighbour
    counts alike; exact for a function linear over a flat neighbourhood. A face with one
    neighbour gets the derivative along that neighbour's direction only.

    Parameters
    ----------
    V, F : the mesh
    graph : DualGraph
    Y : (m, c) float64 ndarray

    Returns
    -------
    (m, 3, c) float64 ndarray
        Orthogonal to the face normals; per unit length of `V`.
    """
    C = face_centroids(V, F)
    N = face_normals(V, F)
    P = np.vstack([graph.pairs, graph.pairs[:, ::-1]])
    f, j = P[:, 0], P[:, 1]
    d = C[j] - C[f]
    d -= (d * N[f]).sum(1, keepdims=True) * N[f]
    length = np.maximum(np.linalg.norm(d, axis=1), 1e-12)
    u = d / length[:, None]
    m = len(F)
    A = np.zeros((m, 3, 3))
    np.add.at(A, f, u[:, :, None] * u[:, None, :])
    # the normal component is pinned to zero by an equation as heavy as the rest
    A += np.maximum(np.trace(A, axis1=1, axis2=2), 1.0)[:, None, None] * N[:, :, None] * N[:, None, :]
    A += 1e-9 * np.eye(3)
    diff = (Y[j] - Y[f]) / length[:, None]  # (2q, c) directional derivatives
    b = np.zeros((m, 3, Y.shape[1]))
    np.add.at(b, f, u[:, :, None] * diff[:, None, :])
    return np.linalg.solve(A, b)


def surface_slopes(V: np.ndarray, F: np.ndarray, graph: DualGraph, Y: np.ndarray) -> np.ndarray:
    """How steeply each of the per-face values `Y` changes along the surface at each face.

    The log of the length of :func:`tangent_gradients` plus a tenth of the column's
    area-weighted mean length. Where a limb leaves a body the shape diameter and the
    distances change fastest; inside a part they barely change.

    Parameters
    ----------
    V, F : the unit-area mesh
    graph : DualGraph
    Y : (m, c) float64 ndarray

    Returns
    -------
    (m, c) float64 ndarray
    """
    norm = np.linalg.norm(tangent_gradients(V, F, graph, Y), axis=1)
    area = face_areas(V, F)
    mean = (area[:, None] * norm).sum(0) / max(area.sum(), 1e-300)
    return np.log(norm + 0.1 * np.maximum(mean, 1e-12))
