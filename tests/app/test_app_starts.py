"""The app opens the demo collection, shows shapes in a real (EGL) polyscope viewport, reports errors."""

from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtCore import Qt

pytest.importorskip("PySide6")


def test_opens_the_demo_collection_and_shows_shapes(qtbot, viewport, tmp_path):
    from scribbleseg_app.main_window import DEFAULT_COLLECTION, MainWindow

    w = MainWindow(viewport=viewport, autosave_dir=tmp_path / "autosave")
    qtbot.addWidget(w)
    w.show()
    assert w.model.folder == DEFAULT_COLLECTION
    assert w.shapes.list.count() == 10
    assert "[scribbled]" in w.shapes.list.item(0).text()
    assert [w.labels.list.item(i).text() for i in range(w.labels.list.count())] == ["1  body", "2  head", "3  leg", "4  tail"]
    qtbot.waitUntil(lambda: viewport.frames > 3, timeout=5000)  # the QTimer drives frames
    w.shapes.list.setCurrentRow(3)
    assert w.model.current == 3
    qtbot.waitUntil(lambda: w.view.showing == 3, timeout=5000)
    shot = tmp_path / "view.png"
    viewport.screenshot(str(shot))
    from PySide6.QtGui import QImage

    img = QImage(str(shot))
    px = np.array([[img.pixelColor(x, y).lightness() for x in range(0, img.width(), 16)] for y in range(0, img.height(), 16)])
    assert (px < 200).mean() > 0.02  # the shape is drawn, not an empty background


def test_a_bad_mesh_is_reported_and_the_rest_stays(qtbot, viewport, tmp_path):
    from scribbleseg_app.main_window import MainWindow

    (tmp_path / "good.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 2 3 4\nf 1 3 4\n")
    (tmp_path / "bad.off").write_text("OFF\n3 1 0\n0 0 0\n")
    w = MainWindow(str(tmp_path), viewport=viewport, autosave_dir=tmp_path / "autosave")
    qtbot.addWidget(w)
    assert w.shapes.list.count() == 2
    w.shapes.list.setCurrentRow(0)  # bad.off sorts first; it loads in the background
    qtbot.waitUntil(lambda: w.model.shapes[0].state == "error", timeout=5000)
    assert "bad.off: truncated" in w.statusBar().currentMessage()
    w.shapes.list.setCurrentRow(1)
    assert w.model.current == 1 and w.model.shapes[1].state == "untouched"


def _drag(viewport, points):
    """Press at the first screen point, move through the rest, release: a mouse stroke."""
    import polyscope.imgui as psim

    io = psim.GetIO()
    io.AddMousePosEvent(*points[0])
    viewport.tick()
    io.AddMouseButtonEvent(0, True)
    viewport.tick()
    for p in points[1:]:
        io.AddMousePosEvent(*p)
        viewport.tick()
    io.AddMouseButtonEvent(0, False)
    viewport.tick()
    viewport.tick()


