"""The signature cache: identical arrays read back without recomputing, corrupt entries recomputed."""

from __future__ import annotations

import numpy as np
import trimesh

from scribbleseg_core.infra.cache import ArrayCache
from scribbleseg_core.signatures.features import cached_face_features


def _mesh():
    s = trimesh.creation.capsule(height=2.0, radius=0.5, count=[32, 32])
    return np.asarray(s.vertices), np.asarray(s.faces)


def test_second_request_is_read_not_recomputed(tmp_path, monkeypatch):
    import scribbleseg_core.signatures.features as features

    V, F = _mesh()
    cache = ArrayCache(tmp_path)
    a = cached_face_features(V, F, cache=cache)

    def recompute(*args, **kwargs):
        raise AssertionError("a cached request computed the signatures again")

    monkeypatch.setattr(features, "face_features", recompute)
    b = cached_face_features(V, F, cache=cache)
    np.testing.assert_array_equal(a, b)
    assert (cache.misses, cache.hits) == (1, 1)
    assert cached_face_features(V, F, cache=ArrayCache(tmp_path / "empty"), compute=False) is None


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
