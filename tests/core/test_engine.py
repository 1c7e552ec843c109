"""The engine on a planted collection: accuracy, hard scribbles, monotone energy, early stop, models,
both variants (face and paper)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from scribbleseg_core.engine.energy import scribble_unary
from scribbleseg_core.engine.graphcut import INF
from scribbleseg_core.engine.network import NetworkParams
from scribbleseg_core.engine.optimize import SegmentParams, fit_model, segment_collection
from scribbleseg_core.engine.predict import predict_shape
from scribbleseg_core.engine.propagate import FaceEnergy, propagate_shape
from scribbleseg_core.engine.shape import REGION_COLUMNS, prepare_shape
from scribbleseg_core.errors import ModelFileError
from scribbleseg_core.infra.cache import ArrayCache
from scribbleseg_core.signatures.context import LOCAL_SHAPE_PER_SCALE
from scribbleseg_core.signatures.features import NUM_FEATURES
from scribbleseg_core.signatures.self_similarity import NUM_BANDS
from scribbleseg_core.store.model_file import VERSION, load_model, save_model
from tests.core.planted import LABELS, creature, stroke_faces

PARAMS = SegmentParams(network=NetworkParams(epochs=30, faces_per_epoch=1000))


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


@pytest.fixture(scope="module")
def paper(collection):
    shapes, gts, _ = collection
    return list(segment_collection(shapes, LABELS, dataclasses.replace(PARAMS, method="paper")))


def test_planted_parts_come_back_on_every_shape(collection):
    """Three scribbled shapes and one without scribbles, in one run."""
    shapes, gts, snaps = collection
    final = snaps[-1]
    assert final.done and final.model is not None
    for labels, gt in zip(final.labels, gts):
        assert (labels == gt).mean() >= 0.95


def test_scribbled_faces_keep_their_label(collection, paper):
    shapes, _, snaps = collection
    for snap in snaps + paper:
        for s, labels in zip(shapes, snap.labels):
            sel = s.scribble >= 0
            np.testing.assert_array_equal(labels[sel], s.scribble[sel])


def test_each_snapshot_carries_the_energy_of_its_labels(collection):
    """The snapshot's energy is the face energy of the scribbled shapes' labels under its
    network (without cross-fitting, the model is the whole network term); the labels of the
    shape without scribbles are its prediction by the snapshot's model (the learned boundary
    term its smoothness), and count in no energy."""
    shapes, _, _ = collection
    assert not all(s.is_scribbled for s in shapes)
    params = dataclasses.replace(PARAMS, cross_fit=0.0)
    snaps = list(segment_collection(shapes, LABELS, params))
    k = len(LABELS)
    assert snaps[-1].model.boundary is not None
    for snap in snaps[1:-1]:
        energies = [FaceEnergy(s.graph, s.scribble, k, params.propagation, s.sdf) for s in shapes if s.is_scribbled]
        logp = [snap.model.log_proba(s) for s in shapes if s.is_scribbled]
        labels = [lab for s, lab in zip(shapes, snap.labels) if s.is_scribbled]
        terms = [e.terms(lab, lp) for e, lab, lp in zip(energies, labels, logp)]
        np.testing.assert_allclose(sum(sum(t) for t in terms), snap.energy.total, rtol=1e-6)
        if snap.phase == "graphcut":
            np.testing.assert_array_equal(snap.labels[3], predict_shape(snap.model, shapes[3]))
    assert snaps[-1].energy == [s for s in snaps if s.phase == "graphcut"][-1].energy


def test_shapes_without_scribbles_train_nothing(collection):
    """The networks learn from the scribbled shapes' labels alone: whatever labels a shape
    without scribbles is given, the trained networks are the same."""
    from scribbleseg_core.engine.optimize import _Networks

    shapes, gts, snaps = collection
    inputs = [PARAMS.network_input(s) for s in shapes]
    labels = [np.array(lab) for lab in snaps[-1].labels]
    scribbled = [s.is_scribbled for s in shapes]
    weights = []
    for other in (labels[3], np.zeros_like(labels[3])):  # the unpainted shape's labels, right or all one label
        net = _Networks(inputs[0].shape[1], len(LABELS), PARAMS.network, 0.7, scribbled, None)
        net.fit(inputs, labels[:3] + [other])
        weights.append([p.detach().numpy().copy() for p in net.main.stage1.net.parameters()])
        assert net.held_out_log_proba(inputs)[3] is None  # no network saw its labels
        assert [h.trained for h in net.fold_nets] == [True, True]  # the halves split shapes 0 and 2 from 1
    for a, b in zip(*weights):
        np.testing.assert_array_equal(a, b)


def test_cross_fitting_mixes_in_networks_that_never_saw_the_shape(collection):
    from scribbleseg_core.engine.optimize import _Networks

    shapes, _, snaps = collection
    inputs = [PARAMS.network_input(s) for s in shapes]
    labels = [lab if s.is_scribbled else None for s, lab in zip(shapes, snaps[-1].labels)]
    net = _Networks(inputs[0].shape[1], len(LABELS), PARAMS.network, 0.7, [s.is_scribbled for s in shapes])
    net.fit(inputs, labels)
    assert all(h.trained for h in net.fold_nets)
    mixed, prior = net.log_proba(inputs)
    for i, (s, x) in enumerate(zip(shapes, inputs)):
        own, other = np.exp(net.main.log_proba(x)), np.exp(net.fold_nets[net.fold_of[i]].log_proba(x))
        expected = 0.3 * own + 0.7 * other if s.is_scribbled else own  # no scribbles: the model alone
        np.testing.assert_allclose(np.exp(mixed[i]), expected, rtol=1e-6)
        np.testing.assert_allclose(np.exp(prior[i]), own, rtol=1e-6)  # the walk's prior: the model's own
    alone = _Networks(inputs[0].shape[1], len(LABELS), PARAMS.network, 0.7, [True])  # one shape: none held out
    assert alone.fold_nets == []


def test_label_context_stage_learns_from_held_out_probabilities(collection, monkeypatch):
    """Stage 2 is trained on the label distances of the fold networks' probabilities (never
    of a network that saw the shape), and the model's prediction runs both stages."""
    from scribbleseg_core.engine import optimize
    from scribbleseg_core.engine.learner import context_input

    shapes, _, snaps = collection
    inputs = [PARAMS.network_input(s) for s in shapes]
    labels = [lab if s.is_scribbled else None for s, lab in zip(shapes, snaps[-1].labels)]
    k = len(LABELS)
    seen = []  # (shape, log P) per call; with two training lanes the calls come in either order
    monkeypatch.setattr(optimize, "context_input",
                        lambda x, c, lp: seen.append((next(i for i, y in enumerate(inputs) if y is x), lp))
                        or context_input(x, c, lp))
    net = optimize._Networks(inputs[0].shape[1], k, PARAMS.network, 0.0, [s.is_scribbled for s in shapes],
                             lambda i: shapes[i].label_context)
    net.fit(inputs, labels)
    assert len(net.fold_nets) == 2 and net.main.stage2.num_inputs == inputs[0].shape[1] + 2 * k
    used = [i for i, lab in enumerate(labels) if lab is not None]
    assert sorted(i for i, _ in seen) == used
    for i, lp in seen:
        np.testing.assert_allclose(lp, net.fold_nets[net.fold_of[i]].log_proba(inputs[i]))
    model = snaps[-1].model
    assert model.learner.stage2 is not None
    s = shapes[3]
    first = model.learner.stage1.log_proba(inputs[3])
    np.testing.assert_allclose(model.log_proba(s),
                               model.learner.stage2.log_proba(context_input(inputs[3], s.label_context, first)))
    off = dataclasses.replace(PARAMS, label_context=False, rounds=1)
    assert next(x for x in segment_collection(shapes, LABELS, off) if x.model).model.learner.stage2 is None


