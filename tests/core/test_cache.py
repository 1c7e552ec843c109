"""The feature cache: identical arrays, much faster, corrupt entries recomputed."""

from __future__ import annotations

import time

import numpy as np
import trimesh

from scribbleseg_core.cache import ArrayCache, cached_face_features


def _mesh():
    s = trimesh.creation.capsule(height=2.0, radius=0.5, count=[32, 32])
    return np.asarray(s.vertices), np.asarray(s.faces)


def test_second_request_is_identical_and_over_20x_faster(tmp_path):
    V, F = _mesh()
    cache = ArrayCache(tmp_path)
    t0 = time.perf_counter()
    a = cached_face_features(V, F, cache=cache)
    t1 = time.perf_counter()
    b = cached_face_features(V, F, cache=cache)
    t2 = time.perf_counter()
    np.testing.assert_array_equal(a, b)
    assert (cache.misses, cache.hits) == (1, 1)
    assert (t1 - t0) > 20 * (t2 - t1)


def test_key_changes_with_the_mesh(tmp_path):
    V, F = _mesh()
    cache = ArrayCache(tmp_path)
    cached_face_features(V, F, cache=cache)
    cached_face_features(V * 1.0001 + 1e-3, F, cache=cache)
    assert cache.misses == 2 and len(list(tmp_path.glob("*.npz"))) == 2


def test_corrupt_or_foreign_entries_are_recomputed(tmp_path):
    V, F = _mesh()
    cache = ArrayCache(tmp_path)
    good = cached_face_features(V, F, cache=cache)
    (entry,) = tmp_path.glob("*.npz")
    for bad in (entry.read_bytes()[:100], b"garbage", b""):
        entry.write_bytes(bad)
        again = cached_face_features(V, F, cache=cache)
        np.testing.assert_array_equal(again, good)
    # a well-formed file with the wrong shape, or holding a pickle, is not trusted either
    np.savez(entry, key=np.array(entry.stem), value=np.zeros((3, 22)))
    np.testing.assert_array_equal(cached_face_features(V, F, cache=cache), good)
    np.savez(entry, key=np.array(entry.stem), value=np.array([{"x": 1}], dtype=object))
    np.testing.assert_array_equal(cached_face_features(V, F, cache=cache), good)
    assert cache.hits == 0
