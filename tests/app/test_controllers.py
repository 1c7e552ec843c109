"""The app's controllers without Qt or a display: results are applied on the 'main thread'
only when the test drains the dispatcher, so every interleaving below is deterministic."""

from __future__ import annotations

import os
import threading
import time

import numpy as np
import pytest
from scribbleseg_app.controllers.files import FilesController
from scribbleseg_app.controllers.frames import FrameClock
from scribbleseg_app.controllers.jobs import Job, QueueDispatcher
from scribbleseg_app.controllers.preview import PreviewController, PreviewEngine
from scribbleseg_app.controllers.run import RunController
from scribbleseg_app.controllers.view import ViewController
from scribbleseg_app.model import CollectionModel

from scribbleseg_core.engine.energy import EnergyTerms
from scribbleseg_core.engine.optimize import Snapshot
from scribbleseg_core.engine.pipeline import FeaturesDone, Scored, StepDone, Suggested
from tests.conftest import icosphere, write_off


def _folder(tmp_path, name, n=3):
    V, F = icosphere(1)
    folder = tmp_path / name
    folder.mkdir()
    for i in range(n):
        write_off(folder / f"s{i}.off", V, F)
    return folder


@pytest.fixture
def setup(tmp_path):
    model = CollectionModel(tmp_path / "autosave")
    errors = []
    model.error.connect(errors.append)
    model.open(_folder(tmp_path, "a"))
    model.add_label("a")
    model.add_label("b")
    return model, QueueDispatcher(), errors


def until(condition, dispatcher, timeout=20.0):
    """Drain the dispatcher until `condition()` holds (the main thread's event loop)."""
    end = time.perf_counter() + timeout
    while time.perf_counter() < end:
        dispatcher.drain()
        if condition():
            return
        time.sleep(0.005)
    raise AssertionError("timed out")


class FakeRun:
    """Stands in for the pipeline's ``collection_run``: features, then (once `gate` is set) one
    training and one cut labelling every shape with `label`, then the end with a model."""

    def __init__(self, label=1):
        self.gate, self.label, self.closed = threading.Event(), label, threading.Event()
        self.warm = []  # the model each run was asked to continue

    def __call__(self, meshes, scribbles, names, params, warm=None):
        self.warm.append(warm)
        n = len(meshes)
        try:
            yield FeaturesDone(0, 1, n)
            assert self.gate.wait(10)
            labels = tuple(np.full(meshes[i].num_file_faces, self.label) for i in range(n))
            e = EnergyTerms(3.0, 2.0, 1.0)
            yield StepDone(Snapshot(1, "train", e, labels, (False,) * n, 0.1, "model"), (), ())
            yield StepDone(Snapshot(1, "graphcut", e, labels, (True,) * n, 0.1, "model"), tuple(range(n)), labels)
            yield StepDone(Snapshot(1, "done", e, labels, (False,) * n, 0.2, "model"), tuple(range(n)), labels)
            for i in range(n):
                yield Scored(i, np.linspace(0, 1, meshes[i].num_file_faces), 0.5)
            yield Suggested(n - 1, np.array([3, 4, 5]), 4, 0.1)
        finally:
            self.closed.set()


@pytest.fixture
def fake_run(monkeypatch):
    fake = FakeRun()
    monkeypatch.setattr("scribbleseg_app.controllers.engine_runs.collection_run", fake)
    return fake


def test_a_run_streams_its_steps_into_the_model(setup, fake_run):
    model, dispatcher, _ = setup
    model.paint_faces(0, [0, 1, 2], 0)
    model.paint_faces(0, [5, 6], 1)
    runs = RunController(model, dispatcher, job=Job)
    ended = []
    runs.finished.connect(ended.append)
    assert runs.segment() is None and runs.running
    assert runs.segment() == "a run is under way"
    fake_run.gate.set()
    until(lambda: ended, dispatcher)
    assert ended[0].startswith("segmentation finished in")
    assert [e.state for e in model.shapes] == ["labeled", "predicted", "predicted"]
    assert all((e.labels == 1).all() for e in model.shapes) and model.trained_model == "model"
    assert [(s.phase, s.energy.total) for s in runs.history.steps] == [("train", 6.0), ("graphcut", 6.0)]
    assert runs.changed == {0, 1, 2} and runs.history.marks == [(0, "round 1")]
    # the confidence of every shape and where to paint next
    assert all(e.mean_confidence == 0.5 and e.confidence[-1] == 1.0 for e in model.shapes)
    assert model.suggestion.index == 2 and model.suggestion.face == 4
    # the next run continues the network of this one and drops the old suggestion at its start
    ended.clear()
    runs.segment()
    assert model.suggestion is None and fake_run.warm == [None, "model"]
    until(lambda: ended, dispatcher)


