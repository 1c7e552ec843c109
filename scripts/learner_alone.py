"""The learner alone on PSB, trained on full labels: no alternation.

Compares learners apart from the alternation. For every category, 5 folds by sorted id (as
``scribbleseg bench --mode test --labels truth``): the learner and the learned boundary term
(:func:`~scribbleseg_core.engine.optimize.fit_model`, default parameters) are trained on the
ground-truth labels of the other folds' shapes, and every held-out shape is labeled twice:

* ``argmax``: every face takes the label of highest probability (no graph cut);
* ``cut``: the graph cut a new shape gets (:func:`~scribbleseg_core.engine.predict.predict_shape`
  with that learner and boundary term): what ``bench --mode test --labels truth`` scores,
  since with every face labeled the alternation stops after its first training.

Compare variants by ``cut``: a change can lower ``argmax`` and raise ``cut`` (softer or
rebalanced probabilities change what the cut's smoothness removes). Prints the Rand Index
error of both per category and their means, and writes them as JSON.

Usage::

    python scripts/learner_alone.py OUT.json [CATEGORY ...] [--seed 0] [--threads N] [--folds 5]

Two processes on half the categories each, ``--threads 1``, take about 12 minutes on 2
cores with the signatures cached; merge by reading both files.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from scribbleseg_core.engine.optimize import SegmentParams, fit_model
from scribbleseg_core.engine.predict import predict_shape
from scribbleseg_core.engine.shape import prepare_shape
from scribbleseg_core.evaluation.benchmark import load_category
from scribbleseg_core.evaluation.metrics import rand_index_error
from scribbleseg_core.evaluation.psb import categories, default_psb_dir


def run_category(root: Path, cat: str, params: SegmentParams, folds: int) -> dict[str, float]:
    """Mean Rand Index error of the category's held-out shapes: ``{"argmax": e, "cut": e}``."""
    items, names, _ = load_category(root, cat)
    shapes = [prepare_shape(it.mesh) for it in items]
    truth = [it.truth[it.mesh.proc_to_file] for it in items]
    fold_of = np.arange(len(items)) * folds // len(items)
    errors: dict[str, list[float]] = {"argmax": [], "cut": []}
    for f in range(folds):
        train = np.flatnonzero(fold_of != f)
        model = fit_model([shapes[i] for i in train], [truth[i] for i in train], names, params)
        for i in np.flatnonzero(fold_of == f):
            logp = model.log_proba(shapes[i])
            for kind, labels in (("argmax", logp.argmax(1)), ("cut", predict_shape(model, shapes[i], logp))):
                errors[kind].append(rand_index_error(items[i].mesh.labels_to_file(labels), items[i].truth))
    return {kind: float(np.mean(e)) for kind, e in errors.items()}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", type=Path, help="JSON file of the errors per category")
    ap.add_argument("categories", nargs="*", help="default: every category of the data")
    ap.add_argument("--data", type=Path, default=None, help="PSB folder (default ../shared/psb)")
    ap.add_argument("--seed", type=int, default=0, help="network seed")
    ap.add_argument("--threads", type=int, default=None, help="torch threads")
    ap.add_argument("--folds", type=int, default=5)
    a = ap.parse_args(argv)
    root = a.data or default_psb_dir()
    if root is None:
        ap.error("no PSB data: pass --data or set SCRIBBLESEG_PSB")
    cats = a.categories or categories(root)
    base = SegmentParams()
    params = replace(base, network=replace(base.network, seed=a.seed, threads=a.threads))
    out = {}
    print(f"{'':10s} argmax  cut")
    for cat in cats:
        t = time.perf_counter()
        out[cat] = run_category(root, cat, params, a.folds)
        print(f"{cat:10s} {out[cat]['argmax']:.4f}  {out[cat]['cut']:.4f}  ({time.perf_counter() - t:.0f} s)", flush=True)
        a.out.write_text(json.dumps(out, indent=1))
    means = {kind: np.mean([v[kind] for v in out.values()]) for kind in ("argmax", "cut")}
    print(f"{'mean':10s} {means['argmax']:.4f}  {means['cut']:.4f}  ({len(out)} categories)")


if __name__ == "__main__":
    main()
