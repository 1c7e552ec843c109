"""The face (dual) graph of a mesh with crease-aware edge lengths and weights."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from scribbleseg_core.geometry.measures import face_centroids, face_normals
from scribbleseg_core.geometry.topology import edges, face_adjacency

#: Convex creases count this fraction of concave ones (Katz & Tal 2003 use 0.1-0.2).
CONVEX_FACTOR = 0.1


@dataclass(frozen=True)
class DualGraph:
    """Faces as nodes, shared edges as arcs.

    Attributes
    ----------
    pairs : (q, 2) int64 ndarray
        Adjacent face pairs.
    length : (q,) float64 ndarray
        Length of the shared mesh edge.
    centroid_dist : (q,) float64 ndarray
        Distance between the two face centroids.
    bend : (q,) float64 ndarray
        ``1 - cos θ`` of the dihedral angle θ between the two normals, in [0, 2].
    concave : (q,) bool ndarray
        Whether the crease is concave (a valley) rather than convex (a ridge).
    num_faces : int
    """

    pairs: np.ndarray
    length: np.ndarray
    centroid_dist: np.ndarray
    bend: np.ndarray
    concave: np.ndarray
    num_faces: int

    def concavity(self, convex: float = CONVEX_FACTOR) -> np.ndarray:
        """The bend where the crease is concave, ``convex · bend`` where it is convex;
        (q,) float64 in [0, 2]."""
        return np.where(self.concave, self.bend, convex * self.bend)

    def crease_distance(self, delta: float = 0.5) -> np.ndarray:
        """Katz–Tal arc length: ``δ·geo/mean(geo) + (1-δ)·ang/mean(ang)``, (q,) float64,
        with ``ang`` the :meth:`concavity` at the default convex factor."""
        geo = self.centroid_dist / max(pair_mean(self.centroid_dist), 1e-300)
        concavity = self.concavity()
        ang_mean = pair_mean(concavity)
        ang = concavity / ang_mean if ang_mean > 0 else np.zeros_like(geo)
        return delta * geo + (1 - delta) * ang + 1e-12

    def crease_potts_weights(self, smoothness: float, crease: float, convex: float = CONVEX_FACTOR) -> np.ndarray:
        """Potts weight per face pair, ``smoothness · (ℓ / mean ℓ) · exp(−concavity /
        crease)`` with the :meth:`concavity` at factor `convex`: cutting along a concave
        crease is cheap, across a smooth or convex region dear; (q,) float64."""
        return smoothness * self.relative_length * np.exp(-self.concavity(convex) / crease)

    @cached_property
    def relative_length(self) -> np.ndarray:
        """``ℓ / mean ℓ`` per face pair, (q,) float64: the length factor of every Potts weight."""
        return self.length / max(pair_mean(self.length), 1e-300)

    @cached_property
    def crease_matrix(self) -> sp.csr_matrix:
        """``matrix(crease_distance())``, built once per graph (patches and the geodesic
        scribble cue both walk it)."""
        return self.matrix(self.crease_distance())

    @cached_property
    def centroid_matrix(self) -> sp.csr_matrix:
        """``matrix(centroid_dist)``, the surface metric between adjacent faces (built once)."""
        return self.matrix(self.centroid_dist + 1e-12)

    @property
    def diffusion_weights(self) -> np.ndarray:
        """Finite-volume arc weights ``shared edge length / centroid distance``, (q,) float64."""
        return self.length / np.maximum(self.centroid_dist, 1e-12)

    def laplacian(self, weights: np.ndarray | None = None) -> sp.csr_matrix:
        """Graph Laplacian ``D − W``, (m, m) csr, with arc weights `weights` (q,); by default
        :attr:`diffusion_weights`."""
        return pair_laplacian(self.pairs, self.diffusion_weights if weights is None else weights, self.num_faces)

    def matrix(self, values: np.ndarray) -> sp.csr_matrix:
        """Symmetric sparse (m, m) matrix with `values` (q,) on the arcs."""
        return pair_matrix(self.pairs, values, self.num_faces)


def dual_graph(V: np.ndarray, F: np.ndarray) -> DualGraph:
    """Build the :class:`DualGraph` of mesh (V, F)."""
    ed = edges(F)
    pairs, edge_of_pair = face_adjacency(F, ed)
    E = ed.E[edge_of_pair]
    length = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    C = face_centroids(V, F)
    N = face_normals(V, F)
    i, j = pairs[:, 0], pairs[:, 1]
    cos = np.clip(np.einsum("ij,ij->i", N[i], N[j]), -1.0, 1.0)
    bend = 1.0 - cos
    # concave when the neighbour's centroid lies above this face's tangent plane
    concave = np.einsum("ij,ij->i", C[j] - C[i], N[i]) > 1e-12 * np.maximum(length, 1e-300)
    return DualGraph(pairs, length, np.linalg.norm(C[i] - C[j], axis=1), bend, concave, F.shape[0])


def pair_matrix(pairs: np.ndarray, values: np.ndarray, n: int) -> sp.csr_matrix:
    """Symmetric sparse (n, n) matrix with `values` (q,) at the node pairs `pairs` (q, 2) and
    their mirror images (values of a repeated pair add up)."""
    i, j = pairs[:, 0], pairs[:, 1]
    values = np.broadcast_to(np.asarray(values, dtype=np.float64), (len(pairs),))
    return sp.coo_matrix((np.r_[values, values], (np.r_[i, j], np.r_[j, i])), shape=(n, n)).tocsr()


def pair_laplacian(pairs: np.ndarray, weights: np.ndarray, n: int) -> sp.csr_matrix:
    """Graph Laplacian ``D − W``, (n, n) csr, of the node pairs `pairs` (q, 2) with arc weights
    `weights` (q,)."""
    W = pair_matrix(pairs, weights, n)
    return (sp.diags(np.asarray(W.sum(axis=1)).ravel()) - W).tocsr()


def pair_mean(values: np.ndarray) -> float:
    """Mean of a per-pair array, (q,) → float; 0 for a graph without pairs (a triangle soup)."""
    return float(values.sum()) / max(values.size, 1)