def test_a_run_says_which_painted_shapes_carry_one_label_only(setup, fake_run):
    """The engine gives a painted shape only the labels painted on it: the run's end names a
    shape painted with one label, not one painted with two, nor one fully labeled."""
    from scribbleseg_app.controllers.run import _painted_with_one_label

    model, dispatcher, _ = setup
    model.paint_faces(0, [0, 1, 2], 0)
    model.paint_faces(1, [0, 1], 0)
    model.paint_faces(1, [5, 6], 1)
    runs = RunController(model, dispatcher, job=Job)
    ended = []
    runs.finished.connect(ended.append)
    runs.segment()
    fake_run.gate.set()
    until(lambda: ended, dispatcher)
    assert ended[0].startswith("s0: painted a only, so all a; paint its other parts too, or leave it unpainted, "
                               "run, then Accept (A) its prediction and correct that; segmentation finished in")
    full = np.zeros(8, np.int64)
    assert _painted_with_one_label(["x", "y", "z"], [full, None, np.r_[full[:4], -1]], ["a", "b"]) == [("z", "a")]
    assert _painted_with_one_label(["z"], [np.r_[full[:4], -1]], ["a"]) == []  # one label in all: meant so
    ended.clear()
    model.paint_faces(2, [0], 1)
    runs.segment()
    until(lambda: ended, dispatcher)
    assert ended[0].startswith("s0 and 1 more: one label painted each, so all that label")


def test_nothing_to_segment_says_why(setup):
    model, dispatcher, _ = setup
    assert "paint at least one stroke" in RunController(model, dispatcher, job=Job).segment()
    assert "no trained network" in RunController(model, dispatcher, job=Job).predict()


def test_a_run_never_writes_into_a_collection_opened_after_it(setup, fake_run, tmp_path):
    model, dispatcher, _ = setup
    model.paint_faces(0, [0, 1, 2], 0)
    runs = RunController(model, dispatcher, job=Job)
    ended = []
    runs.finished.connect(ended.append)
    runs.segment()
    until(lambda: runs.progress and True, dispatcher)
    model.open(_folder(tmp_path, "b"))  # while the run is under way
    assert not runs.running and "another collection was opened" in ended[0]
    fake_run.gate.set()
    assert fake_run.closed.wait(10)  # the job saw the cancel and closed the generator
    dispatcher.drain()
    assert all(e.labels is None and e.state == "untouched" for e in model.shapes)
    assert model.trained_model is None and len(ended) == 1


def test_quitting_during_a_run_waits_for_its_thread_and_applies_nothing(setup, fake_run):
    model, dispatcher, _ = setup
    model.paint_faces(0, [0, 1, 2], 0)
    runs = RunController(model, dispatcher, job=Job)
    runs.segment()
    job = runs.job
    threading.Timer(0.2, fake_run.gate.set).start()  # the step under way ends a moment later
    assert runs.shutdown(timeout=10)
    assert not job.running and fake_run.closed.is_set()
    dispatcher.drain()
    assert all(e.labels is None for e in model.shapes) and model.trained_model is None


def test_a_result_does_not_hide_the_preview_of_strokes_made_during_the_run(setup, fake_run):
    model, dispatcher, _ = setup
    model.paint_faces(0, [0, 1, 2], 0)
    runs = RunController(model, dispatcher, job=Job)
    runs.segment()
    model.paint_faces(1, [5, 6], 1)  # painted while the run works on the strokes before it
    newer = np.zeros(model.shapes[1].mesh().num_file_faces, np.int64)
    model.set_preview(1, newer)
    fake_run.gate.set()
    until(lambda: not runs.running, dispatcher)
    assert (model.shapes[1].labels == 1).all()  # the run's result is kept ...
    np.testing.assert_array_equal(model.shown_labels(1), newer)  # ... under the newer preview
    assert model.shapes[0].preview is None and (model.shown_labels(0) == 1).all()


