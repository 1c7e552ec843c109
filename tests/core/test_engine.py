"""The engine on a planted collection: accuracy, hard scribbles, monotone energy, early stop, models."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from scribbleseg_core.engine.energy import scribble_unary
from scribbleseg_core.engine.graphcut import INF
from scribbleseg_core.engine.network import NetworkParams
from scribbleseg_core.engine.optimize import SegmentParams, segment_collection
from scribbleseg_core.engine.predict import predict_shape
from scribbleseg_core.engine.propagate import propagate_shape
from scribbleseg_core.engine.shape import prepare_shape
from scribbleseg_core.errors import ModelFileError
from scribbleseg_core.infra.cache import ArrayCache
from scribbleseg_core.signatures.context import LOCAL_SHAPE_PER_SCALE
from scribbleseg_core.signatures.features import NUM_FEATURES
from scribbleseg_core.store.model_file import load_model, save_model
from tests.core.planted import LABELS, creature, stroke_faces

PARAMS = SegmentParams(network=NetworkParams(epochs=30, warm_epochs=10, max_faces_per_shape=3000))


@pytest.fixture(scope="module")
def collection(tmp_path_factory):
    cache = ArrayCache(tmp_path_factory.mktemp("cache"))
    shapes, gts = [], []
    for i, (limb, head) in enumerate([(1.6, 0.9), (1.2, 0.7), (2.0, 1.1), (1.4, 0.8)]):
        mesh, gt = creature(limb, head, seed=i)
        scribble = None
        if i < 3:  # three scribbled, one held out
            scribble = np.full(len(gt), -1)
            for lab in range(len(LABELS)):
                scribble[stroke_faces(mesh, gt, lab)] = lab
        shapes.append(prepare_shape(mesh, scribble, cache=cache))
        gts.append(gt)
    snaps = list(segment_collection(shapes, LABELS, PARAMS))
    return shapes, gts, snaps


def test_planted_parts_come_back(collection):
    shapes, gts, snaps = collection
    final = snaps[-1]
    assert final.done and final.model is not None
    for s, gt, labels, patch_labels in zip(shapes[:3], gts, final.labels, final.patch_labels):
        assert (labels == gt).mean() >= 0.95
        assert (patch_labels == gt).mean() >= 0.90


def test_scribbled_faces_keep_their_label(collection):
    shapes, _, snaps = collection
    for snap in snaps:
        for s, labels, patch_labels in zip(shapes, snap.labels, snap.patch_labels):
            sel = s.scribble >= 0
            np.testing.assert_array_equal(labels[sel], s.scribble[sel])
            np.testing.assert_array_equal(patch_labels[sel], s.scribble[sel])


def test_energy_never_increases(collection):
    _, _, snaps = collection
    totals = [s.energy.total for s in snaps if s.iteration >= 1 and s.phase in ("train", "graphcut")]
    assert len(totals) >= 2
    assert all(b <= a * (1 + 1e-9) for a, b in zip(totals, totals[1:]))
    assert snaps[0].phase == "graphcut" and np.isnan(snaps[0].energy.network)


def test_stopping_early_leaves_valid_labels(collection):
    shapes, _, _ = collection
    gen = segment_collection(shapes, LABELS, PARAMS)
    first = next(gen)
    gen.close()
    for s, labels in zip([s for s in shapes if s.is_scribbled], first.labels):
        assert labels.shape == (len(s.mesh.F),) and labels.min() >= 0
        assert set(np.unique(labels)) <= set(s.scribbled_labels)
        assert not labels.flags.writeable  # frozen snapshot


def test_unseen_shape_is_predicted(collection):
    shapes, gts, snaps = collection
    model = snaps[-1].model
    labels, patch_labels = predict_shape(model, shapes[3])
    assert (labels == gts[3]).mean() >= 0.90
    refined, same_patches = predict_shape(dataclasses.replace(model, params=dataclasses.replace(model.params, cores=None)), shapes[3])
    np.testing.assert_array_equal(same_patches, patch_labels)  # cores act after the refinement only
    assert (refined == gts[3]).mean() >= 0.90


def test_model_round_trip_and_refusals(tmp_path, collection):
    shapes, _, snaps = collection
    model = snaps[-1].model
    save_model(tmp_path / "m", model)
    back = load_model(tmp_path / "m", expected_labels=LABELS)
    np.testing.assert_array_equal(predict_shape(back, shapes[3])[0], predict_shape(model, shapes[3])[0])
    x = model.params.network_input(shapes[3])
    np.testing.assert_allclose(back.classifier.log_proba(x), model.classifier.log_proba(x), atol=1e-6)  # no dropout noise
    with pytest.raises(ModelFileError, match="trained on labels"):
        load_model(tmp_path / "m", expected_labels=("a", "b"))
    import json

    import torch

    meta_path = tmp_path / "m" / "model.json"
    meta = json.loads(meta_path.read_text())
    for version, message in [(99, "model format version 99, written by scribbleseg .*; this scribbleseg reads version 2"),
                             (1, "model format version 1, written by scribbleseg .*, older than the version 2")]:
        meta_path.write_text(json.dumps({**meta, "version": version}))
        with pytest.raises(ModelFileError, match=message) as refused:
            load_model(tmp_path / "m")
        assert str(tmp_path / "m") in str(refused.value)
    # what prediction uses travels with the model, switched-off parts included
    assert back.params.cores == model.params.cores and back.params.propagation == model.params.propagation
    assert (back.params.refinement, back.params.lam, back.params.context_scales, back.params.local_shape) == (
        model.params.refinement, model.params.lam, model.params.context_scales, model.params.local_shape)
    save_model(tmp_path / "off", dataclasses.replace(model, params=dataclasses.replace(model.params, cores=None)))
    assert load_model(tmp_path / "off").params.cores is None
    # a file that lacks a part of the schema says which
    meta_path.write_text(json.dumps({k: v for k, v in meta.items() if k != "inputs"}))
    with pytest.raises(ModelFileError, match="model.json lacks 'inputs'"):
        load_model(tmp_path / "m")
    # weights that do not fit the inputs the file describes are refused
    s = len(model.params.context_scales)
    assert model.classifier.num_inputs == NUM_FEATURES * (1 + s) + LOCAL_SHAPE_PER_SCALE * s
    meta_path.write_text(json.dumps({**meta, "inputs": {**meta["inputs"], "local_shape": False}}))
    with pytest.raises(ModelFileError, match=f"expects {model.classifier.num_inputs} inputs per face, its parameters "
                                             f"give {NUM_FEATURES * (1 + s)}"):
        load_model(tmp_path / "m")
    (tmp_path / "m" / "model.json").write_text(json.dumps(meta))
    # a pickle with code in place of the weights is refused, not executed
    torch.save({"weights": object()}, tmp_path / "m" / "weights.pt")
    with pytest.raises(ModelFileError, match="corrupt or foreign"):
        load_model(tmp_path / "m")
    (tmp_path / "m" / "weights.pt").write_bytes(b"garbage")
    with pytest.raises(ModelFileError):
        load_model(tmp_path / "m")
    with pytest.raises(ModelFileError, match="no model.json"):
        load_model(tmp_path)


def test_scribble_unary_follows_eq1():
    patch = np.array([0, 0, 1, 1, 2])
    scribble = np.array([-1, 2, -1, -1, -1])
    U = scribble_unary(patch, scribble, np.array([0, 2]), 3)
    np.testing.assert_array_equal(U[0], [INF, INF, 0.0])
    np.testing.assert_allclose(U[1], [np.log(2), INF, np.log(2)])
    with pytest.raises(ValueError, match="two labels"):
        scribble_unary(np.array([0, 0]), np.array([0, 1]), np.array([0, 1]), 2)


def test_patches_never_mix_scribble_labels_and_are_connected(collection):
    from scipy.sparse.csgraph import connected_components

    shapes, _, _ = collection
    for s in shapes:
        assert 40 <= s.num_patches <= 70
        sel = s.scribble >= 0
        pairs = np.unique(np.stack([s.patch[sel], s.scribble[sel]], 1), axis=0)
        assert len(np.unique(pairs[:, 0])) == len(pairs)
        inside = s.patch[s.graph.pairs[:, 0]] == s.patch[s.graph.pairs[:, 1]]
        G = s.graph.matrix(inside.astype(float))
        G.eliminate_zeros()
        n, _ = connected_components(G, directed=False)
        assert n == s.num_patches


def test_retrain_near_keeps_the_faces_nearest_the_strokes(collection):
    from scribbleseg_core.engine.optimize import _near_strokes

    shapes, gts, _ = collection
    kept = _near_strokes(shapes[:3], gts[:3], len(LABELS), 0.5)
    for s, gt, y in zip(shapes, gts, kept):
        assert 0.45 <= (y >= 0).mean() <= 0.6  # about the nearer half
        sel = s.scribble >= 0
        np.testing.assert_array_equal(y[sel], gt[sel])  # strokes are nearest of all
        np.testing.assert_array_equal(y[y >= 0], gt[y >= 0])  # kept faces keep their label


def test_cross_fit_folds_hold_each_shape_out_once():
    from scribbleseg_core.engine.optimize import cross_fit_folds

    for n, folds in [(20, 4), (3, 4), (2, 2), (7, 3)]:
        held = cross_fit_folds(n, folds)
        assert len(held) == min(n, folds)
        np.testing.assert_array_equal(np.sort(np.concatenate(held)), np.arange(n))
    with pytest.raises(ValueError, match="at least 2 shapes"):
        cross_fit_folds(1, 4)


def test_cross_fit_repeats_split_the_shapes_anew():
    from scribbleseg_core.engine.optimize import cross_fit_folds

    def partition(held):
        return sorted(tuple(h) for h in held)

    for n in (3, 5, 20):
        first, second = cross_fit_folds(n, 2, 0), cross_fit_folds(n, 2, 1)
        assert len(second) == 2
        np.testing.assert_array_equal(np.sort(np.concatenate(second)), np.arange(n))
        assert partition(first) != partition(second)
    np.testing.assert_array_equal(cross_fit_folds(6, 2, 1)[0], [0, 1, 4, 5])  # neighbours paired
    assert cross_fit_folds(2, 2, 1) == []  # two shapes split only one way
    assert cross_fit_folds(4, 4, 1) == []  # leave-one-out has no other split
    assert cross_fit_folds(4, 2, 2) == []  # (i // 4) mod 2: all in one fold


def test_cross_fit_mixes_held_out_networks_and_leaves_the_model_alone(collection):
    shapes, gts, snaps = collection
    phases = [s.phase for s in snaps]
    assert (PARAMS.cross_fit_folds, PARAMS.cross_fit_repeats) == (2, 2)  # the defaults
    assert phases.count("crossfit") == 4  # three scribbled shapes, two folds, two splits
    assert phases.index("retrain") < phases.index("crossfit") < len(phases) - 2
    assert phases[-2:] == ["retrain", "done"]
    one = [s.phase for s in segment_collection(shapes, LABELS, dataclasses.replace(PARAMS, cross_fit_repeats=1))]
    assert one.count("crossfit") == 2
    off = list(segment_collection(shapes, LABELS, dataclasses.replace(PARAMS, cross_fit=0.0)))
    assert "crossfit" not in [s.phase for s in off]
    x = PARAMS.network_input(shapes[3])
    # the model (used on unseen shapes) is the same network either way
    np.testing.assert_allclose(off[-1].model.classifier.log_proba(x), snaps[-1].model.classifier.log_proba(x), atol=1e-6)
    for s, gt, labels in zip(shapes, gts, snaps[-1].labels):
        assert (labels == gt).mean() >= 0.95


def test_held_out_network_replaces_the_own_one_at_share_1(collection):
    from scribbleseg_core.engine.network import FaceClassifier
    from scribbleseg_core.engine.optimize import _held_out_log_proba, _mix

    shapes, gts, _ = collection
    inputs = [PARAMS.network_input(s) for s in shapes[:3]]
    own = np.log(np.full((len(inputs[0]), len(LABELS)), 1.0 / len(LABELS)))
    held = _held_out_log_proba(inputs, gts[:3], np.array([0]), len(LABELS), PARAMS)
    assert list(held) == [0]  # only the held-out shape gets an opinion
    other = FaceClassifier(inputs[0].shape[1], len(LABELS), PARAMS.network)
    other.fit(inputs[1:], gts[1:3])
    np.testing.assert_allclose(held[0], other.log_proba(inputs[0]), atol=1e-6)
    np.testing.assert_allclose(_mix(own, [held[0]], 1.0), held[0], atol=1e-9)
    assert (held[0].argmax(1) == gts[0]).mean() >= 0.9  # learned from the other two shapes
    assert _mix(own, [], 0.7) is own  # no held-out opinion: the own network alone


def test_mix_averages_held_out_probabilities():
    from scribbleseg_core.engine.optimize import _mix

    own = np.log(np.array([[0.9, 0.1]]))
    p1, p2 = np.log(np.array([[0.2, 0.8]])), np.log(np.array([[0.6, 0.4]]))
    mixed = np.exp(_mix(own, [p1, p2], 0.7))
    np.testing.assert_allclose(mixed, 0.3 * np.array([[0.9, 0.1]]) + 0.7 * np.array([[0.4, 0.6]]))


def test_cross_fit_share_is_checked(collection):
    shapes, _, _ = collection
    with pytest.raises(ValueError, match="cross_fit"):
        next(segment_collection(shapes, LABELS, dataclasses.replace(PARAMS, cross_fit=1.5)))
    with pytest.raises(ValueError, match="stroke_network"):
        next(segment_collection(shapes, LABELS, dataclasses.replace(PARAMS, stroke_network=-0.1)))


def test_stroke_network_guides_the_training_labels(collection):
    """The labels the model for unseen shapes learns: the propagation plus the
    −log-probabilities of a network trained on the stroke faces only. Strokes keep their
    labels; weight 0, a single shape or a stroke
    network whose held-out accuracy on the strokes falls short leave the propagation alone; a
    large weight makes the labels follow that network where no stroke holds them."""
    from scribbleseg_core.engine.network import FaceClassifier
    from scribbleseg_core.engine.optimize import (
        _stroke_guided_labels,
        stroke_network_accuracy,
    )

    shapes, gts, _ = collection
    trio, k = shapes[:3], len(LABELS)
    inputs = [PARAMS.network_input(s) for s in trio]
    accuracy = stroke_network_accuracy(trio, inputs, k, PARAMS)
    assert 0.5 <= accuracy <= 1.0  # six stroke faces per part on three shapes: some carry over
    just = dataclasses.replace(PARAMS, stroke_network=0.05, stroke_network_min_accuracy=accuracy)
    above = dataclasses.replace(just, stroke_network_min_accuracy=accuracy + 1e-6)
    assert _stroke_guided_labels(trio, inputs, k, above) is None  # falls short: the propagation alone
    assert _stroke_guided_labels(trio, inputs, k, dataclasses.replace(just, stroke_network=0.0)) is None  # off
    assert np.isnan(stroke_network_accuracy(trio[:1], inputs[:1], k, PARAMS))
    assert _stroke_guided_labels(trio[:1], inputs[:1], k, just) is None  # one shape: nothing to check it on
    guided = _stroke_guided_labels(trio, inputs, k, just)
    for s, y, gt in zip(trio, guided, gts):
        sel = s.scribble >= 0
        np.testing.assert_array_equal(y[sel], s.scribble[sel])
        assert (y == gt).mean() >= 0.95
    plain = [propagate_shape(s, k, PARAMS.propagation) for s in trio]
    net = FaceClassifier(inputs[0].shape[1], k, PARAMS.network)
    net.fit(inputs, [s.scribble for s in trio])  # the stroke network: stroke faces only
    vote = [net.log_proba(x).argmax(1) for x in inputs]
    strong = _stroke_guided_labels(trio, inputs, k, dataclasses.replace(just, stroke_network=50.0))

    def agreement(labels):
        return np.mean([(y == v).mean() for y, v in zip(labels, vote)])

    assert agreement(strong) > agreement(plain) and agreement(strong) >= 0.97


def test_stroke_network_trains_only_the_model_for_unseen_shapes(collection):
    """With the stroke network on (gate open), the scribbled shapes' labels are those of the
    engine without it, and the model handed on for unseen shapes is a network trained on the
    guided labels."""
    from scribbleseg_core.engine.network import FaceClassifier
    from scribbleseg_core.engine.optimize import (
        _stroke_guided_labels,
        stroke_network_accuracy,
    )

    shapes, _, snaps = collection
    on = dataclasses.replace(PARAMS, stroke_network=0.05, stroke_network_min_accuracy=0.0)
    final = list(segment_collection(shapes, LABELS, on))[-1]
    for a, b in zip(final.labels, snaps[-1].labels):
        np.testing.assert_array_equal(a, b)
    trio, k = shapes[:3], len(LABELS)
    inputs = [PARAMS.network_input(s) for s in trio]
    assert stroke_network_accuracy(trio, inputs, k, PARAMS) < PARAMS.stroke_network_min_accuracy  # the fixture's gate was shut
    guided = _stroke_guided_labels(trio, inputs, k, on)
    reference = FaceClassifier(inputs[0].shape[1], k, PARAMS.network)
    reference.fit(inputs, guided)
    x = PARAMS.network_input(shapes[3])
    np.testing.assert_allclose(final.model.classifier.log_proba(x), reference.log_proba(x), atol=1e-5)
    assert not np.allclose(snaps[-1].model.classifier.log_proba(x), reference.log_proba(x), atol=1e-3)
