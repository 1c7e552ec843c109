"""A whole collection, end to end: features, the optimization, predictions.

:func:`collection_run` is a generator of small frozen messages. The CLI's ``segment``
consumes it directly; the app runs it on a background job thread and applies each
message on the main thread.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from scribbleseg_core.engine.optimize import (
    SegmentParams,
    Snapshot,
    TrainedModel,
    segment_collection,
)
from scribbleseg_core.engine.predict import predict_shape
from scribbleseg_core.engine.shape import prepare_shape
from scribbleseg_core.formats.mesh import Mesh


@dataclass(frozen=True)
class FeaturesDone:
    """Shape `index` is prepared; `done` of `total`."""

    index: int
    done: int
    total: int


@dataclass(frozen=True, eq=False)
class StepDone:
    """One optimization step: labels per file face of the shapes `indices` (those the
    optimization has labeled so far)."""

    snapshot: Snapshot
    indices: tuple[int, ...]
    file_labels: tuple[np.ndarray, ...]


@dataclass(frozen=True, eq=False)
class Predicted:
    """Labels per file face predicted for unscribbled shape `index`."""

    index: int
    file_labels: np.ndarray


def collection_run(
    meshes: Sequence[Mesh],
    scribbles: Sequence[np.ndarray | None],
    label_names: Sequence[str],
    params: SegmentParams = SegmentParams(),
    *,
    num_patches: int = 50,
) -> Iterator[FeaturesDone | StepDone | Predicted]:
    """Segment the scribbled shapes, then predict the others.

    Parameters
    ----------
    meshes : sequence of Mesh
    scribbles : sequence of (m0,) int ndarray or None
        Scribble label per file face of each mesh (copies: the worker owns them).
    label_names : sequence of str
    params : SegmentParams
    num_patches : int
        Primitive patches per shape.

    Yields
    ------
    FeaturesDone
        After each shape is prepared.
    StepDone
        After each optimization step; the last one's snapshot is done and has the model.
    Predicted
        For each shape without scribbles, once the model is trained.
    """
    shapes = []
    for i, (mesh, scr) in enumerate(zip(meshes, scribbles)):
        has = scr is not None and bool((scr >= 0).any())
        shapes.append(prepare_shape(mesh, scr if has else None, num_patches=num_patches))
        if params.uses_label_context:
            shapes[-1].label_context  # noqa: B018 - computed (or read) here, in the features phase
        yield FeaturesDone(i, i + 1, len(meshes))
    last = None
    for snap in segment_collection(shapes, label_names, params):
        last = snap
        labeled = tuple(i for i, lab in enumerate(snap.labels) if (lab >= 0).any())
        yield StepDone(snap, labeled, tuple(meshes[i].labels_to_file(snap.labels[i]) for i in labeled))
    for i, (s, lab) in enumerate(zip(shapes, last.labels)):
        if not (lab >= 0).any():  # not part of the optimization (method "paper")
            yield Predicted(i, meshes[i].labels_to_file(predict_shape(last.model, s)))


def predict_run(model: TrainedModel, meshes: Sequence[Mesh], *, num_patches: int = 50) -> Iterator[FeaturesDone | Predicted]:
    """Segment `meshes` with a trained model, one at a time (features, then prediction).

    Yields
    ------
    FeaturesDone
        After each shape is prepared.
    Predicted
        Its labels per file face.
    """
    for i, mesh in enumerate(meshes):
        shape = prepare_shape(mesh, num_patches=num_patches)
        if model.learner.stage2 is not None:
            shape.label_context  # noqa: B018 - computed (or read) in the features phase
        yield FeaturesDone(i, i + 1, len(meshes))
        yield Predicted(i, mesh.labels_to_file(predict_shape(model, shape)))
