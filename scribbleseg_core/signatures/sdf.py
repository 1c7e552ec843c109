"""Shape diameter function (Shapira, Shamir, Cohen-Or 2008), cast with Embree."""

from __future__ import annotations

import numpy as np

from scribbleseg_core.geometry.measures import face_areas, face_centroids, face_normals

#: Half-angle of the ray cone (the paper's 120° cone).
CONE_HALF_ANGLE = np.deg2rad(60.0)


def ray_pattern(num_rays: int = 30, half_angle: float = CONE_HALF_ANGLE) -> np.ndarray:
    """Unit directions spread evenly (Fibonacci spiral, equal solid angle) over a cone about +z.

    Returns
    -------
    D : (r, 3) float64 ndarray
        ``D[:, 2] = cos θ_i``, all ``θ_i`` in (0, half_angle).
    """
    i = np.arange(num_rays) + 0.5
    cos_t = 1.0 - i / num_rays * (1.0 - np.cos(half_angle))
    sin_t = np.sqrt(1.0 - cos_t**2)
    phi = i * np.pi * (3.0 - np.sqrt(5.0))
    return np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], axis=1)


def ray_weights(D: np.ndarray) -> np.ndarray:
    """Shapira's weights: inverse angle between each ray and the cone axis, (r,) float64."""
    return 1.0 / np.arccos(np.clip(D[:, 2], -1.0, 1.0))