@pytest.mark.parametrize("all_scribbled", [False, True], ids=["two halves", "four folds"])
def test_two_training_lanes_give_the_networks_of_one_after_another(collection, monkeypatch, all_scribbled):
    """With two threads to use, the fold networks, stage 1 and stage 2 train in two lanes at once
    (one torch thread each), and the shapes' probabilities come two at a time; every network
    and every probability comes out as when computed one after another. With all four shapes
    scribbled (their last labels taken as given), four folds: one shape left out of each."""
    from concurrent.futures import ThreadPoolExecutor

    import torch

    from scribbleseg_core.engine import optimize

    shapes, _, snaps = collection
    inputs = [PARAMS.network_input(s) for s in shapes]
    mixed = [True] * len(shapes) if all_scribbled else [s.is_scribbled for s in shapes]
    labels = [lab if m else None for m, lab in zip(mixed, snaps[-1].labels)]
    lanes = []
    monkeypatch.setattr(optimize, "ThreadPoolExecutor", lambda n: lanes.append(n) or ThreadPoolExecutor(n))

    def trained(threads):
        params = dataclasses.replace(PARAMS.network, threads=threads)
        net = optimize._Networks(inputs[0].shape[1], len(LABELS), params, 0.7, mixed,
                                 lambda i: shapes[i].label_context)
        for _ in range(2):  # from scratch, then warm
            net.fit(inputs, labels)
        return net

    one, two = trained(1), trained(2)
    assert len(one.fold_nets) == (4 if all_scribbled else 2)
    assert lanes == [1, 1]  # only the run with two threads took the lanes, in both fits
    for a, b in zip(sum(one.log_proba(inputs), []), sum(two.log_proba(inputs), [])):
        np.testing.assert_array_equal(a, b)
    assert lanes == [1, 1, 2]
    for a, b in zip([one.main.stage1, *one.fold_nets, one.main.stage2], [two.main.stage1, *two.fold_nets, two.main.stage2]):
        for (name, x), y in zip(a.net.state_dict().items(), b.net.state_dict().values()):
            assert torch.equal(x, y), name
        np.testing.assert_array_equal(a.mean, b.mean)


