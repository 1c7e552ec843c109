"""The app's state: a collection of shapes, their scribbles and labels. No widgets here."""

from __future__ import annotations

import os
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
from scribbleseg_app.events import Event
from scribbleseg_app.painting import Brush, ScribbleLayer

from scribbleseg_core.errors import ScribblesegError
from scribbleseg_core.formats.collection import find_collection
from scribbleseg_core.formats.labels import LabelSet
from scribbleseg_core.formats.mesh import Mesh, load_mesh

ShapeState = Literal["untouched", "scribbled", "labeled", "predicted", "error"]


@dataclass(frozen=True, eq=False)
class Suggestion:
    """The unsure region that weighs most on its shape after a run (`engine.guidance.suggest`):
    shape `index`, the region's file faces (k,), and the file face at its heart."""

    index: int
    faces: np.ndarray
    face: int


@dataclass
class ShapeEntry:
    """One shape of the collection; the mesh loads on first use."""

    path: Path
    file_scribble: np.ndarray | None = None  # (m0,) scribbles as opened; edits live in the model's layer
    labels: np.ndarray | None = None  # (m0,) result per file face
    preview: np.ndarray | None = None  # (m0,) live preview after the latest edit, if newer than `labels`
    state: ShapeState = "untouched"
    error: str | None = None
    edits: int = 0  # strokes, undos and restores so far: a run's result is stale for a shape edited since it began
    confidence: np.ndarray | None = None  # (m0,) in [0, 1]: how sure the last run is of each face's label
    mean_confidence: float | None = None  # its area-weighted mean
    _mesh: Mesh | None = None
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False, compare=False)

    @property
    def name(self) -> str:
        return self.path.stem

    @property
    def loaded(self) -> bool:
        return self._mesh is not None

    def mesh(self) -> Mesh:
        """The mesh, loaded on first use (from any thread: loads are serialized per shape)."""
        if self._mesh is None:
            with self._lock:
                if self._mesh is None:
                    self._mesh = load_mesh(self.path)
        return self._mesh


