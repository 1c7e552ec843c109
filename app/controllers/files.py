"""Sessions and exports, written off the main thread.

:class:`FilesController` takes what is to be written from the model on the main thread (cheap
copies), writes it on a job thread (meshes load there), and reports on the main thread. Each
kind of write runs one at a time.
"""

from __future__ import annotations

import os
from pathlib import Path

from scribbleseg_app.controllers.jobs import Dispatcher, Job
from scribbleseg_app.events import Event
from scribbleseg_app.model import load_meshes, write_session


def export_shapes(folder, items, label_set) -> tuple[list[Path], list[str]]:
    """Write every ``(entry, labels (m0,), confidence (m0,) or None)`` of `items` as PLY, SEG,
    OBJ, GLB, JSON and VTP into `folder` (the confidence, when known, into the PLY, the JSON and
    the VTP). Returns the files written and one message per shape that failed."""
    from scribbleseg_core.errors import ScribblesegError
    from scribbleseg_core.formats.export import export_labeled_mesh

    written, problems = [], []
    for entry, labels, confidence in items:
        try:
            mesh = entry.mesh()
            written += export_labeled_mesh(folder, entry.name, mesh.V_file, mesh.F_file, labels, label_set,
                                           confidence=confidence)
        except (OSError, ScribblesegError) as e:
            problems.append(f"{entry.name}: export failed: {e}")
    return written, problems


class FilesController:
    """Saves sessions and exports labeled meshes.

    Events
    ------
    saved(folder, skipped)
        A session was written to `folder`; `skipped` names the shapes left out (their mesh
        did not load).
    exported(folder, files)
        The export into `folder` wrote `files` (paths).
    failed(message)
        A save or an export failed (for an export: one message per shape that failed); the
        message names the folder or the shape.

    Parameters
    ----------
    model : CollectionModel
    dispatcher : Dispatcher
    """

    def __init__(self, model, dispatcher: Dispatcher) -> None:
        self.model = model
        self.dispatcher = dispatcher
        self.saved, self.exported, self.failed = Event(), Event(), Event()
        self.saving: Job | None = None
        self.exporting: Job | None = None

    @property
    def busy(self) -> bool:
        return self.saving is not None or self.exporting is not None

    def save(self, folder: str | os.PathLike, *, wait: bool = False) -> bool:
        """Save a session of the model as it is now into `folder`, in the background (or here
        with `wait`, e.g. when quitting). Returns False when it could not start or, with
        `wait`, when it failed."""
        from scribbleseg_core.errors import ScribblesegError

        if self.saving is not None:
            self.failed.emit(f"{folder}: a session is being saved already")
            return False
        folder = Path(folder)
        snapshot = self.model.session_snapshot()

        def done(skipped):
            self.saving = None
            self.model.mark_saved(folder, snapshot.version)
            self.saved.emit(folder, skipped)

        def failed(e):
            self.saving = None
            self.failed.emit(f"{folder}: saving the session failed: {e}")

        if wait:
            try:
                skipped = write_session(folder, snapshot)
            except (OSError, ScribblesegError) as e:
                failed(e)
                return False
            done(skipped)
            return True
        self.saving = Job(write_session, (folder, snapshot), dispatcher=self.dispatcher, on_done=done,
                          on_error=failed, name="scribbleseg-save").start()
        return True

    def export(self, folder: str | os.PathLike, only: list[int] | None = None, *, wait: bool = False) -> list[Path] | None:
        """Export every shape (or those in `only`) that has a result or scribbles, as the user
        sees it, into `folder`, with the last run's confidence where it scores the labels shown;
        in the background, or here with `wait` (then the files written are returned)."""
        items = []
        m = self.model
        for i, entry in enumerate(m.shapes):
            if entry.state == "error" or (only is not None and i not in only):
                continue
            labels = m.shown_labels(i)
            labels = labels.copy() if labels is not None else m.scribble_labels(i)  # a copy; no mesh loads here
            if labels is not None and (labels >= 0).any():  # neither a result nor scribbles otherwise
                # the confidence scores the run's result: not a newer preview, not scribbles alone
                scored = entry.confidence is not None and entry.preview is None and entry.labels is not None
                items.append((entry, labels, entry.confidence.copy() if scored else None))
        folder = Path(folder)

        def done(result):
            self.exporting = None
            files, problems = result
            for p in problems:
                self.failed.emit(p)
            self.exported.emit(folder, files)

        def failed(e):
            self.exporting = None
            self.failed.emit(f"{folder}: export failed: {e}")

        if wait:
            result = export_shapes(folder, items, m.label_set)
            done(result)
            return result[0]
        if self.exporting is not None:
            self.failed.emit(f"{folder}: an export is under way already")
            return None
        self.exporting = Job(export_shapes, (folder, items, m.label_set), dispatcher=self.dispatcher, on_done=done,
                             on_error=failed, name="scribbleseg-export").start()
        return None

    def add_meshes(self, paths) -> None:
        """Read mesh files on a job thread, then add those that loaded to the collection (the
        others are reported by the model)."""
        paths = [Path(p) for p in paths]
        generation = self.model.generation

        def done(loaded):
            if generation == self.model.generation:  # not into a collection opened meanwhile
                self.model.add_meshes(paths, loaded)

        Job(load_meshes, (paths,), dispatcher=self.dispatcher, on_done=done,
            on_error=lambda e: self.failed.emit(f"adding meshes failed: {e}"), name="scribbleseg-add").start()

    def shutdown(self, timeout: float = 30.0) -> bool:
        """Wait for a save or an export under way (quitting must not cut a file short)."""
        return all(job.join(timeout) for job in (self.saving, self.exporting) if job is not None)
