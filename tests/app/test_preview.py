"""The live-preview worker: latest request wins, failures are reported, labels are right."""

from __future__ import annotations

import threading
import time

import numpy as np
from scribbleseg_app.controllers.preview import PreviewEngine, PreviewRequest, PreviewWorker

from tests.core.planted import LABELS, creature, stroke_faces


def _request(gen, mesh, scribble, index=0):
    return PreviewRequest(gen, index, mesh, scribble, len(LABELS), None, time.perf_counter())


def test_preview_labels_the_planted_parts_and_keeps_scribbles():
    mesh, gt = creature(1.6, 0.9, seed=1)
    scribble = np.full(mesh.num_file_faces, -1)
    for lab in range(len(LABELS)):
        scribble[stroke_faces(mesh, gt, lab)] = lab
    labels = PreviewEngine().compute(_request(1, mesh, scribble))
    assert labels.shape == (mesh.num_file_faces,)
    assert (labels == gt).mean() >= 0.95
    np.testing.assert_array_equal(labels[scribble >= 0], scribble[scribble >= 0])
    assert PreviewEngine().compute(_request(1, mesh, np.full_like(scribble, -1))) is None


def test_stroke_by_stroke_edits_give_what_a_fresh_preview_gives():
    """The engine starts each preview from the mesh's previous one and reuses the distances of
    labels no edit touched (tests/core/test_propagate.py checks those equal fresh ones): after
    strokes added one by one, a stroke erased and re-added, and one relabeled and back, every
    preview keeps the strokes, and the last one is what a fresh engine gives."""
    mesh, gt = creature(1.6, 0.9, seed=2)
    engine, scribble = PreviewEngine(), np.full(mesh.num_file_faces, -1)
    strokes = [stroke_faces(mesh, gt, lab) for lab in range(len(LABELS))]
    edits = [(faces, lab) for lab, faces in enumerate(strokes)]
    edits += [(strokes[1], -1), (strokes[1], 1), (strokes[2], 0), (strokes[2], 2)]  # erase, re-add, relabel, undo
    for gen, (faces, lab) in enumerate(edits, 1):
        scribble[faces] = lab
        labels = engine.compute(_request(gen, mesh, scribble.copy()))
        np.testing.assert_array_equal(labels[scribble >= 0], scribble[scribble >= 0])
    assert (labels == gt).mean() >= 0.95
    fresh = PreviewEngine().compute(_request(1, mesh, scribble.copy()))
    assert (labels == fresh).mean() >= 0.99


def test_latest_request_wins_and_results_arrive_in_order():
    mesh, gt = creature(1.6, 0.9, seed=1)
    got, done = [], threading.Event()

    def deliver(result):
        got.append(result)
        if result.generation == 20:
            done.set()

    started, gate = threading.Event(), threading.Event()

    class SlowFirst(PreviewEngine):  # the first preview is still running during the burst
        def compute(self, req):
            if req.generation == 1:
                started.set()
                gate.wait(10)
            return super().compute(req)

    worker = PreviewWorker(deliver, SlowFirst())
    try:
        for gen in range(1, 21):  # a burst of strokes: requests 2..19 go stale before they start
            scribble = np.full(mesh.num_file_faces, -1)
            scribble[stroke_faces(mesh, gt, gen % len(LABELS))] = gen % len(LABELS)
            worker.request(_request(gen, mesh, scribble))
            if gen == 1:
                assert started.wait(10)  # the worker has taken request 1
        gate.set()
        assert done.wait(30)
    finally:
        worker.close()
    assert [r.generation for r in got] == [1, 20]
    assert all(r.error is None and r.seconds > 0 for r in got)


def test_a_failing_preview_is_reported_not_raised():
    mesh, _ = creature(1.6, 0.9, seed=1)
    got, done = [], threading.Event()
    worker = PreviewWorker(lambda r: (got.append(r), done.set()))
    try:
        bad = np.full(mesh.num_file_faces, -1)
        bad[0] = 99  # a label beyond the label count
        worker.request(_request(1, mesh, bad))
        assert done.wait(10)
    finally:
        worker.close()
    assert got[0].file_labels is None and "preview failed" in got[0].error and mesh.name in got[0].error


