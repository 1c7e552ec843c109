"""Loading, repair with face-id maps, topology report, normalization."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from scribbleseg_core.errors import MeshLoadError, ScribblesegError
from scribbleseg_core.formats.mesh import MESH_EXTENSIONS, load_mesh, repair
from scribbleseg_core.geometry.measures import face_areas, normalize
from tests.conftest import icosphere, write_off


@pytest.mark.parametrize("ext", ["off", "obj", "ply", "stl", "glb"])
def test_every_format_loads_the_same_surface(tmp_path, ext):
    V, F = icosphere(2)
    path = tmp_path / f"s.{ext}"
    if ext == "off":
        write_off(path, V, F)
    else:
        trimesh.Trimesh(V, F, process=False).export(path)
    mesh = load_mesh(path)
    assert mesh.F.dtype == np.int64 and mesh.V.dtype == np.float64
    assert mesh.num_file_faces == len(F)
    assert mesh.F.shape == F.shape  # STL's per-face vertices are merged back
    assert mesh.V.shape == V.shape
    assert np.isclose(face_areas(mesh.V, mesh.F).sum(), face_areas(V, F).sum(), rtol=1e-5)
    assert mesh.report.is_closed_manifold and mesh.report.components == 1


def test_file_face_order_is_kept_for_off_and_obj(tmp_path):
    V, F = icosphere(1)
    rng = np.random.default_rng(0)  # fixed seed: a shuffled face order must survive
    F = F[rng.permutation(len(F))]
    write_off(tmp_path / "a.off", V, F)
    obj = "\n".join([*(f"v {x} {y} {z}" for x, y, z in V), "g part", *(f"f {a+1} {b+1} {c+1}" for a, b, c in F)])
    (tmp_path / "a.obj").write_text(obj + "\n")
    for name in ("a.off", "a.obj"):
        mesh = load_mesh(tmp_path / name)
        np.testing.assert_array_equal(mesh.F_file, F)
        np.testing.assert_array_equal(mesh.proc_to_file, np.arange(len(F)))


def test_polygons_are_fan_triangulated_in_order(tmp_path):
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1.0]], float)
    faces = [[0, 3, 2, 1], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]
    write_off(tmp_path / "pyr.off", V, faces)
    mesh = load_mesh(tmp_path / "pyr.off")
    np.testing.assert_array_equal(mesh.F_file[:2], [[0, 3, 2], [0, 2, 1]])
    assert mesh.num_file_faces == 6 and mesh.report.is_closed_manifold


def test_repair_merges_and_drops_but_maps_every_file_face():
    V, F = icosphere(1)
    n = len(V)
    V2 = np.vstack([V, V[:1]])  # vertex n duplicates vertex 0
    F2 = np.vstack([
        F,
        F[:1],                     # duplicate of face 0
        F[1:2, ::-1],              # duplicate of face 1, flipped
        [[0, n, 5]],               # degenerate once n merges into 0
    ])
    F2[3] = np.where(F2[3] == 0, n, F2[3])  # face 3 uses the duplicate vertex
    mesh = repair(V2, F2)
    r = mesh.report
    assert (r.merged_vertices, r.dropped_duplicate_faces, r.dropped_degenerate_faces) == (1, 2, 1)
    assert mesh.F.shape == F.shape and mesh.report.is_closed_manifold
    m0 = len(F)
    assert mesh.file_to_proc[m0] == mesh.file_to_proc[0]
    assert mesh.file_to_proc[m0 + 1] == mesh.file_to_proc[1]
    assert 0 <= mesh.file_to_proc[m0 + 2] < len(mesh.F)
    # labels round trip: labels on file faces -> processing -> file keep kept faces' values
    labels = np.arange(len(F2))
    back = mesh.labels_to_file(mesh.labels_from_file(labels))
    np.testing.assert_array_equal(back[:m0], labels[:m0])
    assert back[m0] == 0 and back[m0 + 1] == 1


def test_report_finds_nonmanifold_boundaries_and_components():
    # Three triangles on one edge (non-manifold), plus a separate open square (boundary).
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1],
                  [5, 0, 0], [6, 0, 0], [6, 1, 0], [5, 1, 0]], float)
    F = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4], [5, 6, 7], [5, 7, 8]])
    r = repair(V, F).report
    assert r.nonmanifold_edges == 1
    assert r.components == 2
    assert r.boundary_loops == 2
    assert not r.is_closed_manifold
    assert any("non-manifold" in w for w in r.warnings())


def test_zero_area_faces_are_reported_not_dropped():
    V = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0]], float)
    F = np.array([[0, 1, 2], [0, 1, 3]])  # face 0 is collinear
    mesh = repair(V, F)
    assert mesh.report.zero_area_faces == 1 and mesh.report.tiny_faces >= 1
    assert len(mesh.F) == 2


def test_normalize_centers_and_scales_to_unit_area(sphere):
    V, F = sphere
    Vn, center, scale = normalize(V * 3 + 7, F)
    assert np.isclose(face_areas(Vn, F).sum(), 1.0)
    np.testing.assert_allclose(center, [7, 7, 7], atol=1e-9)
    assert np.isclose(scale, 1 / (3 * np.sqrt(face_areas(V, F).sum())))


def test_normalized_copy_leaves_export_coordinates_alone(tmp_path, sphere):
    V, F = sphere
    write_off(tmp_path / "s.off", V * 10, F)
    mesh = load_mesh(tmp_path / "s.off")
    assert np.isclose(face_areas(mesh.normalized(), mesh.F).sum(), 1.0)
    np.testing.assert_allclose(mesh.V_file, V * 10)


BAD_FILES = {
    "missing": (None, "file not found"),
    "empty.off": (b"", "empty file"),
    "nan.off": (b"OFF\n3 1 0\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n", "NaN or infinite"),
    "inf.obj": (b"v 0 0 0\nv inf 0 0\nv 0 1 0\nf 1 2 3\n", "NaN or infinite"),
    "range.off": (b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", "out of range"),
    "range.obj": (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "out of range"),
    "trunc.off": (b"OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n", "truncated"),
    "nofaces.off": (b"OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n", "empty mesh"),
    "nofaces.obj": (b"v 0 0 0\nv 1 0 0\n", "no faces"),
    "garbage.ply": (b"\x00\x01garbage" * 20, "PLY"),
    "garbage.stl": (b"solid x\nfacet broken\n", "STL"),
    "garbage.glb": (b"glTF\x02\x00\x00\x00" + b"\xff" * 40, "GLB"),
    "mesh.txt": (b"hello", "unknown mesh extension"),
    "degenerate.off": (b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 0 1\n", "degenerate"),
}


@pytest.mark.parametrize("name", sorted(BAD_FILES))
def test_bad_input_gets_one_clear_error_naming_the_file(tmp_path, name):
    data, expected = BAD_FILES[name]
    path = tmp_path / (name if data is not None else "missing.off")
    if data is not None:
        path.write_bytes(data)
    with pytest.raises(MeshLoadError) as info:
        load_mesh(path)
    assert str(path) in str(info.value)
    assert expected.lower() in str(info.value).lower()


def test_scene_without_triangles_is_refused(tmp_path):
    scene = trimesh.Scene([trimesh.PointCloud(np.random.default_rng(1).random((10, 3)))])
    path = tmp_path / "points.glb"
    path.write_bytes(scene.export(file_type="glb"))
    with pytest.raises(MeshLoadError, match="no triangles"):
        load_mesh(path)


def test_errors_share_the_project_base_type():
    assert issubclass(MeshLoadError, ScribblesegError)
    assert set(MESH_EXTENSIONS) >= {".off", ".obj", ".ply", ".stl", ".glb", ".gltf"}
