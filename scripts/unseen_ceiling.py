"""Where the unseen-shape error comes from: the training labels or the network's inputs.

``python scripts/unseen_ceiling.py [PSB_DIR] [--categories C ...]`` prints, per category, the
Rand Index error on unseen shapes (5 folds by sorted id, as ``scribbleseg bench --mode test``)
of the network trained on

* ``propagated``: the training shapes' propagated scribble labels. This is the model the
  engine ends with (the refinement retrains the network afresh on those labels), so these
  figures equal the benchmark's refined unseen-shape errors, in about a third of the time;
* ``truth``: the training shapes' ground-truth labels, a diagnostic ceiling (a fully
  supervised network on the same inputs), never a result.

The prediction is :func:`predict_shape` (patch graph cut, then face refinement) either way.
``--seeds 0 1 2 3 4`` trains with each network seed and prints the mean and the standard
deviation over seeds: how much of a figure is the seed's luck.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from scribbleseg_core.bench.report import load_category  # noqa: E402
from scribbleseg_core.metrics import rand_index_error  # noqa: E402
from scribbleseg_core.network import FaceClassifier, NetworkParams  # noqa: E402
from scribbleseg_core.optimize import SegmentParams, TrainedModel, predict_shape  # noqa: E402
from scribbleseg_core.patch_features import feature_delta, fit_patch_encoder  # noqa: E402
from scribbleseg_core.psb import categories  # noqa: E402
from scribbleseg_core.shape import prepare_shape  # noqa: E402


def unseen_errors(root: Path, cat: str, params: SegmentParams, folds: int = 5,
                  kinds: tuple[str, ...] = ("propagated", "truth"), seeds: tuple[int, ...] | None = None,
                  ) -> dict[str, np.ndarray]:
    """Mean unseen-shape Rand Index error per kind of training label, one per network seed.

    The shapes, their inputs and training labels are made once; per seed (default
    ``params.network.seed``) the patch codebook and the networks are refit, as the engine
    seeds both from ``NetworkParams.seed``.

    Returns
    -------
    dict
        kind -> (len(seeds),) float64 ndarray.
    """
    seeds = (params.network.seed,) if seeds is None else tuple(seeds)
    items, names, _ = load_category(root, cat)
    k, n = len(names), len(items)
    shapes = [prepare_shape(it.mesh, it.scribbles.face_labels()) for it in items]
    unscribbled = [prepare_shape(it.mesh) for it in items]  # how the held-out shapes are predicted
    inputs = [s.network_input(params.context_scales) for s in shapes]
    train_labels = {}
    if "propagated" in kinds:
        train_labels["propagated"] = [s.propagate(k, params.propagation) for s in shapes]  # as the engine does
    if "truth" in kinds:
        train_labels["truth"] = [np.asarray(it.truth)[it.mesh.proc_to_file] for it in items]
    fold_of = np.arange(n) * folds // n
    means = {kind: [] for kind in train_labels}
    for seed in seeds:
        run = replace(params, network=replace(params.network, seed=seed))
        errors = {kind: [] for kind in train_labels}
        for f in range(folds):
            train = np.flatnonzero(fold_of != f)
            encoder = fit_patch_encoder([shapes[i].X for i in train], seed=seed)
            desc = [encoder.encode(shapes[i].X, shapes[i].area, shapes[i].patch) for i in train]
            delta = feature_delta(desc, [shapes[i].patch_pairs for i in train])
            for kind, labels in train_labels.items():
                clf = FaceClassifier(inputs[0].shape[1], k, run.network)
                clf.fit([inputs[i] for i in train], [labels[i] for i in train])
                model = TrainedModel(clf, encoder, delta, names, run)
                for i in np.flatnonzero(fold_of == f):
                    s = unscribbled[i]
                    refined, _ = predict_shape(model, s)
                    errors[kind].append(rand_index_error(s.mesh.labels_to_file(refined), items[i].truth))
        for kind, v in errors.items():
            means[kind].append(float(np.mean(v)))
    return {kind: np.array(v) for kind, v in means.items()}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", nargs="?", default=str(ROOT.parent / "shared" / "psb"))
    parser.add_argument("--categories", nargs="+")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--seeds", type=int, nargs="+", default=[NetworkParams().seed], help="network seeds")
    parser.add_argument("--kinds", nargs="+", choices=["propagated", "truth"], default=["propagated", "truth"])
    args = parser.parse_args(argv)
    root = Path(args.data)
    if not root.is_dir():
        sys.exit(f"{root}: no benchmark data (expected ../shared/psb beside the project)")
    base = SegmentParams()
    params = replace(base, network=replace(base.network, threads=args.threads))
    kinds = tuple(args.kinds)
    names = {"propagated": "trained on propagated labels", "truth": "trained on ground truth (ceiling)"}
    spread = len(args.seeds) > 1
    print("| category | " + " | ".join(names[k] + (" (mean ± sd over seeds)" if spread else "") for k in kinds)
          + " | seconds |")
    print("|---|" + "---|" * len(kinds) + "---|")
    rows = []
    for cat in args.categories or categories(root):
        t = time.perf_counter()
        row = unseen_errors(root, cat, params, kinds=kinds, seeds=args.seeds)
        rows.append(row)
        print(f"| {cat} | " + " | ".join(_cell(row[k]) for k in kinds) + f" | {time.perf_counter() - t:.0f} |", flush=True)
    # mean over categories per seed, then its mean and spread over seeds
    print("| **average** | " + " | ".join(f"**{_cell(np.mean([r[k] for r in rows], axis=0))}**" for k in kinds) + " | |")


def _cell(values: np.ndarray) -> str:
    return f"{values.mean():.3f}" if len(values) == 1 else f"{values.mean():.4f} ± {values.std(ddof=1):.4f}"


if __name__ == "__main__":
    main()
