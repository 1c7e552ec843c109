"""The worker's generator, without Qt: features, then streamed steps over the whole collection."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scribbleseg_app.controllers.engine_runs import FeaturesDone, Predicted, StepDone, collection_run

from scribbleseg_core.engine.network import NetworkParams
from scribbleseg_core.engine.optimize import SegmentParams
from tests.core.planted import LABELS, creature, stroke_faces


def test_collection_run_streams_steps_of_every_shape(monkeypatch, tmp_path):
    monkeypatch.setenv("SCRIBBLESEG_CACHE_DIR", str(tmp_path))
    meshes, scribbles, gts = [], [], []
    for i, (limb, head) in enumerate([(1.6, 0.9), (1.2, 0.7), (2.0, 1.1)]):
        mesh, gt = creature(limb, head, seed=i)
        meshes.append(mesh)
        gts.append(gt)
        scr = None
        if i < 2:
            scr = np.full(len(gt), -1)
            for lab in range(3):
                scr[stroke_faces(mesh, gt, lab)] = lab
        scribbles.append(scr)
    params = SegmentParams(network=NetworkParams(epochs=20, faces_per_epoch=1000))
    msgs = list(collection_run(meshes, scribbles, LABELS, params))
    assert [m.done for m in msgs if isinstance(m, FeaturesDone)] == [1, 2, 3]
    steps = [m for m in msgs if isinstance(m, StepDone)]
    assert steps[0].snapshot.phase == "init" and steps[-1].snapshot.done
    assert steps[0].indices == (0, 1)  # the shape without scribbles joins at the first cut
    assert steps[-1].indices == (0, 1, 2)
    for i, labels in zip(steps[-1].indices, steps[-1].file_labels):
        assert (labels == gts[i]).mean() > (0.9 if scribbles[i] is not None else 0.85)
    assert not [m for m in msgs if isinstance(m, Predicted)]  # nothing left to predict after the run
    paper = list(collection_run(meshes, scribbles, LABELS, replace(params, method="paper")))
    (pred,) = [m for m in paper if isinstance(m, Predicted)]  # the paper's variant predicts it afterwards
    assert pred.index == 2 and pred.file_labels.shape == gts[2].shape
