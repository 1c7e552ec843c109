"""Screenshots of the app for the README: ``python scripts/screenshots.py`` (headless).

Writes docs/app_window.png (the Qt window, offscreen) and docs/app_viewport.png (polyscope,
EGL) with the demo scribbles, then docs/app_result_window.png and docs/app_result_viewport.png
after "Segment collection" (a shape that had no scribbles, predicted). The pictures of both
windows during and after a run (docs/app_during_run.png, docs/app_after_run.png) are
screenshots of the app under Xvfb, painted with real mouse events (xdotool), not made here.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main(out: Path = ROOT / "docs") -> None:
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    from PySide6.QtWidgets import QApplication
    from scribbleseg_app.main_window import MainWindow
    from scribbleseg_app.viewport import PolyscopeViewport

    app = QApplication.instance() or QApplication(sys.argv[:1])
    viewport = PolyscopeViewport()
    import tempfile

    w = MainWindow(viewport=viewport, autosave_dir=tempfile.mkdtemp())  # no restore offer from the user's own autosave
    w.show()

    def settle(index: int) -> None:
        w.shapes.list.setCurrentRow(index)
        while w.view.showing != index:  # the mesh loads off the main thread
            app.processEvents()
            time.sleep(0.01)
        for _ in range(5):
            app.processEvents()
            viewport.tick()

    settle(0)
    out.mkdir(parents=True, exist_ok=True)
    w.grab().save(str(out / "app_window.png"))
    viewport.screenshot(str(out / "app_viewport.png"))
    w.runs.segment()
    while w.runs.running:  # the window's own timer paces the frames, leaving the run a core
        app.processEvents()
        time.sleep(0.005)
    app.processEvents()
    print(w.statusBar().currentMessage())
    settle(4)  # no scribbles: predicted
    w.grab().save(str(out / "app_result_window.png"))
    viewport.screenshot(str(out / "app_result_viewport.png"))
    print(f"wrote screenshots to {out}")


if __name__ == "__main__":
    main()
