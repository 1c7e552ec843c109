"""The face classifier: learns a separable labeling, is reproducible, standardizes its input."""

from __future__ import annotations

import numpy as np

from scribbleseg_core.engine.network import AdamW, FaceClassifier, NetworkParams, build_mlp, one_cycle

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


def test_adamw_and_one_cycle_match_torch_optim():
    """The plain-tensor AdamW under the one-cycle schedule takes torch.optim's steps."""
    import torch

    total = 37
    nets = [build_mlp(5, 3, (8, 4), seed=0) for _ in range(2)]
    nets[1].load_state_dict(nets[0].state_dict())
    before = nets[1][0].weight.detach().numpy().copy()
    ref = torch.optim.AdamW(nets[0].parameters(), lr=3e-3, weight_decay=1e-2, foreach=False)
    sched = torch.optim.lr_scheduler.OneCycleLR(ref, max_lr=3e-3, total_steps=total)
    ours = AdamW(nets[1].parameters(), 3e-3, 1e-2, total)
    X, y = _blobs(3, n=64)
    Xt, yt = torch.from_numpy(((X - X.mean(0)) / X.std(0)).astype(np.float32)), torch.from_numpy(y)
    for step in range(total):
        lr, beta1 = one_cycle(step, total, 3e-3)
        assert np.isclose(lr, ref.param_groups[0]["lr"]) and np.isclose(beta1, ref.param_groups[0]["betas"][0])
        for net, opt in zip(nets, (ref, ours)):
            opt.zero_grad()
            torch.nn.functional.cross_entropy(net(Xt), yt).backward()
            opt.step()
        sched.step()
    for a, b in zip(nets[0].parameters(), nets[1].parameters()):
        np.testing.assert_allclose(a.detach().numpy(), b.detach().numpy(), rtol=1e-5, atol=1e-6)
    assert np.abs(nets[1][0].weight.detach().numpy() - before).max() > 1e-3  # it did train


def test_training_does_not_import_the_compiler():
    """Training runs without torch.optim, whose first use imports torch._dynamo (seconds)."""
    import subprocess
    import sys

    code = ("import sys, numpy as np; from scribbleseg_core.engine.network import FaceClassifier, NetworkParams;"
            "X = np.random.default_rng(0).normal(size=(200, 4)); y = (X[:, 0] > 0).astype(int);"
            "FaceClassifier(4, 2, NetworkParams(hidden=(8, 4), epochs=2, threads=1)).fit([X], [y]);"
            "print('torch._dynamo' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"
