"""Per-shape data the engine works on: features, dual graph, patches, scribbles."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from scribbleseg_core.engine.patches import over_segment, patch_adjacency
from scribbleseg_core.formats.mesh import Mesh
from scribbleseg_core.geometry.dual_graph import DualGraph, dual_graph
from scribbleseg_core.geometry.measures import face_areas
from scribbleseg_core.infra.cache import ArrayCache, hash_arrays
from scribbleseg_core.signatures.context import LOCAL_SHAPE_PER_SCALE
from scribbleseg_core.signatures.features import NUM_FEATURES, SDF_COLUMN, FeatureParams, cached_face_features
from scribbleseg_core.signatures.geodesic import LabelContext, SourceDistances, cached_source_distances
from scribbleseg_core.signatures.self_similarity import NUM_BANDS


@dataclass(frozen=True, eq=False)
class ShapeData:
    """One shape, ready for the optimization. Face arrays index the repaired faces.

    Attributes
    ----------
    mesh : Mesh
    X : (m, 22) float64 ndarray
        Face features.
    area : (m,) float64 ndarray
        Face areas of the unit-area mesh.
    graph : DualGraph
    scribble : (m,) int64 ndarray
        Scribble label per face (collection label ids), -1 where unscribbled.
    target_patches : int
        About how many primitive patches :attr:`patch` splits the shape into.
    """

    mesh: Mesh
    X: np.ndarray
    area: np.ndarray
    graph: DualGraph
    scribble: np.ndarray
    target_patches: int = 50
    context_cache: ArrayCache | None = field(default=None, repr=False, compare=False)
    geodesic_cache: ArrayCache | None = field(default=None, repr=False, compare=False)
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def patch(self) -> np.ndarray:
        """(m,) int64 patch id per face (:func:`~scribbleseg_core.engine.patches.over_segment`,
        strokes of different labels never in one patch); computed on first use, since only the
        paper's patch-level variant needs it."""
        if "patch" not in self._cache:
            scribble = self.scribble if (self.scribble >= 0).any() else None
            self._cache["patch"] = over_segment(self.graph, self.target_patches, scribble_labels=scribble)
        return self._cache["patch"]

    @property
    def patch_pairs(self) -> np.ndarray:
        """(r, 2) int64 adjacent patches."""
        if "patch_pairs" not in self._cache:
            self._cache["patch_pairs"] = patch_adjacency(self.graph, self.patch)[0]
        return self._cache["patch_pairs"]

    def network_input(self, context_scales: tuple[float, ...] = (), local_shape: bool = False) -> np.ndarray:
        """:func:`network_input` of this shape, kept per scales (with the local shape at
        those scales if `local_shape`)."""
        key = ("input", tuple(context_scales), local_shape)
        if key not in self._cache:
            mesh = (self.mesh.normalized(), self.mesh.F) if local_shape else None
            self._cache[key] = network_input(self.X, self.area, self.graph, context_scales, local_shape_of=mesh,
                                             sources=self.source_distances if context_scales else None,
                                             cache=self.context_cache)
        return self._cache[key]

    @property
    def source_distances(self) -> SourceDistances:
        """Geodesic distances from a sample of the surface to every face
        (:func:`~scribbleseg_core.signatures.geodesic.cached_source_distances`, cached on
        disk), kept."""
        if "sources" not in self._cache:
            self._cache["sources"] = cached_source_distances(self.mesh.normalized(), self.mesh.F, self.geodesic_cache)
        return self._cache["sources"]

    @property
    def label_context(self) -> LabelContext:
        """The learner's label context of this shape, prepared from its geodesic distances to a
        sample of the surface (:func:`~scribbleseg_core.signatures.geodesic.cached_source_distances`,
        cached on disk) and kept."""
        if "label_context" not in self._cache:
            self._cache["label_context"] = LabelContext.of(self.source_distances, self.area)
        return self._cache["label_context"]

    @property
    def sdf(self) -> np.ndarray:
        """(m,) float64: the shape diameter column of `X`."""
        return self.X[:, SDF_COLUMN]

    @property
    def name(self) -> str:
        return self.mesh.name

    @property
    def num_patches(self) -> int:
        return int(self.patch.max()) + 1

    @property
    def is_scribbled(self) -> bool:
        return bool((self.scribble >= 0).any())

    @property
    def scribbled_labels(self) -> np.ndarray:
        """Sorted label ids scribbled on this shape."""
        return np.unique(self.scribble[self.scribble >= 0])

    def patch_matrix(self) -> sp.csr_matrix:
        """Indicator (p, m): row i sums face values over patch i."""
        m = len(self.patch)
        return sp.csr_matrix((np.ones(m), (self.patch, np.arange(m))), shape=(self.num_patches, m))


#: The signatures diffused at the coarser context scales (all but the first), and whose
#: slopes the network reads at every scale: those of a region rather than of fine surface
#: detail, the average geodesic distance, the shape diameter, the Gaussian curvature and the
#: two lowest SI-HKS frequencies. The SI-HKS's higher frequencies, averaged over a tenth of a
#: shape, describe the texture of a region that only the few training shapes share: a network
#: reading them there tells the training shapes apart rather than their parts.
REGION_COLUMNS = (0, 1, 2, 3, 4)


def network_input_width(num_scales: int, local_shape: bool) -> int:
    """d, the length of :func:`network_input` per face: the 22 signatures, them diffused
    at the first of `num_scales` scales, the :data:`REGION_COLUMNS` diffused at each other
    scale, 5 local-shape values and 5 slopes a scale with `local_shape`, and the
    self-similarity's bands with any scale (:class:`ShapeData` gives it the geodesic sample)."""
    if not num_scales:
        return NUM_FEATURES
    return (2 * NUM_FEATURES + len(REGION_COLUMNS) * (num_scales - 1) + NUM_BANDS
            + ((LOCAL_SHAPE_PER_SCALE + len(REGION_COLUMNS)) * num_scales if local_shape else 0))


