"""Benchmark: load (and repair) every mesh of ``../shared/psb``; print time per mesh.

Run ``python -m scribbleseg_core.evaluation.load_speed [PSB_DIR]`` (or ``make bench-load``).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from scribbleseg_core.evaluation.psb import default_psb_dir
from scribbleseg_core.formats.mesh import find_meshes, load_mesh


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    root = Path(argv[0]) if argv else default_psb_dir()
    if root is None or not root.is_dir():
        print("PSB data not found (expected ../shared/psb); nothing to benchmark")
        return 0
    print(f"{'category':<10} {'meshes':>6} {'faces(med)':>10} {'median ms':>9} {'max ms':>7} {'issues':>6}")
    all_times = []
    for cat in sorted(p for p in root.iterdir() if p.is_dir()):
        times, faces, issues = [], [], 0
        for path in find_meshes(cat):
            t0 = time.perf_counter()
            mesh = load_mesh(path)
            times.append(time.perf_counter() - t0)
            faces.append(mesh.num_file_faces)
            issues += bool(mesh.report.warnings())
        all_times += times
        print(f"{cat.name:<10} {len(times):>6} {int(np.median(faces)):>10} "
              f"{1e3 * np.median(times):>9.1f} {1e3 * max(times):>7.1f} {issues:>6}")
    print(f"{'all':<10} {len(all_times):>6} {'':>10} {1e3 * np.median(all_times):>9.1f} "
          f"{1e3 * max(all_times):>7.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
