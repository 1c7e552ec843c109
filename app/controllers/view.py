"""What the viewport shows: the current shape, coloured by the chosen "Show" mode.

:class:`ViewController` loads the current shape's mesh off the main thread, hands the viewport
the mesh and its face colours, updates the colours in place when scribbles, results or labels
change, and computes signature colours in the background (kept per shape until another
collection is opened).
"""

from __future__ import annotations

import numpy as np
from scribbleseg_app.controllers.jobs import Dispatcher, Job
from scribbleseg_app.events import Event

#: What the surface shows ("Show" menu); features are the columns of ``face_features``.
SHOW_MODES = ("Labels and scribbles", "Scribbles only", "Result only",
              "Feature: AGD", "Feature: SDF", "Feature: Gaussian curvature", "Feature: SI-HKS (band 1)")
FEATURE_COLUMN = {"Feature: AGD": 0, "Feature: SDF": 1, "Feature: Gaussian curvature": 2, "Feature: SI-HKS (band 1)": 3}


def value_colors(values: np.ndarray) -> np.ndarray:
    """A blue-to-yellow ramp (viridis anchors) of `values` (m,) between their 2nd and
    98th percentiles, (m, 3) float64 RGB."""
    anchors = np.array([[0.267, 0.005, 0.329], [0.229, 0.322, 0.546], [0.128, 0.567, 0.551],
                        [0.369, 0.789, 0.383], [0.993, 0.906, 0.144]])
    v = np.asarray(values, dtype=np.float64)
    finite = np.isfinite(v)
    lo, hi = np.percentile(v[finite], [2, 98]) if finite.any() else (0.0, 1.0)
    t = np.clip((np.where(finite, v, lo) - lo) / max(hi - lo, 1e-300), 0, 1) * (len(anchors) - 1)
    i = np.minimum(t.astype(int), len(anchors) - 2)
    f = (t - i)[:, None]
    return anchors[i] * (1 - f) + anchors[i + 1] * f


