"""Unseen shapes: the network's confident part cores become scribbles for the propagation.

An unseen shape has no strokes, so its labels come from the network alone, and a graph cut
on network probabilities needs weak smoothing or it merges small parts into their
neighbours. Here the predicted labeling is first reduced to the *cores* of its parts: the
faces far inside each part (relative to the part's own size) where the network is
confident. Those cores are then treated exactly like scribbles by
:func:`~scribbleseg_core.engine.propagate.propagate_scribbles`: hard constraints that hold even
small parts, with strong crease- and SDF-aware smoothness deciding where the boundaries
between them go. The same energy thus labels scribbled and unseen shapes; only the origin
of the seeds differs.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.sparse.csgraph import dijkstra

from scribbleseg_core.engine.propagate import PropagateParams, propagate_scribbles
from scribbleseg_core.geometry.dual_graph import CONVEX_FACTOR, DualGraph
from scribbleseg_core.geometry.topology import label_components


def _core_propagation() -> PropagateParams:
    return PropagateParams(distance=0.0, smoothness=64.0, walk=0.0, convex=CONVEX_FACTOR)


@dataclass(frozen=True)
class CoreParams:
    """How part cores are chosen and propagated.

    Attributes
    ----------
    fraction : float
        A face is in its part's core if its crease-aware distance to the part's boundary is
        at least this fraction of the largest such distance in the part. Default 0.5.
    min_area : float
        Parts (connected components of one label) smaller than this fraction of the surface
        get no core; the propagation may then absorb them. 0.005 is the threshold of the
        PSB scribble protocol (a part that small gets no stroke either). Default 0.005.
    min_confidence : float
        Core faces also need the network's probability of their label to reach this. A
        predicted part where the network is nowhere this sure gets no core, and the
        propagation lets its neighbours absorb it. Default 0.8.
    propagation : PropagateParams
        The propagation from the cores. The distance term is off (cores are dense, so
        the nearest-core distance says little); smoothness 64 rather than the scribbles'
        16, because network unaries are noisier than the distance to a stroke.

    Notes
    -----
    The defaults (0.5, 0.005, 0.8, smoothness 64) were chosen on the 12 PSB categories, on a
    plateau of the unseen shapes' error (``docs/benchmarks.md``).
    """

    fraction: float = 0.5
    min_area: float = 0.005
    min_confidence: float = 0.8
    propagation: PropagateParams = field(default_factory=_core_propagation)


def part_cores(
    graph: DualGraph,
    area: np.ndarray,
    labels: np.ndarray,
    proba: np.ndarray | None = None,
    params: CoreParams = CoreParams(),
) -> np.ndarray:
    """The cores of the parts of a face labeling.

    Parameters
    ----------
    graph : DualGraph
    area : (m,) float ndarray
        Face areas.
    labels : (m,) int ndarray
        A labeling of every face.
    proba : (m, k) float ndarray, optional
        Label probabilities per face, for ``params.min_confidence``.
    params : CoreParams

    Returns
    -------
    seeds : (m,) int64 ndarray
        The label on core faces, -1 elsewhere. A labeling with a single part is all core.
    """
    y = np.asarray(labels, dtype=np.int64)
    m = graph.num_faces
    if y.shape != (m,):
        raise ValueError(f"labels has shape {y.shape}, expected ({m},)")
    i, j = graph.pairs.T
    cut = y[i] != y[j]
    boundary = np.unique(np.concatenate([i[cut], j[cut]]))
    if boundary.size == 0:
        return y.copy()
    depth = dijkstra(graph.crease_matrix, directed=False, indices=boundary, min_only=True)
    part = label_components(graph.pairs, y)
    n = int(part.max()) + 1
    deepest = np.zeros(n)
    np.maximum.at(deepest, part, depth)  # inf for a mesh component without boundary
    a = np.asarray(area, dtype=np.float64)
    part_area = np.bincount(part, weights=a, minlength=n) / max(float(a.sum()), 1e-300)
    core = (depth >= params.fraction * deepest[part]) & (part_area[part] >= params.min_area)
    if proba is not None and params.min_confidence > 0:
        core &= np.asarray(proba)[np.arange(m), y] >= params.min_confidence
    return np.where(core, y, -1)


def propagate_from_cores(
    graph: DualGraph,
    area: np.ndarray,
    labels: np.ndarray,
    log_proba: np.ndarray,
    sdf: np.ndarray | None = None,
    scribble: np.ndarray | None = None,
    params: CoreParams = CoreParams(),
) -> np.ndarray:
    """Relabel a shape by propagating from the cores of `labels`.

    Parameters
    ----------
    graph : DualGraph
    area : (m,) float ndarray
    labels : (m,) int ndarray
        The labeling to take cores from (the network's refined prediction).
    log_proba : (m, k) float ndarray
        Network log-probabilities per face; they are also the propagation's unaries.
    sdf : (m,) float ndarray, optional
        Shape diameter per face, for the propagation's contrast term.
    scribble : (m,) int ndarray, optional
        Strokes on the shape, if any (-1 free); they override cores.
    params : CoreParams

    Returns
    -------
    labels : (m,) int64 ndarray
    """
    log_proba = np.asarray(log_proba, dtype=np.float64)
    seeds = part_cores(graph, area, labels, np.exp(log_proba), params)
    if scribble is not None:
        scribble = np.asarray(scribble, dtype=np.int64)
        seeds = np.where(scribble >= 0, scribble, seeds)
    if not (seeds >= 0).any():
        return np.asarray(labels, dtype=np.int64).copy()
    return propagate_scribbles(graph, seeds, log_proba.shape[1], log_proba=log_proba, sdf=sdf, params=params.propagation)
