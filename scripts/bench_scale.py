"""Throughput of ``scribbleseg predict`` on Dask: 1 worker against 2 on this machine.

``python scripts/bench_scale.py [--shapes 200] [--workers 1 2]``: trains a model on the
demo chairs (``segment assets/Chair``), writes a collection of demo-like shapes (each demo
mesh of both families, rotated at random and jittered, so every one needs its signatures
computed), then predicts the collection once per worker count, each time with an empty
signature cache, and prints shapes per minute, the per-shape cost and the speed-up.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def write_collection(out: Path, count: int, seed: int = 0) -> int:
    """`count` demo-like meshes in `out`; returns their total face count."""
    from scipy.spatial.transform import Rotation

    from scribbleseg_core.formats.mesh import load_mesh

    demos = sorted((ROOT / "assets").glob("*/*.ply"))
    rng = np.random.default_rng(seed)
    faces = 0
    for i in range(count):
        mesh = load_mesh(demos[i % len(demos)])
        V = Rotation.random(random_state=rng.integers(1 << 31)).apply(mesh.V_file)
        V += rng.normal(0, 1e-3 * np.ptp(V, axis=0).max(), V.shape)
        lines = ["OFF", f"{len(V)} {len(mesh.F_file)} 0"] + [f"{a:.9g} {b:.9g} {c:.9g}" for a, b, c in V]
        lines += [f"3 {a} {b} {c}" for a, b, c in mesh.F_file]
        (out / f"shape_{i:04d}.off").write_text("\n".join(lines) + "\n")
        faces += len(mesh.F_file)
    return faces


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shapes", type=int, default=200)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        env = dict(os.environ, SCRIBBLESEG_CACHE_DIR=str(tmp / "train-cache"))
        subprocess.run([sys.executable, "-m", "scribbleseg_core.cli", "segment", str(ROOT / "assets" / "Chair"),
                        "--out", str(tmp / "trained"), "--quiet"], check=True, env=env)
        (tmp / "in").mkdir()
        faces = write_collection(tmp / "in", args.shapes)
        print(f"{args.shapes} shapes, {faces / args.shapes:.0f} faces on average; model from the demo chairs\n")
        print(f"{'workers':>7} {'seconds':>8} {'shapes/min':>11} {'s/shape':>8} {'speed-up':>9}")
        base = None
        for n in args.workers:
            env = dict(os.environ, SCRIBBLESEG_CACHE_DIR=str(tmp / f"cache-{n}"))
            t = time.perf_counter()
            subprocess.run([sys.executable, "-m", "scribbleseg_core.cli", "predict", str(tmp / "trained" / "model"),
                            str(tmp / "in"), "--out", str(tmp / f"out-{n}"), "--workers", str(n), "--quiet"],
                           check=True, env=env)
            sec = time.perf_counter() - t
            rate = 60 * args.shapes / sec
            base = base or rate / n
            print(f"{n:>7} {sec:>8.1f} {rate:>11.1f} {sec * n / args.shapes:>8.2f} {rate / base:>9.2f}")


if __name__ == "__main__":
    main()
