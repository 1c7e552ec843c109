"""Fill regions, the surface brush, per-face confidence and the "paint here next" suggestion."""

from __future__ import annotations

import numpy as np
import pytest

from scribbleseg_core.engine.guidance import UNCONFIDENT, label_confidence, mean_confidence, stroke_agreement, suggest
from scribbleseg_core.engine.regions import RegionFill, components, fill_by_labels, surface_disc
from scribbleseg_core.geometry.dual_graph import dual_graph
from scribbleseg_core.geometry.measures import face_areas
from tests.conftest import icosphere
from tests.core.planted import LABELS, creature


@pytest.fixture(scope="module")
def planted():
    mesh, gt = creature(1.6, 0.9, seed=0)
    V = mesh.normalized()
    return dual_graph(V, mesh.F), gt, face_areas(V, mesh.F), V[mesh.F].mean(axis=1)


def test_fill_by_labels_is_the_connected_part_of_the_seed(planted):
    graph, gt, _, C = planted
    limbs = components(graph, gt == 1)
    assert limbs.max() + 1 == 4  # four separate limbs
    seed = int(np.flatnonzero(limbs == 2)[0])
    np.testing.assert_array_equal(fill_by_labels(graph, seed, gt), np.flatnonzero(limbs == 2))
    with pytest.raises(ValueError, match="out of range"):
        fill_by_labels(graph, graph.num_faces, gt)


def test_crease_fill_stops_at_the_valley_around_a_limb_and_the_threshold_opens_it(planted):
    graph, gt, _, _ = planted
    fill = RegionFill(graph)
    limbs = components(graph, gt == 1)
    tip = int(np.flatnonzero(limbs == 0)[0])
    assert len(fill.by_crease(tip, 3.0)) < 10  # this coarse mesh has edges sharper than 15° inside a limb
    tight = fill.by_crease(tip, 6.0)
    limb = np.flatnonzero(limbs == 0)
    assert np.isin(tight, limb).mean() > 0.8 and np.isin(limb, tight).mean() > 0.9  # that limb, about
    assert len(tight) < 0.2 * graph.num_faces
    wide = fill.by_crease(tip, 180.0)
    assert len(wide) == graph.num_faces  # no border stops it
    assert np.isin(tight, wide).all() and tip in tight


def test_surface_disc_stays_on_the_surface_where_a_ball_would_cross_a_gap():
    # two parallel sheets 0.1 apart: a ball of radius 0.3 reaches the other sheet, the surface disc does not
    V, F = icosphere(3)
    top = V[F].mean(axis=1)[:, 2] > 0
    graph = dual_graph(V, F)
    seed = int(np.argmax(V[F].mean(axis=1)[:, 2]))
    disc = surface_disc(graph, [seed], 0.3)
    C = V[F].mean(axis=1)
    geo = np.arccos(np.clip(C @ C[seed] / np.linalg.norm(C, axis=1) / np.linalg.norm(C[seed]), -1, 1))
    assert seed in disc and top[disc].all()
    assert (geo[disc] <= 0.3 + 0.05).all() and (geo[np.setdiff1d(np.arange(len(F)), disc)] >= 0.3 - 0.05).all()
    assert surface_disc(graph, [], 0.3).size == 0


def test_confidence_is_the_margin_of_the_label_shown():
    P = np.array([[0.7, 0.2, 0.1], [0.4, 0.35, 0.25], [0.1, 0.8, 0.1], [0.5, 0.5, 1e-12]])
    conf = label_confidence(np.log(P), np.array([0, 0, 0, -1]))
    np.testing.assert_allclose(conf, [0.5, 0.05, 0.0, 0.0])  # face 2: the cut overruled the network
    painted = label_confidence(np.log(P), np.array([0, 0, 0, 1]), scribble=np.array([-1, 0, -1, 1]))
    np.testing.assert_allclose(painted, [0.5, 1.0, 0.0, 1.0])
    assert mean_confidence(np.array([1.0, 0.0]), np.array([3.0, 1.0])) == 0.75


def test_suggestion_is_the_largest_unconfident_region_and_its_inner_face(planted):
    graph, gt, area, C = planted
    conf = np.ones(graph.num_faces)
    limbs = components(graph, gt == 1)
    conf[limbs == 1] = 0.1  # one whole limb unsure
    conf[np.flatnonzero(gt == 2)[:20]] = 0.3  # a few head faces
    other = np.full(graph.num_faces, 0.9)
    hint = suggest([graph, graph], [area, area], [other, conf])
    assert hint.shape == 1
    np.testing.assert_array_equal(hint.faces, np.flatnonzero(limbs == 1))
    assert hint.face in hint.faces
    # the inner face lies away from the limb's border: farther from the body than most of the limb
    body = C[gt == 0].mean(axis=0)
    dist = np.linalg.norm(C[hint.faces] - body, axis=1)
    assert np.linalg.norm(C[hint.face] - body) > np.median(dist)
    assert hint.score == pytest.approx(0.9 * area[limbs == 1].sum() / area.sum())
    assert suggest([graph], [area], [np.ones(graph.num_faces)]) is None
    assert suggest([graph], [area], [None]) is None
    assert UNCONFIDENT == 0.5 and len(LABELS) == 3


def test_stroke_agreement_is_the_worst_painted_labels_median_probability():
    P = np.array([[0.9, 0.1], [0.8, 0.2], [0.7, 0.3], [0.4, 0.6], [0.5, 0.5]])
    scribble = np.array([0, 0, 1, 1, -1])
    # label 0 on faces 0, 1: median 0.85; label 1 on faces 2, 3: median 0.45
    assert np.isclose(stroke_agreement(np.log(P), scribble), 0.45)
    assert stroke_agreement(np.log(P), np.full(5, -1)) == 1.0  # no strokes: nothing contradicts
    assert np.isclose(stroke_agreement(np.log(P), np.array([0, -1, -1, -1, -1])), 0.9)
