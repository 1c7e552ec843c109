"""Face-level refinement: a graph cut on faces so boundaries need not follow patch borders."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scribbleseg_core.engine.graphcut import INF, alpha_expansion
from scribbleseg_core.geometry.dual_graph import DualGraph


@dataclass(frozen=True)
class RefineParams:
    """Weights of the face-level energy.

    ``U(f, l) = −log P(l | f) + prior · [l ≠ patch label of f]`` and, on every shared
    edge, ``smoothness · (ℓ / mean ℓ) · exp(−concavity / crease)``: cutting along a
    concave crease is cheap, cutting across a smooth or convex region is not.
    """

    smoothness: float = 2.0
    crease: float = 0.05
    prior: float = 1.0


def refine_labels(
    graph: DualGraph,
    log_proba: np.ndarray,
    patch_labels: np.ndarray,
    allowed: np.ndarray,
    scribble: np.ndarray | None = None,
    params: RefineParams = RefineParams(),
) -> np.ndarray:
    """Face labels by alpha-expansion on the face graph.

    Parameters
    ----------
    graph : DualGraph
    log_proba : (m, k) float64 ndarray
        Network log-probabilities per face.
    patch_labels : (m,) int ndarray
        The patch-level result, as a soft prior and the start labeling.
    allowed : (a,) int ndarray
        Labels the shape may take.
    scribble : (m,) int ndarray, optional
        Hard constraints (-1 free).

    Returns
    -------
    labels : (m,) int64 ndarray
    """
    m, k = log_proba.shape
    U = -np.maximum(log_proba, -30.0)
    U = U + params.prior * (np.arange(k)[None, :] != patch_labels[:, None])
    forbidden = np.ones(k, bool)
    forbidden[allowed] = False
    U[:, forbidden] = INF
    if scribble is not None:
        s = np.flatnonzero(scribble >= 0)
        U[s] = INF
        U[s, scribble[s]] = 0.0
    return alpha_expansion(U, graph.pairs, graph.crease_potts_weights(params.smoothness, params.crease), init=patch_labels, max_sweeps=4)
