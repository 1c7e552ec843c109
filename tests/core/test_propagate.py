"""Scribble propagation: planted parts from one short stroke each, hard scribbles, bad input."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from scribbleseg_core.engine.graphcut import graph_clusters
from scribbleseg_core.engine.propagate import (
    CLUSTER_SIZE,
    PropagateParams,
    RandomWalk,
    propagate_scribbles,
    random_walk_probabilities,
    scribble_distances,
)
from scribbleseg_core.engine.regions import components
from scribbleseg_core.geometry.dual_graph import DualGraph, dual_graph
from tests.core.planted import LABELS, creature, stroke_faces


@pytest.fixture(scope="module")
def creature_graph():
    mesh, gt = creature(1.6, 0.9, seed=0)
    return mesh, dual_graph(mesh.normalized(), mesh.F), gt


@pytest.fixture(scope="module")
def planted(creature_graph):
    mesh, graph, gt = creature_graph
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
    plain = PropagateParams(walk=0.0)
    alone = (propagate_scribbles(graph, scribble, len(LABELS), params=plain) == gt).mean()
    labels = propagate_scribbles(graph, scribble, len(LABELS), log_proba=logp, params=replace(plain, network=3.0))
    assert (labels == gt).mean() >= max(0.975, alone + 0.01)
    off = propagate_scribbles(graph, scribble, len(LABELS), log_proba=logp, params=replace(plain, network=0.0))
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
    labels = propagate_scribbles(graph, scribble, 2, sdf=sdf, params=PropagateParams(contrast=1.0))
    assert (labels[between] == 1).all() and (labels[x < 11] == 0).all()
    with pytest.raises(ValueError, match="shape"):
        propagate_scribbles(graph, scribble, 2, sdf=sdf[:-1], params=PropagateParams(contrast=1.0))


def test_random_walk_probabilities_are_a_distribution(planted):
    graph, gt, scribble = planted
    k = len(LABELS) + 1  # one label never scribbled
    P = random_walk_probabilities(graph, scribble, k, crease=0.03)
    assert P.shape == (graph.num_faces, k)
    np.testing.assert_allclose(P.sum(axis=1), 1.0, atol=1e-6)
    assert np.all(P[:, -1] == 0)  # an absent label gets no probability
    sel = scribble >= 0
    np.testing.assert_array_equal(P[sel].argmax(axis=1), scribble[sel])
    assert np.all(P[sel].max(axis=1) == 1.0)
    # on its own, the walk already finds the planted parts
    assert (P.argmax(axis=1) == gt).mean() >= 0.95


def test_random_walk_on_clusters_is_close_to_the_walk_on_faces(planted):
    graph, gt, scribble = planted
    k = len(LABELS) + 1  # one label never scribbled
    clusters = graph_clusters(graph.crease_matrix, CLUSTER_SIZE)
    P = random_walk_probabilities(graph, scribble, k, crease=0.03)
    Q = random_walk_probabilities(graph, scribble, k, crease=0.03, clusters=clusters)
    np.testing.assert_allclose(Q.sum(axis=1), 1.0, atol=1e-6)
    assert np.all(Q[:, -1] == 0)
    sel = scribble >= 0
    assert np.all(Q[sel, scribble[sel]] == 1.0)  # a stroke's faces never share a cluster with others
    assert np.abs(P - Q).max(axis=1).mean() < 0.05
    assert (Q.argmax(axis=1) == gt).mean() >= 0.95


def test_random_walk_leaves_unscribbled_components_at_zero(planted):
    graph, _, scribble = planted
    # two copies of the mesh side by side, strokes on the first copy only
    m = graph.num_faces
    two = DualGraph(np.vstack([graph.pairs, graph.pairs + m]), np.r_[graph.length, graph.length],
                    np.r_[graph.centroid_dist, graph.centroid_dist], np.r_[graph.bend, graph.bend],
                    np.r_[graph.concave, graph.concave], 2 * m)
    P = random_walk_probabilities(two, np.r_[scribble, np.full(m, -1)], len(LABELS), crease=0.03)
    assert np.all(P[m:] == 0)
    np.testing.assert_allclose(P[:m], random_walk_probabilities(graph, scribble, len(LABELS), crease=0.03), atol=1e-6)


def test_walk_term_joins_the_network_term_only(planted):
    graph, gt, scribble = planted
    k = len(LABELS)
    flat = np.full((graph.num_faces, k), -np.log(k))  # a network that knows nothing
    walk_only = PropagateParams(distance=0.0, walk=1.0, network=1.0)
    assert (propagate_scribbles(graph, scribble, k, log_proba=flat, params=walk_only) == gt).mean() >= 0.95
    # a dominant walk term with next to no smoothing gives the walk's own argmax
    P = random_walk_probabilities(graph, scribble, k, crease=walk_only.crease)
    strong = propagate_scribbles(graph, scribble, k, log_proba=flat, params=replace(walk_only, walk=100.0, smoothness=1e-3))
    np.testing.assert_array_equal(strong, P.argmax(axis=1))
    # without the network (the labels the network is trained on) the walk does not act
    plain = propagate_scribbles(graph, scribble, k, params=PropagateParams(walk=0.0))
    np.testing.assert_array_equal(propagate_scribbles(graph, scribble, k, params=PropagateParams(walk=1.0)), plain)
    np.testing.assert_array_equal(
        propagate_scribbles(graph, scribble, k, log_proba=flat, params=PropagateParams(walk=1.0, network=0.0)), plain)


def _folded_strip(direction: float, at: int = 12):
    """The strip of :func:`_strip` folded by 90° along x = `at`: up (a concave crease) for
    `direction` +1, down (a convex ridge) for -1. Returns V, F and each face's unfolded x."""
    V, F, x = _strip()
    beyond = V[:, 0] > at
    V[beyond, 2] = direction * (V[beyond, 0] - at)
    V[beyond, 0] = at
    return V, F, x


