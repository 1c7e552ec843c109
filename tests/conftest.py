"""Shared fixtures: meshes built in code and the PSB data (skipped where absent)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def icosphere(subdivisions: int = 3, radius: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """A closed genus-0 sphere mesh, V (n, 3) float64, F (m, 3) int64."""
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    return np.asarray(s.vertices, dtype=np.float64), np.asarray(s.faces, dtype=np.int64)


def write_off(path, V, faces) -> None:
    """Write an OFF file with full float precision; `faces` may hold polygons."""
    lines = ["OFF", f"{len(V)} {len(faces)} 0"]
    lines += [" ".join(f"{x:.17g}" for x in v) for v in V]
    lines += [" ".join(str(int(i)) for i in [len(f), *f]) for f in faces]
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text("\n".join(lines) + "\n")


@pytest.fixture(scope="session", autouse=True)
def _private_user_folders(tmp_path_factory):
    """The whole run caches signatures and autosaves into temporary folders, never into the
    user's cache or state folders (tests that need an empty cache set their own)."""
    from scribbleseg_core.infra.user_dirs import CACHE_ENV, STATE_ENV

    saved = {env: os.environ.get(env) for env in (CACHE_ENV, STATE_ENV)}
    os.environ[CACHE_ENV] = str(tmp_path_factory.mktemp("cache"))
    os.environ[STATE_ENV] = str(tmp_path_factory.mktemp("state"))
    yield
    for env, value in saved.items():
        if value is None:
            os.environ.pop(env, None)
        else:
            os.environ[env] = value


@pytest.fixture
def sphere():
    return icosphere(3)


@pytest.fixture(scope="session")
def psb_dir() -> Path:
    from scribbleseg_core.evaluation.psb import default_psb_dir

    root = default_psb_dir()
    if root is None:
        pytest.skip("PSB data not found: expected ../shared/psb beside the project (or $SCRIBBLESEG_PSB)")
    return root
