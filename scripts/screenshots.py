"""Screenshots of the app for the README: ``python scripts/screenshots.py`` (headless).

Writes docs/app_window.png (the Qt window, offscreen) and docs/app_viewport.png (polyscope,
EGL) with the demo scribbles; docs/app_preview_viewport.png, the live preview after two
strokes on an unscribbled shape; then docs/app_result_window.png and
docs/app_result_viewport.png after "Segment collection" (a shape that had no scribbles,
predicted).
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

    from app.main_window import MainWindow
    from app.viewport import PolyscopeViewport

    app = QApplication.instance() or QApplication(sys.argv[:1])
    viewport = PolyscopeViewport()
    w = MainWindow(viewport=viewport)
    w.show()
    w.shape_list.setCurrentRow(0)
    for _ in range(5):
        app.processEvents()
        viewport.tick()
    out.mkdir(parents=True, exist_ok=True)
    w.grab().save(str(out / "app_window.png"))
    viewport.screenshot(str(out / "app_viewport.png"))
    # two strokes on an unscribbled shape, where a user would put them (along the body and
    # one leg, found here from the demo's own part labels), then the live preview
    import numpy as np

    from scribbleseg_core.export import read_seg

    m = w.model
    w.shape_list.setCurrentRow(1)
    entry = m.shapes[1]
    parts = read_seg(entry.path.parent / "labels" / f"{entry.name}.seg")
    mesh = entry.mesh()
    centroids = mesh.V_file[mesh.F_file].mean(axis=1)
    m.brush_radius = 0.03
    diag = float(np.linalg.norm(np.ptp(mesh.V_file, axis=0)))
    for label, axis in ((0, 0), (2, 2)):  # the body along x, one leg along z (z is up)
        c = centroids[parts == label]
        if label == 2:  # one leg: the leg faces near the leg face at the lowest x + y
            c = c[np.linalg.norm(c - c[np.argmin(c[:, 0] + c[:, 1])], axis=1) < 0.15 * diag]
        c = c[np.argsort(c[:, axis])]
        path = c[len(c) // 5 : 4 * len(c) // 5 : max(len(c) // 12, 1)]
        m.set_current_label(label)
        m.begin_stroke()
        for p in path:
            m.paint_at(p)
        m.end_stroke()
    while not w.preview_idle():
        app.processEvents()
        time.sleep(0.01)
    for _ in range(5):
        app.processEvents()
        viewport.tick()
    viewport.screenshot(str(out / "app_preview_viewport.png"))
    for _ in range(2):  # back to the demo's own scribbles for the run
        m.undo()
    w.run_collection()
    while w.worker is not None:  # paced like the app's QTimer, leaving the worker a core
        app.processEvents()
        viewport.tick()
        time.sleep(0.016)
    app.processEvents()
    print(w.statusBar().currentMessage())
    w.shape_list.setCurrentRow(4)  # no scribbles: predicted
    for _ in range(5):
        app.processEvents()
        viewport.tick()
    w.grab().save(str(out / "app_result_window.png"))
    viewport.screenshot(str(out / "app_result_viewport.png"))
    print(f"wrote screenshots to {out}")


if __name__ == "__main__":
    main()
