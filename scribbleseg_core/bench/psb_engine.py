"""Benchmark the engine on ../shared/psb: Rand Index error and seconds per shape.

``python -m scribbleseg_core.bench.psb_engine [--categories A B] [--folds 5] [--init geodesic|paper]``

Two settings per category, each with the paper-faithful patch result and the refined one:

- train: all 20 shapes scribbled; score the labels the optimization gives them (Table 1).
- test: k folds by sorted id; segment the other folds' scribbled shapes, predict the held-out
  fold without its scribbles; every shape predicted once (Table 2 used leave-one-out).

Scores are against the label maps (``labels/*.seg``). Features come from the cache (their
first computation is timed separately).
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from scribbleseg_core.cache import cached_face_features
from scribbleseg_core.export import read_seg
from scribbleseg_core.mesh_io import find_meshes, load_mesh
from scribbleseg_core.metrics import rand_index_error
from scribbleseg_core.optimize import SegmentParams, predict_shape, segment_collection
from scribbleseg_core.psb import categories, default_psb_dir
from scribbleseg_core.scribbles import read_scribbles
from scribbleseg_core.shape import prepare_shape


def _load_category(root: Path, cat: str):
    folder = root / cat
    items = []
    t_feat = 0.0
    for path in find_meshes(folder):
        mesh = load_mesh(path)
        scr = read_scribbles(folder / "scribbles" / f"{path.stem}.json", num_faces=mesh.num_file_faces)
        t = time.perf_counter()
        cached_face_features(mesh.V, mesh.F)
        t_feat += time.perf_counter() - t
        gt = read_seg(folder / "labels" / f"{path.stem}.seg", mesh.num_file_faces)
        items.append((mesh, scr, gt))
    return items, scr.label_names, t_feat


def _run(shapes, names, params):
    last = None
    for snap in segment_collection(shapes, names, params):
        last = snap
    return last


def _ri(mesh, labels, gt) -> float:
    return rand_index_error(mesh.labels_to_file(labels), gt)


def bench_category(root: Path, cat: str, params: SegmentParams, folds: int, modes) -> dict:
    items, names, t_feat = _load_category(root, cat)
    n = len(items)
    out = {"shapes": n, "feature_seconds_per_shape": t_feat / n}
    t = time.perf_counter()
    scribbled = [prepare_shape(m, s.face_labels()) for m, s, _ in items]
    unscribbled = [prepare_shape(m) for m, _, _ in items]
    t_prep = (time.perf_counter() - t) / n
    if "train" in modes:
        t = time.perf_counter()
        snap = _run(scribbled, names, params)
        sec = time.perf_counter() - t
        out["train"] = {
            "ri_error_refined": float(np.mean([_ri(m, l, g) for (m, _, g), l in zip(items, snap.labels)])),
            "ri_error_patch": float(np.mean([_ri(m, l, g) for (m, _, g), l in zip(items, snap.patch_labels)])),
            "iterations": snap.iteration,
            "seconds_per_shape": sec / n + t_prep,
        }
    if "test" in modes:
        ri_ref, ri_patch = np.zeros(n), np.zeros(n)
        t = time.perf_counter()
        fold_of = np.arange(n) * folds // n
        for f in range(folds):
            train_idx = np.flatnonzero(fold_of != f)
            snap = _run([scribbled[i] for i in train_idx], names, params)
            for i in np.flatnonzero(fold_of == f):
                labels, patch_labels = predict_shape(snap.model, unscribbled[i])
                m, _, g = items[i]
                ri_ref[i], ri_patch[i] = _ri(m, labels, g), _ri(m, patch_labels, g)
        sec = time.perf_counter() - t
        out["test"] = {
            "ri_error_refined": float(ri_ref.mean()),
            "ri_error_patch": float(ri_patch.mean()),
            "folds": folds,
            "seconds_per_shape": sec / n + t_prep,
        }
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--psb", default=None)
    ap.add_argument("--categories", nargs="*")
    ap.add_argument("--folds", type=int, default=5)
    ap.add_argument("--modes", nargs="*", default=["train", "test"])
    ap.add_argument("--init", default="geodesic", choices=["geodesic", "paper"])
    ap.add_argument("--json", default=None, help="also write the results here")
    args = ap.parse_args(argv)
    root = Path(args.psb) if args.psb else default_psb_dir()
    if root is None:
        print("PSB data not found (expected ../shared/psb); nothing to benchmark")
        return 0
    paper = json.loads((root / "paper_results.json").read_text())
    p_train = paper["table1_training_shapes"]["paper_train"]
    p_test = paper["table2_leave_one_out"]["paper_test"]
    params = replace(SegmentParams(), init=args.init)
    cats = args.categories or categories(root)
    results = {}
    print(f"{'category':<10} | {'train patch':>11} {'refined':>8} {'paper':>6} {'s/shape':>7} | "
          f"{'test patch':>10} {'refined':>8} {'paper':>6} {'s/shape':>7} | {'feat s':>6}", flush=True)
    for cat in cats:
        r = bench_category(root, cat, params, args.folds, args.modes)
        results[cat] = r
        tr, te = r.get("train", {}), r.get("test", {})
        print(f"{cat:<10} | {tr.get('ri_error_patch', np.nan):>11.3f} {tr.get('ri_error_refined', np.nan):>8.3f} "
              f"{p_train.get(cat, np.nan):>6.3f} {tr.get('seconds_per_shape', np.nan):>7.1f} | "
              f"{te.get('ri_error_patch', np.nan):>10.3f} {te.get('ri_error_refined', np.nan):>8.3f} "
              f"{p_test.get(cat, np.nan):>6.3f} {te.get('seconds_per_shape', np.nan):>7.1f} | "
              f"{r['feature_seconds_per_shape']:>6.2f}", flush=True)
    def avg(mode, key):
        vals = [r[mode][key] for r in results.values() if mode in r]
        return float(np.mean(vals)) if vals else float("nan")
    print(f"{'average':<10} | {avg('train', 'ri_error_patch'):>11.3f} {avg('train', 'ri_error_refined'):>8.3f} "
          f"{np.mean([p_train[c] for c in cats]):>6.3f} {avg('train', 'seconds_per_shape'):>7.1f} | "
          f"{avg('test', 'ri_error_patch'):>10.3f} {avg('test', 'ri_error_refined'):>8.3f} "
          f"{np.mean([p_test.get(c, np.nan) for c in cats]):>6.3f} {avg('test', 'seconds_per_shape'):>7.1f} |")
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
