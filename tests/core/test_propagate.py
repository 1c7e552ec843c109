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


def _strip(nx: int = 40, ny: int = 6):
    """A flat strip of nx × ny unit squares (two triangles each): no creases anywhere."""
    xs, ys = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1), indexing="ij")
    V = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)]).astype(float)
    idx = lambda i, j: i * (ny + 1) + j  # noqa: E731
    F = []
    for i in range(nx):
        for j in range(ny):
            F += [[idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)], [idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)]]
    F = np.array(F)
    return V, F, V[F].mean(axis=1)[:, 0]


def test_contrast_moves_a_crease_free_boundary_to_where_the_sdf_jumps():
    V, F, x = _strip()
    graph = dual_graph(V, F)
    scribble = np.where(x < 2, 0, np.where(x > 38, 1, -1))
    sdf = np.where(x < 12, 1.0, 0.2)  # a thick part meets a thin one at x = 12
    plain = propagate_scribbles(graph, scribble, 2, sdf=sdf, params=PropagateParams(contrast=0.0))
    between = (x > 13) & (x < 19)
    assert (plain[between] == 0).all()  # the boundary sits midway between the strokes
    labels = propagate_scribbles(graph, scribble, 2, sdf=sdf, params=PropagateParams(contrast=1.0, contrast_floor=0.1))
    assert (labels[between] == 1).all() and (labels[x < 11] == 0).all()
    with pytest.raises(ValueError, match="shape"):
        propagate_scribbles(graph, scribble, 2, sdf=sdf[:-1], params=PropagateParams(contrast=1.0))
