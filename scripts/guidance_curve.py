"""Does painting where the app suggests beat painting where the model is merely unsure?

On each PSB category, half the shapes (even positions) may be painted and the other half
are scored. The collection starts with one painted shape (its benchmark scribbles); after
every run a strategy picks the next shape to paint:

* ``suggested``: the shape of :func:`~scribbleseg_core.engine.guidance.suggest`'s region;
* ``random``: the shape of a face drawn at random among the unconfident faces
  (confidence below :data:`~scribbleseg_core.engine.guidance.UNCONFIDENT`).

Painting a shape adds its benchmark scribbles (one stroke per part), so the x axis counts
strokes. Prints the Rand Index error of the scored shapes per step and strategy, and with
``--plot`` draws the curves averaged over categories.

Usage::

    python scripts/guidance_curve.py run OUT [CATEGORY ...] [--steps 4] [--seed 0]
    python scripts/guidance_curve.py plot OUT [OUT ...] --figure docs/guidance_curve.png
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from scribbleseg_core.engine.guidance import UNCONFIDENT, suggest
from scribbleseg_core.engine.optimize import SegmentParams, segment_collection
from scribbleseg_core.engine.pipeline import collection_confidence
from scribbleseg_core.engine.shape import prepare_shape
from scribbleseg_core.evaluation.benchmark import load_category
from scribbleseg_core.evaluation.metrics import rand_index_error
from scribbleseg_core.evaluation.psb import categories, default_psb_dir

STRATEGIES = ("suggested", "random")
#: The error the note reports the strokes needed for.
TARGET = 0.08


def run_category(root: Path, cat: str, steps: int, seed: int, threads: int) -> dict:
    items, names, _ = load_category(root, cat)
    params = SegmentParams(network=replace(SegmentParams().network, seed=seed, threads=threads))
    pool = list(range(0, len(items), 2))
    scored = list(range(1, len(items), 2))
    strokes_of = [len(it.scribbles.strokes) for it in items]
    rng = np.random.default_rng(seed)

    def run(painted: list[int]) -> tuple[float, list[np.ndarray | None], list]:
        shapes = [prepare_shape(it.mesh, it.scribbles.face_labels() if i in painted else None)
                  for i, it in enumerate(items)]
        for snap in segment_collection(shapes, names, params):
            pass
        err = float(np.mean([rand_index_error(shapes[i].mesh.labels_to_file(snap.labels[i]), items[i].truth)
                             for i in scored]))
        conf = [c if i in pool and i not in painted else None
                for i, c in enumerate(collection_confidence(snap, shapes, snap.labels))]
        return err, conf, shapes

    first = [pool[0]]
    err0, conf0, shapes0 = run(first)
    out = {}
    for strategy in STRATEGIES:
        painted, err, conf, shapes = list(first), err0, conf0, shapes0
        curve = [(sum(strokes_of[i] for i in painted), err)]
        for _ in range(steps):
            if strategy == "suggested":
                hint = suggest([s.graph for s in shapes], [s.area for s in shapes], conf)
                pick = None if hint is None else hint.shape
            else:
                low = [(i, np.flatnonzero(c < UNCONFIDENT)) for i, c in enumerate(conf) if c is not None]
                sizes = np.array([len(f) for _, f in low], float)
                pick = None if not sizes.sum() else low[rng.choice(len(low), p=sizes / sizes.sum())][0]
            if pick is None:
                break
            painted.append(pick)
            err, conf, shapes = run(painted)
            curve.append((sum(strokes_of[i] for i in painted), err))
            print(f"  {cat} {strategy}: painted {painted} strokes {curve[-1][0]} error {err:.4f}", flush=True)
        out[strategy] = {"painted": painted, "curve": curve}
    return out


def cmd_run(args) -> int:
    root = default_psb_dir()
    if root is None:
        print("the PSB data is not found (../shared/psb or $SCRIBBLESEG_PSB)", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for cat in args.categories or categories(root):
        target = out / f"{cat}.json"
        if target.is_file():
            continue
        t = time.perf_counter()
        result = run_category(root, cat, args.steps, args.seed, args.threads)
        result["seconds"] = time.perf_counter() - t
        target.write_text(json.dumps(result))
        print(cat, {s: [round(e, 4) for _, e in result[s]["curve"]] for s in STRATEGIES}, flush=True)
    return 0


def load_runs(folders: list[Path]) -> list[dict]:
    """Every category run in `folders` (one JSON per category and seed)."""
    return [json.loads(p.read_text()) for f in folders for p in sorted(f.glob("*.json"))]


def curves(runs: list[dict]) -> tuple[dict, int]:
    """Per strategy, (strokes, error) arrays of shape (runs, steps), cut to the shortest run."""
    steps = min(len(r[s]["curve"]) for r in runs for s in STRATEGIES)
    out = {}
    for s in STRATEGIES:
        x = np.array([[c[0] for c in r[s]["curve"][:steps]] for r in runs], float)
        y = np.array([[c[1] for c in r[s]["curve"][:steps]] for r in runs], float)
        out[s] = (x, y)
    return out, steps


def strokes_to(x: np.ndarray, y: np.ndarray, target: float) -> float:
    """Strokes at which the mean curve first reaches `target` (linear between steps); inf if never."""
    for i in range(len(y)):
        if y[i] <= target:
            if i == 0:
                return float(x[0])
            t = (y[i - 1] - target) / (y[i - 1] - y[i])
            return float(x[i - 1] + t * (x[i] - x[i - 1]))
    return float("inf")


def cmd_plot(args) -> int:
    runs = load_runs([Path(f) for f in args.folders])
    c, steps = curves(runs)
    n = len(runs)
    (xs, ys), (xr, yr) = c["suggested"], c["random"]
    diff = ys - yr
    print(f"{n} category runs; mean over them (± standard error of the paired difference)\n")
    print("| painted shapes | strokes (suggested / random) | error, suggested | error, random | suggested − random | suggested better in |")
    print("|---|---|---|---|---|---|")
    for k in range(steps):
        se = diff[:, k].std(ddof=1) / np.sqrt(n) if n > 1 else float("nan")
        better = int((diff[:, k] < 0).sum())
        print(f"| {k + 1} | {xs[:, k].mean():.1f} / {xr[:, k].mean():.1f} | {ys[:, k].mean():.4f} | {yr[:, k].mean():.4f} "
              f"| {diff[:, k].mean():+.4f} ± {se:.4f} | {better} of {n} |")
    print()
    for target in (TARGET, yr[:, -1].mean()):
        a = strokes_to(xs.mean(0), ys.mean(0), target)
        b = strokes_to(xr.mean(0), yr.mean(0), target)
        print(f"strokes for a mean error of {target:.4f}: suggested {a:.1f}, random {b:.1f}")
    print(f"category runs at or below {TARGET} with the last step: suggested {(ys[:, -1] <= TARGET).sum()}, "
          f"random {(yr[:, -1] <= TARGET).sum()} of {n}")
    if args.figure:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6, 3.6))
        for s, (x, y) in c.items():
            ax.errorbar(x.mean(0), y.mean(0), yerr=y.std(0, ddof=1) / np.sqrt(n), marker="o", capsize=3, label=s)
        ax.axhline(TARGET, color="gray", lw=0.8, ls="--")
        ax.set_xlabel("strokes (mean over category runs)")
        ax.set_ylabel("Rand Index error, unpainted shapes")
        ax.set_title(f"Painting where the app suggests ({n} category runs)", fontsize=10)
        ax.legend()
        fig.tight_layout()
        fig.savefig(args.figure, dpi=110)
        print(f"wrote {args.figure}")
    return 0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("out")
    r.add_argument("categories", nargs="*")
    r.add_argument("--steps", type=int, default=4, help="shapes painted after the first (default 4)")
    r.add_argument("--seed", type=int, default=0)
    r.add_argument("--threads", type=int, default=1, help="torch threads (default 1: run two at once on 2 cores)")
    q = sub.add_parser("plot")
    q.add_argument("folders", nargs="+")
    q.add_argument("--figure")
    args = p.parse_args(argv)
    return cmd_run(args) if args.cmd == "run" else cmd_plot(args)


if __name__ == "__main__":
    sys.exit(main())