def test_energy_never_increases_and_the_result_is_the_last_cut(collection, paper):
    for snaps in (collection[2], paper):
        totals = [s.energy.total for s in snaps if s.iteration >= 1 and s.phase in ("train", "graphcut")]
        assert len(totals) >= 2
        assert all(b <= a * (1 + 1e-9) for a, b in zip(totals, totals[1:]))
        assert snaps[0].phase == "init" and np.isnan(snaps[0].energy.network)
        last_cut = [s for s in snaps if s.phase == "graphcut"][-1]
        for s, a, b in zip(collection[0], last_cut.labels, snaps[-1].labels):
            if s.is_scribbled:
                np.testing.assert_array_equal(a, b)
        assert snaps[-1].energy == last_cut.energy


def _record_stage1_fits(monkeypatch, inputs) -> dict:
    """Record every stage-1 fit: network id → {shape index: the labels of its last fit}.
    `inputs` are the shapes' stage-1 inputs, by which a fit's shapes are recognized."""
    from scribbleseg_core.engine.network import FaceClassifier

    taught = {}
    fit = FaceClassifier.fit

    def recording_fit(self, X, y, **kw):
        if X[0].shape[1] == inputs[0].shape[1]:
            ids = [next(i for i, x in enumerate(inputs) if len(x) == len(xi) and np.array_equal(x, xi)) for xi in X]
            taught[id(self)] = dict(zip(ids, (np.asarray(yi) for yi in y)))
        return fit(self, X, y, **kw)

    monkeypatch.setattr(FaceClassifier, "fit", recording_fit)
    return taught


