"""The app's state: a collection of shapes, their scribbles and labels. No widgets here."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from app.events import Event
from app.painting import Brush, ScribbleLayer
from scribbleseg_core.collection import find_collection
from scribbleseg_core.errors import ScribblesegError
from scribbleseg_core.labels import LabelSet
from scribbleseg_core.mesh_io import Mesh, load_mesh

ShapeState = Literal["untouched", "scribbled", "labeled", "predicted", "error"]


@dataclass
class ShapeEntry:
    """One shape of the collection; the mesh loads on first use."""

    path: Path
    file_scribble: np.ndarray | None = None  # (m0,) scribbles as opened; edits live in the model's layer
    labels: np.ndarray | None = None  # (m0,) result per file face
    preview: np.ndarray | None = None  # (m0,) live preview after the latest edit, if newer than `labels`
    state: ShapeState = "untouched"
    error: str | None = None
    _mesh: Mesh | None = None

    @property
    def name(self) -> str:
        return self.path.stem

    def mesh(self) -> Mesh:
        if self._mesh is None:
            self._mesh = load_mesh(self.path)
        return self._mesh


class CollectionModel:
    """Shapes, label set and the current shape, with events for views to follow.

    Events
    ------
    collection_changed()
        A new collection was opened.
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
    edit_committed(index)
        A stroke ended, or an undo/redo happened, on shape `index` (time for a preview).
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
        self.collection_changed = Event()
        self.current_changed = Event()
        self.error = Event()
        self.scribbles_changed = Event()
        self.current_label_changed = Event()
        self.labels_changed = Event()
        self.state_changed = Event()
        self.edit_committed = Event()

    def open(self, path: str | os.PathLike) -> None:
        """Open a folder of meshes (with scribble files beside them or in ``scribbles/``) or one mesh."""
        path = Path(path)
        try:
            if path.is_dir():
                coll = find_collection(path)
                shapes = [ShapeEntry(p, coll.face_labels(p)) for p in coll.meshes]
                names = coll.label_names or self._label_names_beside(path)
            else:
                load_mesh(path)  # fail now, with the file named, rather than on display
                shapes, names = [ShapeEntry(path.resolve())], ()
        except ScribblesegError as e:
            self.error.emit(str(e))
            return
        for s in shapes:
            if s.file_scribble is not None:
                s.state = "scribbled"
        self.folder = path if path.is_dir() else path.parent
        self.shapes = shapes
        self._layers.clear()
        self._brushes.clear()
        self.label_set = LabelSet.from_names(names)
        self.current = -1
        self.collection_changed.emit()
        if shapes:
            self.set_current(0)

    @staticmethod
    def _label_names_beside(folder: Path) -> tuple[str, ...]:
        from scribbleseg_core.psb import read_label_names

        f = folder / "labels" / "label_names.txt"
        return tuple(read_label_names(f)) if f.is_file() else ()

    def set_current(self, index: int) -> None:
        if not 0 <= index < len(self.shapes) or index == self.current:
            return
        entry = self.shapes[index]
        try:
            entry.mesh()
        except ScribblesegError as e:
            entry.state, entry.error = "error", str(e)
            self.error.emit(str(e))
        self.current = index
        self.current_changed.emit(index)

    # ------------------------------------------------------------------ painting

    def layer(self, index: int) -> ScribbleLayer:
        """The editable scribbles of shape `index` (file faces)."""
        if index not in self._layers:
            entry = self.shapes[index]
            m0 = entry.mesh().num_file_faces
            start = entry.file_scribble if entry.file_scribble is not None else np.full(m0, -1)
            self._layers[index] = ScribbleLayer(start)
        return self._layers[index]

    def add_label(self, name: str) -> int:
        """Append a label; returns its id."""
        name = name.strip()
        if not name or name in self.label_set.names:
            raise ValueError(f"label name {name!r} is empty or already used")
        from scribbleseg_core.labels import default_color

        k = len(self.label_set)
        self.label_set = LabelSet.from_names([*self.label_set.names, name], np.vstack([self.label_set.colors.reshape(-1, 3), default_color(k)]))
        self.labels_changed.emit()
        return k

    def rename_label(self, label: int, name: str) -> None:
        name = name.strip()
        names = list(self.label_set.names)
        if not name or name in names[:label] + names[label + 1 :]:
            raise ValueError(f"label name {name!r} is empty or already used")
        names[label] = name
        self.label_set = LabelSet.from_names(names, self.label_set.colors)
        self.labels_changed.emit()

    def recolor_label(self, label: int, rgb) -> None:
        colors = self.label_set.colors.copy()
        colors[label] = rgb
        self.label_set = LabelSet.from_names(self.label_set.names, colors)
        self.labels_changed.emit()
        if self.current >= 0:
            self.scribbles_changed.emit(self.current, np.zeros(0, np.int64))

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
        if index not in self._brushes:
            mesh = self.shapes[index].mesh()
            V, F = mesh.V_file, mesh.F_file
            self._brushes[index] = Brush(V[F].mean(axis=1), float(np.linalg.norm(V.max(0) - V.min(0))))
        faces = self._brushes[index].faces_along(point, self._last_point, self.brush_radius)
        self._last_point = np.asarray(point, dtype=np.float64)
        changed = self.layer(index).paint(faces, self.current_label)
        if len(changed):
            self.scribbles_changed.emit(index, changed)

    def end_stroke(self) -> None:
        if self.current < 0 or not self.layer(self.current).in_stroke:
            return
        if self.layer(self.current).end():
            self._after_edit(self.current)

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
        entry = self.shapes[index]
        has = bool((self.layer(index).labels >= 0).any())
        if entry.state in ("untouched", "scribbled"):
            state = "scribbled" if has else "untouched"
            if state != entry.state:
                entry.state = state
                self.state_changed.emit(index)
        self.autosave(index)
        self.edit_committed.emit(index)

    def shown_labels(self, index: int) -> np.ndarray | None:
        """The labels the user sees for shape `index` (the preview if newer than the last
        result), (m0,) int64, or None."""
        entry = self.shapes[index]
        return entry.preview if entry.preview is not None else entry.labels

    def autosave(self, index: int) -> Path | None:
        """Write shape `index`'s scribbles (format v1) into the autosave folder, atomically."""
        if self.autosave_dir is None:
            return None
        from scribbleseg_core.scribbles import Scribbles, Stroke, write_scribbles

        entry = self.shapes[index]
        labels = self.layer(index).labels
        strokes = tuple(Stroke(int(lab), np.flatnonzero(labels == lab)) for lab in np.unique(labels[labels >= 0]))
        path = self.autosave_dir / f"{entry.name}.json"
        write_scribbles(path, Scribbles(entry.path.name, len(labels), self.label_set.names, strokes))
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
