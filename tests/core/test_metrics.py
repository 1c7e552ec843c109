"""Metrics: hand-computed small cases, zero on identity, invariance to renaming."""

from __future__ import annotations

import numpy as np
import pytest

from scribbleseg_core.evaluation.metrics import (
    consistency_errors,
    cut_discrepancy,
    error_anatomy,
    hamming_distance,
    labeling_accuracy,
    rand_index_error,
    rand_index_error_area,
    split_components,
)

A = np.array([0, 0, 0, 1, 1])
B = np.array([0, 0, 1, 1, 1])


def test_rand_index_by_hand():
    # pairs: C(5,2)=10. same in A: C(3,2)+C(2,2)=4; in B: 1+3=4; n_ij: (0,0)=2,(0,1)=1,(1,1)=2 -> 1+0+1=2
    assert np.isclose(rand_index_error(A, B), (4 + 4 - 2 * 2) / 10)


def test_area_rand_index_reduces_to_counts_with_unit_area():
    rng = np.random.default_rng(3)  # fixed seed: random segmentations
    a, b = rng.integers(0, 4, 50), rng.integers(0, 3, 50)
    assert np.isclose(rand_index_error_area(a, b, np.ones(50)), rand_index_error(a, b))
    # doubling every area changes nothing
    area = rng.random(50)
    assert np.isclose(rand_index_error_area(a, b, area), rand_index_error_area(a, b, 2 * area))


def test_consistency_errors_by_hand():
    # E(A,B,f): f in A0 (size 3) ∩ B0 (size 2): |A0\B0|/3 = 1/3 for faces 0,1; face 2: A0∩B1: |A0\B1|=2 -> 2/3
    # faces 3,4: A1 ⊂ B1 -> 0.  Σ = 1/3+1/3+2/3 = 4/3
    # E(B,A,f): faces 0,1: B0 ⊂ A0 -> 0; face 2: B1\A0 = 2 of 3 -> 2/3; faces 3,4: B1\A1 = 1 of 3 -> 1/3 each: Σ = 4/3
    gce, lce = consistency_errors(A, B)
    assert np.isclose(gce, (4 / 3) / 5)
    assert np.isclose(lce, (0 + 0 + 2 / 3 + 0 + 0) / 5)


def test_hamming_by_hand():
    missing, false_alarm, mean = hamming_distance(A, B)
    # truth B0={0,1} best pred A0 (2) -> 0 missing; B1={2,3,4} best A1 (2) -> 1 missing
    # pred A0={0,1,2} best truth B0 (2) -> 1 false alarm; A1={3,4} -> 0
    assert (missing, false_alarm, mean) == (0.2, 0.2, 0.2)


@pytest.mark.parametrize("metric", [rand_index_error, lambda a, b: consistency_errors(a, b)[0],
                                    lambda a, b: consistency_errors(a, b)[1], lambda a, b: hamming_distance(a, b)[2]])
def test_zero_for_identical_and_invariant_to_renaming(metric):
    rng = np.random.default_rng(11)
    a = rng.integers(0, 5, 200)
    b = rng.integers(0, 4, 200)
    assert metric(a, a) == 0
    perm = np.array([3, 0, 4, 1, 2])
    assert np.isclose(metric(perm[a], b), metric(a, b))
    assert np.isclose(metric(a, b + 10), metric(a, b))


def test_cut_discrepancy_and_accuracy_on_a_sphere(sphere):
    V, F = sphere
    z = V[F].mean(1)[:, 2]
    a = (z > 0).astype(int)
    b = (z > 0.2).astype(int)
    assert cut_discrepancy(V, F, a, a) == 0
    cd = cut_discrepancy(V, F, a, b)
    # cuts at z=0 and z=0.2 on a unit sphere: about 0.2 apart; average radius about 1
    assert 0.12 < cd < 0.3
    assert np.isnan(cut_discrepancy(V, F, a, np.zeros_like(a)))
    assert labeling_accuracy(a, a) == 1 and 0.8 < labeling_accuracy(a, b) < 1


def test_split_components(sphere):
    V, F = sphere
    z = V[F].mean(1)[:, 2]
    labels = (np.abs(z) > 0.5).astype(int)  # caps share a label but are two components
    assert len(np.unique(split_components(F, labels))) == 3


def _strip(n: int) -> np.ndarray:
    """A strip of 2n triangles in a row, each sharing an edge with the next."""
    return np.array([[i, i + 1, i + 2] for i in range(2 * n)])


def test_error_anatomy_tells_wrong_names_from_misplaced_boundaries():
    F = _strip(10)  # 20 faces in a row
    truth = np.repeat([0, 1, 2, 0], 5)  # four parts; parts 0 and 3 share a label
    renamed = truth.copy()
    renamed[15:] = 1  # the last part named wrongly, its boundary right
    shifted = np.repeat([0, 1, 2, 0], [7, 3, 5, 5])  # the first boundary two faces late
    a = error_anatomy(F, renamed, truth)
    assert a["error"] > 0 and a["names_right"] == 0
    assert a["boundaries_right"] == a["error"]  # true boundaries, the same wrong name
    b = error_anatomy(F, shifted, truth)
    assert b["error"] == b["names_right"] > 0  # naming each region right cannot move a boundary
    assert b["boundaries_right"] == 0
    merged = np.repeat([0, 2, 0], [10, 5, 5])  # parts 0 and 1 in one region
    c = error_anatomy(F, merged, truth)
    assert c["names_right"] > 0 and c["boundaries_right"] > 0  # part 1 takes the region's name
    with pytest.raises(ValueError, match="20 faces"):
        error_anatomy(F, truth[:-1], truth)
