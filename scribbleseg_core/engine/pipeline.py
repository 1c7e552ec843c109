"""A whole collection, end to end: features, the optimization, predictions.

:func:`collection_run` is a generator of small frozen messages. The CLI's ``segment``
consumes it directly; the app runs it on a background job thread and applies each
message on the main thread.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace

import numpy as np

from scribbleseg_core.engine.guidance import label_confidence, mean_confidence, suggest
from scribbleseg_core.engine.optimize import (
    SegmentParams,
    Snapshot,
    TrainedModel,
    segment_collection,
)
from scribbleseg_core.engine.predict import predict_shape, predict_with_confidence
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


@dataclass(frozen=True, eq=False)
class Scored:
    """The confidence of shape `index`'s labels per file face
    (:func:`~scribbleseg_core.engine.guidance.label_confidence`), and its area-weighted mean."""

    index: int
    file_confidence: np.ndarray
    mean: float


@dataclass(frozen=True, eq=False)
class Suggested:
    """The unsure region that weighs most on its shape (:func:`~scribbleseg_core.engine.guidance.suggest`):
    shape `index`, the unconfident region's file faces, and the file face to paint at."""

    index: int
    file_faces: np.ndarray
    file_face: int
    score: float


def collection_run(
    meshes: Sequence[Mesh],
    scribbles: Sequence[np.ndarray | None],
    label_names: Sequence[str],
    params: SegmentParams = SegmentParams(),
    *,
    num_patches: int = 50,
    warm: TrainedModel | None = None,
) -> Iterator[FeaturesDone | StepDone | Predicted | Scored | Suggested]:
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
    warm : TrainedModel, optional
        The model of an earlier run to continue training
        (:func:`~scribbleseg_core.engine.optimize.segment_collection`).

    Yields
    ------
    FeaturesDone
        After each shape is prepared.
    StepDone
        After each optimization step; the last one's snapshot is done and has the model.
    Predicted
        For each shape without scribbles, once the model is trained (method ``"paper"``;
        with ``"face"`` every round's cut predicts them, and their labels come with the
        :class:`StepDone` messages).
    Scored
        For every shape, at the end: the margin of its labels under a network that did not
        see them (:attr:`~scribbleseg_core.engine.optimize.Snapshot.held_out`), else under
        the model.
    Suggested
        Last, unless every face is confident.
    """
    shapes = []
    for i, (mesh, scr) in enumerate(zip(meshes, scribbles)):
        has = scr is not None and bool((scr >= 0).any())
        shapes.append(prepare_shape(mesh, scr if has else None, num_patches=num_patches))
        if params.uses_label_context:
            shapes[-1].label_context  # noqa: B018 - computed (or read) here, in the features phase
        yield FeaturesDone(i, i + 1, len(meshes))
    last = None
    for snap in segment_collection(shapes, label_names, params, warm=warm):
        last = snap
        labeled = tuple(i for i, lab in enumerate(snap.labels) if (lab >= 0).any())
        # the held-out probabilities stay here (they become Scored messages): messages stay small
        yield StepDone(replace(snap, held_out=None), labeled, tuple(meshes[i].labels_to_file(snap.labels[i]) for i in labeled))
    final = list(last.labels)
    for i, (s, lab) in enumerate(zip(shapes, last.labels)):
        if not (lab >= 0).any():  # not part of the optimization (method "paper")
            final[i] = predict_shape(last.model, s)
            yield Predicted(i, meshes[i].labels_to_file(final[i]))
    confidence = collection_confidence(last, shapes, final)
    for i, s in enumerate(shapes):
        yield _scored(i, meshes[i], s, confidence[i])
    hint = suggest([s.graph for s in shapes], [s.area for s in shapes], confidence)
    if hint is not None:
        mesh = meshes[hint.shape]
        yield Suggested(hint.shape, mesh.faces_to_file(hint.faces), int(mesh.proc_to_file[hint.face]), hint.score)


def collection_confidence(last: Snapshot, shapes: Sequence, labels: Sequence[np.ndarray]) -> list[np.ndarray]:
    """Per shape of a segmented collection, the confidence (m_s,) of its `labels`: their margin
    under a network that did not see them (``last.held_out``), else under the model (which
    saw them); painted faces 1 (:func:`~scribbleseg_core.engine.guidance.label_confidence`).

    Parameters
    ----------
    last : Snapshot
        The optimization's last snapshot (phase ``"done"``).
    shapes : sequence of ShapeData
    labels : sequence of (m_s,) int ndarray
    """
    held_out = last.held_out or (None,) * len(shapes)
    return [label_confidence(held if held is not None else last.model.log_proba(s), lab, s.scribble)
            for s, lab, held in zip(shapes, labels, held_out)]


def _scored(index: int, mesh: Mesh, shape, confidence: np.ndarray) -> Scored:
    return Scored(index, mesh.labels_to_file(confidence), mean_confidence(confidence, shape.area))


def predict_run(model: TrainedModel, meshes: Sequence[Mesh], *,
                num_patches: int = 50) -> Iterator[FeaturesDone | Predicted | Scored]:
    """Segment `meshes` with a trained model, one at a time (features, prediction, confidence).

    Yields
    ------
    FeaturesDone
        After each shape is prepared.
    Predicted
        Its labels per file face.
    Scored
        Their confidence.
    """
    for i, mesh in enumerate(meshes):
        shape = prepare_shape(mesh, num_patches=num_patches)
        if model.learner.stage2 is not None:
            shape.label_context  # noqa: B018 - computed (or read) in the features phase
        yield FeaturesDone(i, i + 1, len(meshes))
        labels, confidence = predict_with_confidence(model, shape)
        yield Predicted(i, mesh.labels_to_file(labels))
        yield _scored(i, mesh, shape, confidence)
