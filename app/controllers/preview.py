"""Live preview: after each stroke, re-propagate the shape's labels in the background.

:class:`PreviewWorker` runs one thread that always computes the *latest* request only:
a request made while another is pending replaces it (older strokes are stale).
:class:`PreviewController` asks for a preview after every edit, drops a result that arrives
after a newer request was made (it compares generations), and stores the rest in the model
on the main thread.
"""

from __future__ import annotations

import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scribbleseg_app.controllers.jobs import Dispatcher
from scribbleseg_app.events import Event

from scribbleseg_core.engine.graphcut import graph_clusters
from scribbleseg_core.engine.guidance import stroke_agreement
from scribbleseg_core.engine.propagate import (
    CLUSTER_SIZE,
    PropagateParams,
    propagate_scribbles,
    scribble_distances,
)
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
    """Computes previews by a multilevel graph cut (:meth:`FaceEnergy.cut` with clusters);
    keeps the dual graph, its face clusters, network input and SDF of the last :data:`KEEP`
    meshes (costly once per mesh), and each one's previous preview and scribble distances
    (one more stroke starts from them)."""

    #: Meshes whose costly parts are kept; older ones are released.
    KEEP = 4

    def __init__(self) -> None:
        self._graphs: OrderedDict[int, tuple[Mesh, DualGraph, np.ndarray]] = OrderedDict()  # with face clusters
        self._shapes: OrderedDict[int, ShapeData] = OrderedDict()  # with their network inputs and geodesics
        self._logp: OrderedDict[int, tuple[Mesh, object, np.ndarray]] = OrderedDict()  # (mesh, model, log-probabilities)
        self._sdf: OrderedDict[int, tuple[Mesh, np.ndarray]] = OrderedDict()
        # the previous preview: (mesh, num_labels, labels, scribble, scribble distances)
        self._last: OrderedDict[int, tuple[Mesh, int, np.ndarray, np.ndarray, np.ndarray]] = OrderedDict()

    def _keep(self, cache: OrderedDict, key: int) -> None:
        cache.move_to_end(key)
        while len(cache) > self.KEEP:
            cache.popitem(last=False)

    def cached_meshes(self) -> int:
        """How many meshes have something kept (tests: the caches stay bounded)."""
        return len(set(self._graphs) | set(self._shapes) | set(self._logp) | set(self._sdf) | set(self._last))

    def graph(self, mesh: Mesh) -> DualGraph:
        return self._graph(mesh)[1]

    def _graph(self, mesh: Mesh) -> tuple[Mesh, DualGraph, np.ndarray]:
        key = id(mesh)
        if key not in self._graphs or self._graphs[key][0] is not mesh:
            graph = dual_graph(mesh.normalized(), mesh.F)
            self._graphs[key] = (mesh, graph, graph_clusters(graph.crease_matrix, CLUSTER_SIZE))
        self._keep(self._graphs, key)
        return self._graphs[key]

    def log_proba(self, mesh: Mesh, model) -> np.ndarray:
        """The model's face log-probabilities, kept per mesh while the model stays the same
        (they do not depend on the strokes); features and context come from the disk caches a
        run filled (computed there on first use)."""
        from scribbleseg_core.geometry.measures import face_areas
        from scribbleseg_core.signatures.features import cached_face_features

        key = id(mesh)
        kept = self._logp.get(key)
        if kept is not None and kept[0] is mesh and kept[1] is model:
            self._keep(self._logp, key)
            return kept[2]
        if key not in self._shapes or self._shapes[key].mesh is not mesh:  # the run's inputs and disk caches
            X = cached_face_features(mesh.V, mesh.F)
            scribble = np.full(len(mesh.F), -1, np.int64)
            self._shapes[key] = ShapeData(mesh, X, face_areas(mesh.normalized(), mesh.F), self.graph(mesh), scribble)
        self._keep(self._shapes, key)
        self._logp[key] = (mesh, model, model.log_proba(self._shapes[key]))
        self._keep(self._logp, key)
        return self._logp[key][2]

    def compute(self, req: PreviewRequest) -> np.ndarray | None:
        """(m0,) file-face labels, or None when the shape has no scribbles. The graph cut
        starts from the shape's previous preview, so one more stroke converges in fewer
        moves, and only the labels whose strokes changed get new scribble distances. After a
        run the model's network term joins, scaled by its
        :func:`~scribbleseg_core.engine.guidance.stroke_agreement` with the strokes: where the
        user paints over what the model got wrong, the strokes are what the preview follows."""
        mesh = req.mesh
        scribble = np.asarray(req.file_scribble, dtype=np.int64)[mesh.proc_to_file]
        if not (scribble >= 0).any():
            return None
        logp = self.log_proba(mesh, req.model) if req.model is not None else None
        if logp is not None:  # a network that contradicts the strokes gives way to them
            logp = logp * stroke_agreement(logp, scribble)
        params = req.model.params.propagation if req.model is not None else PropagateParams()
        sdf = self.sdf(mesh) if params.contrast > 0 else None
        key, k = id(mesh), req.num_labels
        _, graph, clusters = self._graph(mesh)
        last = self._last.get(key)
        if last is None or last[0] is not mesh or last[1] != k:
            last = None
        D = scribble_distances(graph, scribble, k, previous=None if last is None else (last[3], last[4]))
        labels = propagate_scribbles(graph, scribble, k, log_proba=logp, sdf=sdf, params=params,
                                     init=None if last is None else last[2], clusters=clusters, distances=D)
        self._last[key] = (mesh, k, labels, scribble, D)
        self._keep(self._last, key)
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
        self._keep(self._sdf, key)
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
        self._reset = False
        self._cond = threading.Condition()
        self._thread = threading.Thread(target=self._loop, name="scribbleseg-preview", daemon=True)
        self._thread.start()

    def request(self, req: PreviewRequest) -> None:
        """Queue `req`, replacing any request not yet started."""
        with self._cond:
            self._pending = req
            self._cond.notify()

    def reset(self) -> None:
        """Release the engine's caches (another collection was opened) before the next preview."""
        with self._cond:
            self._reset = True
            self._pending = None

    def close(self, timeout: float = 5.0) -> bool:
        """Stop the thread after the preview under way; True when it ended within `timeout`."""
        with self._cond:
            self._closed = True
            self._cond.notify()
        self._thread.join(timeout)
        return not self._thread.is_alive()

    def _loop(self) -> None:
        while True:
            with self._cond:
                while self._pending is None and not self._closed:
                    self._cond.wait()
                if self._closed:
                    return
                req, self._pending = self._pending, None
                if self._reset:
                    self.engine, self._reset = type(self.engine)(), False
            try:
                labels, error = self.engine.compute(req), None
            except Exception as e:  # a preview must never take the app down
                labels, error = None, f"{req.mesh.name}: preview failed: {e}"
            self._deliver(PreviewResult(req.generation, req.index, labels, time.perf_counter() - req.requested_at, error))