def test_concave_creases_stop_labels_whatever_the_convex_weight():
    V, F, x = _folded_strip(+1)
    graph = dual_graph(V, F)
    crease = graph.bend > 0.5
    assert crease.any() and graph.concave[crease].all()
    scribble = np.where(x < 2, 0, np.where(x > 38, 1, -1))  # midway between them: x = 20
    for convex in (0.0, 0.02, 0.1):
        labels = propagate_scribbles(graph, scribble, 2, params=PropagateParams(convex=convex))
        np.testing.assert_array_equal(labels, (x > 12).astype(int))


def test_convex_ridges_are_cheap_to_cut_only_with_a_large_convex_weight():
    V, F, x = _folded_strip(-1)
    graph = dual_graph(V, F)
    ridge = graph.bend > 0.5
    assert ridge.any() and not graph.concave[ridge].any()
    np.testing.assert_allclose(graph.concavity(0.02)[ridge], 0.02 * graph.bend[ridge])
    np.testing.assert_array_equal(graph.concavity(0.02)[graph.concave], graph.bend[graph.concave])
    same_length = np.isclose(graph.length, graph.length[ridge][0])
    now = graph.crease_potts_weights(16.0, 0.03, 0.02)
    flat = now[(graph.bend < 1e-9) & same_length].max()
    # a 90° ridge (bend 1): exp(-0.02 / 0.03) ≈ 0.51 of a flat edge at weight 0.02, exp(-0.1 / 0.03) ≈ 0.036 at 0.1
    np.testing.assert_allclose(now[ridge] / flat, np.exp(-0.02 / 0.03), rtol=1e-6)
    np.testing.assert_allclose(graph.crease_potts_weights(16.0, 0.03, 0.1)[ridge] / flat, np.exp(-0.1 / 0.03), rtol=1e-6)


def _noisy_log_proba(gt, k, seed):
    """Log-probabilities that favour the truth (0.6) with a random 15% of faces wrong."""
    rng = np.random.default_rng(seed)  # fixed per call site
    believed = np.where(rng.random(len(gt)) < 0.15, (gt + 1) % k, gt)
    P = np.full((len(gt), k), 0.4 / (k - 1))
    P[np.arange(len(gt)), believed] = 0.6
    return np.log(P)


def test_face_energy_terms_add_up_to_the_potts_energy_the_cut_minimizes(planted):
    from scribbleseg_core.engine.graphcut import potts_energy
    from scribbleseg_core.engine.propagate import FaceEnergy

    graph, gt, scribble = planted
    k = len(LABELS)
    logp = _noisy_log_proba(gt, k, seed=0)
    energy = FaceEnergy(graph, scribble, k)
    labels = energy.cut(logp)
    total = potts_energy(labels, energy.unary(logp), energy.pairs, energy.weights)
    np.testing.assert_allclose(sum(energy.terms(labels, logp)), total, rtol=1e-9)
    assert sum(energy.terms(labels, logp)) <= sum(energy.terms(gt, logp)) + 1e-6  # a minimum, at least below the truth
    again = energy.cut(logp, init=labels)  # starting from a minimum never makes it worse
    assert sum(energy.terms(again, logp)) <= sum(energy.terms(labels, logp)) + 1e-6


