"""Segment a shape with a trained model: the graph-cut step of the alternation on one shape."""

from __future__ import annotations

import numpy as np

from scribbleseg_core.engine.energy import feature_weights, network_unary, scribble_unary
from scribbleseg_core.engine.graphcut import alpha_expansion
from scribbleseg_core.engine.guidance import label_confidence
from scribbleseg_core.engine.optimize import TrainedModel
from scribbleseg_core.engine.propagate import FaceEnergy
from scribbleseg_core.engine.shape import ShapeData


def predict_with_confidence(model: TrainedModel, shape: ShapeData) -> tuple[np.ndarray, np.ndarray]:
    """:func:`predict_shape`'s labels (m,) and their confidence (m,) in [0, 1] under the model's
    probabilities (:func:`~scribbleseg_core.engine.guidance.label_confidence`; the model never
    saw the shape), from one pass of the network."""
    logp = model.log_proba(shape)
    labels = predict_shape(model, shape, logp)
    return labels, label_confidence(logp, labels, shape.scribble)


def predict_shape(model: TrainedModel, shape: ShapeData, log_proba: np.ndarray | None = None) -> np.ndarray:
    """Labels of `shape` from the model's network and the energy it was trained with.

    ``method="face"``: the face energy's graph cut with the network's log-probabilities
    (:class:`~scribbleseg_core.engine.propagate.FaceEnergy`), the shape's scribbles, if any,
    hard; on a shape without scribbles the smoothness is the model's learned boundary term
    (:mod:`~scribbleseg_core.engine.boundary`). ``method="paper"``: the patch-level cut of
    eq. 1–4 with the collection's patch descriptors.

    Parameters
    ----------
    model : TrainedModel
    shape : ShapeData
    log_proba : (m, k) float ndarray, optional
        ``model.log_proba(shape)`` when the caller has it already (:func:`predict_with_confidence`).

    Returns
    -------
    labels : (m,) int64 ndarray
        Per face of the repaired mesh.
    """
    k = len(model.label_names)
    params = model.params
    logp = model.log_proba(shape) if log_proba is None else log_proba
    if params.method == "face":
        boundary = None if shape.is_scribbled else model.boundary_proba(shape)
        return FaceEnergy(shape.graph, shape.scribble, k, params.propagation, shape.sdf, boundary).cut(logp)
    D = model.encoder.encode(shape.X, shape.area, shape.patch)
    w = feature_weights(D, shape.patch_pairs, model.delta, params.lam)
    U = network_unary(shape.patch_matrix(), logp) + scribble_unary(shape.patch, shape.scribble, np.arange(k), k)
    return alpha_expansion(U, shape.patch_pairs, w)[shape.patch]