def test_the_sdf_for_the_contrast_term_comes_only_from_the_cache(tmp_path, monkeypatch):
    from scribbleseg_core.signatures.features import cached_face_features

    monkeypatch.setenv("SCRIBBLESEG_CACHE_DIR", str(tmp_path))
    mesh, _ = creature(1.6, 0.9, seed=2)
    engine = PreviewEngine()
    assert engine.sdf(mesh) is None  # never computed: the preview does not wait for it
    assert not list(tmp_path.rglob("*.npz"))
    X = cached_face_features(mesh.V, mesh.F)  # what a run (or "show feature") leaves behind
    np.testing.assert_array_equal(engine.sdf(mesh), X[:, 1])
    import scribbleseg_core.signatures.features as features_module

    def no_lookup(*args, **kwargs):
        raise AssertionError("the SDF is read from the disk cache at every stroke")

    monkeypatch.setattr(features_module, "cached_face_features", no_lookup)
    np.testing.assert_array_equal(engine.sdf(mesh), X[:, 1])  # kept once found


def test_the_network_runs_once_per_mesh_and_model(monkeypatch):
    """After a run the preview adds the network's log-probabilities; they do not depend on the
    strokes, so the next strokes reuse them until another model comes."""
    from types import SimpleNamespace

    import scribbleseg_core.signatures.features as features_module
    from scribbleseg_core.engine.propagate import PropagateParams

    mesh, gt = creature(1.6, 0.9, seed=1)
    monkeypatch.setattr(features_module, "cached_face_features", lambda V, F, **kw: np.zeros((len(F), 22)))

    class Model:
        params = SimpleNamespace(propagation=PropagateParams(contrast=0.0))

        def __init__(self):
            self.calls = 0

        def log_proba(self, shape):
            self.calls += 1
            return np.log(np.full((len(shape.mesh.F), len(LABELS)), 1.0 / len(LABELS)))

    engine, first, second = PreviewEngine(), Model(), Model()
    scribble = np.full(mesh.num_file_faces, -1)
    for gen, lab in enumerate(range(len(LABELS)), 1):
        scribble[stroke_faces(mesh, gt, lab)] = lab
        labels = engine.compute(PreviewRequest(gen, 0, mesh, scribble.copy(), len(LABELS), first, time.perf_counter()))
    assert first.calls == 1
    assert (labels == gt).mean() >= 0.95
    engine.compute(PreviewRequest(9, 0, mesh, scribble.copy(), len(LABELS), second, time.perf_counter()))
    assert second.calls == 1  # a new model: its own probabilities


def test_a_model_that_contradicts_the_strokes_gives_way_to_them(monkeypatch):
    """A model sure that every face is body (as a model can be on a shape unlike those it was
    trained on): the strokes of head and limbs still label their parts in the preview."""
    from types import SimpleNamespace

    import scribbleseg_core.signatures.features as features_module
    from scribbleseg_core.engine.propagate import PropagateParams

    mesh, gt = creature(0.6, 0.3, seed=1)  # low lobes, short strokes: the strokes alone barely hold them
    monkeypatch.setattr(features_module, "cached_face_features", lambda V, F, **kw: np.zeros((len(F), 22)))
    sure = np.full(len(LABELS), 1e-12)
    sure[0] = 1 - 1e-12 * (len(LABELS) - 1)

    class Model:
        params = SimpleNamespace(propagation=PropagateParams(contrast=0.0))

        def log_proba(self, shape):
            return np.log(np.tile(sure, (len(shape.mesh.F), 1)))

    scribble = np.full(mesh.num_file_faces, -1)
    for lab in range(len(LABELS)):
        scribble[stroke_faces(mesh, gt, lab, n=3)] = lab
    labels = PreviewEngine().compute(PreviewRequest(1, 0, mesh, scribble, len(LABELS), Model(), time.perf_counter()))
    assert (labels == gt).mean() >= 0.95  # 0.76 with the network term at full weight: head and limbs lost