class CollectionModel:
    """Shapes, label set and the current shape, with events for views to follow.

    Events
    ------
    collection_changed()
        A new collection was opened (:attr:`generation` counts them).
    current_changed(index)
        Another shape is shown.
    error(message)
        Something the user asked for failed; the message names the file and the problem.
    scribbles_changed(index, faces)
        Scribbles of shape `index` changed on `faces` (file face ids).
    current_label_changed(label)
        The label the brush paints (-1: eraser).
    labels_changed()
        Label names or colors changed.
    state_changed(index)
        Shape `index` changed state (untouched, scribbled, ...).
    result_changed(index)
        The labels shown for shape `index` changed (a run's result or a live preview).
    edit_committed(index)
        A stroke ended, or an undo/redo happened, on shape `index` (time for a preview).
    shapes_added(indices)
        Meshes were appended to the collection.
    restore_available(count)
        After opening: autosaved scribbles of `count` shapes differ from the opened ones
        (the app crashed or closed before a save); see :meth:`restore_autosave`.
    unsaved_changed(unsaved)
        The collection now has (True) or no longer has (False) changes not saved to a
        session: scribbles, labels, results, added meshes.
    confidence_changed(index)
        Shape `index` has a new per-face confidence (after a run), or lost it.
    suggestion_changed()
        :attr:`suggestion` (where to paint next) changed.
    """

    def __init__(self, autosave_dir: str | os.PathLike | None = None) -> None:
        self.shapes: list[ShapeEntry] = []
        self.label_set = LabelSet.from_names([])
        self.folder: Path | None = None
        self.current = -1
        self.current_label = 0
        self.brush_radius = 0.02  # fraction of the bounding-box diagonal
        self.autosave_dir = Path(autosave_dir) if autosave_dir else None
        self._layers: dict[int, ScribbleLayer] = {}
        self._brushes: dict[int, Brush] = {}
        self._last_point = None
        self.trained_model = None
        self.session_path: Path | None = None
        self.generation = 0  # bumped by every collection opened: work begun for another one is stale
        self.version = 0  # bumped by every unsaved change: a save that began before it leaves the work unsaved
        self.collection_changed = Event()
        self.restore_available = Event()
        self.shapes_added = Event()
        self.current_changed = Event()
        self.error = Event()
        self.scribbles_changed = Event()
        self.current_label_changed = Event()
        self.labels_changed = Event()
        self.state_changed = Event()
        self.result_changed = Event()
        self.edit_committed = Event()
        self.unsaved_changed = Event()
        self.confidence_changed = Event()
        self.suggestion_changed = Event()
        self.suggestion: Suggestion | None = None
        self._unsaved = False
        self._brush_lock = threading.Lock()

    @property
    def unsaved(self) -> bool:
        """Changes since the collection was opened or last saved as a session (scribbles
        are autosaved regardless; results, labels and added meshes are not)."""
        return self._unsaved

    def _set_unsaved(self, value: bool) -> None:
        if value:
            self.version += 1
        if value != self._unsaved:
            self._unsaved = value
            self.unsaved_changed.emit(value)

    def open(self, path: str | os.PathLike) -> None:
        """Open a saved session, a folder of meshes (with scribble files beside them or in
        ``scribbles/``), or one mesh. On failure the open collection stays as it was."""
        from scribbleseg_core.store.session import is_session

        path = Path(path)
        if is_session(path):
            self.open_session(path)
            return
        try:
            if path.is_dir():
                coll = find_collection(path)
                shapes = [ShapeEntry(p, coll.face_labels(p)) for p in coll.meshes]
                names = coll.label_names or self._label_names_beside(path)
            else:
                mesh = load_mesh(path)  # fail now, with the file named, rather than on display
                shapes, names = [ShapeEntry(path.resolve(), _mesh=mesh)], ()
        except ScribblesegError as e:
            self.error.emit(str(e))
            return
        for s in shapes:
            if s.file_scribble is not None:
                s.state = "scribbled"
        self._install(path if path.is_dir() else path.parent, shapes, LabelSet.from_names(names), None, 0, None)

    def _install(self, folder: Path, shapes, label_set: LabelSet, model, current: int, session_path: Path | None) -> None:
        self.folder = folder
        self.session_path = session_path
        self.shapes = shapes
        self._layers.clear()
        self._brushes.clear()
        self.suggestion = None
        self.label_set = label_set
        self.trained_model = model
        self.current = -1
        self.generation += 1
        self._set_unsaved(False)
        self.collection_changed.emit()
        if shapes:
            self.set_current(current)
        pending = self.autosaved_changes()
        if pending:
            self.restore_available.emit(len(pending))

    def add_meshes(self, paths, loaded: dict | None = None) -> list[int]:
        """Add mesh files to the open collection (e.g. new shapes to predict); a file that
        fails to load is reported and not added. Returns the new shape indices.

        `loaded` maps a path to its :class:`Mesh` or to the :class:`ScribblesegError` its
        load raised (read elsewhere, e.g. by :func:`load_meshes` on a job thread); paths not
        in it are read here."""
        added = []
        known = {e.path.resolve() for e in self.shapes}
        loaded = loaded or {}
        for p in map(Path, paths):
            if p.resolve() in known:
                continue
            mesh = loaded.get(p)
            try:
                if mesh is None:
                    mesh = load_mesh(p)
                elif isinstance(mesh, ScribblesegError):
                    raise mesh
            except ScribblesegError as e:
                self.error.emit(str(e))
                continue
            self.shapes.append(ShapeEntry(p.resolve(), _mesh=mesh))
            known.add(p.resolve())
            added.append(len(self.shapes) - 1)
        if added:
            if self.folder is None:
                self.folder = Path(paths[0]).resolve().parent
            self._set_unsaved(True)
            self.shapes_added.emit(added)
        return added

    def set_result(self, index: int, labels: np.ndarray, state: ShapeState, edits: int | None = None) -> None:
        """Store a run's or a prediction's labels (m0,) for shape `index`. `edits`: the
        shape's :attr:`ShapeEntry.edits` when the run began; if it was edited since, a preview
        of the newer strokes stays shown over the result."""
        entry = self.shapes[index]
        entry.labels = np.asarray(labels, dtype=np.int64)
        if edits is None or edits == entry.edits:
            entry.preview = None  # the result is newer
        if entry.state != state:
            entry.state = state
        self._set_unsaved(True)
        self.state_changed.emit(index)
        self.result_changed.emit(index)

    def set_confidence(self, index: int, confidence: np.ndarray | None, mean: float | None = None) -> None:
        """Per-face confidence (m0,) in [0, 1] of shape `index`'s result, and its mean (None: unknown)."""
        entry = self.shapes[index]
        entry.confidence = None if confidence is None else np.asarray(confidence, dtype=np.float64)
        entry.mean_confidence = mean
        self.confidence_changed.emit(index)

    def set_suggestion(self, suggestion: Suggestion | None) -> None:
        """Where to paint next (None: no suggestion)."""
        self.suggestion = suggestion
        self.suggestion_changed.emit()

    def accept(self, index: int) -> int:
        """Accept shape `index`'s result as its labels: every face without scribbles takes the
        label shown, as scribbles, in one undo step (correct it with the brush or the fill
        after; the next run trains on it as a fully labeled shape). Returns the faces painted;
        0 when there is no result to accept."""
        labels = self.shown_labels(index)
        if labels is None or self.shapes[index].state == "error":
            return 0
        layer = self.layer(index)
        faces = np.flatnonzero((layer.labels < 0) & (labels >= 0))
        changed = self.paint_faces(index, faces, labels[faces]) if faces.size else faces
        entry = self.shapes[index]
        if len(changed) and entry.state != "scribbled":  # its labels are the user's now: it trains as painted
            entry.state = "scribbled"
            self.state_changed.emit(index)
        return int(len(changed))

    def set_preview(self, index: int, labels: np.ndarray | None) -> None:
        """The live preview (m0,) of shape `index` after its latest edit (None: nothing to preview)."""
        self.shapes[index].preview = None if labels is None else np.asarray(labels, dtype=np.int64)
        self.result_changed.emit(index)

    # ------------------------------------------------------------------ sessions

    def open_session(self, path: str | os.PathLike) -> None:
        """Open a session folder written by :meth:`save_session`."""
        from scribbleseg_core.store.session import load_session

        try:
            session = load_session(path)
        except ScribblesegError as e:
            self.error.emit(str(e))
            return
        shapes = []
        for sh in session.shapes:
            entry = ShapeEntry(sh.mesh, file_scribble=sh.scribble, labels=sh.labels, state=sh.state)
            shapes.append(entry)
        folder = Path(path) if Path(path).is_dir() else Path(path).parent
        self._install(folder, shapes, session.label_set, session.model, session.current, folder)
        for problem in session.problems:
            self.error.emit(problem)

    def save_session(self, folder: str | os.PathLike) -> list[str]:
        """Write the collection, labels, scribbles, results and model into `folder` (here, on
        this thread: :meth:`session_snapshot`, :func:`write_session` and :meth:`mark_saved`).

        Returns
        -------
        list of str
            Shapes left out (their mesh did not load, so their face count is unknown).
        """
        snapshot = self.session_snapshot()
        skipped = write_session(folder, snapshot)
        self.mark_saved(folder, snapshot.version)
        return skipped

    def session_snapshot(self) -> SessionSnapshot:
        """Copies of what a session holds, taken on the main thread; the meshes load and the
        files are written elsewhere (:func:`write_session`)."""
        shapes = []
        for i, entry in enumerate(self.shapes):
            scribble = self.scribble_labels(i)  # a copy; no mesh loads here
            labels = self.shown_labels(i)
            shapes.append((entry, scribble, None if labels is None else labels.copy()))
        current = max(0, self.current - sum(1 for e in self.shapes[: max(self.current, 0)] if e.state == "error"))
        return SessionSnapshot(shapes, self.label_set, current, self.trained_model, self.version)

    def mark_saved(self, folder: str | os.PathLike, version: int) -> None:
        """A session of the model as it was at `version` was written to `folder`; the work
        is saved unless it changed since."""
        self.session_path = Path(folder)
        if version == self.version:
            self._set_unsaved(False)

    # ------------------------------------------------------------------ autosave

    def autosave_folder(self) -> Path | None:
        """Where this collection's scribbles are autosaved: one folder per collection."""
        if self.autosave_dir is None or self.folder is None:
            return None
        import hashlib

        key = hashlib.sha256(str(self.folder.resolve()).encode()).hexdigest()[:16]
        return self.autosave_dir / key

    def autosaved_changes(self) -> dict[int, tuple[np.ndarray, tuple[str, ...]]]:
        """Autosaved scribbles that differ from what is open:
        {shape index: ((m0,) labels, the label names they index)}.

        No mesh is read here (it runs as a collection opens): the scribbles are compared with
        those opened, and an autosave of a shape opened without scribbles is checked against its
        mesh's face count in :meth:`restore_autosave`. Unreadable autosave files are reported
        through `error` and skipped.
        """
        from scribbleseg_core.formats.scribbles import read_scribbles

        folder = self.autosave_folder()
        if folder is None or not folder.is_dir():
            return {}
        by_name = {e.name: i for i, e in enumerate(self.shapes)}
        out = {}
        for f in sorted(folder.glob("*.json")):
            i = by_name.get(f.stem)
            if i is None or self.shapes[i].state == "error":
                continue
            entry = self.shapes[i]
            now = self._layers[i].labels if i in self._layers else entry.file_scribble
            try:
                scr = read_scribbles(f, num_faces=None if now is None else len(now))
            except ScribblesegError as e:
                self.error.emit(f"autosave not restorable: {e}")
                continue
            labels = scr.face_labels()
            if (labels >= 0).any() if now is None else not np.array_equal(labels, now):
                out[i] = (labels, scr.label_names)
        return out

    def restore_autosave(self) -> list[int]:
        """Take the autosaved scribbles that differ from the open ones; returns the shapes."""
        changes = self.autosaved_changes()
        for i, (labels, names) in list(changes.items()):
            m0 = self.shapes[i].mesh().num_file_faces
            if len(labels) != m0:
                self.error.emit(f"autosave not restorable: {self.autosave_folder() / (self.shapes[i].name + '.json')}: "
                                f"it has {len(labels)} faces, the mesh {m0}")
                del changes[i]
                continue
            for name in names[len(self.label_set):]:  # labels added before the crash
                self.add_label(name if name not in self.label_set.names else f"{name} (restored)")
            layer = self.layer(i)
            layer.begin()
            layer.paint(np.arange(len(labels)), labels)
            layer.end()  # one undo step: the restore can be undone
            self.scribbles_changed.emit(i, np.arange(len(labels)))
            self._after_edit(i)
        return sorted(changes)

    def discard_autosave(self) -> Path | None:
        """Set the autosave aside (renamed, not deleted) so it is not offered again."""
        import time

        folder = self.autosave_folder()
        if folder is None or not folder.is_dir():
            return None
        target = folder.with_name(f"{folder.name}-discarded-{time.strftime('%Y%m%d-%H%M%S')}")
        folder.rename(target)
        return target

    @staticmethod
    def _label_names_beside(folder: Path) -> tuple[str, ...]:
        from scribbleseg_core.evaluation.psb import read_label_names

        f = folder / "labels" / "label_names.txt"
        return tuple(read_label_names(f)) if f.is_file() else ()

    def set_current(self, index: int) -> None:
        """Show shape `index`; its mesh loads wherever the view asks for it first."""
        if not 0 <= index < len(self.shapes) or index == self.current:
            return
        self.current = index
        self.current_changed.emit(index)

    def mark_error(self, index: int, message: str) -> None:
        """Shape `index`'s mesh failed to load: `message` names the file and the problem."""
        entry = self.shapes[index]
        entry.state, entry.error = "error", message
        self.state_changed.emit(index)
        self.error.emit(message)

    # ------------------------------------------------------------------ painting

    def layer(self, index: int) -> ScribbleLayer:
        """The editable scribbles of shape `index` (file faces)."""
        if index not in self._layers:
            entry = self.shapes[index]
            m0 = entry.mesh().num_file_faces
            start = entry.file_scribble if entry.file_scribble is not None else np.full(m0, -1)
            self._layers[index] = ScribbleLayer(start)
        return self._layers[index]

    def scribble_labels(self, index: int) -> np.ndarray | None:
        """A copy of shape `index`'s scribbles per file face (m0,), or None when it has
        none; unlike :meth:`layer` it never loads the mesh."""
        if index in self._layers:
            return self._layers[index].labels.copy()
        start = self.shapes[index].file_scribble
        return None if start is None else np.array(start, dtype=np.int64)

    def has_scribbles(self, index: int) -> bool:
        s = self.scribble_labels(index)
        return s is not None and bool((s >= 0).any())

    def add_label(self, name: str) -> int:
        """Append a label; returns its id."""
        name = name.strip()
        if not name or name in self.label_set.names:
            raise ValueError(f"label name {name!r} is empty or already used")
        from scribbleseg_core.formats.labels import default_color

        k = len(self.label_set)
        self.label_set = LabelSet.from_names([*self.label_set.names, name], np.vstack([self.label_set.colors.reshape(-1, 3), default_color(k)]))
        self._set_unsaved(True)
        self.labels_changed.emit()
        return k

    def rename_label(self, label: int, name: str) -> None:
        name = name.strip()
        names = list(self.label_set.names)
        if not name or name in names[:label] + names[label + 1 :]:
            raise ValueError(f"label name {name!r} is empty or already used")
        names[label] = name
        self.label_set = LabelSet.from_names(names, self.label_set.colors)
        self._set_unsaved(True)
        self.labels_changed.emit()

    def recolor_label(self, label: int, rgb) -> None:
        colors = self.label_set.colors.copy()
        colors[label] = rgb
        self.label_set = LabelSet.from_names(self.label_set.names, colors)
        self._set_unsaved(True)
        self.labels_changed.emit()
        if self.current >= 0:
            self.scribbles_changed.emit(self.current, np.zeros(0, np.int64))

    def delete_label(self, label: int) -> int:
        """Remove `label`: its scribbles are erased and its result faces unlabeled; higher
        ids move down by one. The trained model no longer fits and is dropped.

        Returns
        -------
        int
            Scribbled faces erased (over all shapes).
        """
        if not 0 <= label < len(self.label_set):
            raise ValueError(f"label {label} out of range: there are {len(self.label_set)} labels")

        def shift(a):
            if a is None:
                return None
            a = a.copy()
            a[a == label] = -1
            a[a > label] -= 1
            return a

        erased = 0
        for i, entry in enumerate(self.shapes):
            if i in self._layers:
                layer = self._layers[i]
                erased += int((layer.labels == label).sum())
                self._layers[i] = ScribbleLayer(shift(layer.labels))  # history ids no longer apply
            elif entry.file_scribble is not None:
                erased += int((entry.file_scribble == label).sum())
            entry.file_scribble = shift(entry.file_scribble)
            entry.labels, entry.preview = shift(entry.labels), shift(entry.preview)
        keep = [j for j in range(len(self.label_set)) if j != label]
        self.label_set = LabelSet.from_names([self.label_set.names[j] for j in keep], self.label_set.colors[keep])
        self.trained_model = None
        self._set_unsaved(True)
        if self.current_label >= len(self.label_set) or self.current_label == label:
            self.current_label = 0 if len(self.label_set) else -1
        self.labels_changed.emit()
        for i in self._layers:
            self._refresh_state(i)
            self.autosave(i)
        if self.current >= 0:
            self.scribbles_changed.emit(self.current, np.zeros(0, np.int64))
        return erased

    def set_brush_radius(self, radius: float) -> None:
        """The brush's radius, as a fraction of the bounding-box diagonal (default 0.02)."""
        if not radius > 0:
            raise ValueError(f"brush radius must be positive; got {radius}")
        self.brush_radius = float(radius)

    def set_trained_model(self, model) -> None:
        """The model a run trained (prediction and the preview use it); the work is unsaved."""
        self.trained_model = model
        self._set_unsaved(True)

    def set_current_label(self, label: int) -> None:
        """Paint with `label` (-1: erase)."""
        if not -1 <= label < len(self.label_set):
            raise ValueError(f"label {label} out of range: there are {len(self.label_set)} labels")
        self.current_label = int(label)
        self.current_label_changed.emit(self.current_label)

    def begin_stroke(self) -> None:
        if self.current < 0 or self.shapes[self.current].state == "error":
            return
        self.layer(self.current).begin()
        self._last_point = None

    def paint_at(self, point: np.ndarray) -> None:
        """Paint the current label under the brush at 3D `point` (joined to the previous one)."""
        if self.current < 0 or not self.layer(self.current).in_stroke:
            return
        if self.current_label >= 0 and not len(self.label_set):
            self.error.emit("add a label before painting")
            return
        index = self.current
        faces = self.brush(index).faces_along(point, self._last_point, self.brush_radius)
        self._last_point = np.asarray(point, dtype=np.float64)
        changed = self.layer(index).paint(faces, self.current_label)
        if len(changed):
            self.scribbles_changed.emit(index, changed)

    def brush(self, index: int) -> Brush:
        """The surface brush of shape `index` (its face graph), made on first use (any thread)."""
        with self._brush_lock:
            if index not in self._brushes:
                self._brushes[index] = Brush(self.shapes[index].mesh())
            return self._brushes[index]

    def paint_stroke_faces(self, faces) -> np.ndarray:
        """Within a stroke (:meth:`begin_stroke` … :meth:`end_stroke`) on the current shape:
        paint file faces `faces` with the current label, as a brush sample would. Returns the
        faces that changed."""
        if self.current < 0 or not self.layer(self.current).in_stroke:
            return np.zeros(0, np.int64)
        changed = self.layer(self.current).paint(np.asarray(faces, dtype=np.int64), self.current_label)
        if len(changed):
            self.scribbles_changed.emit(self.current, changed)
        return changed

    def end_stroke(self) -> None:
        if self.current < 0 or not self.layer(self.current).in_stroke:
            return
        if self.layer(self.current).end():
            self._after_edit(self.current)

    def paint_faces(self, index: int, faces, label: int | np.ndarray) -> np.ndarray:
        """Give file faces `faces` of shape `index` the scribble `label` (-1 erases), or each its
        own label (`label` of the length of `faces`), in one undo step, as a finished stroke does
        (autosave, preview). Returns the faces that changed."""
        layer = self.layer(index)
        layer.begin()
        changed = layer.paint(faces, label)
        if layer.end():
            self.scribbles_changed.emit(index, changed)
            self._after_edit(index)
        return changed

    def undo(self) -> None:
        self._history(self.layer(self.current).undo) if self.current >= 0 else None

    def redo(self) -> None:
        self._history(self.layer(self.current).redo) if self.current >= 0 else None

    def _history(self, step) -> None:
        faces = step()
        if faces is not None:
            self.scribbles_changed.emit(self.current, faces)
            self._after_edit(self.current)

    def _after_edit(self, index: int) -> None:
        if self.suggestion is not None and self.suggestion.index == index:
            self.set_suggestion(None)  # acted on: the next run makes a new one
        self.shapes[index].edits += 1
        self._set_unsaved(True)
        self._refresh_state(index)
        self.autosave(index)
        self.edit_committed.emit(index)

    def _refresh_state(self, index: int) -> None:
        entry = self.shapes[index]
        has = bool((self.layer(index).labels >= 0).any())
        if entry.state in ("untouched", "scribbled"):
            state = "scribbled" if has else "untouched"
            if state != entry.state:
                entry.state = state
                self.state_changed.emit(index)

    def shown_labels(self, index: int) -> np.ndarray | None:
        """The labels the user sees for shape `index` (the preview if newer than the last
        result), (m0,) int64, or None."""
        entry = self.shapes[index]
        return entry.preview if entry.preview is not None else entry.labels

    def autosave(self, index: int) -> Path | None:
        """Write shape `index`'s scribbles (format v1) into the autosave folder, atomically."""
        if self.autosave_dir is None:
            return None
        from scribbleseg_core.formats.scribbles import Scribbles, write_scribbles

        entry = self.shapes[index]
        folder = self.autosave_folder()
        path = folder / f"{entry.name}.json"
        try:
            if not (folder / "collection.txt").is_file():
                from scribbleseg_core.infra.atomic import atomic_write_text

                atomic_write_text(folder / "collection.txt", f"{self.folder.resolve()}\n")
            write_scribbles(path, Scribbles.from_face_labels(entry.path.name, self.layer(index).labels, self.label_set.names))
        except OSError as e:  # the edit itself stands; only its safety copy failed
            self.error.emit(f"{path}: autosave failed: {e}")
            return None
        return path

    def face_colors(self, index: int) -> np.ndarray:
        """What the viewport shows for shape `index`: result labels, with scribbles on top
        drawn darker; (m0, 3) float64 RGB."""
        entry = self.shapes[index]
        m0 = entry.mesh().num_file_faces
        labels = self.shown_labels(index)
        labels = labels if labels is not None else np.full(m0, -1)
        colors = self.label_set.face_colors(labels)
        scribble = self.layer(index).labels
        s = scribble >= 0
        colors[s] = self.label_set.face_colors(scribble[s]) * 0.6
        return colors