def test_the_model_learns_the_result_and_labels_the_unpainted_shapes(monkeypatch):
    """The final model's networks learned every face of the scribbled shapes' final labels,
    even where the alternation stopped after its first round (whose networks learn only the
    faces the strokes decide); the shape without scribbles is what that model predicts."""
    shapes, gts = [], []
    for i, (limb, head) in enumerate([(1.6, 0.9), (1.2, 0.7), (1.4, 0.8)]):
        mesh, gt = creature(limb, head, seed=i)
        # two shapes painted but for the bottom of the body, far from every other part: the first
        # cut gives it the body's label and changes nothing, so the run stops after round 1
        scribble = gt.copy()
        centroids = mesh.V[mesh.F].mean(1)
        scribble[centroids[:, 2] / np.linalg.norm(centroids, axis=1) < -0.9] = -1
        shapes.append(prepare_shape(mesh, scribble if i < 2 else None))
        gts.append(gt)
    params = dataclasses.replace(PARAMS, decided=1.0)  # only the painted faces are decided
    inputs = [params.network_input(s) for s in shapes]
    taught = _record_stage1_fits(monkeypatch, inputs)
    monkeypatch.setattr("scribbleseg_core.engine.optimize.UNDECIDED_SHARE", 0.0)
    snaps = list(segment_collection(shapes, LABELS, params))
    assert [s.phase for s in snaps[1:]] == ["train", "graphcut", "done"]
    first = snaps[1].model.learner.stage1
    assert any((y < 0).any() for y in taught[id(first)].values())  # round 1 skipped the faces the walk leaves undecided
    final = snaps[-1]
    learned = taught[id(final.model.learner.stage1)]
    assert sorted(learned) == [0, 1]
    for i in (0, 1):
        np.testing.assert_array_equal(learned[i], final.labels[i])
    np.testing.assert_array_equal(final.labels[2], predict_shape(final.model, shapes[2]))
    assert (final.labels[2] == gts[2]).mean() >= 0.9


@pytest.mark.parametrize("undone_round", [2, 3])
def test_an_undone_training_leaves_a_model_that_learned_every_face(collection, monkeypatch, undone_round):
    """A training that raises the energy is undone and ends the run. If the kept networks are
    the first round's (which learn mostly the faces the strokes decide), the undone ones, which
    learned every face of the final labels, become the model; later networks stay the model."""
    from scribbleseg_core.engine import optimize
    from scribbleseg_core.engine.energy import EnergyTerms

    shapes, _, _ = collection
    # scripted energies: every cut changes labels and lowers E; the training of `undone_round` raises it
    totals = [1000.0, 900.0, 800.0, 700.0, 600.0, 500.0, 400.0]
    totals[2 * undone_round - 1] = totals[2 * undone_round - 2] + 50.0
    calls = iter(totals)
    monkeypatch.setattr(optimize._FaceProblem, "energy", lambda self, *a, **kw: EnergyTerms(next(calls), 0.0, 0.0))
    monkeypatch.setattr(optimize, "_changes", lambda labels, new: tuple(b is not None for b in new))
    inputs = [PARAMS.network_input(s) for s in shapes]
    taught = _record_stage1_fits(monkeypatch, inputs)
    snaps = list(segment_collection(shapes, LABELS, PARAMS))
    trainings = [s for s in snaps if s.phase == "train"]
    assert len(trainings) == undone_round - 1  # the undone training yields no snapshot
    final = snaps[-1]
    kept = trainings[-1].model.learner.stage1
    if undone_round == 2:
        assert final.model.learner.stage1 is not kept
        learned = taught[id(final.model.learner.stage1)]
        for i in (0, 1, 2):
            np.testing.assert_array_equal(learned[i], final.labels[i])
    else:
        assert final.model.learner.stage1 is kept
    np.testing.assert_array_equal(final.labels[3], predict_shape(final.model, shapes[3]))


def test_a_shape_without_scribbles_joins_at_the_first_cut(collection):
    shapes, _, snaps = collection
    assert not shapes[3].is_scribbled
    assert (snaps[0].labels[3] == -1).all() and snaps[0].changed[3] is False
    first_cut = next(s for s in snaps if s.phase == "graphcut")
    assert (first_cut.labels[3] >= 0).all() and first_cut.changed[3]


