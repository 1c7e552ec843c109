"""Rigid co-alignment of a collection's shapes, so that face positions carry over between them.

The shapes of a collection are rarely turned the same way (in the PSB categories a part's
mean position varies across shapes as much as its distance from the center). Each shape is
reduced to a point cloud: area-weighted samples of its face centroids, centered, in units of
its RMS radius, expressed in its principal axes. Principal axes fix a frame only up to the
order and signs of the axes, so a cloud is aligned to reference clouds by trying the 48
signed axis permutations (rotations and reflections: part labels do not depend on
handedness), each refined by a short ICP (rotation only) on a small sample, since principal
axes of nearly equal variance leave the frame free to turn between them; the map of least
symmetric chamfer distance to the references' points wins and is refined by ICP against all
reference points together.

:func:`co_align` aligns a set of shapes among themselves (each to the ones before it, then
each once more to all the others); :func:`align_to` aligns a new shape to aligned references.

References
----------
P. J. Besl, N. D. McKay, "A method for registration of 3-D shapes", IEEE TPAMI 14(2), 1992.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

#: Points per cloud; the candidate search uses the first :data:`SEARCH_POINTS` of them (its
#: ICP half of those), against those of at most :data:`SEARCH_REFERENCES` reference clouds
#: (evenly spaced among those given) together.
CLOUD_POINTS = 1000
SEARCH_POINTS = 200
SEARCH_REFERENCES = 8
#: Iterations of the search's ICP from every candidate; the final ICP reads at most
#: :data:`ICP_POINTS` reference points.
SEARCH_ITERATIONS = 8
ICP_POINTS = 4000


def _signed_permutations() -> np.ndarray:
    """(48, 3, 3): every matrix with one ±1 per row and column."""
    out = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            C = np.zeros((3, 3))
            C[list(perm), range(3)] = signs
            out.append(C)
    return np.array(out)


_CANDIDATES = _signed_permutations()


@dataclass(frozen=True, eq=False)
class PrincipalCloud:
    """A shape in its own principal frame.

    Attributes
    ----------
    points : (n, 3) float64 ndarray
        Area-weighted samples of face centroids, ``(c − center) @ axes / rms``.
    center : (3,) float64 ndarray
        Area-weighted centroid of the faces.
    axes : (3, 3) float64 ndarray
        Principal axes as columns, by decreasing variance.
    rms : float
        Area-weighted RMS distance of the face centroids from `center`.
    """

    points: np.ndarray
    center: np.ndarray
    axes: np.ndarray
    rms: float

    @classmethod
    def of(cls, V: np.ndarray, F: np.ndarray, area: np.ndarray, n: int = CLOUD_POINTS, seed: int = 0) -> PrincipalCloud:
        """The cloud of a mesh (V (n_v, 3), F (m, 3)) with face areas `area` (m,); deterministic."""
        c = np.asarray(V, dtype=np.float64)[F].mean(axis=1)
        w = np.asarray(area, dtype=np.float64)
        w = w / w.sum()
        center = w @ c
        d = c - center
        cov = (d * w[:, None]).T @ d
        rms = float(np.sqrt(max(np.trace(cov), 1e-300)))
        axes = np.linalg.eigh(cov)[1][:, ::-1]
        idx = np.random.default_rng(seed).choice(len(c), size=n, p=w)
        return cls(d[idx] @ axes / rms, center, axes, rms)

    def positions(self, V: np.ndarray, F: np.ndarray, rotation: np.ndarray) -> np.ndarray:
        """Face centroids of (V, F) in the aligned frame, units of the RMS radius, (m, 3)."""
        c = np.asarray(V, dtype=np.float64)[F].mean(axis=1)
        return (c - self.center) @ self.axes / self.rms @ rotation


def _icp(A: np.ndarray, target: np.ndarray, tree: cKDTree, iterations: int = 20) -> np.ndarray:
    """Rotation R (3, 3), det +1, so that ``A @ R`` lies on `target` (closest-point ICP;
    `tree` indexes `target`)."""
    R = np.eye(3)
    for _ in range(iterations):
        Y = target[tree.query(A @ R)[1]]
        U, _, Vt = np.linalg.svd(A.T @ Y)
        D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt)) or 1.0])
        R_new = U @ D @ Vt
        done = np.allclose(R_new, R, atol=1e-7)
        R = R_new
        if done:
            break
    return R


def align_to(points: np.ndarray, references: Sequence[np.ndarray]) -> np.ndarray:
    """The map (3, 3) that aligns a principal-frame cloud to aligned reference clouds.

    Parameters
    ----------
    points : (n, 3) float ndarray
        :attr:`PrincipalCloud.points` of the shape.
    references : sequence of (n_r, 3) float ndarray
        Clouds already aligned (their points times their maps); at least one. The candidate
        search reads up to :data:`SEARCH_REFERENCES` of them, ICP all.

    Returns
    -------
    (3, 3) float64 ndarray
        Orthogonal (a reflection when a mirrored permutation fits best); ``points @ M`` is
        aligned.
    """
    if not len(references):
        raise ValueError("align_to needs at least one reference cloud")
    refs = [np.asarray(r, dtype=np.float64) for r in references]
    step = max(1, -(-len(refs) // SEARCH_REFERENCES))
    union = np.vstack([r[:SEARCH_POINTS] for r in refs[::step]])
    tree_u = cKDTree(union)
    q = np.asarray(points, dtype=np.float64)[:SEARCH_POINTS]
    # a short ICP from every candidate at once, on half the sample
    head = q[:SEARCH_POINTS // 2]
    maps = _CANDIDATES.copy()
    sign = np.sign(np.linalg.det(_CANDIDATES))
    for _ in range(SEARCH_ITERATIONS):
        moved = np.einsum("nj,cjk->cnk", head, maps)
        Y = union[tree_u.query(moved.reshape(-1, 3))[1]].reshape(moved.shape)
        U, _, Vt = np.linalg.svd(np.einsum("nj,cnk->cjk", head, Y))
        D = np.ones((len(maps), 3))
        D[:, 2] = sign * np.sign(np.linalg.det(U @ Vt))
        maps = (U * D[:, None, :]) @ Vt
    # rank by the symmetric chamfer distance; maps are orthogonal, so |q M − r| = |q − r Mᵀ|
    there = tree_u.query(np.einsum("nj,cjk->cnk", q, maps).reshape(-1, 3))[0].reshape(len(maps), -1)
    some = union[np.random.default_rng(0).permutation(len(union))[:SEARCH_POINTS * 2]]
    back = cKDTree(q).query(np.einsum("nk,cjk->cnj", some, maps).reshape(-1, 3))[0].reshape(len(maps), -1)
    best = maps[int(np.argmin((there ** 2).mean(axis=1) + (back ** 2).mean(axis=1)))]
    full = np.vstack(refs)
    if len(full) > ICP_POINTS:
        full = full[np.random.default_rng(0).choice(len(full), ICP_POINTS, replace=False)]
    start = np.asarray(points, dtype=np.float64) @ best
    return best @ _icp(start, full, cKDTree(full))


def own_map(points: np.ndarray, references: np.ndarray, tol: float = 1e-6) -> np.ndarray | None:
    """The map of a cloud that is itself among `references` (r, n, 3): M with
    ``points @ M == references[j]`` for some j, else None. A shape of the collection a model was
    trained on is then positioned exactly as in training, with no new alignment."""
    points = np.asarray(points, dtype=np.float64)
    for ref in references:
        if ref.shape != points.shape:
            continue
        M = np.linalg.lstsq(points, ref, rcond=None)[0]
        if np.abs(points @ M - ref).max() <= tol:
            return M
    return None


def co_align(clouds: Sequence[np.ndarray], window: int = 6) -> list[np.ndarray]:
    """Maps (3, 3) that align principal-frame clouds among themselves.

    The first cloud keeps its principal frame; each next one is aligned to up to `window` of
    those aligned before it, then each is aligned once more to all the others, so that the
    result depends little on the order.

    Parameters
    ----------
    clouds : sequence of (n_i, 3) float ndarray
        :attr:`PrincipalCloud.points` of the shapes.

    Returns
    -------
    list of (3, 3) float64 ndarray
    """
    maps: list[np.ndarray] = []
    for i, q in enumerate(clouds):
        maps.append(np.eye(3) if i == 0 else align_to(q, [clouds[j] @ maps[j] for j in range(max(0, i - window), i)]))
    if len(clouds) > 2:
        for i, q in enumerate(clouds):
            maps[i] = align_to(q, [clouds[j] @ maps[j] for j in range(len(clouds)) if j != i])
    return maps