def test_the_latest_preview_wins_and_a_late_one_is_dropped(setup, tmp_path):
    model, dispatcher, _ = setup
    started, gate = threading.Event(), threading.Event()

    class Slow(PreviewEngine):
        def compute(self, req):
            started.set()
            assert gate.wait(10)
            return np.full(req.mesh.num_file_faces, req.generation, np.int64)

    previews = PreviewController(model, dispatcher, Slow())
    try:
        model.paint_faces(0, [0, 1], 0)  # request 1: the worker takes it and blocks
        assert started.wait(10)
        model.paint_faces(0, [2, 3], 1)  # request 2 replaces nothing started: it waits
        model.paint_faces(0, [4, 5], 1)  # request 3 replaces request 2
        assert not previews.idle
        gate.set()
        until(lambda: previews.idle, dispatcher)
        assert (model.shapes[0].preview == 3).all()  # request 1's result came back stale
        gate.clear()
        started.clear()
        model.paint_faces(1, [0, 1], 0)
        assert started.wait(10)
        model.open(_folder(tmp_path, "b"))  # the preview under way belongs to the old collection
        gate.set()
        time.sleep(0.1)
        dispatcher.drain()
        assert previews.idle and all(e.preview is None for e in model.shapes)
    finally:
        gate.set()
        previews.close()


def test_preview_caches_stay_bounded_over_many_collections(setup, tmp_path):
    model, dispatcher, _ = setup
    previews = PreviewController(model, dispatcher)
    try:
        for cycle in range(6):
            model.open(_folder(tmp_path, f"c{cycle}", n=2))
            model.add_label("a")
            for i in range(2):
                model.paint_faces(i, [0, 1], 0)
                until(lambda: previews.idle, dispatcher)
            assert previews.engine.cached_meshes() <= 2  # the last collection's only: the old ones were released
    finally:
        previews.close()


class FakeViewport:
    def __init__(self):
        self.shown, self.colored = [], []

    def show(self, V, F, colors):
        self.shown.append((len(F), colors))

    def set_colors(self, colors):
        self.colored.append(colors)


def test_the_view_loads_meshes_off_the_main_thread_and_recolours_in_place(tmp_path):
    folder = _folder(tmp_path, "v", n=2)
    (folder / "bad.off").write_text("OFF\n3 1 0\n0 0 0\n")  # sorts first
    model = CollectionModel(tmp_path / "autosave")
    errors = []
    model.error.connect(errors.append)
    dispatcher, viewport = QueueDispatcher(), FakeViewport()
    view = ViewController(model, dispatcher, viewport)
    model.open(folder)  # shows shape 0, bad.off: its load fails in the background
    assert model.shapes[0].state != "error" and not viewport.shown
    until(lambda: model.shapes[0].state == "error", dispatcher)
    assert "bad.off" in errors[0] and "truncated" in errors[0] and not viewport.shown
    model.set_current(1)
    until(lambda: viewport.shown, dispatcher)
    model.add_label("a")
    before = len(viewport.colored)
    model.paint_faces(1, [0, 1, 2], 0)
    assert len(viewport.colored) > before and len(viewport.shown) == 1  # colours updated, mesh not re-sent
    assert (viewport.colored[-1][[0, 1, 2]] != viewport.colored[-1][3]).any()
    view.set_mode("Feature: SDF")  # computed in the background; the labels show meanwhile
    until(lambda: view.feature_values(1, 1) is not None, dispatcher, timeout=60)
    assert viewport.colored[-1].std(axis=0).max() > 0 and "SDF =" in view.hover_text(4)


def test_a_session_saves_off_the_main_thread_and_later_edits_stay_unsaved(setup, tmp_path):
    from scribbleseg_core.store.session import load_session

    model, dispatcher, _ = setup
    files = FilesController(model, dispatcher)
    saved = []
    files.saved.connect(lambda folder, skipped: saved.append(folder))
    model.paint_faces(0, [0, 1, 2], 1)
    assert files.save(tmp_path / "session")
    model.paint_faces(1, [3], 0)  # after the snapshot was taken
    until(lambda: saved, dispatcher)
    assert model.unsaved and model.session_path == tmp_path / "session"
    session = load_session(tmp_path / "session")
    assert (session.shapes[0].scribble[:3] == 1).all()
    assert session.shapes[1].scribble is None or (session.shapes[1].scribble == -1).all()  # painted after the snapshot
    assert files.save(tmp_path / "session", wait=True) and not model.unsaved
    exported = []
    files.exported.connect(lambda folder, paths: exported.append(paths))
    files.export(tmp_path / "out")
    until(lambda: exported, dispatcher)
    assert sorted(p.name for p in exported[0] if p.suffix == ".ply") == ["s0.ply", "s1.ply"]  # s2 has nothing


