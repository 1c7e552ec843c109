"""Live-preview latency in the real app (offscreen Qt + EGL polyscope), on PSB shapes.

``python scripts/bench_preview.py [PSB_DIR] [--shapes N]``: opens each PSB category as a
collection, replays one shape's fixed scribbles stroke by stroke through the model (each stroke painted
and shown first, as during a drag), and times each stroke from the release to the frame that
shows the preview. Prints a table per shape and the median and worst over all strokes.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np


def main() -> None:
    from scribbleseg_core.evaluation.psb import default_psb_dir

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("psb", nargs="?", type=Path, default=default_psb_dir())
    ap.add_argument("--shapes", type=int, default=1, help="shapes per category")
    args = ap.parse_args()
    if args.psb is None or not Path(args.psb).is_dir():
        sys.exit("PSB data not found: pass its folder (e.g. ../shared/psb)")
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    from PySide6.QtWidgets import QApplication
    from scribbleseg_app.main_window import MainWindow
    from scribbleseg_app.viewport import PolyscopeViewport

    from scribbleseg_core.evaluation.psb import categories
    from scribbleseg_core.formats.scribbles import read_scribbles

    app = QApplication.instance() or QApplication(sys.argv[:1])
    viewport = PolyscopeViewport()
    import tempfile

    w = MainWindow(viewport=viewport, autosave_dir=tempfile.mkdtemp())
    all_ms = []
    print(f"{'shape':16s} {'faces':>6s} {'strokes':>7s} {'first ms':>8s} {'median ms':>9s} {'max ms':>7s}")
    for cat in categories(args.psb):
        w.model.open(args.psb / cat)
        m = w.model
        for index in range(min(args.shapes, len(m.shapes))):
            entry = m.shapes[index]
            scr = read_scribbles(args.psb / cat / "scribbles" / f"{entry.name}.json", num_faces=entry.mesh().num_file_faces)
            m.set_current(index)
            m.paint_faces(index, np.arange(entry.mesh().num_file_faces), -1)  # start from a clean shape
            while not w.previews.idle:
                app.processEvents()
            times = []
            for stroke in scr.strokes:
                m.set_current_label(stroke.label)
                m.begin_stroke()  # the stroke is painted and shown, as while the mouse drags
                m.paint_stroke_faces(stroke.faces)
                app.processEvents()
                viewport.tick()
                t0 = time.perf_counter()
                m.end_stroke()  # the release: autosave, preview request
                while not w.previews.idle:
                    app.processEvents()
                    time.sleep(0.001)
                app.processEvents()
                viewport.tick()  # the frame that shows the new colors
                times.append((time.perf_counter() - t0) * 1000)
            all_ms += times[1:]
            print(f"{cat + '/' + entry.name:16s} {entry.mesh().num_file_faces:6d} {len(times):7d} {times[0]:8.0f} "
                  f"{statistics.median(times[1:] or times):9.0f} {max(times):7.0f}")
    print(f"all strokes after the first: median {statistics.median(all_ms):.0f} ms, max {max(all_ms):.0f} ms "
          "(the first stroke of a shape also builds its dual graph)")


if __name__ == "__main__":
    main()
