"""The face classifier: learns a separable labeling, is reproducible, standardizes its input."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from scribbleseg_core.engine.network import FaceClassifier, NetworkParams, build_mlp, drop_inputs

# small and fast; the schedule is the default one scaled down
PARAMS = NetworkParams(hidden=(16, 8), epochs=30, threads=1)


def _blobs(seed: int, n: int = 600, k: int = 3, d: int = 5):
    """k Gaussian blobs in d dimensions, far apart, with a large offset and scale (so the
    standardization matters); labels known by construction."""
    rng = np.random.default_rng(seed)  # fixed per call site
    centers = rng.normal(size=(k, d)) * 6
    y = rng.integers(0, k, n)
    X = 1000.0 + 50.0 * (centers[y] + rng.normal(size=(n, d)))
    return X, y


def test_learns_separable_labels_and_outputs_log_probabilities():
    X, y = _blobs(0)
    clf = FaceClassifier(X.shape[1], 3, PARAMS)
    clf.fit([X[:300], X[300:]], [y[:300], y[300:]])
    Xt, yt = _blobs(0, n=200)  # same centres, new samples
    logp = clf.log_proba(Xt)
    assert logp.shape == (200, 3) and logp.dtype == np.float64
    np.testing.assert_allclose(np.exp(logp).sum(1), 1.0, atol=1e-5)
    assert (logp.argmax(1) == yt).mean() > 0.95
    # the standardization is the training faces' own
    np.testing.assert_allclose(clf.mean, X.mean(0))
    np.testing.assert_allclose(clf.std, X.std(0) + 1e-8)


def test_faces_labeled_minus_one_are_not_trained_on():
    X, y = _blobs(1)
    hidden = y.copy()
    hidden[y == 2] = -1  # label 2 never shown
    clf = FaceClassifier(X.shape[1], 3, PARAMS)
    clf.fit([X], [hidden])
    assert (clf.log_proba(X[y == 2]).argmax(1) != 2).all()
    np.testing.assert_allclose(clf.mean, X[y != 2].mean(0))


def test_same_seed_same_network_and_warm_start_continues():
    X, y = _blobs(2)
    a, b = FaceClassifier(5, 3, PARAMS), FaceClassifier(5, 3, PARAMS)
    a.fit([X], [y])
    b.fit([X], [y])
    np.testing.assert_array_equal(a.log_proba(X), b.log_proba(X))
    before = a.log_proba(X)
    a.fit([X], [y], warm=True)  # keeps the standardization, trains on from the current weights
    np.testing.assert_allclose(a.mean, b.mean)
    assert not np.array_equal(a.log_proba(X), before)


def test_architecture_is_d_h1_h2_k():
    import torch.nn as nn

    net = build_mlp(7, 4, (16, 8), dropout=0.3)
    linear = [m for m in net if isinstance(m, nn.Linear)]
    assert [(m.in_features, m.out_features) for m in linear] == [(7, 16), (16, 8), (8, 4)]
    assert len(net) == 7 and len(build_mlp(7, 4, (16, 8))) == 5  # a dropout after each hidden layer


def test_dropout_zeroes_the_given_share_in_training_only_and_keeps_the_mean():
    import torch

    drop = build_mlp(7, 4, (16, 8), dropout=0.3, seed=0)[2]
    x = torch.ones(1000, 400)
    y = drop(x)
    zeroed = float((y == 0).float().mean())
    assert abs(zeroed - 77 / 256) < 0.005  # 0.3 rounded to a multiple of 1/256
    assert abs(float(y.mean()) - 1.0) < 0.01  # survivors are scaled up
    drop.eval()
    assert torch.equal(drop(x), x)


def test_input_dropout_zeroes_the_given_share_and_keeps_the_mean():
    Z = np.ones((1000, 400), dtype=np.float32)
    out = drop_inputs(Z, 0.2, np.random.default_rng(0))
    assert out is Z
    assert abs(float((Z == 0).mean()) - 51 / 256) < 0.005  # 0.2 rounded to a multiple of 1/256
    assert abs(float(Z.mean()) - 1.0) < 0.01
    untouched = np.ones((10, 4), dtype=np.float32)
    rng = np.random.default_rng(0)
    state = rng.bit_generator.state
    assert (drop_inputs(untouched, 0.0, rng) == 1).all() and rng.bit_generator.state == state


def test_input_dropout_changes_training_only():
    X, y = _blobs(3)
    plain = FaceClassifier(5, 3, replace(PARAMS, input_dropout=0.0))
    masked = FaceClassifier(5, 3, replace(PARAMS, input_dropout=0.5))
    plain.fit([X], [y])
    masked.fit([X], [y])
    assert not np.array_equal(plain.log_proba(X), masked.log_proba(X))
    np.testing.assert_array_equal(masked.log_proba(X), masked.log_proba(X))  # no masks in prediction
    assert (masked.log_proba(X).argmax(1) == y).mean() > 0.95
    with pytest.raises(ValueError, match="input_dropout"):
        NetworkParams(input_dropout=1.0)
