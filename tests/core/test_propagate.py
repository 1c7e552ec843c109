"""Scribble propagation: planted parts from one short stroke each, hard scribbles, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from scribbleseg_core.dual_graph import dual_graph
from scribbleseg_core.propagate import PropagateParams, propagate_scribbles, scribble_distances
from tests.core.planted import LABELS, creature, stroke_faces


@pytest.fixture(scope="module")
def planted():
    mesh, gt = creature(1.6, 0.9, seed=0)
    graph = dual_graph(mesh.normalized(), mesh.F)
    scribble = np.full(len(gt), -1)
    for lab in range(len(LABELS)):
        scribble[stroke_faces(mesh, gt, lab)] = lab
    return graph, gt, scribble


def test_parts_come_back_from_short_strokes(planted):
    graph, gt, scribble = planted
    labels = propagate_scribbles(graph, scribble, len(LABELS))
    assert (labels == gt).mean() >= 0.95
    sel = scribble >= 0
    np.testing.assert_array_equal(labels[sel], scribble[sel])


def test_network_term_can_override_distance(planted):
    graph, gt, scribble = planted
    # a confident "network" that knows the truth fixes what distance alone gets wrong
    logp = np.log(np.where(np.arange(len(LABELS))[None, :] == gt[:, None], 0.97, 0.03 / (len(LABELS) - 1)))
    alone = (propagate_scribbles(graph, scribble, len(LABELS)) == gt).mean()
    labels = propagate_scribbles(graph, scribble, len(LABELS), log_proba=logp, params=PropagateParams(network=3.0))
    assert (labels == gt).mean() >= max(0.975, alone + 0.01)
    off = propagate_scribbles(graph, scribble, len(LABELS), log_proba=logp, params=PropagateParams(network=0.0))
    assert (off == gt).mean() == alone  # weight 0: the network is ignored


def test_distances_are_zero_on_own_scribbles_and_inf_for_absent_labels(planted):
    graph, _, scribble = planted
    one = np.where(scribble == 0, 0, -1)
    D = scribble_distances(graph, one, 3)
    assert np.all(D[one == 0, 0] == 0)
    assert np.isinf(D[:, 1:]).all()
    labels = propagate_scribbles(graph, one, 3)
    assert (labels == 0).all()  # one label scribbled: everything takes it


def test_bad_input_is_refused(planted):
    graph, _, scribble = planted
    with pytest.raises(ValueError, match="no face is scribbled"):
        propagate_scribbles(graph, np.full_like(scribble, -1), 3)
    with pytest.raises(ValueError, match="out of range"):
        propagate_scribbles(graph, scribble, 2)
    with pytest.raises(ValueError, match="shape"):
        propagate_scribbles(graph, scribble[:-1], len(LABELS))
