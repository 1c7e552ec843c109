"""The GUI entry point starts (offscreen)."""

from __future__ import annotations

import pytest

pytest.importorskip("PySide6")


def test_main_window_starts(qtbot):
    from app.main_window import MainWindow

    w = MainWindow()
    qtbot.addWidget(w)
    w.show()
    qtbot.waitExposed(w)
    assert "scribbleseg" in w.windowTitle()