def test_a_shape_without_scribbles_is_labeled_by_the_network_and_smoothness(planted):
    from scribbleseg_core.engine.propagate import FaceEnergy

    graph, gt, _ = planted
    k = len(LABELS)
    logp = _noisy_log_proba(gt, k, seed=1)
    energy = FaceEnergy(graph, np.full(len(gt), -1), k, PropagateParams(smoothness=2.0))
    assert not energy.is_scribbled
    labels = energy.cut(logp)
    assert (labels == gt).mean() > (logp.argmax(1) == gt).mean() + 0.1  # smoothing removes the noise
    scribble_term, network_term, _ = energy.terms(labels, logp)
    assert scribble_term == 0.0 and network_term > 0
    with pytest.raises(ValueError, match="needs the network"):
        energy.cut()


def test_no_term_is_negative_on_a_fully_painted_shape(planted):
    from scribbleseg_core.engine.propagate import FaceEnergy

    graph, gt, _ = planted
    k = len(LABELS)
    logp = _noisy_log_proba(gt, k, seed=2)
    energy = FaceEnergy(graph, gt, k, PropagateParams())  # every face painted (an accepted shape)
    labels = energy.cut(logp)
    np.testing.assert_array_equal(labels, gt)
    scribble_term, network_term, smooth = energy.terms(labels, logp)
    assert scribble_term >= 0 and network_term == 0.0 and smooth > 0
    np.testing.assert_allclose(scribble_term + network_term + smooth, sum(energy.terms(gt, logp)))


def test_learned_boundary_moves_the_cut_of_an_unscribbled_shape_to_where_it_is_likely():
    """A shape without scribbles takes its smoothness from the boundary probabilities, so an
    uncertain network's boundary moves to where the classifier puts one; a scribbled shape
    keeps the crease rule."""
    from scribbleseg_core.engine.propagate import FaceEnergy, learned_weights

    V, F, x = _strip()
    graph = dual_graph(V, F)
    i, j = graph.pairs.T
    xi, xj = x[i], x[j]
    # the network: label 0 left of x = 20, label 1 right of it, hardly sure within 10 of it
    p1 = np.clip(0.5 + (x - 20) / 40, 0.02, 0.98)
    logp = np.log(np.column_stack([1 - p1, p1]))
    across = (np.minimum(xi, xj) < 14) & (np.maximum(xi, xj) > 14)  # the edges across x = 14
    proba = np.where(across, 0.9, 0.01)
    none = np.full(graph.num_faces, -1)
    plain = FaceEnergy(graph, none, 2).cut(logp)
    assert (plain[(x > 15) & (x < 19)] == 0).all()  # the crease-free rule: at the network's 0.5
    learned = FaceEnergy(graph, none, 2, boundary_proba=proba).cut(logp)
    assert (learned[x < 14] == 0).all() and (learned[x > 14] == 1).all()
    np.testing.assert_allclose(FaceEnergy(graph, none, 2, PropagateParams(boundary=3.0), boundary_proba=proba).weights,
                               learned_weights(graph, proba, 3.0))
    off = FaceEnergy(graph, none, 2, PropagateParams(boundary=0.0), boundary_proba=proba)
    np.testing.assert_allclose(off.weights, FaceEnergy(graph, none, 2).weights)  # 0: the crease rule
    painted = none.copy()
    painted[0] = 0
    np.testing.assert_allclose(FaceEnergy(graph, painted, 2, boundary_proba=proba).weights,
                               FaceEnergy(graph, painted, 2).weights)
    with pytest.raises(ValueError, match="boundary_proba has shape"):
        FaceEnergy(graph, none, 2, boundary_proba=proba[:-1])


def test_distances_from_a_previous_call_equal_fresh_ones(planted):
    graph, gt, scribble = planted
    k = len(LABELS)
    first = np.where(np.isin(scribble, [0, 1]), scribble, -1)
    D = scribble_distances(graph, first, k)
    for step in (scribble, np.where(scribble == 2, -1, scribble), np.where(scribble == 1, 0, scribble)):
        again = scribble_distances(graph, step, k, previous=(first, D))  # a stroke added, erased, relabeled
        np.testing.assert_array_equal(again, scribble_distances(graph, step, k))
        first, D = step, again
    np.testing.assert_array_equal(scribble_distances(graph, scribble, k + 1, previous=(first, D)),
                                  scribble_distances(graph, scribble, k + 1))  # another label count: recomputed


def test_multilevel_cut_brings_the_parts_back_like_the_full_cut(planted):
    graph, gt, scribble = planted
    clusters = graph_clusters(graph.crease_matrix, CLUSTER_SIZE)
    labels = propagate_scribbles(graph, scribble, len(LABELS), clusters=clusters)
    assert (labels == gt).mean() >= 0.95
    sel = scribble >= 0
    np.testing.assert_array_equal(labels[sel], scribble[sel])


