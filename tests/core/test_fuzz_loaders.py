"""Property-based: random and truncated bytes into every loader; only MeshLoadError may come out."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from scribbleseg_core.errors import MeshLoadError
from scribbleseg_core.formats.mesh import load_mesh
from tests.conftest import icosphere

EXTS = ["off", "obj", "ply", "stl", "glb", "gltf"]
FUZZ = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def _valid_bytes(ext: str) -> bytes:
    V, F = icosphere(1)
    mesh = trimesh.Trimesh(V, F, process=False)
    if ext == "off":
        return trimesh.exchange.off.export_off(mesh).encode()
    if ext == "ply-ascii":
        return trimesh.exchange.ply.export_ply(mesh, encoding="ascii")
    if ext == "gltf":  # one self-contained file, buffers embedded as data URIs
        return trimesh.exchange.gltf.export_gltf(mesh, embed_buffers=True)["model.gltf"]
    data = mesh.export(file_type=ext)
    return data.encode() if isinstance(data, str) else data


VALID = {ext: _valid_bytes(ext) for ext in [*EXTS, "ply-ascii"]}


def _load(tmp_path, ext, data):
    path = tmp_path / f"fuzz.{ext.split('-')[0]}"
    path.write_bytes(data)
    try:
        mesh = load_mesh(path)
    except MeshLoadError as e:
        assert str(path) in str(e)
        return None
    # whatever loads must be a valid mesh
    assert np.isfinite(mesh.V).all() and mesh.F.min() >= 0 and mesh.F.max() < len(mesh.V)
    return mesh


@pytest.mark.parametrize("ext", EXTS)
@FUZZ
@given(data=st.binary(max_size=2048))
def test_random_bytes(tmp_path, ext, data):
    _load(tmp_path, ext, data)


@pytest.mark.parametrize("ext", [*EXTS, "ply-ascii"])
@FUZZ
@given(frac=st.floats(0.0, 0.999))
def test_truncated_valid_file(tmp_path, ext, frac):
    good = VALID[ext]
    _load(tmp_path, ext, good[: int(len(good) * frac)])


@pytest.mark.parametrize("ext", ["off", "ply", "stl", "glb", "ply-ascii"])
@FUZZ
@given(pos=st.floats(0.0, 0.999), byte=st.integers(0, 255))
def test_one_corrupted_byte(tmp_path, ext, pos, byte):
    good = bytearray(VALID[ext])
    good[int(len(good) * pos)] = byte
    _load(tmp_path, ext, bytes(good))


@pytest.mark.parametrize("ext", ["off", "ply", "stl", "ply-ascii"])
def test_truncated_files_of_known_size_are_refused(tmp_path, ext):
    """Formats that state their size must not load a prefix silently."""
    good = VALID[ext]
    assert _load(tmp_path, ext, good) is not None
    assert _load(tmp_path, ext, good[: len(good) * 3 // 4]) is None
