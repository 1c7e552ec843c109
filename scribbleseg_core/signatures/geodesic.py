"""Geodesic distances from every face to a sample of the surface, and what they say about
where each label lies relative to a face (the classifier's label context).

A face's label depends on what surrounds it: a leg is the thin part far from the head, a
handle the part beside the body. Given per-face label probabilities from a first
classifier, :func:`label_distances` measures, for every face and label, how far the surface
of that label is: its probability-weighted mean geodesic distance and a soft minimum. This
is the role of the contextual label features of Kalogerakis et al. 2010 (histograms of the
first classifier's labels in geodesic rings around a face), read from one set of distances.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scribbleseg_core.geometry.measures import face_areas
from scribbleseg_core.geometry.topology import face_components
from scribbleseg_core.infra.cache import ArrayCache, hash_arrays
from scribbleseg_core.signatures.agd import farthest_point_distances

#: Sources of the sample (farthest-point, heat-method distances), shared among components by area.
NUM_SOURCES = 64
#: Version of the definition, part of the cache key.
GEODESIC_VERSION = 1
#: Softness of the soft minimum, and the distance given to a label absent from a face's
#: component; both in units of the mean geodesic distance.
SOFTNESS, FAR = 0.05, 5.0


@dataclass(frozen=True)
class SourceDistances:
    """Geodesic distances from each face to a sample of the surface.

    Attributes
    ----------
    D : (S, m) float32 ndarray
        Distance from source s to face f (mean over the face's vertices) on the unit-area
        mesh; -1 where they lie in different components.
    """

    D: np.ndarray

    @property
    def source_face(self) -> np.ndarray:
        """(S,) int64: the face nearest each source (one of the faces at its vertex)."""
        return np.argmin(np.where(self.D >= 0, self.D, np.inf), axis=1)

    def source_area(self, area: np.ndarray) -> np.ndarray:
        """(S,) float64: the area of each source's geodesic Voronoi cell, from face areas (m,)."""
        nearest = np.argmin(np.where(self.D >= 0, self.D, np.inf), axis=0)
        return np.bincount(nearest, area, minlength=self.D.shape[0])

    def normalized(self, area: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The distances in units of the shape's mean geodesic distance (its area-weighted
        mean over faces and sources, each source weighted by :meth:`source_area`).

        Returns
        -------
        Dn : (S, m) float64 ndarray
            0 where a face and a source lie in different components.
        reach : (S, m) bool ndarray
            Which sources each face can reach.
        source_area : (S,) float64 ndarray
        """
        reach = self.D >= 0
        Dz = np.where(reach, self.D, 0.0).astype(np.float64)
        a = self.source_area(area)
        scale = (area * (a @ Dz)).sum() / max((area * (a @ reach)).sum(), 1e-300)
        return Dz / max(scale, 1e-12), reach, a


def source_distances(V: np.ndarray, F: np.ndarray, num_sources: int = NUM_SOURCES) -> SourceDistances:
    """Heat-method geodesic distances from farthest-point sources to every face.

    Each component gets sources in proportion to its area (at least one); the first source
    of a component is its vertex nearest the area centroid, each next the vertex farthest
    from those chosen.

    Parameters
    ----------
    V : (n, 3) float64 ndarray
        Vertices of the unit-area mesh.
    F : (m, 3) int64 ndarray
    num_sources : int

    Returns
    -------
    SourceDistances

    References
    ----------
    K. Crane, C. Weischedel, M. Wardetzky, "Geodesics in heat", ACM TOG 2013.
    """
    import potpourri3d as pp3d

    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    m = len(F)
    count, comp = face_components(F)
    fa = face_areas(V, F)
    areas = np.bincount(comp, fa, minlength=count)
    total = max(areas.sum(), 1e-300)
    rows = []
    for c in np.argsort(-areas):
        faces = np.flatnonzero(comp == c)
        verts, Fl = np.unique(F[faces], return_inverse=True)
        Fl = Fl.reshape(-1, 3)
        Vc = V[verts]
        k = min(len(verts), max(1, int(round(num_sources * areas[c] / total))))
        w = np.bincount(Fl.ravel(), np.repeat(fa[faces] / 3.0, 3), minlength=len(verts))
        try:
            solver = pp3d.MeshHeatMethodDistanceSolver(Vc, Fl, use_robust=True)
            distance = lambda s: np.asarray(solver.compute_distance(s), dtype=np.float64)  # noqa: E731
        except Exception:  # geometry-central refuses some inputs: straight-line distances
            distance = lambda s: np.linalg.norm(Vc - Vc[s], axis=1)  # noqa: E731
        block = np.full((k, m), -1.0, np.float32)
        block[:, faces] = farthest_point_distances(distance, Vc, w, k)[:, Fl].mean(axis=2)
        rows.append(block)
    return SourceDistances(np.vstack(rows))


def cached_source_distances(V: np.ndarray, F: np.ndarray, cache: ArrayCache | None = None, *,
                            compute: bool = True) -> SourceDistances | None:
    """:func:`source_distances` with :data:`NUM_SOURCES`, cached on disk (`cache`, default
    the user cache's ``geodesic`` folder), keyed by a hash of V and F. With ``compute=False``
    only the cache is read: None when they were never computed."""
    cache = cache or ArrayCache(kind="geodesic")
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    key = hash_arrays(V, F, meta={"geodesic": GEODESIC_VERSION, "sources": NUM_SOURCES})
    if not compute:
        D = cache.get(key)
        return None if D is None else SourceDistances(D)
    return SourceDistances(cache.get_or_compute(key, lambda: source_distances(V, F).D))


@dataclass(frozen=True, eq=False)
class LabelContext:
    """What :func:`label_distances` needs of one shape, prepared once: the distances in units
    of the shape's mean geodesic distance and their exponentials, so that each call with new
    probabilities is three small matrix products.

    Attributes
    ----------
    source_face : (S,) int64 ndarray
    weight : (S,) float64 ndarray
        Voronoi area of each source.
    Dn : (S, m) float32 ndarray
        Normalized distances, 0 where unreachable.
    Z : (S, m) float32 ndarray
        ``exp(−(Dn − nearest)/τ)``, 0 where unreachable; `nearest` (m,) is the distance to
        the face's nearest source.
    nearest : (m,) float64 ndarray
    reach : (S, m) bool ndarray or None
        Which sources each face can reach; None when all can (one component).
    """

    source_face: np.ndarray
    weight: np.ndarray
    Dn: np.ndarray
    Z: np.ndarray
    nearest: np.ndarray
    reach: np.ndarray | None

    @classmethod
    def of(cls, dist: SourceDistances, area: np.ndarray) -> LabelContext:
        """Prepare from a shape's :class:`SourceDistances` and its face areas (m,)."""
        Dn, reach, a = dist.normalized(area)
        nearest = np.where(reach, Dn, np.inf).min(axis=0)
        Z = np.where(reach, np.exp(-(Dn - nearest) / SOFTNESS), 0.0)
        return cls(dist.source_face, a, Dn.astype(np.float32), Z.astype(np.float32), nearest,
                   None if reach.all() else reach)

    def distances(self, proba: np.ndarray) -> np.ndarray:
        """:func:`label_distances` for per-face probabilities `proba` (m, k): (m, 2k) float64."""
        W = (self.weight[:, None] * np.asarray(proba, dtype=np.float64)[self.source_face]).astype(np.float32)
        total = W.sum(axis=0).astype(np.float64)[:, None]  # (k, 1)
        mass = total if self.reach is None else (W.T @ self.reach.astype(np.float32)).astype(np.float64)
        ok = mass > 1e-12 * max(self.weight.sum(), 1e-300)
        safe = np.where(ok, mass, 1.0)
        mean = np.where(ok, (W.T @ self.Dn) / safe, FAR)
        ratio = (W.T @ self.Z) / safe
        soft = np.where(ok & (ratio > 0), self.nearest - SOFTNESS * np.log(np.maximum(ratio, 1e-300)), FAR)
        return np.minimum(np.vstack([mean, soft]).T, FAR)


def label_distances(dist: SourceDistances, area: np.ndarray, proba: np.ndarray) -> np.ndarray:
    """How far each label lies from each face, given per-face label probabilities.

    Each source stands for its Voronoi cell, with the label probabilities of its face. For
    face f and label l, with weights ``w_s = a_s P(l | s)`` over the sources s of f's
    component:

    * the mean distance ``Σ_s w_s d(s, f) / Σ_s w_s``;
    * the soft minimum ``−τ log(Σ_s w_s exp(−d(s, f)/τ) / Σ_s w_s)``, τ = :data:`SOFTNESS`.

    Distances are divided by the area-weighted mean distance over the whole shape (so the
    values are scale invariant); a label with no weight in f's component gets :data:`FAR`.
    For repeated calls on one shape, prepare a :class:`LabelContext` once.

    Parameters
    ----------
    dist : SourceDistances
    area : (m,) float64 ndarray
        Face areas.
    proba : (m, k) float64 ndarray
        Label probabilities per face (rows summing to 1).

    Returns
    -------
    (m, 2k) float64 ndarray
        The k mean distances, then the k soft minima.
    """
    return LabelContext.of(dist, area).distances(proba)
