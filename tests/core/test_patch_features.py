"""Patch descriptors: area-weighted histograms that sum to one, comparable across shapes."""

from __future__ import annotations

import numpy as np

from scribbleseg_core.engine.patch_features import PatchEncoder, feature_delta, fit_patch_encoder
from scribbleseg_core.signatures.features import NUM_FEATURES


def _features(seed: int, m: int = 400) -> np.ndarray:
    rng = np.random.default_rng(seed)  # fixed per call site
    return rng.normal(size=(m, NUM_FEATURES))


def test_descriptor_is_one_histogram_per_signature_each_summing_to_one():
    X = _features(0)
    enc = fit_patch_encoder([X], bins=10, words=8, seed=0)
    patch = np.arange(len(X)) % 5
    D = enc.encode(X, np.ones(len(X)), patch)
    assert D.shape == (5, 3 * 10 + 8) == (5, enc.dim)
    for block in (slice(0, 10), slice(10, 20), slice(20, 30), slice(30, 38)):
        np.testing.assert_allclose(D[:, block].sum(1), 1.0)


def test_histograms_are_area_weighted_and_bin_by_the_collection_range():
    lo, hi = np.zeros(3), np.ones(3)
    enc = PatchEncoder(lo, hi, np.zeros(19), np.ones(19), np.zeros((1, 19)), bins=4, smooth=0.0)
    X = np.zeros((2, NUM_FEATURES))
    X[:, 0] = [0.1, 0.9]  # AGD in the first and the last of 4 bins
    D = enc.encode(X, np.array([1.0, 3.0]), np.zeros(2, np.int64))
    np.testing.assert_allclose(D[0, :4], [0.25, 0.0, 0.0, 0.75])
    X[:, 0] = [-5.0, 7.0]  # outside the range: clipped into the end bins
    np.testing.assert_allclose(enc.encode(X, np.ones(2), np.zeros(2, np.int64))[0, :4], [0.5, 0, 0, 0.5])


def test_words_are_the_nearest_codebook_centres():
    codebook = np.stack([np.zeros(19), np.full(19, 10.0)])
    enc = PatchEncoder(np.zeros(3), np.ones(3), np.zeros(19), np.ones(19), codebook, bins=4)
    X = np.zeros((3, NUM_FEATURES))
    X[1, 3:] = 9.0
    X[2, 3:] = 4.0
    np.testing.assert_array_equal(enc.assign_words(X), [0, 1, 0])


def test_delta_is_the_rms_distance_of_adjacent_descriptors():
    D = np.array([[0.0, 0.0], [3.0, 4.0], [0.0, 0.0]])
    pairs = np.array([[0, 1], [1, 2]])
    assert feature_delta([D], [pairs]) == 5.0  # sqrt(mean(25, 25))
    assert feature_delta([D, D], [pairs, np.zeros((0, 2), np.int64)]) == 5.0  # no pairs: no say
    # identical neighbours: a tiny positive delta, never zero
    assert feature_delta([np.zeros((2, 2))], [np.array([[0, 1]])]) > 0
