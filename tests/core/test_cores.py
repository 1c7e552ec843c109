"""Part cores of a predicted labeling, and the propagation from them (unseen shapes)."""

from __future__ import annotations

import numpy as np
import pytest

from scribbleseg_core.engine.cores import CoreParams, part_cores, propagate_from_cores
from scribbleseg_core.engine.graphcut import alpha_expansion
from scribbleseg_core.geometry.dual_graph import dual_graph
from scribbleseg_core.geometry.measures import face_areas
from scribbleseg_core.geometry.topology import label_components
from tests.core.planted import LABELS, creature

K = len(LABELS)


@pytest.fixture(scope="module")
def planted():
    mesh, gt = creature(1.6, 0.9, seed=0)
    V = mesh.normalized()
    return dual_graph(V, mesh.F), face_areas(V, mesh.F), gt


def _parts(graph, labels):
    part = label_components(graph.pairs, labels)
    return int(part.max()) + 1, part


def _noisy_log_proba(gt, flip, seed=0):
    """A network that is right (p = 0.9) except on a random `flip` fraction of faces,
    where it is as confidently wrong."""
    rng = np.random.default_rng(seed)
    said = gt.copy()
    wrong = rng.random(len(gt)) < flip
    said[wrong] = (gt[wrong] + rng.integers(1, K, wrong.sum())) % K
    P = np.full((len(gt), K), 0.1 / (K - 1))
    P[np.arange(len(gt)), said] = 0.9
    return np.log(P), said


def test_cores_lie_inside_every_part(planted):
    graph, area, gt = planted
    seeds = part_cores(graph, area, gt)
    core = seeds >= 0
    np.testing.assert_array_equal(seeds[core], gt[core])
    i, j = graph.pairs.T
    border = np.unique(np.r_[i[gt[i] != gt[j]], j[gt[i] != gt[j]]])
    assert not core[border].any()
    n, part = _parts(graph, gt)
    assert n == 6  # body, head, four limbs: each has a core
    assert set(np.unique(part[core])) == set(range(n))
    assert 0.05 < core.mean() < 0.9


def test_small_parts_and_unsure_faces_get_no_core(planted):
    graph, area, gt = planted
    body = np.flatnonzero(gt == 0)
    labels = gt.copy()
    speck = body[:1]  # one face of the body called "head": far below 0.5% of the surface
    labels[speck] = 2
    assert area[speck].sum() / area.sum() < 0.005
    assert (part_cores(graph, area, labels)[speck] == -1).all()
    assert (part_cores(graph, area, labels, params=CoreParams(min_area=0.0))[speck] == 2).all()
    proba = np.full((len(gt), K), 1.0 / K)
    proba[np.arange(len(gt)), gt] = 0.95
    unsure = body[::2]
    proba[unsure] = 1.0 / K
    seeds = part_cores(graph, area, gt, proba)
    assert (seeds[unsure] == -1).all()
    assert (seeds[body[1::2]] == 0).any()


def test_one_part_is_all_core(planted):
    graph, area, gt = planted
    np.testing.assert_array_equal(part_cores(graph, area, np.zeros_like(gt)), 0)


def test_propagation_cleans_a_noisy_prediction(planted):
    graph, area, gt = planted
    logp, said = _noisy_log_proba(gt, flip=0.2)
    assert 0.75 < (said == gt).mean() < 0.85
    labels = propagate_from_cores(graph, area, said, logp)
    assert (labels == gt).mean() >= 0.95
    assert _parts(graph, labels)[0] == 6


def test_cores_hold_a_small_part_that_strong_smoothing_alone_erases_but_it_shrinks(planted):
    graph, area, gt = planted
    # a confidently predicted small part on the smooth body, with no crease around it
    # (a plier's small jaw part, an eye on a bust)
    mesh, _ = creature(1.6, 0.9, seed=0)
    c = mesh.normalized()[mesh.F].mean(axis=1)
    c /= np.linalg.norm(c, axis=1, keepdims=True)
    spot = (c @ (np.array([1.0, 1.0, 0.2]) / np.linalg.norm([1.0, 1.0, 0.2])) > 0.97) & (gt == 0)
    assert 0.005 < area[spot].sum() / area.sum() < 0.05
    truth = np.where(spot, 1, gt)
    logp, said = _noisy_log_proba(truth, flip=0.0)
    labels = propagate_from_cores(graph, area, said, logp)
    core = part_cores(graph, area, said, np.exp(logp)) == 1
    assert (core & spot).any() and (labels[core] == 1).all()
    # it is held, but with no crease around it the strong smoothing shrinks it to its core
    assert 0.3 < (labels[spot] == 1).mean() < 0.9
    p = CoreParams().propagation
    plain = alpha_expansion(-p.network * logp, graph.pairs, graph.crease_potts_weights(p.smoothness, p.crease), init=said)
    assert (plain[spot] == 1).mean() < 0.2


def test_strokes_override_cores(planted):
    graph, area, gt = planted
    logp, _ = _noisy_log_proba(gt, flip=0.0)
    head = np.flatnonzero(gt == 2)
    scribble = np.full(len(gt), -1)
    scribble[head[:5]] = 0  # the user says these head faces are body
    labels = propagate_from_cores(graph, area, gt, logp, scribble=scribble)
    assert (labels[head[:5]] == 0).all()
    assert (labels[head[5:]] == 2).mean() > 0.9


def test_bad_labels_are_refused(planted):
    graph, area, gt = planted
    with pytest.raises(ValueError, match="shape"):
        part_cores(graph, area, gt[:-1])
