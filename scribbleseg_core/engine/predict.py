"""Segment an unseen shape with a trained model (no scribbles needed)."""

from __future__ import annotations

import numpy as np

from scribbleseg_core.engine.cores import propagate_from_cores
from scribbleseg_core.engine.energy import (
    feature_weights,
    network_unary,
    scribble_unary,
)
from scribbleseg_core.engine.graphcut import alpha_expansion
from scribbleseg_core.engine.optimize import TrainedModel
from scribbleseg_core.engine.refine import refine_labels
from scribbleseg_core.engine.shape import ShapeData


def predict_shape(model: TrainedModel, shape: ShapeData, *, refine: bool | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Segment an unseen shape with a trained model (no scribbles needed).

    Patch-level graph cut on the network's log-probabilities and the feature term, then
    (optionally) the face-level refinement and the propagation from its part cores
    (``params.cores``). Scribbles on the shape, if any, are honoured.

    Returns
    -------
    labels : (m,) int64 ndarray
        Refined face labels (equal to `patch_labels` without refinement).
    patch_labels : (m,) int64 ndarray
        The patch-level result on faces.
    """
    k = len(model.label_names)
    refine = model.params.refine if refine is None else refine
    allowed = np.arange(k)
    logp = model.classifier.log_proba(model.params.network_input(shape))
    D = model.encoder.encode(shape.X, shape.area, shape.patch)
    w = feature_weights(D, shape.patch_pairs, model.delta, model.params.lam)
    U = network_unary(shape.patch_matrix(), logp)
    U = U + scribble_unary(shape.patch, shape.scribble, allowed, k)
    y = alpha_expansion(U, shape.patch_pairs, w)
    patch_faces = y[shape.patch]
    if not refine:
        return patch_faces, patch_faces
    labels = refine_labels(shape.graph, logp, patch_faces, allowed, shape.scribble, model.params.refinement)
    if model.params.cores is not None:
        labels = propagate_from_cores(shape.graph, shape.area, labels, logp, shape.sdf, shape.scribble,
                                      model.params.cores)
    return labels, patch_faces