def network_input(
    X: np.ndarray,
    area: np.ndarray,
    graph: DualGraph,
    context_scales: tuple[float, ...] = (),
    *,
    local_shape_of: tuple[np.ndarray, np.ndarray] | None = None,
    sources: SourceDistances | None = None,
    cache: ArrayCache | None = None,
) -> np.ndarray:
    """The classifier's input per face: the 22 signatures, then the same diffused at the
    first of `context_scales` and the :data:`REGION_COLUMNS` of them diffused at each other
    scale (see :mod:`scribbleseg_core.signatures.context`), then (given the mesh) the local
    shape and the slopes of the region signatures at each scale, then (given the geodesic
    sources) the self-similarity of the signatures diffused at the first scale
    (:mod:`scribbleseg_core.signatures.self_similarity`).

    The parts beyond the signatures are cached on disk (`cache`, default the user cache's
    ``context`` folder): each costs 0.1–2 s a shape and holds the interpreter meanwhile.

    Parameters
    ----------
    X : (m, 22) float64 ndarray
    area : (m,) float64 ndarray
        Face areas of the unit-area mesh.
    graph : DualGraph
    context_scales : tuple of float
    local_shape_of : ((n, 3) float64 ndarray, (m, 3) int64 ndarray), optional
        V and F of the unit-area mesh: append :func:`~scribbleseg_core.signatures.context.local_shape`
        and :func:`~scribbleseg_core.signatures.context.surface_slopes`.
    sources : SourceDistances, optional
        The shape's geodesic sample: append the
        :func:`~scribbleseg_core.signatures.self_similarity.self_similarity` (with at least
        one context scale).

    Returns
    -------
    (m, :func:`network_input_width`) float64 ndarray
        With s = len(context_scales) ≥ 1: 22 + 22 + 5 · (s − 1) signature columns, then
        5 · s local-shape and 5 · s slope columns with `local_shape_of`, then 5
        self-similarity bands with `sources`; 22 columns with no scale.
    """
    from scribbleseg_core.signatures.context import diffuse_face_values, local_shape, surface_slopes
    from scribbleseg_core.signatures.self_similarity import self_similarity

    scales = tuple(float(t) for t in context_scales)
    cache = cache or ArrayCache(kind="context")
    region_columns = list(REGION_COLUMNS)

    def diffuse():
        first = diffuse_face_values(graph, area, X, scales[:1])
        return np.hstack([first, diffuse_face_values(graph, area, X[:, region_columns], scales[1:])])

    diffused = cache.get_or_compute(
        hash_arrays(X, area, graph.pairs, meta={"context": list(scales), "region": region_columns}),
        diffuse,
        shape=(len(X), X.shape[1] * min(len(scales), 1) + len(region_columns) * max(len(scales) - 1, 0)),
    )
    parts = [X, diffused]
    if local_shape_of is not None:
        V, F = local_shape_of
        parts.append(cache.get_or_compute(
            hash_arrays(V, F, meta={"local_shape": list(scales), "version": 1}),
            lambda: local_shape(V, F, graph, area, scales),
            shape=(len(X), LOCAL_SHAPE_PER_SCALE * len(scales)),
        ))
        # the region signatures diffused at every scale: at the first among all 22, beyond it alone
        region = np.hstack([diffused[:, region_columns], diffused[:, X.shape[1]:]]) if scales else diffused
        parts.append(cache.get_or_compute(
            hash_arrays(V, F, region, meta={"slopes": 1}),
            lambda: surface_slopes(V, F, graph, region),
            shape=(len(X), len(REGION_COLUMNS) * len(scales)),
        ))
    if sources is not None and scales:
        first = diffused[:, : X.shape[1]]
        parts.append(cache.get_or_compute(
            hash_arrays(first, area, sources.D, meta={"self_similarity": 1}),
            lambda: self_similarity(first, area, sources),
            shape=(len(X), NUM_BANDS),
        ))
    return np.hstack(parts)


def prepare_shape(
    mesh: Mesh,
    file_scribble: np.ndarray | None = None,
    *,
    num_patches: int = 50,
    feature_params: FeatureParams = FeatureParams(),
    cache: ArrayCache | None = None,
    X: np.ndarray | None = None,
) -> ShapeData:
    """Features (cached) and dual graph of one shape; its patches are made when first used.

    Parameters
    ----------
    mesh : Mesh
    file_scribble : (m0,) int ndarray, optional
        Scribble label per *file* face (-1 unscribbled), as from ``Scribbles.face_labels``.
    num_patches : int
    feature_params : FeatureParams
    cache : ArrayCache, optional
    X : (m, 22) ndarray, optional
        Precomputed face features (skips the cache).
    """
    V = mesh.normalized()
    F = mesh.F
    if X is None:
        X = cached_face_features(mesh.V, F, feature_params, cache=cache)
    scribble = np.full(len(F), -1, np.int64)
    if file_scribble is not None:
        # a repaired face is scribbled if its own file face was
        scribble = np.asarray(file_scribble, dtype=np.int64)[mesh.proc_to_file]
    graph = dual_graph(V, F)
    # the context and geodesic caches sit beside a given feature cache (else the user cache's)
    beside = (lambda kind: None) if cache is None else (
        lambda kind: ArrayCache(cache.folder.parent / f"{cache.folder.name}-{kind}"))
    return ShapeData(mesh, X, face_areas(V, F), graph, scribble, num_patches, beside("context"), beside("geodesic"))
