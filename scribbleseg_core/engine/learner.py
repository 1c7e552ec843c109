"""The face learner: a classifier of each face from its own descriptor, followed by one that
also reads where the labels lie around the face (label context, auto-context).

Stage 1 is the paper's network on the face's descriptor. Stage 2 is the same kind of network
on the descriptor plus :func:`~scribbleseg_core.signatures.geodesic.label_distances` of
stage 1's probabilities: for every label, how far (geodesically) the surface stage 1 gives
that label lies from the face. Stage 2 is trained on stage-1 probabilities from networks
that did not see the shape's labels (held out), so that it learns how far to trust stage 1
on shapes it has not seen.

References
----------
E. Kalogerakis, A. Hertzmann, K. Singh, "Learning 3D mesh segmentation and labeling",
ACM TOG 29(4), 2010 (contextual label features). Z. Tu, X. Bai, "Auto-context and its
application to high-level vision tasks and 3D brain image segmentation", IEEE TPAMI 2010.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scribbleseg_core.engine.network import FaceClassifier
from scribbleseg_core.signatures.geodesic import LabelContext


def context_input(x: np.ndarray, context: LabelContext, log_proba: np.ndarray) -> np.ndarray:
    """Stage 2's input: the face descriptor `x` (m, d), then the label distances (m, 2k) of the
    probabilities ``exp(log_proba)`` (m, k) on the shape of `context`."""
    return np.hstack([x, context.distances(np.exp(log_proba))])


@dataclass(eq=False)
class Learner:
    """The trained face classifier of a model.

    Attributes
    ----------
    stage1 : FaceClassifier
        Reads the face descriptor (d inputs).
    stage2 : FaceClassifier or None
        Reads the descriptor and the label distances of stage 1 (d + 2k inputs); None
        without label context.
    """

    stage1: FaceClassifier
    stage2: FaceClassifier | None = None

    def log_proba(self, x: np.ndarray, context: LabelContext | None = None) -> np.ndarray:
        """Log label probabilities per face, (m, k) float64.

        Parameters
        ----------
        x : (m, d) float64 ndarray
            The face descriptors (:meth:`SegmentParams.network_input`).
        context : LabelContext
            The shape's (:attr:`ShapeData.label_context`); required with a stage 2.
        """
        first = self.stage1.log_proba(x)
        if self.stage2 is None:
            return first
        if context is None:
            raise ValueError("this learner has a label-context stage: pass the shape's label context")
        return self.stage2.log_proba(context_input(x, context, first))

    def with_threads(self, threads: int | None) -> Learner:
        """This learner predicting on `threads` torch threads (None: the cores this process
        may use); it shares the weights, and this one is left as it is."""
        return Learner(self.stage1.with_threads(threads), None if self.stage2 is None else self.stage2.with_threads(threads))