def test_stopping_early_leaves_valid_labels(collection):
    shapes, _, _ = collection
    gen = segment_collection(shapes, LABELS, PARAMS)
    first = next(gen)
    gen.close()
    for s, labels in zip(shapes, first.labels):
        assert labels.shape == (len(s.mesh.F),)
        assert not labels.flags.writeable  # frozen snapshot
        if s.is_scribbled:
            assert set(np.unique(labels)) <= set(s.scribbled_labels)
            np.testing.assert_array_equal(labels, propagate_shape(s, len(LABELS), PARAMS.propagation))


def test_unseen_shape_is_predicted_as_the_collection_labeled_it(collection):
    shapes, gts, snaps = collection
    model = snaps[-1].model
    labels = predict_shape(model, shapes[3])
    assert (labels == gts[3]).mean() >= 0.95
    np.testing.assert_array_equal(labels, snaps[-1].labels[3])  # the same cut with the same network
    one = model.with_threads(1)  # the app's prediction: torch and the boundary trees on one thread
    assert one.params.network.threads == 1 and one.learner.stage1.params.threads == 1
    assert model.params.network.threads != 1  # the model itself is left as it was
    np.testing.assert_array_equal(predict_shape(one, shapes[3]), labels)


def test_fit_model_trains_both_stages_and_the_boundary_term_on_given_labels(collection):
    shapes, gts, _ = collection
    model = fit_model(shapes[:3], gts[:3], LABELS, PARAMS)
    learner = model.learner
    assert model.boundary is not None and predict_shape(model, shapes[3]).shape == gts[3].shape
    assert learner.stage2 is not None and learner.stage2.num_inputs == learner.stage1.num_inputs + 2 * len(LABELS)
    labels = learner.log_proba(PARAMS.network_input(shapes[3]), shapes[3].label_context).argmax(1)
    assert (labels == gts[3]).mean() >= 0.9  # the held-out shape, without a cut
    alone = fit_model(shapes[:3], gts[:3], LABELS, dataclasses.replace(PARAMS, label_context=False)).learner
    assert alone.stage2 is None
    with pytest.raises(ValueError, match="3 shapes but 2"):
        fit_model(shapes[:3], gts[:2], LABELS, PARAMS)


def test_paper_variant_is_the_patch_level_alternation(collection, paper):
    """Eq. 1 alone starts it: on these short strokes its cut keeps to the strokes' patches
    (graph cuts' shrinking bias), which the face method's distance term avoids."""
    shapes, gts, snaps = collection
    final = paper[-1]
    assert final.model.params.method == "paper" and final.model.encoder is not None
    for s, labels in zip(shapes[:3], final.labels):
        assert set(np.unique(labels)) <= set(s.scribbled_labels)
        assert len(np.unique(labels[s.patch == s.patch[0]])) == 1  # patch-level: one label per patch
    assert (final.labels[3] == -1).all()  # the paper trains on scribbled shapes only
    predicted = predict_shape(final.model, shapes[3])
    assert predicted.shape == gts[3].shape and set(np.unique(predicted)) <= {0, 1, 2}
    face = np.mean([(lab == gt).mean() for lab, gt in zip(snaps[-1].labels, gts)])
    patch = np.mean([(lab == gt).mean() for lab, gt in zip(final.labels[:3], gts)])
    assert face > patch


def test_parameters_are_checked_when_made():
    for bad, message in [(dict(method="magic"), "method must be one of 'face', 'paper'"),
                         (dict(rounds=0), "rounds must be at least 1"),
                         (dict(context_scales=(0.01, -1.0)), "context_scales must be positive")]:
        with pytest.raises(ValueError, match=message):
            SegmentParams(**bad)
    for bad, message in [(dict(hidden=(64, 0)), "hidden must be two positive widths"),
                         (dict(dropout=1.0), "dropout must lie in"),
                         (dict(epochs=0), "epochs and faces_per_epoch must be positive"),
                         (dict(threads=0), "threads must be positive")]:
        with pytest.raises(ValueError, match=message):
            NetworkParams(**bad)
    assert NetworkParams(epochs=30).warm_epochs == 10 and NetworkParams(epochs=1).warm_epochs == 1


