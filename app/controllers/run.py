"""Segmentation and prediction runs: one at a time, each bound to the collection it began on.

:class:`RunController` starts a job on the core's pipeline
(:mod:`~scribbleseg_app.controllers.engine_runs`), applies what it streams to the model on the
main thread, and keeps the energy of every step (:class:`EnergyHistory`) for the plot. A run's
results never reach another collection: opening one cancels the run, and the job's late
messages are dropped. A shape the user painted on after the run began keeps the preview of
those newer strokes over the run's result.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from scribbleseg_app.controllers.jobs import Dispatcher, Job, ProcessJob, SpareProcess
from scribbleseg_app.events import Event

from scribbleseg_core.engine.energy import EnergyTerms


@dataclass(frozen=True)
class EnergyStep:
    """One optimization step: round `iteration`, `phase` ("train" or "graphcut"), and the
    energy of its labels split into its terms (``network`` NaN before training)."""

    iteration: int
    phase: str
    energy: EnergyTerms


@dataclass
class EnergyHistory:
    """The energy steps of the latest run and the moments worth marking on the plot.

    Attributes
    ----------
    steps : list of EnergyStep
    marks : list of (int, str)
        ``(number of steps before it, text)``: where each round and a prediction began. Steps
        start at the first training (the painted shapes' energy, network term included).
    """

    steps: list[EnergyStep] = field(default_factory=list)
    marks: list[tuple[int, str]] = field(default_factory=list)

    def mark(self, text: str) -> None:
        """Mark the next step; a mark not yet followed by a step is replaced."""
        if self.marks and self.marks[-1][0] == len(self.steps):
            self.marks.pop()
        self.marks.append((len(self.steps), text))


#: What a run's child process does while it waits for its run.
WARM_UP = "scribbleseg_app.controllers.engine_runs:warm_up"


class RunController:
    """Runs the engine on the open collection in the background.

    Events
    ------
    started(kind)
        ``"segmentation"`` or ``"prediction"`` began.
    progress(done, total)
        Shapes prepared (signatures) or predicted so far.
    step(snapshot)
        An optimization step was applied to the model (:attr:`history` has its energy).
    finished(message)
        The run ended (also when stopped or cancelled); `message` says how.

    Parameters
    ----------
    model : CollectionModel
    dispatcher : Dispatcher
    params : SegmentParams, optional
        The engine's parameters (default ones when None).
    job : type
        How a run executes: :class:`ProcessJob` (default; in a child process, so the viewport
        never waits for the run's interpreter lock) or :class:`Job` (a thread of this process).
        With processes, the next run's child is started ahead (:meth:`prepare`, and after
        every run) and imports the engine and torch while the user paints
        (:func:`~scribbleseg_app.controllers.engine_runs.warm_up`).

    Attributes
    ----------
    spare : SpareProcess or None
        The next run's child process (None with threads).
    """

    def __init__(self, model, dispatcher: Dispatcher, params=None, job: type[Job] = ProcessJob) -> None:
        self.model = model
        self.dispatcher = dispatcher
        self.params = params
        self._job_type = job
        self.spare = SpareProcess(WARM_UP) if issubclass(job, ProcessJob) else None
        self.job: Job | None = None
        self.kind: str | None = None
        self.history = EnergyHistory()
        self.changed: set[int] = set()  # shapes whose labels the last round changed
        self.seconds = 0.0
        self.started, self.progress, self.step, self.finished = Event(), Event(), Event(), Event()
        self._indices: list[int] = []
        self._edits: dict[int, int] = {}
        self._one_label: list[tuple[str, str]] = []  # (shape, label) painted with that label only
        self._started_at = 0.0
        self._applied: set[int] = set()
        model.collection_changed.connect(self._on_collection_changed)

    @property
    def running(self) -> bool:
        return self.job is not None

    @property
    def size(self) -> int:
        """Shapes in the run under way (or the last one)."""
        return len(self._indices)

    def segment(self) -> str | None:
        """Segment the collection (shapes without scribbles take part), continuing the training
        of the last run's network when there is one. Returns why it cannot start, or None when
        it started."""
        from scribbleseg_app.controllers.engine_runs import MeshFiles, collection_run

        from scribbleseg_core.engine.optimize import SegmentParams

        if self.running:
            return "a run is under way"
        m = self.model
        usable = [i for i, e in enumerate(m.shapes) if e.state != "error"]
        scribbles = [m.scribble_labels(i) for i in usable]
        if not any(s is not None and (s >= 0).any() for s in scribbles):
            return "paint at least one stroke before segmenting"
        self.history = EnergyHistory()
        self.changed = set()
        self._one_label = _painted_with_one_label([m.shapes[i].name for i in usable], scribbles, m.label_set.names)
        meshes = MeshFiles([m.shapes[i].path for i in usable])  # read by the run itself
        m.set_suggestion(None)
        self._start("segmentation", collection_run,
                    (meshes, scribbles, m.label_set.names, self.params or SegmentParams(), m.trained_model), usable)
        return None

    def predict(self) -> str | None:
        """Segment the shapes with neither scribbles nor a result (e.g. meshes added after the
        run) with the trained model. Returns why it cannot start, or None when it started
        (also when there is nothing to predict: then it says so through `finished`)."""
        from scribbleseg_app.controllers.engine_runs import MeshFiles, predict_run

        if self.running:
            return "a run is under way"
        m = self.model
        if m.trained_model is None:
            return "no trained network yet: paint some shapes and run 'Segment collection' first"
        if len(m.trained_model.label_names) != len(m.label_set):
            return "the labels changed since the network was trained: run 'Segment collection' again"
        targets = [i for i, e in enumerate(m.shapes) if e.state == "untouched" and not m.has_scribbles(i)]
        if not targets:
            self.finished.emit("every shape already has scribbles or a result")
            return None
        self.history.mark("prediction")
        meshes = MeshFiles([m.shapes[i].path for i in targets])
        self._start("prediction", predict_run, (m.trained_model, meshes), targets)
        return None

    def prepare(self) -> None:
        """Start the next run's child process now (with processes), so that the run does not
        wait for Python to start and import the engine (about 2 s warm, 6 s with torch's
        files read from disk). The child waits at low priority, holding 340–420 MB."""
        if self.spare is not None:
            from scribbleseg_app.controllers.engine_runs import limit_threads

            limit_threads(1)  # the child's BLAS and torch threads, fixed when it starts
            self.spare.refill()

    def stop(self) -> None:
        """Stop the run now (a :class:`ProcessJob` ends its process; a :class:`Job` stops
        after the step under way); the labels so far stay."""
        if self.job is not None:
            self.job.cancel()
            self._end("stopped")

    def shutdown(self, timeout: float = 10.0) -> bool:
        """Cancel any run and wait for it to end, and end the waiting child process
        (quitting); True when the run ended in time."""
        if self.spare is not None:
            self.spare.close()
        job = self.job
        if job is None:
            return True
        job.cancel()
        self._end("stopped: the app is closing")
        return job.join(timeout)

    def _start(self, kind: str, fn, args: tuple, indices: list[int]) -> None:
        from scribbleseg_app.controllers.engine_runs import limit_threads

        limit_threads(1)
        m = self.model
        self.kind, self._indices, self._applied = kind, indices, set()
        self._edits = {i: m.shapes[i].edits for i in indices}
        self._started_at = time.perf_counter()
        spare = {"spare": self.spare} if self.spare is not None else {}
        self.job = self._job_type(fn, args, dispatcher=self.dispatcher, on_item=self._on_message,
                                  on_error=lambda e: self._end(f"{kind} failed: {e}", error=True),
                                  on_finished=lambda: self._end("finished"), name=f"scribbleseg-{kind}", **spare)
        self.started.emit(kind)
        self.job.start()

    def _end(self, how: str, error: bool = False) -> None:
        if self.job is None:
            return
        self.job = None
        self.seconds = time.perf_counter() - self._started_at
        if how == "finished":
            how = f"{self.kind} finished in {self.seconds:.1f} s"
            if self.kind == "segmentation" and self._one_label:  # first: the status bar may cut the end
                how = f"{_one_label_notice(self._one_label)}; {how}"
        self.finished.emit(("error: " if error else "") + how)

    def _on_collection_changed(self) -> None:
        if self.job is not None:  # its shapes and labels are the previous collection's
            self.job.cancel()
            self._end("the run was stopped: another collection was opened")

    def _on_message(self, msg) -> None:
        from scribbleseg_app.controllers.engine_runs import FeaturesDone, Predicted, Scored, StepDone, Suggested
        from scribbleseg_app.model import Suggestion

        m = self.model  # a run of another collection was cancelled: its messages never get here
        if isinstance(msg, FeaturesDone):
            self.progress.emit(msg.done, msg.total)
        elif isinstance(msg, StepDone):
            snap = msg.snapshot
            if snap.phase == "graphcut":
                self.changed = {self._indices[j] for j in msg.indices if snap.changed[j]}
            for j, labels in zip(msg.indices, msg.file_labels):
                if j in self._applied and not snap.changed[j]:
                    continue  # the same labels as the step before
                self._applied.add(j)
                index = self._indices[j]
                m.set_result(index, labels, "labeled" if m.has_scribbles(index) else "predicted", self._edits[index])
            # from the first training on (the initial labels have no network term)
            if snap.iteration >= 1 and snap.phase in ("train", "graphcut"):
                if snap.phase == "train":
                    self.history.mark(f"round {snap.iteration}")
                self.history.steps.append(EnergyStep(snap.iteration, snap.phase, snap.energy))
            if snap.done:
                m.set_trained_model(snap.model)
            self.step.emit(snap)
        elif isinstance(msg, Predicted):
            index = self._indices[msg.index]
            m.set_result(index, msg.file_labels, "predicted", self._edits[index])
        elif isinstance(msg, Scored):
            index = self._indices[msg.index]
            if m.shapes[index].edits == self._edits[index]:  # else it scores labels the user no longer sees
                m.set_confidence(index, msg.file_confidence, msg.mean)
        elif isinstance(msg, Suggested):
            m.set_suggestion(Suggestion(self._indices[msg.index], msg.file_faces, msg.file_face))


def _painted_with_one_label(names, scribbles, label_names) -> list[tuple[str, str]]:
    """``(shape name, label name)`` of every shape whose strokes (per file face, -1 unpainted;
    None: no strokes) carry one label only while some faces are unpainted: the engine gives a
    painted shape only the labels painted on it, so all of it takes that one. A shape whose
    every face carries the one label is meant so and not listed; nor is any shape when the
    collection has a single label."""
    if len(label_names) < 2:
        return []
    found = []
    for name, s in zip(names, scribbles):
        if s is None:
            continue
        painted = np.unique(s[s >= 0])
        if len(painted) == 1 and (s < 0).any():
            found.append((name, label_names[int(painted[0])]))
    return found


def _one_label_notice(shapes: list[tuple[str, str]]) -> str:
    """What a run's end says of the shapes :func:`_painted_with_one_label` found."""
    name, label = shapes[0]
    if len(shapes) == 1:
        return (f"{name}: painted {label} only, so all {label}; paint its other parts too, or leave it unpainted, "
                "run, then Accept (A) its prediction and correct that")
    return (f"{name} and {len(shapes) - 1} more: one label painted each, so all that label; paint their other "
            "parts too, or leave them unpainted, run, then Accept (A) their predictions and correct those")
