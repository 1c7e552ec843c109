"""Geodesic sample distances and the label distances read from them."""

from __future__ import annotations

import numpy as np

from scribbleseg_core.geometry.measures import face_areas, face_centroids
from scribbleseg_core.signatures.geodesic import FAR, cached_source_distances, label_distances, source_distances


def grid(nx: int, ny: int, x0: float = 0.0):
    """A flat nx × ny grid of squares (two triangles each) in the plane z = 0, from x = x0."""
    xs, ys = np.meshgrid(np.arange(nx + 1, dtype=float) + x0, np.arange(ny + 1, dtype=float), indexing="ij")
    V = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)])
    idx = lambda i, j: i * (ny + 1) + j  # noqa: E731
    F = []
    for i in range(nx):
        for j in range(ny):
            a, b, c, d = idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)
            F += [[a, b, c], [a, c, d]]
    return V, np.array(F, dtype=np.int64)


def test_distances_on_a_plane_are_straight_lines():
    V, F = grid(20, 4)
    d = source_distances(V, F, num_sources=8)
    P = face_centroids(V, F)
    assert d.D.shape == (8, len(F)) and d.D.dtype == np.float32
    for s, f in enumerate(d.source_face):
        straight = np.linalg.norm(P - P[f], axis=1)
        assert np.abs(d.D[s] - straight).max() < 0.2 * straight.max()
    # farthest-point sampling spreads the sources along the strip
    assert np.ptp(P[d.source_face, 0]) > 15
    assert np.isclose(d.source_area(face_areas(V, F)).sum(), face_areas(V, F).sum())


def test_label_distances_say_where_a_label_lies():
    V, F = grid(30, 3)
    area = face_areas(V, F)
    x = face_centroids(V, F)[:, 0]
    proba = np.zeros((len(F), 2))
    proba[x < 5, 0] = 1  # label 0 on the left end, label 1 elsewhere
    proba[x >= 5, 1] = 1
    L = label_distances(source_distances(V, F, num_sources=16), area, proba)
    assert L.shape == (len(F), 4) and np.isfinite(L).all()
    mean0, soft0 = L[:, 0], L[:, 2]
    order = np.argsort(x)
    assert np.corrcoef(x[order], mean0[order])[0, 1] > 0.99  # farther right, farther from label 0
    assert soft0[x < 4].max() < 0.4 and soft0[x > 25].min() > 1.5  # mean distance here: about 10
    assert (soft0 <= mean0 + 1e-9).all()  # the soft minimum never exceeds the mean


def test_a_label_absent_from_a_component_is_far(tmp_path):
    from scribbleseg_core.infra.cache import ArrayCache

    V1, F1 = grid(6, 2)
    V2, F2 = grid(6, 2, x0=20.0)
    V, F = np.vstack([V1, V2]), np.vstack([F1, F2 + len(V1)])
    cache = ArrayCache(tmp_path)
    d = cached_source_distances(V, F, cache)
    assert (d.D < 0).any() and cache.misses == 1
    again = cached_source_distances(V, F, cache)
    assert cache.hits == 1 and np.array_equal(again.D, d.D)  # -1 marks survive the cache
    proba = np.zeros((len(F), 2))
    proba[: len(F1), 0] = 1  # label 0 only on the first component
    proba[len(F1):, 1] = 1
    L = label_distances(d, face_areas(V, F), proba)
    assert (L[len(F1):, 0] == FAR).all() and (L[len(F1):, 2] == FAR).all()
    assert (L[: len(F1), 0] < FAR).all()