def test_no_scribbles_at_all_is_refused(collection):
    shapes, _, _ = collection
    with pytest.raises(ValueError, match="no shape has scribbles"):
        next(segment_collection([shapes[3]], LABELS, PARAMS))


def test_with_every_shape_painted_the_boundary_term_is_trained_once_for_new_shapes(collection):
    """No cut of a painted collection uses the boundary term, so it is trained once, at the
    end, on the labels the kept networks learned from; new shapes are cut with it."""
    shapes, gts, _ = collection
    painted = [s for s in shapes if s.is_scribbled]
    snaps = list(segment_collection(painted, LABELS, dataclasses.replace(PARAMS, rounds=2)))
    assert all(s.model.boundary is None for s in snaps[1:-1])
    final = snaps[-1].model
    assert final.boundary is not None
    held = shapes[3]
    p = final.boundary_proba(held)
    truth = gts[3][held.mesh.proc_to_file]
    across = truth[held.graph.pairs[:, 0]] != truth[held.graph.pairs[:, 1]]
    assert p[across].mean() > 3 * p[~across].mean()


def test_model_round_trip_and_refusals(tmp_path, collection):
    shapes, _, snaps = collection
    model = snaps[-1].model
    save_model(tmp_path / "m", model)
    back = load_model(tmp_path / "m", expected_labels=LABELS)
    np.testing.assert_array_equal(predict_shape(back, shapes[3]), predict_shape(model, shapes[3]))
    assert back.learner.stage2 is not None and back.params.label_context
    np.testing.assert_allclose(back.log_proba(shapes[3]), model.log_proba(shapes[3]), atol=1e-6)  # no dropout noise
    np.testing.assert_allclose(back.boundary_proba(shapes[3]), model.boundary_proba(shapes[3]), atol=1e-9)
    with pytest.raises(ModelFileError, match="trained on labels"):
        load_model(tmp_path / "m", expected_labels=("a", "b"))
    import json

    import torch

    meta_path = tmp_path / "m" / "model.json"
    meta = json.loads(meta_path.read_text())
    for version, message in [(99, f"model format version 99, written by scribbleseg .*; this scribbleseg reads version {VERSION}"),
                             (VERSION - 1, f"model format version {VERSION - 1}, written by scribbleseg .*, older than the version {VERSION}")]:
        meta_path.write_text(json.dumps({**meta, "version": version}))
        with pytest.raises(ModelFileError, match=message) as refused:
            load_model(tmp_path / "m")
        assert str(tmp_path / "m") in str(refused.value)
    # what prediction uses travels with the model
    assert (back.params.method, back.params.propagation, back.params.context_scales, back.params.local_shape) == (
        model.params.method, model.params.propagation, model.params.context_scales, model.params.local_shape)
    assert back.encoder is None and model.encoder is None  # the face method needs no patch descriptors
    # a file that lacks a part of the schema says which
    meta_path.write_text(json.dumps({k: v for k, v in meta.items() if k != "inputs"}))
    with pytest.raises(ModelFileError, match="model.json lacks 'inputs'"):
        load_model(tmp_path / "m")
    # weights that do not fit the inputs the file describes are refused
    s = len(model.params.context_scales)
    signatures = 2 * NUM_FEATURES + len(REGION_COLUMNS) * (s - 1)  # all 22 at the first scale, 5 at the others
    assert model.learner.stage1.num_inputs == signatures + (LOCAL_SHAPE_PER_SCALE + len(REGION_COLUMNS)) * s + NUM_BANDS
    meta_path.write_text(json.dumps({**meta, "inputs": {**meta["inputs"], "local_shape": False}}))
    with pytest.raises(ModelFileError, match=f"expects {model.learner.stage1.num_inputs} inputs per face, its parameters "
                                             f"give {signatures + NUM_BANDS}"):
        load_model(tmp_path / "m")
    # a file whose stages disagree with its weights is refused
    meta_path.write_text(json.dumps({**meta, "label_context": False}))
    with pytest.raises(ModelFileError, match="does not hold the stages"):
        load_model(tmp_path / "m")
    (tmp_path / "m" / "model.json").write_text(json.dumps(meta))
    # the boundary classifier: missing, or not LightGBM's text, is refused with the file named
    text = (tmp_path / "m" / "boundary.txt").read_text()
    (tmp_path / "m" / "boundary.txt").unlink()
    with pytest.raises(ModelFileError, match="incomplete model: boundary.txt is missing"):
        load_model(tmp_path / "m")
    (tmp_path / "m" / "boundary.txt").write_text("tree\nversion=v4\nnum_class=1\ngarbage")
    with pytest.raises(ModelFileError, match="corrupt or foreign"):
        load_model(tmp_path / "m")
    (tmp_path / "m" / "boundary.txt").write_text(text)
    # a pickle with code in place of the weights is refused, not executed
    torch.save({"weights": object()}, tmp_path / "m" / "weights.pt")
    with pytest.raises(ModelFileError, match="corrupt or foreign"):
        load_model(tmp_path / "m")
    (tmp_path / "m" / "weights.pt").write_bytes(b"garbage")
    with pytest.raises(ModelFileError):
        load_model(tmp_path / "m")
    with pytest.raises(ModelFileError, match="no model.json"):
        load_model(tmp_path)


