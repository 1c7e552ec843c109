"""One polyscope viewport (real EGL pixels) for every app test in the process."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def viewport():
    pytest.importorskip("PySide6")
    from scribbleseg_app.viewport import PolyscopeViewport

    return PolyscopeViewport("openGL3_egl")


@pytest.fixture(autouse=True)
def _unsaved_work_is_discarded(monkeypatch):
    """Closing a window with unsaved work asks a modal question; tests answer 'discard'
    (a test of the question itself replaces the answer)."""
    try:
        from scribbleseg_app.main_window import MainWindow
    except ImportError:  # no Qt: the model tests still run
        return
    monkeypatch.setattr(MainWindow, "_ask_unsaved", lambda self, can_cancel: "discard")
