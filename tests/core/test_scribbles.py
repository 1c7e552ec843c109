"""Scribble files, format v1: round trip and every refusal the format lists."""

from __future__ import annotations

import json

import numpy as np
import pytest

from scribbleseg_core.errors import ScribbleFileError
from scribbleseg_core.formats.scribbles import (
    Scribbles,
    Stroke,
    read_scribbles,
    resolve_mesh_path,
    scribbles_to_json,
    write_scribbles,
)


def _doc(**over):
    doc = {
        "format": "scribbleseg-scribbles", "version": 1, "mesh": "m.off", "num_faces": 10,
        "label_names": ["a", "b"], "strokes": [{"label": 0, "faces": [1, 2]}, {"label": 1, "faces": [2, 9]}],
    }
    doc.update(over)
    return doc


def test_round_trip_and_later_strokes_win(tmp_path):
    scr = Scribbles("m.off", 10, ("a", "b"), (Stroke(0, np.array([1, 2])), Stroke(1, np.array([2, 9]))))
    write_scribbles(tmp_path / "m.json", scr)
    back = read_scribbles(tmp_path / "m.json", num_faces=10)
    assert scribbles_to_json(back) == scribbles_to_json(scr)
    np.testing.assert_array_equal(back.face_labels(), [-1, 0, 1, -1, -1, -1, -1, -1, -1, 1])
    np.testing.assert_array_equal(back.used_labels, [0, 1])


REFUSALS = {
    "face out of range": (_doc(strokes=[{"label": 0, "faces": [10]}]), "face id 10 out of range"),
    "negative face": (_doc(strokes=[{"label": 0, "faces": [-1]}]), "out of range"),
    "label out of range": (_doc(strokes=[{"label": 2, "faces": [0]}]), "label 2 out of range"),
    "unknown format": (_doc(format="something-else"), "unknown format"),
    "newer version": (_doc(version=2), "newer"),
    "no mesh": (_doc(mesh=""), "mesh"),
    "bad faces": (_doc(strokes=[{"label": 0, "faces": ["x"]}]), "integers"),
    "bool label": (_doc(strokes=[{"label": True, "faces": [0]}]), "int 'label'"),
}


@pytest.mark.parametrize("case", sorted(REFUSALS))
def test_refusals_name_the_file_and_the_problem(tmp_path, case):
    doc, expected = REFUSALS[case]
    path = tmp_path / "s.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(ScribbleFileError) as info:
        read_scribbles(path)
    assert str(path) in str(info.value) and expected in str(info.value)


def test_mismatched_num_faces_is_refused(tmp_path):
    path = tmp_path / "s.json"
    path.write_text(json.dumps(_doc()))
    with pytest.raises(ScribbleFileError, match="num_faces is 10 but the mesh 'm.off' has 12 faces"):
        read_scribbles(path, num_faces=12)


@pytest.mark.parametrize("content", ["", "{", "[1,2]", "\xff\xfe"])
def test_garbage_is_refused(tmp_path, content):
    path = tmp_path / "s.json"
    path.write_text(content, encoding="latin-1")
    with pytest.raises(ScribbleFileError):
        read_scribbles(path)


def test_mesh_is_found_beside_or_in_parent(tmp_path):
    (tmp_path / "scribbles").mkdir()
    (tmp_path / "m.off").write_text("OFF\n")
    scr = Scribbles("m.off", 10, ("a",), ())
    assert resolve_mesh_path(tmp_path / "scribbles" / "m.json", scr) == tmp_path / "m.off"
    (tmp_path / "scribbles" / "m.off").write_text("OFF\n")
    assert resolve_mesh_path(tmp_path / "scribbles" / "m.json", scr) == tmp_path / "scribbles" / "m.off"
    with pytest.raises(ScribbleFileError, match="neither beside"):
        resolve_mesh_path(tmp_path / "scribbles" / "x.json", Scribbles("gone.off", 1, ("a",), ()))


def test_every_psb_scribble_file_reads(psb_dir):
    files = sorted(psb_dir.glob("*/scribbles/*.json"))
    assert len(files) == 240
    for f in files:
        scr = read_scribbles(f)
        assert resolve_mesh_path(f, scr).exists()
        assert scr.strokes