class PreviewController:
    """Previews the edited shape after every stroke (``model.edit_committed``).

    Events
    ------
    done(index, seconds)
        The preview of shape `index` is in the model (``ShapeEntry.preview``), `seconds`
        after the stroke's release.
    failed(message)
        A preview failed; the message names the shape.

    Parameters
    ----------
    model : CollectionModel
    dispatcher : Dispatcher
    engine : PreviewEngine, optional
    """

    def __init__(self, model, dispatcher: Dispatcher, engine: PreviewEngine | None = None) -> None:
        self.model = model
        self.dispatcher = dispatcher
        self.enabled = True
        self.last_seconds: float | None = None
        self.done, self.failed = Event(), Event()
        self._engine = engine
        self._worker: PreviewWorker | None = None
        self._requested = 0  # generation of the latest request
        self._arrived = 0  # generation of the latest result back (used or stale)
        self._models: tuple[object, object] | None = None  # (the model's trained model, its one-thread copy)
        model.edit_committed.connect(self.request)
        model.collection_changed.connect(self._on_collection_changed)

    @property
    def idle(self) -> bool:
        """True when the latest requested preview has arrived (tests wait on this)."""
        return self._arrived == self._requested

    @property
    def engine(self) -> PreviewEngine | None:
        return self._worker.engine if self._worker is not None else self._engine

    def request(self, index: int) -> None:
        """Re-propagate shape `index`'s labels in the background; older requests go stale."""
        m = self.model
        if not self.enabled or not 0 <= index < len(m.shapes) or m.shapes[index].state == "error":
            return
        if self._worker is None:
            self._worker = PreviewWorker(self._deliver, self._engine)
        self._requested += 1
        self._worker.request(PreviewRequest(self._requested, index, m.shapes[index].mesh(), m.layer(index).labels.copy(),
                                            max(len(m.label_set), 1), self._model(), time.perf_counter()))

    def _model(self):
        """The trained model on one torch thread (its own copy), or None when it no longer fits the labels."""
        model = self.model.trained_model
        if model is None or len(model.label_names) != len(self.model.label_set):
            return None  # labels were added or deleted since the run
        if self._models is None or self._models[0] is not model:
            self._models = (model, model.with_threads(1))
        return self._models[1]

    def _deliver(self, result: PreviewResult) -> None:  # on the worker thread
        self.dispatcher.post(lambda: self._apply(result))

    def _apply(self, result: PreviewResult) -> None:
        self._arrived = max(self._arrived, result.generation)
        if result.generation != self._requested:
            return  # a newer stroke, or another collection (it counts as a request), made it stale
        if result.error:
            self.failed.emit(result.error)
            return
        self.model.set_preview(result.index, result.file_labels)
        self.last_seconds = result.seconds
        self.done.emit(result.index, result.seconds)

    def _on_collection_changed(self) -> None:
        self._requested += 1  # a pending preview belongs to the old collection
        self._arrived = self._requested
        self._models = None
        if self._worker is not None:
            self._worker.reset()

    def close(self, timeout: float = 5.0) -> bool:
        return self._worker.close(timeout) if self._worker is not None else True
