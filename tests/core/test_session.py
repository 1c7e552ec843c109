"""Sessions round-trip as plain files, move with their meshes, and refuse what is not theirs."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from scribbleseg_core.errors import SessionFileError
from scribbleseg_core.formats.labels import LabelSet
from scribbleseg_core.store.session import (
    Session,
    SessionShape,
    is_session,
    load_session,
    save_session,
)
from tests.conftest import icosphere, write_off


@pytest.fixture
def session(tmp_path):
    V, F = icosphere(1)
    meshes = tmp_path / "meshes"
    meshes.mkdir()
    shapes = []
    for i in range(3):
        path = meshes / f"s{i}.off"
        write_off(path, V, F)
        scribble = np.full(len(F), -1)
        scribble[[i, i + 5]] = i % 2
        labels = None if i == 2 else np.arange(len(F)) % 2
        shapes.append(SessionShape(path, len(F), scribble if i < 2 else None, labels, ["labeled", "labeled", "untouched"][i]))
    return Session(LabelSet.from_names(["leg", "seat"], [[1, 0, 0], [0, 0.5, 1]]), shapes, current=1)


def _same(a: Session, b: Session):
    assert a.label_set.names == b.label_set.names
    np.testing.assert_allclose(a.label_set.colors, b.label_set.colors)
    assert a.current == b.current and len(a.shapes) == len(b.shapes)
    for x, y in zip(a.shapes, b.shapes):
        assert x.mesh.name == y.mesh.name and x.num_faces == y.num_faces and x.state == y.state
        for u, v in ((x.scribble, y.scribble), (x.labels, y.labels)):
            assert (u is None) == (v is None)
            if u is not None:
                np.testing.assert_array_equal(u, v)


def test_round_trip(tmp_path, session):
    path = save_session(tmp_path / "work.scribbleseg", session)
    assert is_session(path.parent) and is_session(path)
    back = load_session(path.parent)
    _same(session, back)
    assert back.shapes[0].mesh == session.shapes[0].mesh.resolve() and back.problems == []
    doc = json.loads(path.read_text())
    assert doc["shapes"][0]["mesh"] == "../meshes/s0.off"  # portable: relative to the session


def test_moved_together_with_its_meshes_still_opens(tmp_path, session):
    save_session(tmp_path / "work", session)
    moved = tmp_path / "elsewhere"
    moved.mkdir()
    shutil.move(tmp_path / "work", moved / "work")
    shutil.move(tmp_path / "meshes", moved / "meshes")
    back = load_session(moved / "work")
    assert back.shapes[1].mesh == (moved / "meshes" / "s1.off").resolve() and back.shapes[1].mesh.is_file()


def test_saving_again_replaces_results(tmp_path, session):
    save_session(tmp_path / "w", session)
    session.shapes[0].labels = np.zeros(session.shapes[0].num_faces, np.int64)
    save_session(tmp_path / "w", session)
    assert (load_session(tmp_path / "w").shapes[0].labels == 0).all()


@pytest.mark.parametrize(
    "edit, match",
    [
        (lambda d: d.update(format="something-else"), "not a scribbleseg session"),
        (lambda d: d.update(version=99), "newer than this scribbleseg"),
        (lambda d: d["shapes"][0].update(num_faces=7), "num_faces is 80 but the mesh"),
        (lambda d: d["shapes"][0].update(state="weird"), "unknown state"),
        (lambda d: d.pop("shapes"), "malformed session"),
        (lambda d: d["shapes"][1].update(result="results/missing.seg"), "file not found"),
    ],
)
def test_bad_sessions_are_refused_naming_the_file(tmp_path, session, edit, match):
    path = save_session(tmp_path / "w", session)
    doc = json.loads(path.read_text())
    edit(doc)
    path.write_text(json.dumps(doc))
    with pytest.raises(SessionFileError, match=match) as info:
        load_session(tmp_path / "w")
    assert "session.json" in str(info.value)


def test_not_a_session_and_unreadable(tmp_path):
    with pytest.raises(SessionFileError, match="no session.json"):
        load_session(tmp_path)
    (tmp_path / "session.json").write_bytes(b"\x80\x81 not json")
    with pytest.raises(SessionFileError, match="unreadable"):
        load_session(tmp_path)


def test_a_result_out_of_label_range_is_refused(tmp_path, session):
    save_session(tmp_path / "w", session)
    seg = tmp_path / "w" / "results" / "s0.seg"
    seg.write_text("\n".join(["5"] * session.shapes[0].num_faces))
    with pytest.raises(SessionFileError, match="outside 0..1"):
        load_session(tmp_path / "w")


def test_a_foreign_model_is_left_out_and_reported(tmp_path, session):
    save_session(tmp_path / "w", session)
    (tmp_path / "w" / "model").mkdir()
    (tmp_path / "w" / "model" / "model.json").write_text('{"format": "other"}')
    doc = json.loads((tmp_path / "w" / "session.json").read_text())
    doc["model"] = "model"
    (tmp_path / "w" / "session.json").write_text(json.dumps(doc))
    back = load_session(tmp_path / "w")
    assert back.model is None and "not a scribbleseg model" in back.problems[0]
    _same(session, back)
