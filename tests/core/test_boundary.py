"""The learned boundary term: it finds where planted parts meet on a shape it did not see."""

from __future__ import annotations

import numpy as np
import pytest

from scribbleseg_core.engine.boundary import BoundaryClassifier, edge_features, label_boundaries
from scribbleseg_core.engine.optimize import SegmentParams
from scribbleseg_core.engine.shape import prepare_shape
from scribbleseg_core.infra.cache import ArrayCache
from tests.core.planted import creature


@pytest.fixture(scope="module")
def planted(tmp_path_factory):
    cache = ArrayCache(tmp_path_factory.mktemp("cache"))
    out = []
    for i, (limb, head) in enumerate([(1.6, 0.9), (1.2, 0.7), (2.0, 1.1), (1.4, 0.8)]):
        mesh, gt = creature(limb, head, seed=i)
        s = prepare_shape(mesh, cache=cache)
        out.append((s, gt[s.mesh.proc_to_file], edge_features(s.graph, s.X, SegmentParams().network_input(s))))
    return out


def _auc(score: np.ndarray, positive: np.ndarray) -> float:
    """The chance that a positive scores above a negative (ties count half)."""
    order = np.argsort(score, kind="stable")
    ranks = np.empty(len(score))
    ranks[order] = np.arange(1, len(score) + 1)
    n1, n0 = positive.sum(), (~positive).sum()
    return float((ranks[positive].sum() - n1 * (n1 + 1) / 2) / (n1 * n0))


def test_boundaries_are_found_on_a_shape_not_trained_on(planted):
    train, (held, gt, E) = planted[:3], planted[3]
    clf = BoundaryClassifier.fit(((E_, label_boundaries(s.graph, y)) for s, y, E_ in train), threads=1)
    truth = label_boundaries(held.graph, gt)
    p = clf.proba(E, threads=1)
    assert p.shape == truth.shape and np.all((p >= 0) & (p <= 1))
    assert _auc(p, truth) > 0.95
    assert p[truth].mean() > 3 * p[~truth].mean()


def test_text_round_trip_and_refusals(planted):
    s, gt, E = planted[0]
    clf = BoundaryClassifier.fit([(E, label_boundaries(s.graph, gt))], seed=1, threads=1)
    back = BoundaryClassifier.from_text(clf.to_text())
    assert back.num_inputs == E.shape[1]
    np.testing.assert_allclose(back.proba(E, threads=1), clf.proba(E, threads=1))
    with pytest.raises(ValueError, match="not a LightGBM model"):
        BoundaryClassifier.from_text("import os; os.system('echo no')")
    with pytest.raises(ValueError, match="edge descriptors have 3 values"):
        clf.proba(E[:, :3])


def test_labels_without_a_boundary_teach_nothing(planted):
    s, gt, E = planted[0]
    assert BoundaryClassifier.fit([(E, np.zeros(len(E), bool))]) is None
    assert BoundaryClassifier.fit([]) is None
