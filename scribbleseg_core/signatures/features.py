"""The method's 22-dimensional per-face descriptor.

Columns of :func:`face_features` (all computed on the mesh centered and scaled to unit
area, so they are invariant to rotation, translation and uniform scale):

======  =========  ==============================================================
column  name       definition
======  =========  ==============================================================
0       agd        average geodesic distance / sqrt(component area), vertex mean
1       sdf        shape diameter function, Shapira-normalized to [0, 1]
2       gauss      asinh of the Gaussian curvature (angle defect / mixed area)
3-21    sihks_i    scale-invariant heat kernel signature, 19 FFT magnitudes
======  =========  ==============================================================
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np

from scribbleseg_core.geometry.laplacian import eigenpairs, laplacian
from scribbleseg_core.geometry.measures import normalize
from scribbleseg_core.geometry.topology import face_components
from scribbleseg_core.infra.cache import ArrayCache, hash_arrays
from scribbleseg_core.signatures.agd import average_geodesic_distance
from scribbleseg_core.signatures.curvature import face_gaussian_curvature
from scribbleseg_core.signatures.hks import si_hks_from_spectrum
from scribbleseg_core.signatures.sdf import normalize_sdf, raw_sdf

#: Bumped whenever a definition changes, so stale cache entries are never used.
FEATURE_VERSION = 1

FEATURE_NAMES: tuple[str, ...] = ("agd", "sdf", "gauss", *(f"sihks_{i}" for i in range(19)))
NUM_FEATURES = len(FEATURE_NAMES)
SDF_COLUMN = FEATURE_NAMES.index("sdf")


@dataclass(frozen=True)
class FeatureParams:
    """Parameters of the per-face signatures (part of the cache key)."""

    num_eigenpairs: int = 100
    sdf_rays: int = 30
    agd_sources: int = 64
    seed: int = 0


def face_features(V: np.ndarray, F: np.ndarray, params: FeatureParams = FeatureParams()) -> np.ndarray:
    """Per-face descriptor (m, 22) float64; columns in the module docstring. Deterministic."""
    return face_features_timed(V, F, params)[0]


def face_features_timed(
    V: np.ndarray, F: np.ndarray, params: FeatureParams = FeatureParams()
) -> tuple[np.ndarray, dict[str, float]]:
    """:func:`face_features` plus seconds spent per signature.

    Returns
    -------
    X : (m, 22) float64 ndarray, finite
    seconds : dict
        ``{"sihks", "sdf", "agd", "gauss"}`` -> seconds.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    Vn, _, _ = normalize(V, F)
    seconds = {}
    t = time.perf_counter()
    L, M = laplacian(Vn, F)
    evals, evecs = eigenpairs(L, M, params.num_eigenpairs)
    hks = si_hks_from_spectrum(evals, evecs)[F].mean(axis=1)
    seconds["sihks"] = time.perf_counter() - t
    t = time.perf_counter()
    sdf = normalize_sdf(raw_sdf(Vn, _outward(Vn, F), num_rays=params.sdf_rays, seed=params.seed))
    seconds["sdf"] = time.perf_counter() - t
    t = time.perf_counter()
    agd = average_geodesic_distance(Vn, F, num_sources=params.agd_sources)[F].mean(axis=1)
    seconds["agd"] = time.perf_counter() - t
    t = time.perf_counter()
    gauss = face_gaussian_curvature(Vn, F)
    seconds["gauss"] = time.perf_counter() - t
    X = np.column_stack([agd, sdf, gauss, hks])
    return np.nan_to_num(X, nan=0.0, posinf=0.0, neginf=0.0), seconds


def _outward(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Flip the faces of every component whose signed volume is negative (inward normals)."""
    count, comp = face_components(F)
    P = V[F]
    vol = np.einsum("ij,ij->i", P[:, 0], np.cross(P[:, 1], P[:, 2])) / 6.0
    flip = np.bincount(comp, vol, minlength=count) < 0
    out = F.copy()
    sel = flip[comp]
    out[sel] = out[sel][:, ::-1]
    return out


def params_key(params: FeatureParams) -> dict:
    return {"feature_version": FEATURE_VERSION, **asdict(params)}


def cached_face_features(
    V: np.ndarray, F: np.ndarray, params: FeatureParams | None = None, *, cache: ArrayCache | None = None,
    compute: bool = True,
) -> np.ndarray | None:
    """:func:`face_features`, cached on disk (:class:`~scribbleseg_core.infra.cache.ArrayCache`,
    keyed by a hash of V, F, `params` and :data:`FEATURE_VERSION`).

    With ``compute=False`` only the cache is read: None when the features were never computed.

    Returns
    -------
    X : (m, 22) float64 ndarray, or None
    """
    params = params or FeatureParams()
    cache = cache or ArrayCache()
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    key = hash_arrays(V, F, meta=params_key(params))
    if not compute:
        return cache.get(key, shape=(F.shape[0], NUM_FEATURES))
    return cache.get_or_compute(key, lambda: face_features(V, F, params), shape=(F.shape[0], NUM_FEATURES))