def test_paper_model_round_trip(tmp_path, collection, paper):
    shapes = collection[0]
    model = paper[-1].model
    save_model(tmp_path / "p", model)
    back = load_model(tmp_path / "p")
    assert back.params.method == "paper" and back.delta == model.delta
    np.testing.assert_array_equal(back.encoder.codebook, model.encoder.codebook)
    np.testing.assert_array_equal(predict_shape(back, shapes[3]), predict_shape(model, shapes[3]))
    assert model.boundary is None and not (tmp_path / "p" / "boundary.txt").exists()
    # saved over a face model's folder, the other model's boundary term goes with it
    save_model(tmp_path / "f", collection[2][-1].model)
    assert (tmp_path / "f" / "boundary.txt").is_file()
    save_model(tmp_path / "f", model)
    assert not (tmp_path / "f" / "boundary.txt").exists() and load_model(tmp_path / "f").boundary is None


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


def test_a_run_continues_the_networks_of_an_earlier_one(collection, monkeypatch):
    from scribbleseg_core.engine.network import FaceClassifier

    shapes, gts, snaps = collection
    last = snaps[-1]
    assert len(last.model.fold_nets) == 2 and last.held_out is not None
    assert [h is not None for h in last.held_out] == [s.is_scribbled for s in shapes]
    fits = []
    fit = FaceClassifier.fit
    monkeypatch.setattr(FaceClassifier, "fit", lambda self, X, y, warm=False, **kw: fits.append(warm and self.trained)
                        or fit(self, X, y, warm=warm, **kw))
    *_, warm = segment_collection(shapes, LABELS, PARAMS, warm=last.model)
    assert fits and all(fits)  # every training continued (warm epochs), the first round's too
    assert np.mean([(lab == gt).mean() for lab, gt in zip(warm.labels, gts)]) >= 0.9
    # other labels: the earlier model does not fit, and the run starts over
    fits.clear()
    *_, fresh = segment_collection(shapes, (*LABELS[:2], "other"), PARAMS, warm=dataclasses.replace(
        last.model, label_names=("x", "y", "z")))
    assert fits[:4] == [False] * 4 and fresh.model is not None


def test_fold_count_leaves_one_out_of_few_shapes_within_the_budget_of_two_halves():
    from scribbleseg_core.engine.optimize import FOLD_BUDGET, fold_count

    assert [fold_count(n) for n in (0, 1, 2, 3, 4, 5, 6, 7, 10, 11, 20, 40)] == [0, 0, 2, 2, 4, 5, 4, 3, 3, 2, 2, 2]
    for n in range(2, 41):
        k = fold_count(n)
        assert 2 <= k <= n and ((k - 1) * n <= FOLD_BUDGET or k == 2)


