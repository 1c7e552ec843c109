"""The demo creatures before and after painting the shape *Paint here next* points to.

Runs the collection ``assets/Quadruped`` with its three scribbled creatures, takes the
suggestion among the creatures without strokes (:func:`~scribbleseg_core.engine.guidance.suggest`
on the confidence the app shows; the app's *Paint here next* weighs the painted shapes too),
paints that creature with the demo's stroke protocol (one stroke per connected part,
:func:`assets.generate.psb_protocol_strokes`) and runs again. Prints the Rand Index error of
every creature still predicted, after each run. What the README's figures after *Paint here
next* come from; the app's user paints by hand instead (fewer strokes, other faces).

Usage::

    python scripts/demo_next.py [--seed 0] [--threads 2]
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from scribbleseg_core.engine.guidance import suggest
from scribbleseg_core.engine.optimize import SegmentParams, segment_collection
from scribbleseg_core.engine.pipeline import collection_confidence
from scribbleseg_core.engine.shape import prepare_shape
from scribbleseg_core.evaluation.benchmark import load_category
from scribbleseg_core.evaluation.metrics import rand_index_error
from scribbleseg_core.formats.scribbles import Scribbles, Stroke

ASSETS = Path(__file__).resolve().parents[1] / "assets"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=0, help="network seed")
    ap.add_argument("--threads", type=int, default=2, help="torch threads")
    a = ap.parse_args(argv)
    sys.path.insert(0, str(ASSETS))
    from generate import psb_protocol_strokes

    items, names, _ = load_category(ASSETS, "Quadruped")
    base = SegmentParams()
    params = replace(base, network=replace(base.network, seed=a.seed, threads=a.threads))
    painted = {i: it.scribbles.face_labels() for i, it in enumerate(items) if it.scribbles is not None}

    def run():
        shapes = [prepare_shape(it.mesh, painted.get(i)) for i, it in enumerate(items)]
        for snap in segment_collection(shapes, names, params):
            pass
        errors = [rand_index_error(s.mesh.labels_to_file(lab), it.truth)
                  for s, lab, it in zip(shapes, snap.labels, items)]
        confidence = [None if i in painted else c
                      for i, c in enumerate(collection_confidence(snap, shapes, snap.labels))]
        predicted = [i for i in range(len(items)) if i not in painted]
        print(f"painted {', '.join(items[i].mesh.name for i in sorted(painted))}: the "
              f"{len(predicted)} predicted {np.mean([errors[i] for i in predicted]):.4f}")
        for i in predicted:
            print(f"  {items[i].mesh.name}  {errors[i]:.3f}")
        return shapes, errors, confidence

    shapes, _, confidence = run()
    hint = suggest([s.graph for s in shapes], [s.area for s in shapes], confidence)
    if hint is None:
        print("no unsure face: nothing to suggest")
        return
    mesh, truth = items[hint.shape].mesh, items[hint.shape].truth
    strokes = tuple(Stroke(label, faces) for label, faces in psb_protocol_strokes(mesh.V_file, mesh.F_file, truth))
    painted[hint.shape] = Scribbles(f"{mesh.name}.ply", mesh.num_file_faces, names, strokes).face_labels()
    print(f"Paint here next: {mesh.name}")
    _, errors, _ = run()
    print(f"  {mesh.name} (newly painted)  {errors[hint.shape]:.3f}")


if __name__ == "__main__":
    main()