def test_paint_undo_redo_through_the_mouse_path(qtbot, viewport, tmp_path):
    import json

    from PySide6.QtWidgets import QTableWidget
    from scribbleseg_app.main_window import MainWindow

    w = MainWindow(viewport=viewport, autosave_dir=tmp_path / "autosave")
    qtbot.addWidget(w)
    w.show()
    w.activateWindow()
    qtbot.waitActive(w)
    w.shapes.list.setCurrentRow(1)  # quadruped_02: untouched
    qtbot.waitUntil(lambda: w.view.showing == 1, timeout=5000)  # loaded off the main thread, then shown
    assert w.model.shapes[1].state == "untouched"
    w.tools.paint_box.setChecked(True)
    qtbot.keyClick(w, Qt.Key.Key_2)  # head
    assert w.model.current_label == 1
    width, height = viewport.window_size()
    cx, cy = width // 2, height // 2
    _drag(viewport, [(cx - 40, cy), (cx + 40, cy)])  # a fast drag: 2 samples far apart
    layer = w.model.layer(1)
    painted = np.flatnonzero(layer.labels == 1)
    assert len(painted) > 20
    assert w.model.shapes[1].state == "scribbled" and "[scribbled]" in w.shapes.list.item(1).text()
    # the live preview labels the whole shape in the background, scribbles kept
    qtbot.waitUntil(lambda: w.previews.idle, timeout=10_000)
    preview = w.model.shapes[1].preview
    assert preview is not None and (preview == 1).all()  # one label painted: all head
    assert 0 < w.previews.last_seconds < 5 and "preview in" in w.statusBar().currentMessage()
    saved = json.loads((w.model.autosave_folder() / "quadruped_02.json").read_text())
    assert saved["strokes"][0]["label"] == 1 and len(saved["strokes"][0]["faces"]) == len(painted)
    # the painted faces form one connected band: no gaps between the two samples
    from scribbleseg_core.evaluation.metrics import split_components

    mesh = w.model.shapes[1].mesh()
    sub = np.isin(np.arange(mesh.num_file_faces), painted)
    comps = split_components(mesh.F_file, sub.astype(int))
    assert len(np.unique(comps[painted])) == 1
    # eraser, then undo / redo (Ctrl+Z, Ctrl+Shift+Z)
    w.tools.eraser_box.setChecked(True)
    _drag(viewport, [(cx - 10, cy), (cx + 10, cy)])
    assert (layer.labels == 1).sum() < len(painted)
    qtbot.keyClick(w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    np.testing.assert_array_equal(np.flatnonzero(layer.labels == 1), painted)
    qtbot.keyClick(w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    assert (layer.labels == -1).all() and w.model.shapes[1].state == "untouched"
    qtbot.keyClick(w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier)
    np.testing.assert_array_equal(np.flatnonzero(layer.labels == 1), painted)
    # the same keys pressed in polyscope's window (Qt never sees them): undo, label, redo
    import polyscope.imgui as psim

    io = psim.GetIO()

    def key(k, ctrl=False, shift=False):
        for mod, on in ((psim.ImGuiMod_Ctrl, ctrl), (psim.ImGuiMod_Shift, shift)):
            if on:
                io.AddKeyEvent(mod, True)
        io.AddKeyEvent(k, True)
        viewport.tick()
        io.AddKeyEvent(k, False)
        for mod in (psim.ImGuiMod_Ctrl, psim.ImGuiMod_Shift):
            io.AddKeyEvent(mod, False)
        viewport.tick()

    key(psim.ImGuiKey_Z, ctrl=True)
    assert (layer.labels == -1).all()
    key(psim.ImGuiKey_Z, ctrl=True, shift=True)
    np.testing.assert_array_equal(np.flatnonzero(layer.labels == 1), painted)
    key(psim.ImGuiKey_3)
    assert w.model.current_label == 2
    # a drag that starts off the shape moves the camera and paints nothing
    w.tools.eraser_box.setChecked(False)
    before = layer.labels.copy()
    _drag(viewport, [(5, 5), (60, 40)])
    np.testing.assert_array_equal(layer.labels, before)
    # hiding a label shows its faces as the bare surface; showing it again brings the colour back
    from scribbleseg_app.controllers.view import SURFACE

    w.labels.toggle_visible(1)
    assert w.view.label_opacity(1) == 0 and np.allclose(w.view.colors(1)[painted], SURFACE)
    w.labels.toggle_visible(1)
    assert not np.allclose(w.view.colors(1)[painted], SURFACE)
    # the fill: F pressed in the viewport window, then a click paints the region around it, one undo step
    key(psim.ImGuiKey_F)
    assert w.toolbox.tool == "fill" and w.tools.fill_radio.isChecked()
    qtbot.waitUntil(lambda: w.toolbox.regions(1) is not None, timeout=30_000)
    key(psim.ImGuiKey_1)  # body
    before = layer.labels.copy()
    _drag(viewport, [(cx, cy)])  # a click
    filled = np.flatnonzero(layer.labels != before)
    assert len(filled) > 20 and (layer.labels[filled] == 0).all()
    qtbot.keyClick(w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    np.testing.assert_array_equal(layer.labels, before)
    # Help → Keys lists every key
    from scribbleseg_app.keys import sheet

    w.command("keys")
    assert w.keys_dialog.isVisible() and w.keys_dialog.findChild(QTableWidget).rowCount() == len(sheet())


def test_segment_collection_streams_results_then_export(qtbot, viewport, tmp_path, monkeypatch):
    import trimesh
    from scribbleseg_app.main_window import MainWindow

    from scribbleseg_core.formats.export import read_ply_labels

    monkeypatch.setenv("SCRIBBLESEG_CACHE_DIR", str(tmp_path / "cache"))
    w = MainWindow(viewport=viewport, autosave_dir=tmp_path / "autosave")
    qtbot.addWidget(w)
    w.show()
    frames_before = viewport.frames
    w.runs.prepare()  # as the app does once its window shows
    spare = w.runs.spare.pid
    w.run_panel.run_button.click()
    assert w.runs.job.pid == spare  # the run went to the child started ahead
    assert not w.run_panel.run_button.isEnabled() and w.run_panel.stop_button.isEnabled()
    assert not w.labels.add_button.isEnabled() and not w.labels.delete_button.isEnabled()
    qtbot.waitUntil(lambda: not w.runs.running, timeout=300_000)
    assert viewport.frames > frames_before + 10  # the window kept rendering during the run
    assert w.runs.seconds > 0 and 0 < w.frames.max_gap < w.runs.seconds
    assert w.labels.add_button.isEnabled() and w.labels.delete_button.isEnabled()
    assert "finished in" in w.statusBar().currentMessage()
    assert w.statusBar().toolTip() == w.statusBar().currentMessage()  # the whole message, where cut
    states = [e.state for e in w.model.shapes]
    assert states.count("labeled") == 3 and states.count("predicted") == 7
    assert len(w.runs.history.steps) >= 2 and w.runs.history.marks[0] == (0, "round 1")
    assert w.model.trained_model is not None
    from scribbleseg_core.formats.seg import read_seg

    gt = read_seg(w.model.shapes[0].path.parent / "labels" / "quadruped_01.seg")
    assert (w.model.shapes[0].labels == gt).mean() > 0.9
    # every shape has the run's confidence, the list shows it and sorts by it, and a suggestion is made
    means = [e.mean_confidence for e in w.model.shapes]
    assert all(0 <= c <= 1 for c in means) and all(len(e.confidence) == len(e.labels) for e in w.model.shapes)
    assert "confidence" in w.shapes.list.item(0).text()
    w.shapes.sort_box.setChecked(True)
    assert [means[i] for i in w.shapes.order] == sorted(means)
    hint = w.model.suggestion
    assert hint is not None and hint.face in hint.faces and w.run_panel.suggest_button.isEnabled()
    w.command("suggestion")
    assert w.model.current == hint.index
    written = w.files.export(tmp_path / "export", wait=True)
    assert len(written) == 10 * 7  # ply, seg, obj, mtl, glb, json, vtp per shape
    for e in w.model.shapes:
        np.testing.assert_array_equal(read_ply_labels(tmp_path / "export" / f"{e.name}.ply"), e.labels)
        ply = trimesh.load(tmp_path / "export" / f"{e.name}.ply", process=False).metadata["_ply_raw"]["face"]["data"]
        np.testing.assert_allclose(np.asarray(ply["confidence"]).ravel(), e.confidence, atol=1e-6)
    assert len(trimesh.load(tmp_path / "export" / "quadruped_05.ply", process=False).faces) == len(w.model.shapes[4].labels)
    # save the session, reopen it in a fresh window: the same scribbles, results and model
    monkeypatch.setattr("PySide6.QtWidgets.QFileDialog.getExistingDirectory", lambda *a, **k: str(tmp_path / "session"))
    assert w.save_session()  # no session folder yet: asks for one; saves in the background
    qtbot.waitUntil(lambda: not w.files.busy, timeout=30_000)
    w2 = MainWindow(str(tmp_path / "session"), viewport=viewport, autosave_dir=tmp_path / "autosave2")
    qtbot.addWidget(w2)
    assert w2.model.session_path == tmp_path / "session" and w2.model.trained_model is not None
    assert w2.model.label_set.names == w.model.label_set.names
    for i, (a, b) in enumerate(zip(w.model.shapes, w2.model.shapes)):
        assert a.path == b.path and a.state == b.state
        np.testing.assert_array_equal(a.labels, b.labels)
        np.testing.assert_array_equal(w.model.layer(i).labels, w2.model.layer(i).labels)
    # a mesh opened later is predicted with the reopened model
    import shutil

    extra = tmp_path / "later" / "newcomer.ply"
    extra.parent.mkdir()
    shutil.copy(w.model.shapes[4].path, extra)
    assert w2.model.add_meshes([extra]) == [10] and w2.shapes.list.count() == 11
    w2.run_panel.predict_button.click()
    qtbot.waitUntil(lambda: not w2.runs.running, timeout=120_000)
    assert w2.model.shapes[10].state == "predicted"
    assert (w2.model.shapes[10].labels == w.model.shapes[4].labels).mean() > 0.95  # same mesh, same model
    # export only the current shape
    w2.shapes.list.setCurrentRow(10)
    written = w2.files.export(tmp_path / "export_one", only=[w2.model.current], wait=True)
    assert sorted(p.suffix for p in written) == [".glb", ".json", ".mtl", ".obj", ".ply", ".seg", ".vtp"]
    # inspect: a feature as the surface color (computed in the background, from the cache)
    w2.tools.show_combo.setCurrentText("Feature: SDF")
    qtbot.waitUntil(lambda: w2.view.feature_values(10, 1) is not None, timeout=60_000)
    colors = w2.view.colors(10)
    assert colors.shape == (len(w2.model.shapes[10].labels), 3) and colors.std(axis=0).max() > 0.05
    text = w2.view.hover_text(5)
    assert "face 5: label" in text and "SDF =" in text


def test_autosaved_scribbles_are_offered_after_a_crash(qtbot, viewport, tmp_path, monkeypatch):
    from PySide6.QtWidgets import QApplication
    from scribbleseg_app.main_window import MainWindow

    w = MainWindow(viewport=viewport, autosave_dir=tmp_path / "autosave")
    qtbot.addWidget(w)
    w.model.paint_faces(1, np.arange(30), 2)  # a stroke: autosaved
    painted = w.model.layer(1).labels.copy()
    w.close()  # "crash": nothing saved but the autosave
    asked = []
    monkeypatch.setattr(MainWindow, "_confirm", lambda self, title, text: asked.append(text) or True)
    w2 = MainWindow(viewport=viewport, autosave_dir=tmp_path / "autosave")
    qtbot.addWidget(w2)
    qtbot.waitUntil(lambda: bool(asked), timeout=5000)
    assert "1 shape(s)" in asked[0]
    np.testing.assert_array_equal(w2.model.layer(1).labels, painted)
        # declined: set aside, not offered again, nothing deleted
    monkeypatch.setattr(MainWindow, "_confirm", lambda self, title, text: asked.append(text) or False)
    w2.model.paint_faces(1, np.arange(30, 40), 0)
    w3 = MainWindow(viewport=viewport, autosave_dir=tmp_path / "autosave")
    qtbot.addWidget(w3)
    qtbot.waitUntil(lambda: len(asked) == 2, timeout=5000)
    assert list((tmp_path / "autosave").glob("*-discarded-*"))
    w4 = MainWindow(viewport=viewport, autosave_dir=tmp_path / "autosave")
    qtbot.addWidget(w4)
    assert w4.model.autosaved_changes() == {}  # nothing left to offer
    QApplication.processEvents()  # an offer would be a zero-delay timer posted while opening
    assert len(asked) == 2


def test_delete_label_erases_its_scribbles_and_shifts_ids(qtbot, viewport, tmp_path, monkeypatch):
    from scribbleseg_app.main_window import MainWindow

    w = MainWindow(viewport=viewport, autosave_dir=tmp_path / "autosave")
    qtbot.addWidget(w)
    before = w.model.layer(0).labels.copy()  # demo scribbles: body 0, head 1, leg 2, tail 3
    monkeypatch.setattr(MainWindow, "_confirm", lambda self, title, text: True)
    w.labels.list.setCurrentRow(1)
    w.labels.delete_button.click()
    assert w.model.label_set.names == ("body", "leg", "tail") and w.labels.list.count() == 3
    after = w.model.layer(0).labels
    assert (after[before == 1] == -1).all() and (after[before == 2] == 1).all() and (after[before == 0] == 0).all()


def test_quitting_with_unsaved_work_offers_to_save_a_session(qtbot, viewport, tmp_path, monkeypatch):
    from PySide6.QtWidgets import QFileDialog
    from scribbleseg_app.main_window import MainWindow

    from scribbleseg_core.store.session import load_session

    w = MainWindow(viewport=viewport, autosave_dir=tmp_path / "autosave")
    qtbot.addWidget(w)
    w.show()
    assert not w.model.unsaved and not w.windowTitle().endswith("*")
    w.close()  # nothing changed: no question
    assert not w.isVisible()
    w.show()
    w.model.paint_faces(1, np.arange(25), 2)
    assert w.model.unsaved and w.windowTitle().endswith(" *")
    answers = ["cancel"]
    monkeypatch.setattr(MainWindow, "_ask_unsaved", lambda self, can_cancel: answers.pop(0))
    w.close()
    assert w.isVisible()  # cancelled: still open, nothing lost
    answers.append("save")
    monkeypatch.setattr(QFileDialog, "getExistingDirectory", staticmethod(lambda *a, **k: ""))
    w.close()
    assert w.isVisible()  # the save dialog was cancelled: stay
    answers.append("save")
    monkeypatch.setattr(QFileDialog, "getExistingDirectory", staticmethod(lambda *a, **k: str(tmp_path / "session")))
    quit_action = next(a for a in w.menuBar().actions()[0].menu().actions() if a.text() == "Quit")
    quit_action.trigger()  # File → Quit goes through the same question
    assert not w.isVisible() and not w.model.unsaved
    saved = load_session(tmp_path / "session")
    np.testing.assert_array_equal(saved.shapes[1].scribble[:25], 2)


def test_a_run_never_writes_into_a_collection_opened_after_it(qtbot, viewport, tmp_path, monkeypatch):
    from pathlib import Path

    from scribbleseg_app.main_window import MainWindow

    monkeypatch.setenv("SCRIBBLESEG_CACHE_DIR", str(tmp_path / "cache"))
    w = MainWindow(viewport=viewport, autosave_dir=tmp_path / "autosave")  # the demo creatures
    qtbot.addWidget(w)
    w.show()
    ended = []
    w.runs.finished.connect(ended.append)
    w.run_panel.run_button.click()
    qtbot.waitUntil(lambda: w.run_panel.progress.value() >= 1, timeout=60_000)  # the run is under way
    job = w.runs.job
    w.model.open(Path(__file__).resolve().parents[2] / "assets" / "Chair")
    assert not w.runs.running and "stopped: another collection was opened" in ended[0]
    assert w.run_panel.run_button.isEnabled()
    qtbot.waitUntil(lambda: not job.running, timeout=120_000)  # the old run's thread ends at its next step
    qtbot.wait(50)  # anything it posted has been delivered (and dropped)
    assert all(e.state in ("untouched", "scribbled") and e.labels is None for e in w.model.shapes)
    assert w.model.trained_model is None and len(ended) == 1
