"""The face classifier: the single network and the ensemble of them."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from scribbleseg_core.network import FaceClassifier, NetworkParams

PARAMS = NetworkParams(epochs=40, batch_size=64, threads=1)


def _blobs(seed: int, n: int = 600):
    """Three labels in 5 dimensions, separable by the first two coordinates."""
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, 5))
    y = (X[:, 0] > 0).astype(np.int64) + (X[:, 1] > 0.5)
    return X, y


def test_members_one_is_the_single_network():
    import torch.nn as nn

    clf = FaceClassifier(5, 3, PARAMS)
    assert isinstance(clf.net, nn.Sequential)
    with pytest.raises(ValueError, match="members"):
        FaceClassifier(5, 3, dataclasses.replace(PARAMS, members=0))


def test_ensemble_averages_its_members_probabilities():
    import torch

    from scribbleseg_core.ensemble import MLPEnsemble

    X, y = _blobs(0)
    clf = FaceClassifier(5, 3, dataclasses.replace(PARAMS, members=4))
    clf.fit([X[:300], X[300:]], [y[:300], y[300:]])
    net = clf.net
    assert isinstance(net, MLPEnsemble) and net.members == 4
    # members start apart and stay apart
    W = net.weights[0].detach()
    assert all(not torch.allclose(W[0], W[j]) for j in range(1, 4))
    Xt, yt = _blobs(1)
    logp = clf.log_proba(Xt)
    assert logp.shape == (len(Xt), 3)
    np.testing.assert_allclose(np.exp(logp).sum(1), 1.0, atol=1e-5)
    with torch.no_grad():
        Z = torch.from_numpy(((Xt - clf.mean) / clf.std).astype(np.float32))
        members = torch.softmax(net(Z), dim=2).numpy()  # (K, m, c), one member's network each
    np.testing.assert_allclose(np.exp(logp), members.mean(0), atol=1e-5)
    assert (logp.argmax(1) == yt).mean() >= 0.95
    # each member alone has learned it too: they are networks, not parts of one
    assert all((members[j].argmax(1) == yt).mean() >= 0.9 for j in range(4))


def test_ensemble_members_see_their_own_order_and_are_reproducible():
    X, y = _blobs(2)
    params = dataclasses.replace(PARAMS, members=3, epochs=3)
    a, b = FaceClassifier(5, 3, params), FaceClassifier(5, 3, params)
    a.fit([X], [y])
    b.fit([X], [y])
    np.testing.assert_array_equal(a.log_proba(X), b.log_proba(X))  # seeded
    c = FaceClassifier(5, 3, dataclasses.replace(params, seed=1))
    c.fit([X], [y])
    assert not np.allclose(a.log_proba(X), c.log_proba(X))
