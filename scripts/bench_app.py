"""The app's responsiveness: frame gaps during a run and a prediction, memory over repeated
collection opens, and the CPU an idle app uses.

``python scripts/bench_app.py [--cycles N] [--idle-seconds S]``

* Frame gaps: the demo collection is segmented in the real window (offscreen Qt, EGL
  polyscope), then its unpainted shapes are predicted again; the longest time between two
  rendered viewport frames is printed for each, with the run's time.
* Memory: the demo creatures and the bundled chairs are opened alternately N times (each shape
  shown, one stroke previewed); the resident memory after each cycle is printed.
* Idle CPU (needs a display, e.g. ``Xvfb :99 &; DISPLAY=:99``): ``scribbleseg-app`` is started
  on the demo, left alone, and its CPU time over S seconds is printed as a share of one core.
"""

from __future__ import annotations

import argparse
import faulthandler
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def _cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def in_window(cycles: int, run: bool = True) -> None:
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    os.environ.setdefault("SCRIBBLESEG_CACHE_DIR", tempfile.mkdtemp())
    import numpy as np
    from PySide6.QtWidgets import QApplication
    from scribbleseg_app.main_window import MainWindow
    from scribbleseg_app.viewport import PolyscopeViewport

    app = QApplication.instance() or QApplication(sys.argv[:1])
    MainWindow._confirm = lambda self, title, text: False  # reopening offers the autosave: decline, no dialog
    MainWindow._ask_unsaved = lambda self, can_cancel: "discard"  # closing: no dialog
    w = MainWindow(viewport=PolyscopeViewport(), autosave_dir=tempfile.mkdtemp())
    w.show()

    def wait(condition, timeout=600.0):
        end = time.perf_counter() + timeout
        while not condition():
            if time.perf_counter() > end:
                raise TimeoutError
            app.processEvents()
            time.sleep(0.002)

    def timed(start) -> tuple[float, float]:
        problem = start()
        if problem:
            raise SystemExit(problem)
        wait(lambda: not w.runs.running)
        return w.runs.seconds, w.frames.max_gap

    if run:
        print("frames while the engine works (demo collection, 10 shapes)")
        seconds, gap = timed(w.runs.segment)
        print(f"  segment collection: {seconds:6.1f} s, longest frame gap {gap * 1000:4.0f} ms")
        for i, e in enumerate(w.model.shapes):  # forget the unpainted shapes' results: predict them again
            if not w.model.has_scribbles(i):
                e.labels, e.state = None, "untouched"
        seconds, gap = timed(w.runs.predict)
        print(f"  predict unlabeled:  {seconds:6.1f} s, longest frame gap {gap * 1000:4.0f} ms")

    print(f"memory over {cycles} collection opens (each shape shown, one stroke previewed)")
    folders = [ROOT / "assets" / "Quadruped", ROOT / "assets" / "Chair"]
    for cycle in range(cycles):
        w.model.open(folders[cycle % 2])
        m = w.model
        for i in range(len(m.shapes)):
            m.set_current(i)
            wait(lambda i=i: w.view.showing == i)
        if not len(m.label_set):
            m.add_label("part")
        m.paint_faces(0, np.arange(20), 0)
        wait(lambda: w.previews.idle)
        for _ in range(3):
            app.processEvents()
        print(f"  cycle {cycle + 1:2d}: {_rss_mb():7.0f} MB")
    w.close()


def idle_cpu(seconds: float) -> None:
    if not os.environ.get("DISPLAY"):
        print("idle CPU: skipped (no DISPLAY; start Xvfb and set DISPLAY)")
        return
    app = Path(sys.executable).with_name("scribbleseg-app")
    with tempfile.TemporaryDirectory() as state:
        env = {**os.environ, "XDG_STATE_HOME": state}
        proc = subprocess.Popen([str(app), str(ROOT / "assets" / "Quadruped")], env=env,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            time.sleep(10)  # opened and settled
            before = _cpu_seconds(proc.pid)
            time.sleep(seconds)
            share = (_cpu_seconds(proc.pid) - before) / seconds
            print(f"idle CPU over {seconds:.0f} s (the demo open, nothing moving): {share * 100:.1f}% of one core")
        finally:
            proc.terminate()
            proc.wait(10)


def main() -> None:
    faulthandler.enable()
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=20)
    ap.add_argument("--idle-seconds", type=float, default=20.0, help="0 skips the idle measurement")
    ap.add_argument("--no-run", action="store_true", help="skip the frame gaps of a run")
    args = ap.parse_args()
    if args.idle_seconds > 0:
        idle_cpu(args.idle_seconds)
    in_window(args.cycles, run=not args.no_run)


if __name__ == "__main__":
    main()