class ViewController:
    """Keeps the viewport showing the model's current shape in the chosen mode.

    Events
    ------
    status(message)
        Something worth a line in the status bar (a shape shown, signatures computing).
    shown(index)
        Shape `index` is in the viewport (its mesh loaded).

    Parameters
    ----------
    model : CollectionModel
    dispatcher : Dispatcher
    viewport : object
        ``show(V, F, colors)`` and ``set_colors(colors)`` (a
        :class:`~scribbleseg_app.viewport.PolyscopeViewport`, or a stand-in in tests); a
        callable returning one is taken too (made on first use).
    """

    def __init__(self, model, dispatcher: Dispatcher, viewport) -> None:
        self.model = model
        self.dispatcher = dispatcher
        self._viewport = viewport
        self.mode = SHOW_MODES[0]
        self.status, self.shown = Event(), Event()
        self.showing = -1  # the shape in the viewport
        self._features: dict[tuple[int, int], np.ndarray] = {}
        self._jobs: dict[int, Job] = {}  # features being computed, per shape
        self._loading: Job | None = None
        model.collection_changed.connect(self._on_collection_changed)
        model.current_changed.connect(self._on_current_changed)
        model.scribbles_changed.connect(lambda index, faces: self.refresh(index))
        model.result_changed.connect(self.refresh)
        model.labels_changed.connect(lambda: self.refresh(model.current))

    @property
    def viewport(self):
        if callable(self._viewport) and not hasattr(self._viewport, "show"):
            self._viewport = self._viewport()
        return self._viewport

    def set_mode(self, mode: str) -> None:
        if mode not in SHOW_MODES:
            raise ValueError(f"unknown show mode {mode!r}; one of {', '.join(SHOW_MODES)}")
        self.mode = mode
        self.refresh(self.model.current)

    # ------------------------------------------------------------------ colours

    def colors(self, index: int) -> np.ndarray | None:
        """Face colours of shape `index` in the current mode, (m0, 3) float64; None while
        its mesh is not loaded. A feature not computed yet shows the labels meanwhile."""
        m = self.model
        entry = m.shapes[index]
        if not entry.loaded:
            return None
        if self.mode == "Scribbles only":
            return m.label_set.face_colors(m.layer(index).labels)
        if self.mode == "Result only":
            labels = m.shown_labels(index)
            return m.label_set.face_colors(labels if labels is not None else np.full(entry.mesh().num_file_faces, -1))
        if self.mode in FEATURE_COLUMN:
            values = self.feature_values(index, FEATURE_COLUMN[self.mode])
            if values is not None:
                return value_colors(values)
        return m.face_colors(index)

    def refresh(self, index: int) -> None:
        """Re-colour shape `index` if it is the one shown."""
        if index != self.showing or index != self.model.current or index < 0:
            return
        colors = self.colors(index)
        if colors is not None:
            self.viewport.set_colors(colors)

    def feature_values(self, index: int, column: int) -> np.ndarray | None:
        """Signature `column` per file face of shape `index`, or None while it is computed in
        the background (the view refreshes when it is ready)."""
        key = (index, column)
        if key in self._features:
            return self._features[key]
        if index not in self._jobs:
            from scribbleseg_core.signatures.features import cached_face_features

            mesh = self.model.shapes[index].mesh()
            self.status.emit(f"{mesh.name}: computing shape signatures…")
            generation = self.model.generation

            def done(X, index=index, mesh=mesh):
                self._jobs.pop(index, None)
                if generation != self.model.generation:
                    return
                for c in set(FEATURE_COLUMN.values()):
                    self._features[(index, c)] = mesh.labels_to_file(X[:, c])
                self.status.emit(f"{mesh.name}: signatures ready")
                self.refresh(index)

            def failed(e, index=index, mesh=mesh):
                self._jobs.pop(index, None)
                self.status.emit(f"{mesh.name}: signatures failed: {e}")

            self._jobs[index] = Job(cached_face_features, (mesh.V, mesh.F), dispatcher=self.dispatcher,
                                    on_done=done, on_error=failed, name="scribbleseg-signatures").start()
        return None

    def hover_text(self, face: int) -> str | None:
        """What the status bar says about file face `face` of the current shape."""
        m = self.model
        i = m.current
        if face < 0 or i < 0 or not m.shapes[i].loaded:
            return None
        names = m.label_set.names
        scribble = int(m.layer(i).labels[face]) if face < len(m.layer(i).labels) else -1
        labels = m.shown_labels(i)
        label = int(labels[face]) if labels is not None and face < len(labels) else -1
        text = f"{m.shapes[i].name}  face {face}: label {names[label] if 0 <= label < len(names) else '—'}"
        if scribble >= 0:
            text += f", scribbled {names[scribble] if scribble < len(names) else scribble}"
        if self.mode in FEATURE_COLUMN and (i, FEATURE_COLUMN[self.mode]) in self._features:
            text += f", {self.mode[9:]} = {self._features[(i, FEATURE_COLUMN[self.mode])][face]:.4g}"
        return text

    # ------------------------------------------------------------------ the shown shape

    def _on_current_changed(self, index: int) -> None:
        entry = self.model.shapes[index]
        if entry.state == "error":
            return
        if entry.loaded:
            self._show(index)
            return
        self.status.emit(f"{entry.name}: loading…")
        if self._loading is not None:
            self._loading.cancel()  # the user moved on: its result would show the wrong shape
        generation = self.model.generation

        def loaded(_mesh, index=index):
            self._loading = None
            if generation == self.model.generation and index == self.model.current:
                self._show(index)

        def failed(e, index=index):
            self._loading = None
            if generation == self.model.generation:
                self.model.mark_error(index, str(e))

        self._loading = Job(entry.mesh, dispatcher=self.dispatcher, on_done=loaded, on_error=failed,
                            name="scribbleseg-load").start()

    def _show(self, index: int) -> None:
        mesh = self.model.shapes[index].mesh()
        self.showing = index
        self.viewport.show(mesh.V_file, mesh.F_file, self.colors(index))
        self.status.emit(f"{mesh.name}: {mesh.report.summary()}")
        self.shown.emit(index)

    def _on_collection_changed(self) -> None:
        for job in self._jobs.values():
            job.cancel()
        self._jobs.clear()
        self._features.clear()
        if self._loading is not None:
            self._loading.cancel()
            self._loading = None
        self.showing = -1

    def shutdown(self, timeout: float = 5.0) -> None:
        """Cancel background work (quitting); jobs that are mid-computation are not waited for
        past `timeout`."""
        jobs = [*self._jobs.values(), *([self._loading] if self._loading else [])]
        for job in jobs:
            job.cancel()
        for job in jobs:
            job.join(timeout)
