"""The app's model without widgets: sessions, added meshes, bad input keeps the session intact."""

from __future__ import annotations

import json

import numpy as np
from scribbleseg_app.model import CollectionModel

from tests.conftest import icosphere, write_off


def _collection(tmp_path, n=3):
    V, F = icosphere(1)
    folder = tmp_path / "coll"
    folder.mkdir()
    for i in range(n):
        write_off(folder / f"s{i}.off", V, F)
    return folder


def _model(tmp_path, folder):
    m = CollectionModel(tmp_path / "autosave")
    errors = []
    m.error.connect(errors.append)
    m.open(folder)
    m.add_label("a")
    m.add_label("b")
    return m, errors


def _paint(m, index, faces, label):
    m.paint_faces(index, faces, label)


def test_bad_added_mesh_is_reported_and_not_added(tmp_path):
    m, errors = _model(tmp_path, _collection(tmp_path))
    (tmp_path / "bad.off").write_text("OFF\n3 1 0\n0 0 0\n")
    added = []
    m.shapes_added.connect(added.append)
    assert m.add_meshes([tmp_path / "bad.off"]) == []
    assert "bad.off: truncated" in errors[-1] and len(m.shapes) == 3 and added == []
    V, F = icosphere(1)
    write_off(tmp_path / "new.off", V, F)
    assert m.add_meshes([tmp_path / "new.off", tmp_path / "new.off"]) == [3]  # once
    assert added == [[3]] and m.shapes[3].state == "untouched"


def test_session_round_trip_through_the_model(tmp_path):
    folder = _collection(tmp_path)
    m, errors = _model(tmp_path, folder)
    _paint(m, 1, [0, 1, 2], 1)
    m.set_result(2, np.arange(80) % 2, "predicted")
    m.recolor_label(0, (0.1, 0.2, 0.3))
    assert m.save_session(tmp_path / "sess") == []
    m2, errors2 = CollectionModel(tmp_path / "autosave2"), []
    m2.error.connect(errors2.append)
    m2.open(tmp_path / "sess")  # open() recognizes a session folder
    assert errors2 == [] and m2.session_path == tmp_path / "sess"
    assert m2.label_set.names == ("a", "b") and np.allclose(m2.label_set.colors[0], (0.1, 0.2, 0.3))
    assert [e.state for e in m2.shapes] == ["untouched", "scribbled", "predicted"]
    np.testing.assert_array_equal(m2.layer(1).labels, m.layer(1).labels)
    np.testing.assert_array_equal(m2.shapes[2].labels, np.arange(80) % 2)


def test_a_bad_session_leaves_the_open_collection_alone(tmp_path):
    folder = _collection(tmp_path)
    m, errors = _model(tmp_path, folder)
    _paint(m, 0, [5], 0)
    m.save_session(tmp_path / "sess")
    doc = json.loads((tmp_path / "sess" / "session.json").read_text())
    doc["version"] = 7
    (tmp_path / "sess" / "session.json").write_text(json.dumps(doc))
    m.open(tmp_path / "sess")
    assert "newer than this scribbleseg" in errors[-1] and "session.json" in errors[-1]
    assert m.folder == folder and m.layer(0).labels[5] == 0  # nothing lost


def test_delete_label_updates_results_and_drops_the_model(tmp_path):
    m, _ = _model(tmp_path, _collection(tmp_path))
    m.add_label("c")
    _paint(m, 0, [0, 1], 2)
    _paint(m, 0, [2], 0)
    m.set_result(1, np.r_[np.zeros(40, int), np.full(40, 2)], "predicted")
    m.trained_model = object()
    assert m.delete_label(0) == 1
    assert m.label_set.names == ("b", "c") and m.trained_model is None
    assert list(m.layer(0).labels[:3]) == [1, 1, -1]
    assert set(m.shapes[1].labels[:40]) == {-1} and set(m.shapes[1].labels[40:]) == {1}


def test_a_stroke_painted_by_face_ids_is_one_undo_step(tmp_path):
    m, _ = _model(tmp_path, _collection(tmp_path))
    m.set_current(1)
    committed, changed = [], []
    m.edit_committed.connect(committed.append)
    m.scribbles_changed.connect(lambda i, faces: changed.append(len(faces)))
    m.set_current_label(1)
    m.begin_stroke()
    m.paint_stroke_faces([0, 1, 2])
    m.paint_stroke_faces([2, 3])
    assert changed == [3, 1] and not committed  # shown while painting, committed at the release
    m.end_stroke()
    assert committed == [1] and m.shapes[1].state == "scribbled" and m.shapes[1].edits == 1
    m.undo()
    assert (m.layer(1).labels == -1).all()


def test_autosaves_are_found_without_reading_meshes_and_a_wrong_one_is_named(tmp_path):
    folder = _collection(tmp_path)
    m, errors = _model(tmp_path, folder)
    _paint(m, 1, np.arange(10), 1)
    _paint(m, 2, np.arange(5), 0)
    saved = m.autosave_folder() / "s2.json"
    doc = json.loads(saved.read_text())
    doc["num_faces"] = 7  # an autosave that no longer fits its mesh
    doc["strokes"] = [{"label": 0, "faces": [1, 2]}]
    saved.write_text(json.dumps(doc))
    m2 = CollectionModel(tmp_path / "autosave")
    errors2 = []
    m2.error.connect(errors2.append)
    offered = []
    m2.restore_available.connect(offered.append)
    m2.open(folder)
    assert offered == [2] and not any(e.loaded for e in m2.shapes)  # no mesh read to find them
    assert m2.restore_autosave() == [1]
    assert (m2.layer(1).labels[:10] == 1).all()
    assert len(errors2) == 1 and "s2.json" in errors2[0] and "7 faces" in errors2[0]
    assert not errors
