"""The learner alone on PSB, trained on full labels: no alternation, no graph cut.

Compares learners apart from the energy around them. For every category, 5 folds by sorted
id (as ``scribbleseg bench --mode test --labels truth``): the learner
(:func:`~scribbleseg_core.engine.optimize.fit_learner`, default parameters) is trained on the
ground-truth labels of the other folds' shapes, and every held-out face takes the label of
highest probability. Prints the Rand Index error per category and their mean, and writes
them as JSON.

Usage::

    python scripts/learner_alone.py OUT.json [CATEGORY ...] [--seed 0] [--threads N] [--folds 5]

Two processes on half the categories each, ``--threads 1``, take about 10 minutes on 2
cores with the signatures cached; merge by reading both files.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from scribbleseg_core.engine.optimize import SegmentParams, fit_learner
from scribbleseg_core.engine.shape import prepare_shape
from scribbleseg_core.evaluation.benchmark import load_category
from scribbleseg_core.evaluation.metrics import rand_index_error
from scribbleseg_core.evaluation.psb import categories, default_psb_dir


def run_category(root: Path, cat: str, params: SegmentParams, folds: int) -> float:
    """Mean Rand Index error of the category's held-out shapes."""
    items, names, _ = load_category(root, cat)
    shapes = [prepare_shape(it.mesh) for it in items]
    truth = [it.truth[it.mesh.proc_to_file] for it in items]
    fold_of = np.arange(len(items)) * folds // len(items)
    errors = []
    for f in range(folds):
        train = np.flatnonzero(fold_of != f)
        learner = fit_learner([shapes[i] for i in train], [truth[i] for i in train], len(names), params)
        for i in np.flatnonzero(fold_of == f):
            x = params.network_input(shapes[i])
            ctx = shapes[i].label_context if learner.stage2 is not None else None
            labels = learner.log_proba(x, ctx).argmax(1)
            errors.append(rand_index_error(items[i].mesh.labels_to_file(labels), items[i].truth))
    return float(np.mean(errors))


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
    for cat in cats:
        t = time.perf_counter()
        out[cat] = run_category(root, cat, params, a.folds)
        print(f"{cat:10s} {out[cat]:.4f}  ({time.perf_counter() - t:.0f} s)", flush=True)
        a.out.write_text(json.dumps(out, indent=1))
    print(f"{'mean':10s} {np.mean(list(out.values())):.4f}  ({len(out)} categories)")


if __name__ == "__main__":
    main()