def robust_weighted_mean(lengths: np.ndarray, weights: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Per face weighted mean of ray lengths after dropping outliers.

    A length is kept if valid and within ``median ± max(1.5·MAD·1.4826, 0.1·median)`` of
    the face's valid lengths (MAD: median absolute deviation; the floor keeps rays whose
    spread is tiny but non-zero).

    Parameters
    ----------
    lengths : (m, r) float64 ndarray
    weights : (r,) float64 ndarray
    valid : (m, r) bool ndarray

    Returns
    -------
    sdf : (m,) float64 ndarray
        NaN where a face has no valid ray.
    """
    L = np.where(valid, lengths, np.nan)
    with np.errstate(all="ignore"), _quiet():
        med = np.nanmedian(L, axis=1, keepdims=True)
        mad = np.nanmedian(np.abs(L - med), axis=1, keepdims=True) * 1.4826
        spread = np.maximum(1.5 * mad, 0.1 * med)
        keep = valid & (np.abs(L - med) <= spread)
        w = np.where(keep, weights[None, :], 0.0)
        wsum = w.sum(axis=1)
        out = np.where(wsum > 0, (np.where(keep, L, 0.0) * w).sum(axis=1) / np.where(wsum > 0, wsum, 1), np.nan)
    return out


class _quiet:
    def __enter__(self):
        import warnings

        self._w = warnings.catch_warnings()
        self._w.__enter__()
        warnings.simplefilter("ignore", RuntimeWarning)

    def __exit__(self, *exc):
        self._w.__exit__(*exc)


def raw_sdf(V: np.ndarray, F: np.ndarray, *, num_rays: int = 30, seed: int = 0) -> np.ndarray:
    """Shape diameter per face in mesh units: the robust weighted mean ray length.

    From each face centroid, `num_rays` rays inside a 120° cone around the inward normal
    (the same pattern for every face, turned about the normal by a seeded random angle)
    are cast with Embree. A ray counts only if its first hit is a face seen from inside
    (the hit face's outward normal points along the ray); Shapira et al. drop the others
    as false intersections. Faces left without a valid ray get NaN.

    Parameters
    ----------
    V : (n, 3) float64 ndarray
    F : (m, 3) int64 ndarray
        Outward-oriented faces.

    Returns
    -------
    sdf : (m,) float64 ndarray

    References
    ----------
    L. Shapira, A. Shamir, D. Cohen-Or, "Consistent mesh partitioning and skeletonisation
    using the shape diameter function", The Visual Computer 2008.
    """
    N = face_normals(V, F)
    C = face_centroids(V, F)
    m = F.shape[0]
    D = ray_pattern(num_rays)
    edge = V[F[:, 1]] - V[F[:, 0]]
    dirs = _orient_pattern(D, -N, edge, np.random.default_rng(seed).uniform(0, 2 * np.pi, m))
    eps = 1e-6 * np.sqrt(max(face_areas(V, F).sum(), 1e-30))
    origins = np.repeat(C - eps * N, num_rays, axis=0)
    rays = dirs.reshape(-1, 3)
    hit = _intersect_first(V, F, origins, rays)
    length = np.full(hit.shape, np.inf)
    ok = hit >= 0
    h = hit[ok]
    Nh = N[h]
    denom = np.einsum("ij,ij->i", rays[ok], Nh)
    P0 = V[F[h, 0]]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.einsum("ij,ij->i", P0 - origins[ok], Nh) / denom
    length[ok] = t
    valid = np.zeros(hit.shape, bool)
    valid[ok] = (denom > 0) & np.isfinite(t) & (t > 0)
    return robust_weighted_mean(length.reshape(m, num_rays), ray_weights(D), valid.reshape(m, num_rays))


def _orient_pattern(D: np.ndarray, axis: np.ndarray, edge: np.ndarray, roll: np.ndarray) -> np.ndarray:
    """Map pattern `D` (r, 3) into each face's frame: +z onto `axis`, +x along `edge`
    turned by `roll` (all (m, 3) / (m,)).

    The frame is the face's own (its first edge), so rotating the mesh rotates the rays
    with it and the SDF is rotation invariant.

    Returns
    -------
    dirs : (m, r, 3) float64 ndarray
    """
    norm = np.linalg.norm(axis, axis=1, keepdims=True)
    a = np.where(norm > 0, axis / np.where(norm > 0, norm, 1.0), [[0.0, 0.0, -1.0]])
    u = edge - np.einsum("ij,ij->i", edge, a)[:, None] * a
    un = np.linalg.norm(u, axis=1, keepdims=True)
    helper = np.where(np.abs(a[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    fallback = np.cross(a, helper)  # degenerate faces only
    u = np.where(un > 1e-12, u / np.where(un > 1e-12, un, 1.0), fallback / np.linalg.norm(fallback, axis=1, keepdims=True))
    v = np.cross(a, u)
    c, s = np.cos(roll)[:, None], np.sin(roll)[:, None]
    u, v = c * u + s * v, -s * u + c * v
    return D[None, :, 0:1] * u[:, None] + D[None, :, 1:2] * v[:, None] + D[None, :, 2:3] * a[:, None]


def _intersect_first(V, F, origins, dirs) -> np.ndarray:
    """Index of the first face each ray hits (-1 for none), with Embree through trimesh."""
    import trimesh
    from trimesh.ray.ray_pyembree import RayMeshIntersector

    mesh = trimesh.Trimesh(V, F, process=False, validate=False)
    return np.asarray(RayMeshIntersector(mesh).intersects_first(origins, dirs), dtype=np.int64)


def normalize_sdf(sdf: np.ndarray, *, alpha: float = 4.0) -> np.ndarray:
    """Shapira's normalization: to [0, 1] by min/max, then ``log(x·α + 1) / log(α + 1)``.

    NaN entries (faces with no valid ray) are first filled with the median.

    Returns
    -------
    s : (m,) float64 ndarray in [0, 1]
    """
    sdf = np.asarray(sdf, dtype=np.float64).copy()
    finite = np.isfinite(sdf)
    sdf[~finite] = np.median(sdf[finite]) if finite.any() else 0.0
    lo, hi = sdf.min(), sdf.max()
    x = (sdf - lo) / (hi - lo) if hi > lo else np.zeros_like(sdf)
    return np.log1p(x * alpha) / np.log1p(alpha)
