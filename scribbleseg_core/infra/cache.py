"""On-disk cache of costly per-mesh arrays, keyed by a hash of the arrays and parameters.

Entries are ``.npz`` files read with ``allow_pickle=False``; one that fails to load, or
whose stored key or shape does not match, is recomputed and overwritten, never trusted.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from scribbleseg_core.infra.atomic import atomic_write
from scribbleseg_core.infra.user_dirs import default_cache_dir


def hash_arrays(*arrays: np.ndarray, meta: dict | None = None) -> str:
    """SHA-256 over the arrays' dtype, shape and bytes, and a JSON-encoded `meta`."""
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(a.tobytes())
    h.update(json.dumps(meta or {}, sort_keys=True).encode())
    return h.hexdigest()


class ArrayCache:
    """A folder of cached arrays.

    Parameters
    ----------
    folder : str or os.PathLike, optional
        Default :func:`default_cache_dir` / ``kind``.
    kind : str
        Subfolder naming what is cached (``"features"``).
    """

    def __init__(self, folder: str | os.PathLike | None = None, kind: str = "features"):
        self.folder = Path(folder) if folder is not None else default_cache_dir() / kind
        self.hits = 0
        self.misses = 0

    def path(self, key: str) -> Path:
        return self.folder / f"{key}.npz"

    def get_or_compute(
        self, key: str, compute: Callable[[], np.ndarray], *, shape: tuple | None = None
    ) -> np.ndarray:
        """The cached array for `key`, or ``compute()`` stored under it.

        Parameters
        ----------
        key : str
            From :func:`hash_arrays`.
        compute : callable
            Returns the array when the cache has none (or a bad one).
        shape : tuple, optional
            Expected shape; an entry of another shape is recomputed.
        """
        cached = self._load(key, shape)
        if cached is not None:
            self.hits += 1
            return cached
        self.misses += 1
        value = np.asarray(compute())
        try:
            with atomic_write(self.path(key), "wb") as f:
                np.savez(f, key=np.array(key), value=value)
        except OSError:
            pass  # a read-only or full cache folder costs speed, never results
        return value

    def get(self, key: str, *, shape: tuple | None = None) -> np.ndarray | None:
        """The cached array for `key`, or None (nothing computed)."""
        return self._load(key, shape)

    def _load(self, key: str, shape) -> np.ndarray | None:
        path = self.path(key)
        if not path.is_file():
            return None
        try:
            with np.load(path, allow_pickle=False) as z:
                if str(z["key"]) != key:
                    return None
                value = z["value"]
        except Exception:  # truncated, corrupt, or not ours: recompute
            return None
        if shape is not None and value.shape != tuple(shape):
            return None
        if value.dtype.kind == "f" and not np.isfinite(value).all():
            return None
        return value
