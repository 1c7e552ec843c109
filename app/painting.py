"""Scribble editing on file faces: strokes, brush, undo and redo. No widgets here."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

#: Label value of the eraser.
ERASE = -1


@dataclass(frozen=True)
class Edit:
    """One undo step: faces (k,) and their labels before and after a stroke."""

    faces: np.ndarray
    before: np.ndarray
    after: np.ndarray


class ScribbleLayer:
    """The scribble labels of one shape, (m0,) int64 with -1 unscribbled, and its history.

    A stroke is ``begin()``, any number of ``paint(faces, label)``, ``end()``; the whole
    stroke is one undo step.
    """

    def __init__(self, labels: np.ndarray):
        self.labels = np.asarray(labels, dtype=np.int64).copy()
        self._undo: list[Edit] = []
        self._redo: list[Edit] = []
        self._stroke: dict[int, int] | None = None  # face -> label before the stroke

    @property
    def in_stroke(self) -> bool:
        return self._stroke is not None

    def begin(self) -> None:
        self._stroke = {}

    def paint(self, faces: np.ndarray, label: int | np.ndarray) -> np.ndarray:
        """Set `faces` to `label` (ERASE clears them), or each face to its own label (`label` of
        the length of `faces`; the first one where a face repeats); returns the faces that
        changed, sorted."""
        if self._stroke is None:
            raise RuntimeError("paint() outside a stroke: call begin() first")
        faces = np.asarray(faces, dtype=np.int64)
        labels = np.broadcast_to(np.asarray(label, dtype=np.int64), faces.shape)
        faces, first = np.unique(faces, return_index=True)
        labels = labels[first]
        differs = self.labels[faces] != labels
        changed = faces[differs]
        for f in changed:
            self._stroke.setdefault(int(f), int(self.labels[f]))
        self.labels[changed] = labels[differs]
        return changed

    def end(self) -> bool:
        """Close the stroke; returns whether it changed anything (an undo step was made)."""
        stroke, self._stroke = self._stroke, None
        if not stroke:
            return False
        faces = np.fromiter(stroke.keys(), np.int64, len(stroke))
        before = np.fromiter(stroke.values(), np.int64, len(stroke))
        keep = self.labels[faces] != before  # painted over and back: no change
        if not keep.any():
            return False
        self._undo.append(Edit(faces[keep], before[keep], self.labels[faces[keep]].copy()))
        self._redo.clear()
        return True

    def undo(self) -> np.ndarray | None:
        """Revert the last stroke; returns the faces changed, or None if nothing to undo."""
        if self.in_stroke or not self._undo:
            return None
        e = self._undo.pop()
        self.labels[e.faces] = e.before
        self._redo.append(e)
        return e.faces

    def redo(self) -> np.ndarray | None:
        if self.in_stroke or not self._redo:
            return None
        e = self._redo.pop()
        self.labels[e.faces] = e.after
        self._undo.append(e)
        return e.faces

    @property
    def can_undo(self) -> bool:
        return bool(self._undo)

    @property
    def can_redo(self) -> bool:
        return bool(self._redo)


class Brush:
    """Faces under a round brush on a mesh, the radius measured along the surface: those whose
    centroid lies within `radius` of the brush center by the shortest path over adjacent
    faces (:func:`~scribbleseg_core.engine.regions.surface_disc`), so a stroke over a thin part
    (a finger, a chair leg) does not reach the surface behind it. The path between two samples
    is filled so fast drags leave no gaps.

    Parameters
    ----------
    mesh : Mesh
        Brush samples are points in its file coordinates; faces are file faces.
    """

    def __init__(self, mesh):
        from scribbleseg_core.geometry.dual_graph import dual_graph

        V, F = mesh.V, mesh.F
        self.graph = dual_graph(V, F)
        self.tree = cKDTree(V[F].mean(axis=1))
        self.scale = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
        self.mesh = mesh

    def faces_along(self, p: np.ndarray, q: np.ndarray | None, radius: float) -> np.ndarray:
        """File faces within ``radius · scale`` along the surface of the segment from `q`
        (previous sample, or None) to `p`, (k,) int64 sorted; scale is the bounding-box diagonal."""
        from scribbleseg_core.engine.regions import surface_disc

        r = radius * self.scale
        p = np.asarray(p, dtype=np.float64)
        if q is None:
            pts = p[None]
        else:
            n = max(1, int(np.ceil(np.linalg.norm(p - np.asarray(q)) / (0.5 * max(r, 1e-12)))))
            t = np.linspace(0.0, 1.0, n + 1)[:, None]
            pts = np.asarray(q)[None] * (1 - t) + p[None] * t
        seeds = np.unique(self.tree.query(pts)[1])
        return self.mesh.faces_to_file(surface_disc(self.graph, seeds, r))
