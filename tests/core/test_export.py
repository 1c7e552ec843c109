"""Exports: every format re-read gives the same labels; writes are atomic."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from scribbleseg_core.errors import ScribbleFileError, ScribblesegError
from scribbleseg_core.formats.export import (
    export_labeled_mesh,
    read_obj_groups,
    read_ply_labels,
)
from scribbleseg_core.formats.labels import LabelSet
from scribbleseg_core.formats.seg import read_seg, write_seg
from scribbleseg_core.infra.atomic import atomic_write
from tests.conftest import icosphere

NAMES = ("seat", "back", "front leg", "arm")


@pytest.fixture
def labeled():
    V, F = icosphere(2)
    rng = np.random.default_rng(7)  # fixed seed: arbitrary labels incl. unlabeled (-1)
    labels = rng.integers(-1, len(NAMES), len(F))
    return V, F, labels, LabelSet.from_names(NAMES)


def test_ply_round_trip_and_meshlab_reads_quality_and_colors(tmp_path, labeled):
    V, F, labels, ls = labeled
    (path,) = export_labeled_mesh(tmp_path, "x", V, F, labels, ls, formats=["ply"])
    np.testing.assert_array_equal(read_ply_labels(path), labels)
    loaded = trimesh.load(path, process=False)
    np.testing.assert_array_equal(loaded.faces, F)
    np.testing.assert_allclose(loaded.vertices, V)
    pymeshlab = pytest.importorskip("pymeshlab")
    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(path))
    m = ms.current_mesh()
    assert m.has_face_scalar() and m.has_face_color()
    np.testing.assert_array_equal(m.face_scalar_array().astype(int), labels)
    expected = ls.face_colors(labels)
    np.testing.assert_allclose(m.face_color_matrix()[:, :3], np.round(expected * 255) / 255, atol=1e-6)


def test_seg_round_trip(tmp_path, labeled):
    V, F, labels, ls = labeled
    (path,) = export_labeled_mesh(tmp_path, "x", V, F, labels, ls, formats=["seg"])
    np.testing.assert_array_equal(read_seg(path, len(F)), labels)
    with pytest.raises(ScribbleFileError, match="mesh has 3 faces"):
        read_seg(path, 3)


def test_obj_has_one_group_per_label_and_same_labels(tmp_path, labeled):
    V, F, labels, ls = labeled
    obj, mtl = export_labeled_mesh(tmp_path, "x", V, F, labels, ls, formats=["obj"])
    F2, group, names = read_obj_groups(obj)
    assert sorted(names) == sorted(["seat", "back", "front_leg", "arm", "unlabeled"])
    assert len(names) == len(set(names))
    # identify faces by their corner triple (vertex order is kept)
    key = {tuple(sorted(f)): i for i, f in enumerate(F)}
    ids = np.array([key[tuple(sorted(f))] for f in F2])
    token = {-1: "unlabeled", **{i: n.replace(" ", "_") for i, n in enumerate(NAMES)}}
    got = np.array([names[g] for g in group])
    want = np.array([token[int(labels[i])] for i in ids])
    np.testing.assert_array_equal(got, want)
    assert "newmtl front_leg" in mtl.read_text()
    scene = trimesh.load(obj, process=False)  # trimesh splits parts by material
    assert len(scene.geometry) == len(names)
    assert sum(len(g.faces) for g in scene.geometry.values()) == len(F)


def test_glb_one_colored_part_per_label(tmp_path, labeled):
    V, F, labels, ls = labeled
    (path,) = export_labeled_mesh(tmp_path, "x", V, F, labels, ls, formats=["glb"])
    scene = trimesh.load(path)
    assert set(scene.geometry) == {*NAMES, "unlabeled"}
    tree = cKDTree(V[F].mean(axis=1))
    for name, part in scene.geometry.items():
        lab = NAMES.index(name) if name in NAMES else -1
        _, idx = tree.query(np.asarray(part.vertices)[part.faces].mean(axis=1))
        assert (labels[idx] == lab).all()
        rgba = np.asarray(part.visual.material.baseColorFactor)
        np.testing.assert_array_equal(rgba[:3], np.round(ls.face_colors(np.array([lab]))[0] * 255))


def test_json_sidecar(tmp_path, labeled):
    V, F, labels, ls = labeled
    (path,) = export_labeled_mesh(tmp_path, "x", V, F, labels, ls, formats=["json"])
    doc = json.loads(path.read_text())
    assert doc["label_names"] == list(NAMES) and len(doc["label_colors"]) == len(NAMES)
    assert sum(doc["face_counts"].values()) == len(F)


def test_bad_labels_are_refused(tmp_path, labeled):
    V, F, labels, ls = labeled
    with pytest.raises(ScribblesegError, match="out of range"):
        export_labeled_mesh(tmp_path, "x", V, F, np.full(len(F), 4), ls)
    with pytest.raises(ScribblesegError, match="one value per face"):
        export_labeled_mesh(tmp_path, "x", V, F, labels[:-1], ls)
    with pytest.raises(ValueError, match="valid are"):
        export_labeled_mesh(tmp_path, "x", V, F, labels, ls, formats=["fbx"])
    assert not list(tmp_path.iterdir())


def test_crash_mid_save_keeps_the_good_file(tmp_path):
    path = tmp_path / "labels.seg"
    write_seg(path, np.arange(5))
    before = path.read_bytes()

    class Crash(Exception):
        pass

    with pytest.raises(Crash):
        with atomic_write(path, "w") as f:
            f.write("1\n2\n")
            raise Crash
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["labels.seg"]  # no temp file left


def test_psb_ground_truth_exports_round_trip(tmp_path, psb_dir):
    from scribbleseg_core.evaluation.psb import read_label_names
    from scribbleseg_core.formats.mesh import load_mesh

    mesh = load_mesh(psb_dir / "Chair" / "101.off")
    labels = read_seg(psb_dir / "Chair" / "labels" / "101.seg", mesh.num_file_faces)
    ls = LabelSet.from_names(read_label_names(psb_dir / "Chair" / "labels" / "label_names.txt"))
    export_labeled_mesh(tmp_path, "101", mesh.V_file, mesh.F_file, labels, ls)
    np.testing.assert_array_equal(read_ply_labels(tmp_path / "101.ply"), labels)
    np.testing.assert_array_equal(read_seg(tmp_path / "101.seg"), labels)


def test_confidence_goes_into_the_ply_the_json_and_the_vtp(tmp_path, labeled):
    import base64
    import struct
    import xml.etree.ElementTree as ET

    from scribbleseg_core.formats.export import read_vtp_cell_data

    V, F, labels, ls = labeled
    conf = np.random.default_rng(1).random(len(F))
    written = export_labeled_mesh(tmp_path, "x", V, F, labels, ls, formats=["ply", "json", "vtp"], confidence=conf)
    assert [p.name for p in written] == ["x.ply", "x.labels.json", "x.vtp"]
    ply = trimesh.load(tmp_path / "x.ply", process=False)
    np.testing.assert_allclose(np.asarray(ply.metadata["_ply_raw"]["face"]["data"]["confidence"]).ravel(), conf,
                               rtol=1e-6)
    np.testing.assert_array_equal(read_ply_labels(tmp_path / "x.ply"), labels)
    summary = json.loads((tmp_path / "x.labels.json").read_text())["confidence"]
    assert summary["unconfident_faces"] == int((conf < 0.5).sum())
    assert summary["per_label"]["-1"]["mean"] == pytest.approx(conf[labels == -1].mean(), abs=1e-4)
    cells = read_vtp_cell_data(tmp_path / "x.vtp")
    np.testing.assert_array_equal(cells["Label"], labels)
    np.testing.assert_allclose(cells["Confidence"], conf, rtol=1e-6)
    # the geometry as VTK reads it: points, then triangles as connectivity + offsets
    piece = ET.parse(tmp_path / "x.vtp").getroot().find("PolyData/Piece")
    assert int(piece.get("NumberOfPolys")) == len(F) and int(piece.get("NumberOfPoints")) == len(V)

    def array(path, dtype):
        raw = base64.b64decode(piece.find(path).text)
        return np.frombuffer(raw[8:8 + struct.unpack("<Q", raw[:8])[0]], dtype)

    np.testing.assert_allclose(array("Points/DataArray", "<f8").reshape(-1, 3), V)
    np.testing.assert_array_equal(array("Polys/DataArray[@Name='connectivity']", "<i8").reshape(-1, 3), F)
    np.testing.assert_array_equal(array("Polys/DataArray[@Name='offsets']", "<i8"), 3 * np.arange(1, len(F) + 1))
    # without confidence: no such property or array
    export_labeled_mesh(tmp_path, "y", V, F, labels, ls, formats=["vtp", "json"])
    assert set(read_vtp_cell_data(tmp_path / "y.vtp")) == {"Label"}
    assert "confidence" not in json.loads((tmp_path / "y.labels.json").read_text())
    for bad in (conf[:-1], conf * 2, np.full(len(F), np.nan)):
        with pytest.raises(ScribblesegError, match="confidence"):
            export_labeled_mesh(tmp_path, "z", V, F, labels, ls, formats=["ply"], confidence=bad)
