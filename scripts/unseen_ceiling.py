"""Where the unseen-shape error comes from: the training labels or the network's inputs.

``python scripts/unseen_ceiling.py [PSB_DIR] [--categories C ...]`` prints, per category, the
Rand Index error on unseen shapes (5 folds by sorted id, as ``scribbleseg bench --mode test``)
of the network trained on

* ``engine``: the labels the engine's model for unseen shapes learns (:func:`unseen_targets`:
  the scribble propagation, guided by the stroke network where it carries over). The engine
  trains that model afresh at its end, so these figures equal the benchmark's refined
  unseen-shape errors, in about a third of the time;
* ``propagated``: the training shapes' propagated scribble labels (without the stroke
  network's guide);
* ``truth``: the training shapes' ground-truth labels, a diagnostic ceiling (a fully
  supervised network on the same inputs), never a result.

The prediction is :func:`predict_shape` (patch graph cut, then face refinement) either way.
``--seeds 0 1 2 3 4`` trains with each network seed and prints the mean and the standard
deviation over seeds: how much of a figure is the seed's luck. Options of the engine are
not flags here: the script runs ``SegmentParams()`` as it is.
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

from scribbleseg_core.engine.network import FaceClassifier, NetworkParams  # noqa: E402
from scribbleseg_core.engine.optimize import SegmentParams, TrainedModel, unseen_targets  # noqa: E402
from scribbleseg_core.engine.patch_features import feature_delta, fit_patch_encoder  # noqa: E402
from scribbleseg_core.engine.predict import predict_shape  # noqa: E402
from scribbleseg_core.engine.propagate import propagate_shape  # noqa: E402
from scribbleseg_core.engine.shape import prepare_shape  # noqa: E402
from scribbleseg_core.evaluation.benchmark import load_category  # noqa: E402
from scribbleseg_core.evaluation.metrics import rand_index_error  # noqa: E402
from scribbleseg_core.evaluation.psb import categories  # noqa: E402


def unseen_errors(root: Path, cat: str, params: SegmentParams, folds: int = 5,
                  kinds: tuple[str, ...] = ("engine", "truth"), seeds: tuple[int, ...] | None = None,
                  ) -> dict[str, np.ndarray]:
    """Mean unseen-shape Rand Index error per kind of training label, one per network seed.

    The shapes, their inputs and propagated labels are made once; per seed (default
    ``params.network.seed``) the patch codebook, the stroke network and the networks are
    refit, as the engine seeds all of them from ``NetworkParams.seed``.

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
    inputs = [params.network_input(s) for s in shapes]
    propagated = [propagate_shape(s, k, params.propagation) for s in shapes] if {"engine", "propagated"} & set(kinds) else None
    truth = [np.asarray(it.truth)[it.mesh.proc_to_file] for it in items]
    fold_of = np.arange(n) * folds // n
    means = {kind: [] for kind in kinds}
    for seed in seeds:
        run = replace(params, network=replace(params.network, seed=seed))
        errors = {key: [] for key in means}
        for f in range(folds):
            train = np.flatnonzero(fold_of != f)
            encoder = fit_patch_encoder([shapes[i].X for i in train], seed=seed)
            desc = [encoder.encode(shapes[i].X, shapes[i].area, shapes[i].patch) for i in train]
            delta = feature_delta(desc, [shapes[i].patch_pairs for i in train])
            for kind in kinds:
                if kind == "engine":  # what the engine's model for unseen shapes learns
                    labels = unseen_targets([shapes[i] for i in train], [inputs[i] for i in train],
                                            [propagated[i] for i in train], k, run)
                else:
                    labels = [(propagated if kind == "propagated" else truth)[i] for i in train]
                clf = FaceClassifier(inputs[0].shape[1], k, run.network)
                clf.fit([inputs[i] for i in train], labels)
                model = TrainedModel(clf, encoder, delta, names, run)
                for i in np.flatnonzero(fold_of == f):
                    s = unscribbled[i]
                    refined, _ = predict_shape(model, s)
                    errors[kind].append(rand_index_error(s.mesh.labels_to_file(refined), items[i].truth))
        for key, v in errors.items():
            means[key].append(float(np.mean(v)))
    return {key: np.array(v) for key, v in means.items()}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", nargs="?", default=str(ROOT.parent / "shared" / "psb"))
    parser.add_argument("--categories", nargs="+")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--seeds", type=int, nargs="+", default=[NetworkParams().seed], help="network seeds")
    parser.add_argument("--kinds", nargs="+", choices=["engine", "propagated", "truth"], default=["engine", "truth"])
    args = parser.parse_args(argv)
    root = Path(args.data)
    if not root.is_dir():
        sys.exit(f"{root}: no benchmark data (expected ../shared/psb beside the project)")
    base = SegmentParams()
    params = replace(base, network=replace(base.network, threads=args.threads))
    keys = args.kinds
    names = {"engine": "engine's labels", "propagated": "propagated labels", "truth": "ground truth (ceiling)"}
    spread = len(args.seeds) > 1
    print("| category | " + " | ".join(names[kind] + (" (mean ± sd over seeds)" if spread else "") for kind in keys)
          + " | seconds |")
    print("|---|" + "---|" * len(keys) + "---|")
    rows = []
    for cat in args.categories or categories(root):
        t = time.perf_counter()
        row = unseen_errors(root, cat, params, kinds=tuple(args.kinds), seeds=args.seeds)
        rows.append(row)
        print(f"| {cat} | " + " | ".join(_cell(row[key]) for key in keys) + f" | {time.perf_counter() - t:.0f} |", flush=True)
    # mean over categories per seed, then its mean and spread over seeds
    print("| **average** | " + " | ".join(f"**{_cell(np.mean([r[key] for r in rows], axis=0))}**" for key in keys) + " | |")


def _cell(values: np.ndarray) -> str:
    return f"{values.mean():.4f}" if len(values) == 1 else f"{values.mean():.4f} ± {values.std(ddof=1):.4f}"


if __name__ == "__main__":
    main()