@pytest.fixture(scope="module")
def one_limb(creature_graph):
    """The planted creature painted as a user might: body, head and one of the four limbs."""
    mesh, graph, gt = creature_graph
    scribble = np.full(len(gt), -1)
    for lab in range(len(LABELS)):
        faces = stroke_faces(mesh, gt, lab)
        scribble[faces[:6] if LABELS[lab] == "limb" else faces] = lab  # 6 faces a part: one limb
    return graph, gt, scribble


def test_walk_with_the_network_as_prior_finds_the_limbs_left_unpainted(one_limb):
    graph, gt, scribble = one_limb
    k, limb = len(LABELS), LABELS.index("limb")
    unsure = np.log(np.where(np.arange(k)[None, :] == gt[:, None], 0.6, 0.2))  # a network right at 0.6
    plain = propagate_scribbles(graph, scribble, k, log_proba=unsure, params=PropagateParams(walk_reach=0.0))
    assert (plain[gt == limb] == limb).mean() < 0.4  # the walk runs to the body's stroke: body
    reach = propagate_scribbles(graph, scribble, k, log_proba=unsure)  # the default reach
    assert (reach[gt == limb] == limb).mean() > 0.97
    assert (reach == gt).mean() > 0.95
    sel = scribble >= 0
    np.testing.assert_array_equal(reach[sel], scribble[sel])


def test_walk_with_a_prior_is_a_distribution_that_meets_near_strokes_first(one_limb):
    graph, gt, scribble = one_limb
    k, head = len(LABELS) + 1, LABELS.index("head")  # one label never scribbled, which the prior still names
    prior = np.full((graph.num_faces, k), 0.1 / (k - 1))
    prior[:, head] = 0.9  # the head everywhere
    walk = RandomWalk(graph, scribble, k, crease=0.03, reach=0.5)
    P = walk.probabilities(prior)
    np.testing.assert_allclose(P.sum(axis=1), 1.0, atol=1e-6)
    assert np.all(P[:, -1] == 0)  # the prior renormalized over the painted labels
    sel = scribble >= 0
    assert np.all(P[sel, scribble[sel]] == 1.0)
    # the prior pulls the free faces toward the head; the shorter the reach, the more
    plain = random_walk_probabilities(graph, scribble, k, crease=0.03)
    near = RandomWalk(graph, scribble, k, crease=0.03, reach=0.1).probabilities(prior)
    assert near[~sel, head].mean() > P[~sel, head].mean() > plain[~sel, head].mean() + 0.05
    # beside a stroke the walk meets it before it stops
    body = LABELS.index("body")
    beside = np.unique(graph.pairs[np.isin(graph.pairs, np.flatnonzero(scribble == body)).any(axis=1)])
    beside = beside[scribble[beside] < 0]
    assert P[beside, body].min() > 0.5
    # no reach: the plain walk, whatever the prior; the same solve on clusters
    np.testing.assert_allclose(RandomWalk(graph, scribble, k, crease=0.03).probabilities(prior), plain)
    with pytest.raises(ValueError, match="prior"):
        walk.probabilities()
    clusters = graph_clusters(graph.crease_matrix, CLUSTER_SIZE)
    Q = RandomWalk(graph, scribble, k, crease=0.03, clusters=clusters, reach=0.5).probabilities(prior)
    np.testing.assert_allclose(Q.sum(axis=1), 1.0, atol=1e-6)
    assert np.abs(P - Q).max(axis=1).mean() < 0.05


def test_walk_reached_is_high_near_strokes_and_nil_on_limbs_no_stroke_reaches(one_limb):
    graph, gt, scribble = one_limb
    k, limb = len(LABELS), LABELS.index("limb")
    walk = RandomWalk(graph, scribble, k, crease=0.03, reach=0.5)
    reached = walk.reached()
    sel = scribble >= 0
    assert np.all(reached[sel] == 1.0) and np.all((reached >= 0) & (reached <= 1))
    # the painted limb is decided by its stroke; the three others are reached by none
    part = components(graph, gt == limb)
    painted_limb = part == part[np.flatnonzero(scribble == limb)[0]]
    assert (reached[painted_limb] >= 0.5).mean() > 0.9
    other_limbs = (gt == limb) & ~painted_limb
    assert reached[other_limbs].max() < 0.05
    # a shorter reach decides fewer faces; none: every face of a painted component
    near = RandomWalk(graph, scribble, k, crease=0.03, reach=0.1).reached()
    assert near[~sel].mean() < reached[~sel].mean()
    np.testing.assert_allclose(RandomWalk(graph, scribble, k, crease=0.03).reached(), 1.0, atol=1e-6)
    clusters = graph_clusters(graph.crease_matrix, CLUSTER_SIZE)
    coarse = RandomWalk(graph, scribble, k, crease=0.03, clusters=clusters, reach=0.5).reached()
    assert np.abs(coarse - reached).mean() < 0.05

