"""The app's state: a collection of shapes, their scribbles and labels. No widgets here."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from app.events import Event
from scribbleseg_core.collection import find_collection
from scribbleseg_core.errors import ScribblesegError
from scribbleseg_core.labels import LabelSet
from scribbleseg_core.mesh_io import Mesh, load_mesh

ShapeState = Literal["untouched", "scribbled", "labeled", "predicted", "error"]


@dataclass
class ShapeEntry:
    """One shape of the collection; the mesh loads on first use."""

    path: Path
    file_scribble: np.ndarray | None = None  # (m0,) label per file face, -1 unscribbled
    labels: np.ndarray | None = None  # (m0,) result per file face
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
    """

    def __init__(self) -> None:
        self.shapes: list[ShapeEntry] = []
        self.label_set = LabelSet.from_names([])
        self.folder: Path | None = None
        self.current = -1
        self.collection_changed = Event()
        self.current_changed = Event()
        self.error = Event()

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

    def face_colors(self, index: int) -> np.ndarray:
        """What the viewport shows for shape `index`: result labels, with scribbles on top
        drawn darker; (m0, 3) float64 RGB."""
        entry = self.shapes[index]
        m0 = entry.mesh().num_file_faces
        labels = entry.labels if entry.labels is not None else np.full(m0, -1)
        colors = self.label_set.face_colors(labels)
        if entry.file_scribble is not None:
            s = entry.file_scribble >= 0
            colors[s] = self.label_set.face_colors(entry.file_scribble[s]) * 0.6
        return colors