def test_the_frame_clock_renders_on_change_and_slowly_when_idle():
    now = [0.0]
    clock = FrameClock(lambda: now[0], active_s=1.0, busy_interval=0.05, idle_interval=0.3)
    assert clock.due()
    clock.rendered()
    now[0] = 0.1
    assert not clock.due()  # idle: next frame at 0.3
    clock.wake()  # a change or input: full rate for a second
    assert clock.due()
    clock.rendered()
    now[0] = 0.12
    assert clock.due()  # still active
    now[0] = 1.15
    assert clock.due()  # idle again, and the last frame was long ago
    clock.rendered()
    assert clock.max_gap == pytest.approx(1.05)
    now[0] = 1.2
    assert not clock.due()
    clock.busy = True  # a run streams results: every 50 ms
    assert clock.due()
    now[0] = 1.25
    clock.reset_gap()  # the run starts 0.05 s after the last idle frame
    now[0] = 1.26
    clock.rendered()
    assert clock.max_gap == pytest.approx(0.01)  # counted from the run's start
    now[0] = 1.4
    clock.rendered()
    assert clock.max_gap == pytest.approx(0.14)


def test_frames_give_way_to_a_preview_being_computed_unless_the_user_acts():
    now, waiting = [0.0], [False]
    clock = FrameClock(lambda: now[0], active_s=1.0, busy_interval=0.05, idle_interval=0.3, waiting=lambda: waiting[0],
                       waiting_interval=0.05)
    clock.rendered()
    clock.wake()  # a stroke was released: a change
    waiting[0] = True  # and its preview is under way
    now[0] = 0.02
    assert not clock.due()  # a frame now would show nothing new
    now[0] = 0.06
    assert clock.due()  # but frames still come every waiting interval
    clock.rendered(acting=True)  # the user moves the mouse in the viewport
    now[0] = 0.07
    assert clock.due()  # full rate while they act
    clock.rendered()
    now[0] = 0.08
    assert not clock.due()
    waiting[0] = False  # the preview arrived
    assert clock.due()  # full rate again: the change (and the input) are recent


def _count(n, fail_at=None):
    """A generator function for a child process: 0 .. n-1, or an error at `fail_at`."""
    for i in range(n):
        if i == fail_at:
            raise ValueError(f"no {i}")
        yield np.full(3, i)


def _sleep(seconds):
    time.sleep(seconds)
    return "woke"


def test_a_process_job_streams_from_a_child_and_ends_it_on_cancel():
    from scribbleseg_app.controllers.jobs import ProcessJob

    dispatcher, got = QueueDispatcher(), []
    ProcessJob(_count, (3,), dispatcher=dispatcher, on_item=got.append, on_finished=lambda: got.append("end")).start()
    until(lambda: got and isinstance(got[-1], str), dispatcher, timeout=60)
    assert [int(a[0]) for a in got[:-1]] == [0, 1, 2]
    errors = []
    ProcessJob(_count, (3, 1), dispatcher=dispatcher, on_item=got.append, on_error=errors.append).start()
    until(lambda: errors, dispatcher, timeout=60)
    assert "ValueError: no 1" in str(errors[0])
    job = ProcessJob(_sleep, (60,), dispatcher=dispatcher, on_done=got.append, on_error=errors.append).start()
    time.sleep(0.5)
    t = time.perf_counter()
    job.cancel()
    assert job.join(10) and time.perf_counter() - t < 5  # the child is ended, not waited for
    dispatcher.drain()
    assert not any(isinstance(g, str) and g == "woke" for g in got) and len(errors) == 1


