"""The app opens the demo collection, shows shapes in a real (EGL) polyscope viewport, reports errors."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("PySide6")


@pytest.fixture(scope="module")
def viewport():
    from app.viewport import PolyscopeViewport

    return PolyscopeViewport("openGL3_egl")


def test_opens_the_demo_collection_and_shows_shapes(qtbot, viewport, tmp_path):
    from app.main_window import DEFAULT_COLLECTION, MainWindow

    w = MainWindow(viewport=viewport)
    qtbot.addWidget(w)
    w.show()
    assert w.model.folder == DEFAULT_COLLECTION
    assert w.shape_list.count() == 10
    assert "[scribbled]" in w.shape_list.item(0).text()
    assert "leg" in w.labels_info.text()
    qtbot.waitUntil(lambda: viewport.frames > 3, timeout=5000)  # the QTimer drives frames
    w.shape_list.setCurrentRow(3)
    assert w.model.current == 3
    shot = tmp_path / "view.png"
    viewport.screenshot(str(shot))
    from PySide6.QtGui import QImage

    img = QImage(str(shot))
    px = np.array([[img.pixelColor(x, y).lightness() for x in range(0, img.width(), 16)] for y in range(0, img.height(), 16)])
    assert (px < 200).mean() > 0.02  # the shape is drawn, not an empty background


def test_a_bad_mesh_is_reported_and_the_rest_stays(qtbot, viewport, tmp_path):
    from app.main_window import MainWindow

    (tmp_path / "good.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 2 3 4\nf 1 3 4\n")
    (tmp_path / "bad.off").write_text("OFF\n3 1 0\n0 0 0\n")
    w = MainWindow(str(tmp_path), viewport=viewport)
    qtbot.addWidget(w)
    assert w.shape_list.count() == 2
    w.shape_list.setCurrentRow(0)  # bad.off sorts first
    assert w.model.shapes[0].state == "error"
    assert "bad.off: truncated" in w.statusBar().currentMessage()
    w.shape_list.setCurrentRow(1)
    assert w.model.current == 1 and w.model.shapes[1].state == "untouched"
