"""Benchmark: seconds per shape per signature on the PSB meshes, against face count.

``python -m scribbleseg_core.evaluation.signature_speed [--per-category N] [--psb DIR]`` (``make bench``).
Runs without the cache, with BLAS limited to the threads given (default: all cores).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from scribbleseg_core.evaluation.psb import default_psb_dir
from scribbleseg_core.formats.mesh import find_meshes, load_mesh
from scribbleseg_core.signatures.features import face_features_timed

SIGNATURES = ("sihks", "sdf", "agd", "gauss")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--psb", default=None, help="PSB folder (default ../shared/psb)")
    ap.add_argument("--per-category", type=int, default=3, help="shapes per category (0 = all)")
    args = ap.parse_args(argv)
    root = default_psb_dir() if args.psb is None else __import__("pathlib").Path(args.psb)
    if root is None:
        print("PSB data not found (expected ../shared/psb); nothing to benchmark")
        return 0
    rows = []
    print(f"{'shape':<16} {'faces':>7} " + " ".join(f"{s:>7}" for s in SIGNATURES) + f" {'total':>7} {'us/face':>7}")
    for cat in sorted(p for p in root.iterdir() if p.is_dir()):
        paths = find_meshes(cat)
        if args.per_category:
            paths = paths[: args.per_category]
        for path in paths:
            mesh = load_mesh(path)
            t0 = time.perf_counter()
            _, sec = face_features_timed(mesh.V, mesh.F)
            total = time.perf_counter() - t0
            m = len(mesh.F)
            rows.append((m, total, *[sec[s] for s in SIGNATURES]))
            print(f"{cat.name + '/' + path.stem:<16} {m:>7} " + " ".join(f"{sec[s]:>7.2f}" for s in SIGNATURES)
                  + f" {total:>7.2f} {1e6 * total / m:>7.1f}", flush=True)
    R = np.array(rows)
    print(f"\n{len(R)} shapes; median faces {int(np.median(R[:, 0]))}")
    print("share of time: " + ", ".join(f"{s} {100 * R[:, 2 + i].sum() / R[:, 1].sum():.0f}%" for i, s in enumerate(SIGNATURES)))
    for lo, hi in [(0, 12000), (12000, 25000), (25000, 40000), (40000, 10**9)]:
        sel = (R[:, 0] >= lo) & (R[:, 0] < hi)
        if sel.any():
            print(f"faces {lo:>6}-{min(hi, 10**6):<7}: {sel.sum():>3} shapes, median {np.median(R[sel, 1]):.2f} s, "
                  f"max {R[sel, 1].max():.2f} s")
    slope = np.polyfit(R[:, 0], R[:, 1], 1)
    print(f"linear fit: {slope[0] * 1e6:.1f} us/face + {slope[1]:.2f} s; at 20k faces: {np.polyval(slope, 20000):.2f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