def test_a_cancelled_job_reports_nothing():
    dispatcher, got = QueueDispatcher(), []
    gate = threading.Event()

    def items():
        yield 1
        gate.wait(10)
        yield 2

    job = Job(items, dispatcher=dispatcher, on_item=got.append, on_finished=lambda: got.append("end")).start()
    until(lambda: got == [1], dispatcher)
    job.cancel()
    gate.set()
    assert job.join(10)
    dispatcher.drain()
    assert got == [1]
    failing = Job(lambda: 1 / 0, dispatcher=dispatcher, on_error=got.append).start()
    failing.join(10)
    dispatcher.drain()
    assert isinstance(got[-1], ZeroDivisionError)


def test_added_meshes_are_read_off_the_main_thread(setup, tmp_path):
    model, dispatcher, errors = setup
    V, F = icosphere(1)
    good, bad = tmp_path / "extra.off", tmp_path / "broken.off"
    write_off(good, V, F)
    bad.write_text("OFF\n3 1 0\n0 0 0\n")
    files = FilesController(model, dispatcher)
    added = []
    model.shapes_added.connect(added.append)
    files.add_meshes([good, bad])
    assert len(model.shapes) == 3  # nothing yet: the files are being read
    until(lambda: added, dispatcher)
    assert added == [[3]] and model.shapes[3].loaded and "broken.off" in errors[-1]


_WARMED_IN = None


def _mark_warm():
    """A warm-up for a spare child: records the process it ran in."""
    global _WARMED_IN
    _WARMED_IN = os.getpid()


def _where():
    """A job: the process it runs in and the one the warm-up ran in."""
    return os.getpid(), _WARMED_IN


def test_a_process_job_runs_in_the_spare_child_warmed_up_before_it():
    from scribbleseg_app.controllers.jobs import ProcessJob, SpareProcess

    dispatcher, got, errors = QueueDispatcher(), [], []
    spare = SpareProcess(f"{__name__}:_mark_warm")
    try:
        spare.refill()
        assert spare.waiting
        first = spare.pid
        spare.refill()  # one waits already: no second
        assert spare.pid == first
        ProcessJob(_where, dispatcher=dispatcher, spare=spare, on_done=got.append, on_error=errors.append).start()
        until(lambda: got or errors, dispatcher, timeout=60)
        assert got == [(first, first)]  # the job ran where the warm-up had run
        until(lambda: spare.waiting, dispatcher, timeout=30)  # the next one is started once the job ended
        second = spare.pid
        assert second != first
        os.kill(second, 9)  # a spare that died is replaced by a new child, not used
        until(lambda: not spare.waiting, dispatcher, timeout=10)
        ProcessJob(_where, dispatcher=dispatcher, spare=spare, on_done=got.append, on_error=errors.append).start()
        until(lambda: len(got) == 2 or errors, dispatcher, timeout=60)
        pid, warmed = got[1]
        assert pid not in (first, second) and warmed == pid and not errors
    finally:
        spare.close()
    assert not spare.waiting
    spare.refill()  # closed: starts nothing
    assert not spare.waiting


def test_a_failed_warm_up_leaves_the_job_to_run():
    from scribbleseg_app.controllers.jobs import ProcessJob, SpareProcess

    dispatcher, got = QueueDispatcher(), []
    spare = SpareProcess("no_such_module_here:warm")
    try:
        ProcessJob(_count, (2,), dispatcher=dispatcher, spare=spare, on_item=got.append,
                   on_finished=lambda: got.append("end")).start()
        until(lambda: got and isinstance(got[-1], str), dispatcher, timeout=60)
        assert [int(a[0]) for a in got[:-1]] == [0, 1]
    finally:
        spare.close()


def test_the_run_controller_prepares_its_next_process_and_ends_it_on_quit(tmp_path):
    dispatcher = QueueDispatcher()
    model = CollectionModel(tmp_path / "autosave")
    runs = RunController(model, dispatcher)
    runs.prepare()
    try:
        assert runs.spare.waiting and runs.spare.warm_up == "scribbleseg_app.controllers.engine_runs:warm_up"
    finally:
        assert runs.shutdown()
    assert not runs.spare.waiting
    assert RunController(model, dispatcher, job=Job).spare is None  # threads: no process to prepare


def test_the_warm_up_of_a_run_process_trains_a_network():
    """The spare child's warm-up must itself work: a failure there is only printed, and the
    run then pays the imports it was meant to hide."""
    import sys

    from scribbleseg_app.controllers.engine_runs import warm_up

    warm_up()
    assert "torch" in sys.modules and "scribbleseg_core.engine.pipeline" in sys.modules
