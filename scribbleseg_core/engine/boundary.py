"""The learned boundary term: where, in this collection, one part meets another.

A classifier of the shared edges of adjacent faces (the dual graph's pairs) learns from the
labeled shapes whether a label boundary runs across the edge, from the edge's bend, the
jump of the 22 signatures across it and the two faces' network inputs (so it learns
*where* on a shape of this kind boundaries lie, not only that they like concave creases).
On a shape without scribbles its probability replaces the hand-set crease rule in the
graph cut's smoothness (:class:`~scribbleseg_core.engine.propagate.FaceEnergy`,
``boundary_proba``): cutting an edge costs ``−log P(boundary)``.

The classifier is gradient-boosted trees (LightGBM), stored as LightGBM's text model: no
code runs when a model is read.

References
----------
E. Kalogerakis, A. Hertzmann, K. Singh, "Learning 3D mesh segmentation and labeling",
ACM TOG 29(4), 2010, Section 4 (the learned pairwise term).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from scribbleseg_core.geometry.dual_graph import DualGraph
from scribbleseg_core.infra.cpu import usable_cores
from scribbleseg_core.signatures.features import NUM_FEATURES

#: Boosting rounds, learning rate, leaves per tree.
ROUNDS, LEARNING_RATE, LEAVES = 200, 0.05, 31
#: Edges without a boundary drawn per shape for training: this many per boundary edge, plus
#: :data:`EXTRA_NEGATIVES` (boundary edges are a few percent of all).
NEGATIVES_PER_BOUNDARY, EXTRA_NEGATIVES = 4, 500


def edge_features(graph: DualGraph, X: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The descriptor of every face pair of `graph`, (q, 3 + 22 + d) float32.

    Columns: the bend (``1 − cos`` of the dihedral angle), whether the crease is concave,
    the bend where concave (0 elsewhere); the absolute difference of the 22 signatures `X`
    (m, 22) across the pair; the mean of the two faces' network inputs `x` (m, d).
    """
    i, j = graph.pairs.T
    return np.hstack([
        graph.bend[:, None], graph.concave[:, None], (graph.bend * graph.concave)[:, None],
        np.abs(X[i, :NUM_FEATURES] - X[j, :NUM_FEATURES]), 0.5 * (x[i] + x[j]),
    ]).astype(np.float32)


def label_boundaries(graph: DualGraph, labels: np.ndarray) -> np.ndarray:
    """(q,) bool: does the label change across each face pair of `graph`?"""
    return labels[graph.pairs[:, 0]] != labels[graph.pairs[:, 1]]


@dataclass(eq=False)
class BoundaryClassifier:
    """P(a label boundary runs across an edge) from :func:`edge_features`.

    Attributes
    ----------
    booster : lightgbm.Booster
    num_inputs : int
        Edge descriptor length.
    """

    booster: object
    num_inputs: int

    @classmethod
    def fit(cls, shapes: Iterable[tuple[np.ndarray, np.ndarray]], *, seed: int = 0,
            threads: int | None = None) -> BoundaryClassifier | None:
        """Train on the edges of labeled shapes.

        Parameters
        ----------
        shapes : iterable of ((q_s, e) ndarray, (q_s,) bool ndarray)
            Per shape, its :func:`edge_features` and :func:`label_boundaries`; read one at a
            time (a generator keeps one shape's descriptors in memory).
        seed : int
            The draw of non-boundary edges and LightGBM's bagging.
        threads : int, optional
            LightGBM threads; default the cores this process may use.

        Returns
        -------
        BoundaryClassifier, or None when the labels hold no boundary (or nothing but).
        """
        import lightgbm as lgb

        rng = np.random.default_rng(seed)
        rows, targets = [], []
        for E, b in shapes:
            pos, neg = np.flatnonzero(b), np.flatnonzero(~b)
            neg = rng.choice(neg, min(neg.size, NEGATIVES_PER_BOUNDARY * pos.size + EXTRA_NEGATIVES), replace=False)
            rows.append(E[np.r_[pos, neg]])
            targets.append(np.r_[np.ones(pos.size), np.zeros(neg.size)])
        y = np.concatenate(targets) if targets else np.zeros(0)
        if not (y.any() and (y == 0).any()):
            return None
        params = dict(objective="binary", learning_rate=LEARNING_RATE, num_leaves=LEAVES, bagging_fraction=0.8,
                      bagging_freq=1, feature_fraction=0.5, num_threads=threads or usable_cores(), verbose=-1,
                      seed=seed, deterministic=True, force_row_wise=True)
        X = np.vstack(rows)
        booster = lgb.train(params, lgb.Dataset(X, y, free_raw_data=True), num_boost_round=ROUNDS)
        return cls(booster, X.shape[1])

    def proba(self, features: np.ndarray, threads: int | None = None) -> np.ndarray:
        """(q,) float64 probability of a boundary across each edge of `features` (q, e)."""
        if features.shape[1] != self.num_inputs:
            raise ValueError(f"edge descriptors have {features.shape[1]} values, the classifier reads {self.num_inputs}")
        return np.asarray(self.booster.predict(features, num_threads=threads or usable_cores()), dtype=np.float64)

    def to_text(self) -> str:
        """LightGBM's text model."""
        return self.booster.model_to_string()

    @classmethod
    def from_text(cls, text: str) -> BoundaryClassifier:
        """A classifier from :meth:`to_text`; raises ValueError on anything else."""
        import lightgbm as lgb

        try:
            booster = lgb.Booster(model_str=text)
        except lgb.basic.LightGBMError as e:
            raise ValueError(f"not a LightGBM model ({e})") from None
        return cls(booster, booster.num_feature())