@dataclass(frozen=True)
class SessionSnapshot:
    """What :func:`write_session` writes: (entry, scribbles (m0,) or None, shown labels (m0,)
    or None) per shape, the labels, the current shape, the model, and the model's version."""

    shapes: list
    label_set: LabelSet
    current: int
    model: object
    version: int


def write_session(folder: str | os.PathLike, snapshot: SessionSnapshot) -> list[str]:
    """Write `snapshot` as a session into `folder` (any thread: it loads meshes for their face
    counts). Returns the shapes left out, whose mesh did not load."""
    from scribbleseg_core.store.session import Session, SessionShape, save_session

    shapes, skipped = [], []
    for entry, scribble, labels in snapshot.shapes:
        if entry.state == "error":
            skipped.append(entry.name)
            continue
        try:
            n = entry.mesh().num_file_faces
        except ScribblesegError:
            skipped.append(entry.name)
            continue
        scribble = np.full(n, -1, np.int64) if scribble is None else scribble
        state = entry.state if entry.state in ("labeled", "predicted") else ("scribbled" if (scribble >= 0).any() else "untouched")
        shapes.append(SessionShape(entry.path, n, scribble, labels, state))
    save_session(folder, Session(snapshot.label_set, shapes, snapshot.current, snapshot.model))
    return skipped


def load_meshes(paths) -> dict:
    """``{path: Mesh or the ScribblesegError its load raised}`` for :meth:`CollectionModel.add_meshes`
    (any thread)."""
    out = {}
    for p in map(Path, paths):
        try:
            out[p] = load_mesh(p)
        except ScribblesegError as e:
            out[p] = e
    return out