def test_each_fold_network_learns_from_the_other_folds_only(collection, monkeypatch):
    """Four scribbled shapes: four folds, each network trained on the three shapes it does not
    hold out, and stage 2 on the probabilities of the network that left the shape out."""
    from scribbleseg_core.engine import optimize
    from scribbleseg_core.engine.network import FaceClassifier

    shapes, _, snaps = collection
    inputs = [PARAMS.network_input(s) for s in shapes]
    labels = list(snaps[-1].labels)
    seen = {}  # network -> ids of the shapes it was trained on
    fit = FaceClassifier.fit

    def recording_fit(self, X, y, **kw):
        seen[id(self)] = [next(i for i, x in enumerate(inputs) if x is xi) for xi in X]
        return fit(self, X, y, **kw)

    monkeypatch.setattr(FaceClassifier, "fit", recording_fit)
    net = optimize._Networks(inputs[0].shape[1], len(LABELS), PARAMS.network, 0.7, [True] * 4)
    net.fit(inputs, labels)
    assert list(net.fold_of) == [0, 1, 2, 3]
    for f, fold_net in enumerate(net.fold_nets):
        assert seen[id(fold_net)] == [i for i in range(4) if i != f]
    assert seen[id(net.main.stage1)] == [0, 1, 2, 3]
    for i, x in enumerate(inputs):
        np.testing.assert_array_equal(net.held_out_log_proba(inputs)[i], net.fold_nets[i].log_proba(x))


def test_the_first_round_learns_only_the_faces_the_strokes_decide(monkeypatch):
    """Three shapes painted on body, head and one limb of four: the initial labels call the
    other limbs body, and the first round's networks skip all but a tenth of them (and of
    every face the walk from the strokes rarely reaches); the second round learns every face,
    and the limbs come out limb."""
    from scribbleseg_core.engine.network import FaceClassifier

    shapes, gts = [], []
    for i, (limb, head) in enumerate([(1.6, 0.9), (1.2, 0.7), (2.0, 1.1)]):
        mesh, gt = creature(limb, head, seed=i)
        scribble = np.full(len(gt), -1)
        for lab in range(len(LABELS)):
            faces = stroke_faces(mesh, gt, lab)
            scribble[faces[:6] if LABELS[lab] == "limb" else faces] = lab
        shapes.append(prepare_shape(mesh, scribble))
        gts.append(gt)
    params = dataclasses.replace(PARAMS, rounds=2)
    inputs = [params.network_input(s) for s in shapes]
    undecided = [FaceEnergy(s.graph, s.scribble, len(LABELS), params.propagation, s.sdf).walk_reached() < params.decided
                 for s in shapes]
    learned = []  # per fit: for each shape it learns, the faces it skips
    fit = FaceClassifier.fit

    def recording_fit(self, X, y, **kw):
        ids = [next(i for i, x in enumerate(inputs) if len(x) == len(xi) and np.array_equal(x, xi[:, : x.shape[1]]))
               for xi in X]  # stage 2's inputs begin with stage 1's
        learned.append({i: np.asarray(yi) < 0 for i, yi in zip(ids, y)})
        return fit(self, X, y, **kw)

    monkeypatch.setattr(FaceClassifier, "fit", recording_fit)
    snaps = list(segment_collection(shapes, LABELS, params))
    limb = LABELS.index("limb")
    first = [fit for fit in learned if any(skip.any() for skip in fit.values())]
    assert first and learned[: len(first)] == first  # the first round's fits skip faces, the later ones none
    assert len(learned) > len(first)
    for fit in first:
        for i, skip in fit.items():
            assert not (skip & ~undecided[i]).any()  # every decided face learned
            assert 0.85 < skip[undecided[i]].mean() < 0.95  # a tenth of the others (UNDECIDED_SHARE)
            # the three limbs left unpainted are mostly skipped, the painted one learned
            assert 0.6 < skip[gts[i] == limb].mean() < 0.75
    for labels, gt in zip(snaps[-1].labels, gts):
        assert (labels[gt == limb] == limb).mean() > 0.95
