"""How sure the model is of each face, and where it is least sure.

The confidence of a face is the margin of its label under the learner's probabilities,
``P(y) − max_{l ≠ y} P(l)`` clipped to [0, 1]: near 1 where the learner is sure of the label
shown, 0 where it hesitates between two labels or where the graph cut overruled it (the
smoothing and the network disagree). Painted faces have confidence 1.

:func:`suggest` picks the connected region of unconfident faces that weighs most on its
shape (area times doubt), where the app suggests the next stroke.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.sparse.csgraph import dijkstra

from scribbleseg_core.engine.regions import components
from scribbleseg_core.formats.export import UNCONFIDENT
from scribbleseg_core.geometry.dual_graph import DualGraph


def label_confidence(log_proba: np.ndarray, labels: np.ndarray, scribble: np.ndarray | None = None) -> np.ndarray:
    """The margin of each face's label under the learner.

    Parameters
    ----------
    log_proba : (m, k) float ndarray
        The learner's log label probabilities.
    labels : (m,) int ndarray
        The labels shown (the graph cut's); -1 gives confidence 0.
    scribble : (m,) int ndarray, optional
        Painted label per face, -1 elsewhere: painted faces get 1.

    Returns
    -------
    confidence : (m,) float64 ndarray in [0, 1]
    """
    P = np.exp(np.asarray(log_proba, dtype=np.float64))
    labels = np.asarray(labels, dtype=np.int64)
    m, k = P.shape
    if labels.shape != (m,):
        raise ValueError(f"labels has shape {labels.shape}, expected ({m},)")
    idx = np.arange(m)
    y = np.maximum(labels, 0)
    own = P[idx, y]
    other = P.copy()
    other[idx, y] = -np.inf
    best_other = other.max(axis=1) if k > 1 else np.zeros(m)
    conf = np.clip(own - best_other, 0.0, 1.0)
    conf[labels < 0] = 0.0
    if scribble is not None:
        conf[np.asarray(scribble) >= 0] = 1.0
    return conf


def stroke_agreement(log_proba: np.ndarray, scribble: np.ndarray) -> float:
    """How far a network that never saw a shape's strokes agrees with them, in [0, 1].

    For each painted label, the median probability the network gives that label on the faces
    painted with it; the smallest over the labels (1 without strokes). Near 0 when some stroke
    paints what the network takes for another part: its term should then not outweigh the
    strokes (the app's live preview scales the network term by this).

    Parameters
    ----------
    log_proba : (m, k) float ndarray
        The network's log label probabilities per face.
    scribble : (m,) int ndarray
        Painted label per face, -1 elsewhere.
    """
    scribble = np.asarray(scribble)
    painted = np.flatnonzero(scribble >= 0)
    if not len(painted):
        return 1.0
    p = np.exp(np.asarray(log_proba)[painted, scribble[painted]])
    lab = scribble[painted]
    return float(min(np.median(p[lab == label]) for label in np.unique(lab)))


def mean_confidence(confidence: np.ndarray, area: np.ndarray) -> float:
    """Area-weighted mean confidence of a shape, in [0, 1]."""
    area = np.asarray(area, dtype=np.float64)
    return float(np.dot(confidence, area) / max(area.sum(), 1e-300))


@dataclass(frozen=True, eq=False)
class Suggestion:
    """Where to paint next.

    Attributes
    ----------
    shape : int
        Index of the shape among those given to :func:`suggest`.
    faces : (r,) int64 ndarray
        The unconfident region (repaired face ids of that shape).
    face : int
        The face to paint at: the one of the region farthest from its border.
    score : float
        The region's ``Σ area · (1 − confidence)`` over the shape's area, in (0, 1].
    """

    shape: int
    faces: np.ndarray
    face: int
    score: float


def suggest(
    graphs: Sequence[DualGraph],
    areas: Sequence[np.ndarray],
    confidences: Sequence[np.ndarray | None],
    *,
    threshold: float = UNCONFIDENT,
) -> Suggestion | None:
    """The region of unconfident faces that weighs most on its shape (area times doubt).

    Parameters
    ----------
    graphs : sequence of DualGraph
        One per shape.
    areas : sequence of (m_s,) float ndarray
        Face areas.
    confidences : sequence of (m_s,) float ndarray or None
        :func:`label_confidence` per face; None skips the shape.
    threshold : float
        Faces below this confidence form the candidate regions. Default :data:`UNCONFIDENT`.

    Returns
    -------
    Suggestion or None
        None when no face of any shape is below the threshold.
    """
    best = None
    for s, (graph, area, conf) in enumerate(zip(graphs, areas, confidences)):
        if conf is None:
            continue
        low = conf < threshold
        if not low.any():
            continue
        comp = components(graph, low)
        doubt = np.bincount(comp[low], weights=(area * (1.0 - conf))[low]) / max(float(area.sum()), 1e-300)
        c = int(doubt.argmax())
        if best is None or doubt[c] > best[0]:
            best = (float(doubt[c]), s, np.flatnonzero(comp == c))
    if best is None:
        return None
    score, s, faces = best
    return Suggestion(s, faces.astype(np.int64), _innermost(graphs[s], faces, confidences[s]), score)


def _innermost(graph: DualGraph, faces: np.ndarray, confidence: np.ndarray) -> int:
    """The face of region `faces` farthest (along the surface) from the region's border; the
    least confident one when the region has no border (it is the whole shape)."""
    inside = np.zeros(graph.num_faces, bool)
    inside[faces] = True
    a, b = inside[graph.pairs[:, 0]], inside[graph.pairs[:, 1]]
    border = np.unique(np.r_[graph.pairs[a & ~b, 0], graph.pairs[b & ~a, 1]])
    if border.size == 0:
        return int(faces[np.argmin(confidence[faces])])
    both = a & b
    sub = DualGraph(graph.pairs[both], graph.length[both], graph.centroid_dist[both], graph.bend[both],
                    graph.concave[both], graph.num_faces)
    d = dijkstra(sub.centroid_matrix, directed=False, indices=border, min_only=True)
    d = np.where(inside & np.isfinite(d), d, -1.0)
    return int(np.argmax(d))
