"""Face-level refinement: the network's evidence moves boundaries onto creases; scribbles and allowed labels hold."""

from __future__ import annotations

import numpy as np
import trimesh

from scribbleseg_core.engine.refine import RefineParams, refine_labels
from scribbleseg_core.geometry.dual_graph import dual_graph


def _two_boxes():
    """Two unit boxes stacked (a concave crease where the small one sits on the big one):
    faces above z = 0.5 belong to the top box (label 1), the rest to the bottom (label 0)."""
    bottom = trimesh.creation.box(extents=(2.0, 2.0, 1.0))
    top = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    top.apply_translation((0, 0, 1.0))
    mesh = trimesh.boolean.union([bottom, top], engine="manifold").subdivide_to_size(0.1)
    V, F = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)
    truth = (V[F].mean(1)[:, 2] > 0.5 + 1e-9).astype(np.int64)
    return V, F, truth


def _noisy_log_proba(truth, k, flip, seed):
    """Log-probabilities that favour the truth (0.7) except on a random `flip` fraction."""
    rng = np.random.default_rng(seed)  # fixed per call site
    believed = truth.copy()
    flipped = rng.random(len(truth)) < flip
    believed[flipped] = (truth[flipped] + 1) % k
    P = np.full((len(truth), k), 0.3 / (k - 1))
    P[np.arange(len(truth)), believed] = 0.7
    return np.log(P), flipped


def test_smoothing_cleans_noise_and_keeps_the_crease_boundary():
    V, F, truth = _two_boxes()
    g = dual_graph(V, F)
    logp, flipped = _noisy_log_proba(truth, 2, 0.2, seed=0)
    noisy = logp.argmax(1)
    assert (noisy != truth).mean() > 0.15
    labels = refine_labels(g, logp, noisy, np.arange(2), params=RefineParams(prior=0.0))
    assert (labels != truth).mean() < 0.02


def test_scribbles_are_hard_and_forbidden_labels_never_appear():
    V, F, truth = _two_boxes()
    g = dual_graph(V, F)
    logp, _ = _noisy_log_proba(truth, 3, 0.0, seed=1)
    scribble = np.full(len(F), -1)
    scribble[:5] = 2  # against the evidence
    labels = refine_labels(g, logp, truth, np.array([0, 2]), scribble)
    np.testing.assert_array_equal(labels[:5], 2)
    assert set(np.unique(labels)) <= {0, 2}


def test_the_patch_prior_breaks_ties_toward_the_patch_labels():
    V, F, truth = _two_boxes()
    g = dual_graph(V, F)
    undecided = np.log(np.full((len(F), 2), 0.5))
    labels = refine_labels(g, undecided, truth, np.arange(2))
    np.testing.assert_array_equal(labels, truth)
