"""Live preview: after each stroke, re-propagate the shape's labels in the background.

:class:`PreviewWorker` runs one thread that always computes the *latest* request only:
a request made while another is pending replaces it (older strokes are stale), and a
result that arrives after a newer request was made is dropped by the caller, who compares
generations. No Qt here; the window hops results onto the main thread.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from scribbleseg_core.engine.propagate import PropagateParams, propagate_scribbles
from scribbleseg_core.engine.shape import ShapeData
from scribbleseg_core.formats.mesh import Mesh
from scribbleseg_core.geometry.dual_graph import DualGraph, dual_graph


@dataclass(frozen=True)
class PreviewRequest:
    """What one preview needs; arrays are copies the caller no longer touches.

    Attributes
    ----------
    generation : int
    index : int
        Shape index in the collection.
    mesh : Mesh
    file_scribble : (m0,) int64 ndarray
        Scribble label per file face, -1 unscribbled.
    num_labels : int
    model : TrainedModel or None
        When given, its network's log-probabilities join the scribbles.
    requested_at : float
        ``time.perf_counter()`` when the user released the mouse.
    """

    generation: int
    index: int
    mesh: Mesh
    file_scribble: np.ndarray
    num_labels: int
    model: object = None
    requested_at: float = 0.0


@dataclass(frozen=True)
class PreviewResult:
    generation: int
    index: int
    file_labels: np.ndarray | None  # (m0,) int64; None when nothing is scribbled
    seconds: float  # from the request to the result
    error: str | None = None


class PreviewEngine:
    """Computes previews; keeps each mesh's dual graph, network input and SDF (costly once)."""

    def __init__(self) -> None:
        self._graphs: dict[int, tuple[Mesh, DualGraph]] = {}
        self._shapes: dict[int, ShapeData] = {}  # with their network inputs and geodesics
        self._sdf: dict[int, tuple[Mesh, np.ndarray]] = {}

    def graph(self, mesh: Mesh) -> DualGraph:
        key = id(mesh)
        if key not in self._graphs or self._graphs[key][0] is not mesh:
            self._graphs[key] = (mesh, dual_graph(mesh.normalized(), mesh.F))
        return self._graphs[key][1]

    def log_proba(self, mesh: Mesh, model) -> np.ndarray:
        """The model's face log-probabilities; features and context come from the disk
        caches a run filled (computed there on first use)."""
        from scribbleseg_core.geometry.measures import face_areas
        from scribbleseg_core.signatures.features import cached_face_features

        key = id(mesh)
        if key not in self._shapes or self._shapes[key].mesh is not mesh:  # the run's inputs and disk caches
            X = cached_face_features(mesh.V, mesh.F)
            scribble = np.full(len(mesh.F), -1, np.int64)
            self._shapes[key] = ShapeData(mesh, X, face_areas(mesh.normalized(), mesh.F), self.graph(mesh), scribble)
        return model.log_proba(self._shapes[key])

    def compute(self, req: PreviewRequest) -> np.ndarray | None:
        """(m0,) file-face labels, or None when the shape has no scribbles."""
        mesh = req.mesh
        scribble = np.asarray(req.file_scribble, dtype=np.int64)[mesh.proc_to_file]
        if not (scribble >= 0).any():
            return None
        logp = self.log_proba(mesh, req.model) if req.model is not None else None
        params = req.model.params.propagation if req.model is not None else PropagateParams()
        sdf = self.sdf(mesh) if params.contrast > 0 else None
        labels = propagate_scribbles(self.graph(mesh), scribble, req.num_labels, log_proba=logp, sdf=sdf, params=params)
        return mesh.labels_to_file(labels)

    def sdf(self, mesh: Mesh) -> np.ndarray | None:
        """The shape diameter per face if the signatures are already cached (after a run, or
        shown as colors), else None: the preview never waits for them, and propagates
        without the SDF contrast until they exist."""
        from scribbleseg_core.signatures.features import (
            SDF_COLUMN,
            cached_face_features,
        )

        key = id(mesh)
        if key not in self._sdf or self._sdf[key][0] is not mesh:
            X = cached_face_features(mesh.V, mesh.F, compute=False)  # hashes the mesh, reads the file
            if X is None:
                return None  # looked up again at the next stroke: a run may have computed them
            self._sdf[key] = (mesh, X[:, SDF_COLUMN].copy())
        return self._sdf[key][1]


class PreviewWorker:
    """One background thread computing the latest :class:`PreviewRequest`.

    Parameters
    ----------
    deliver : callable(PreviewResult)
        Called on the worker thread with each result (also failures, with ``error``).
    engine : PreviewEngine, optional
    """

    def __init__(self, deliver: Callable[[PreviewResult], None], engine: PreviewEngine | None = None) -> None:
        self.engine = engine or PreviewEngine()
        self._deliver = deliver
        self._pending: PreviewRequest | None = None
        self._closed = False
        self._cond = threading.Condition()
        self._thread = threading.Thread(target=self._loop, name="scribbleseg-preview", daemon=True)
        self._thread.start()

    def request(self, req: PreviewRequest) -> None:
        """Queue `req`, replacing any request not yet started."""
        with self._cond:
            self._pending = req
            self._cond.notify()

    def close(self, timeout: float = 5.0) -> None:
        with self._cond:
            self._closed = True
            self._cond.notify()
        self._thread.join(timeout)

    def _loop(self) -> None:
        while True:
            with self._cond:
                while self._pending is None and not self._closed:
                    self._cond.wait()
                if self._closed:
                    return
                req, self._pending = self._pending, None
            try:
                labels, error = self.engine.compute(req), None
            except Exception as e:  # a preview must never take the app down
                labels, error = None, f"{req.mesh.name}: preview failed: {e}"
            self._deliver(PreviewResult(req.generation, req.index, labels, time.perf_counter() - req.requested_at, error))
