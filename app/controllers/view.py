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

from scribbleseg_core.geometry.measures import face_centroids

#: What the surface shows ("Show" menu); features are the columns of ``face_features``.
SHOW_MODES = ("Labels and scribbles", "Scribbles only", "Result only", "Confidence",
              "Feature: AGD", "Feature: SDF", "Feature: Gaussian curvature", "Feature: SI-HKS (band 1)")
#: The bare surface: what a hidden label, or a face without labels, shows.
SURFACE = np.array([0.78, 0.78, 0.78])
#: Tint of the region a fill click would paint.
FILL_TINT = np.array([1.0, 1.0, 1.0])
#: The suggested region ("paint here next") is hatched: every other band of faces, across the
#: shape, darkened to this fraction of its colour, so that it reads as a mark over the labels
#: (which show between the stripes) and never as a label of its own.
SUGGESTION_SHADE = 0.3
#: Width of a hatching band, as a fraction of the shape's bounding-box diagonal (narrower on a
#: small region, so that it shows at least four bands).
SUGGESTION_BAND = 0.025
FEATURE_COLUMN = {"Feature: AGD": 0, "Feature: SDF": 1, "Feature: Gaussian curvature": 2, "Feature: SI-HKS (band 1)": 3}


def value_colors(values: np.ndarray, span: tuple[float, float] | None = None) -> np.ndarray:
    """A blue-to-yellow ramp (viridis anchors) of `values` (m,) over `span` (lo, hi), by default
    between their 2nd and 98th percentiles; (m, 3) float64 RGB."""
    anchors = np.array([[0.267, 0.005, 0.329], [0.229, 0.322, 0.546], [0.128, 0.567, 0.551],
                        [0.369, 0.789, 0.383], [0.993, 0.906, 0.144]])
    v = np.asarray(values, dtype=np.float64)
    finite = np.isfinite(v)
    if span is not None:
        lo, hi = span
    else:
        lo, hi = np.percentile(v[finite], [2, 98]) if finite.any() else (0.0, 1.0)
    t = np.clip((np.where(finite, v, lo) - lo) / max(hi - lo, 1e-300), 0, 1) * (len(anchors) - 1)
    i = np.minimum(t.astype(int), len(anchors) - 2)
    f = (t - i)[:, None]
    return anchors[i] * (1 - f) + anchors[i + 1] * f


def hatched(mesh, faces: np.ndarray) -> np.ndarray:
    """Which of the file faces `faces` (k,) of `mesh` lie in the dark bands of a hatching of
    them: bands along (1, 1, 1), the first dark, of width ``SUGGESTION_BAND`` × the shape's
    bounding-box diagonal, or a quarter of the faces' extent along it where that is narrower
    (a small region still shows bands, and at least one dark face); (k,) bool."""
    V, F = mesh.V_file, mesh.F_file
    # A sum, not `@`: a BLAS call here changed the thread state under which the asset
    # generator's remeshing later ran in the same test process (tests/test_assets.py).
    along = face_centroids(V, F[np.asarray(faces, dtype=np.int64)]).sum(axis=1) / np.sqrt(3.0)
    if along.size == 0:
        return np.zeros(0, bool)
    along = along - along.min()
    width = min(SUGGESTION_BAND * float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))), along.max() / 4)
    return np.floor(along / max(width, 1e-12)).astype(np.int64) % 2 == 0


class ViewController:
    """Keeps the viewport showing the model's current shape in the chosen mode.

    Events
    ------
    status(message)
        Something worth a line in the status bar (a shape shown, signatures computing).
    shown(index)
        Shape `index` is in the viewport (its mesh loaded).

    Labels can be hidden or faded (:meth:`set_label_opacity`, :attr:`only_current`): a face
    shows its label's colour blended over the bare surface by the label's opacity. The region a
    fill would paint (:meth:`set_highlight`) is tinted on top; the suggested region (the model's
    :attr:`~scribbleseg_app.model.CollectionModel.suggestion`; not over the confidence, which
    shows it already) is hatched (:func:`hatched`).

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
        self.opacity: dict[int, float] = {}  # label -> opacity in [0, 1]; 1 when absent
        self._label_count = len(model.label_set)
        self.only_current = False
        self.highlight: tuple[int, np.ndarray] | None = None  # (shape, file faces) a fill would paint
        self._hatch: tuple[object, np.ndarray] | None = None  # (suggestion, its dark file faces)
        model.collection_changed.connect(self._on_collection_changed)
        model.confidence_changed.connect(self.refresh)
        model.suggestion_changed.connect(lambda: self.refresh(model.current))
        model.current_label_changed.connect(lambda label: self.only_current and self.refresh(model.current))
        model.current_changed.connect(self._on_current_changed)
        model.scribbles_changed.connect(lambda index, faces: self.refresh(index))
        model.result_changed.connect(self.refresh)
        model.labels_changed.connect(self._on_labels_changed)

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

    def _on_labels_changed(self) -> None:
        if len(self.model.label_set) != self._label_count:  # a label added or deleted: ids moved
            self._label_count = len(self.model.label_set)
            self.opacity.clear()
        self.refresh(self.model.current)

    def set_label_opacity(self, label: int, opacity: float) -> None:
        """Show `label`'s scribbles and results at `opacity` in [0, 1] (0 hides them)."""
        self.opacity[int(label)] = float(np.clip(opacity, 0.0, 1.0))
        self.refresh(self.model.current)

    def label_opacity(self, label: int) -> float:
        return self.opacity.get(int(label), 1.0)

    def set_only_current(self, on: bool) -> None:
        """Show only the label the brush paints (the others as the bare surface)."""
        self.only_current = bool(on)
        self.refresh(self.model.current)

    def set_highlight(self, index: int, faces: np.ndarray | None) -> None:
        """Tint file faces `faces` of shape `index` (the region a fill would paint); None clears."""
        old, self.highlight = self.highlight, None if faces is None else (index, np.asarray(faces, dtype=np.int64))
        if old is not None or faces is not None:
            self.refresh(index)

    # ------------------------------------------------------------------ colours

    def colors(self, index: int) -> np.ndarray | None:
        """Face colours of shape `index` in the current mode, (m0, 3) float64; None while
        its mesh is not loaded. A feature not computed yet, or a confidence before any run,
        shows the labels meanwhile."""
        m = self.model
        entry = m.shapes[index]
        if not entry.loaded:
            return None
        feature = self.feature_values(index, FEATURE_COLUMN[self.mode]) if self.mode in FEATURE_COLUMN else None
        if self.mode == "Confidence" and entry.confidence is not None:
            colors = value_colors(entry.confidence, (0.0, 1.0))
        elif feature is not None:
            colors = value_colors(feature)
        else:
            colors = self._label_colors(index)
        suggestion = m.suggestion
        if suggestion is not None and suggestion.index == index and self.mode != "Confidence":
            if self._hatch is None or self._hatch[0] is not suggestion:
                self._hatch = suggestion, suggestion.faces[hatched(entry.mesh(), suggestion.faces)]
            dark = self._hatch[1]
            colors[dark] = SUGGESTION_SHADE * colors[dark]
        if self.highlight is not None and self.highlight[0] == index:
            faces = self.highlight[1]
            colors[faces] = 0.4 * colors[faces] + 0.6 * FILL_TINT
        return colors

    def _label_colors(self, index: int) -> np.ndarray:
        """Labels and scribbles (or one of them, by mode), each label at its opacity over the bare surface."""
        m = self.model
        m0 = m.shapes[index].mesh().num_file_faces
        scribble = m.layer(index).labels
        result = m.shown_labels(index)
        result = result if result is not None else np.full(m0, -1)
        if self.mode == "Scribbles only":
            shown, colors = scribble, m.label_set.face_colors(scribble)
        elif self.mode == "Result only":
            shown, colors = result, m.label_set.face_colors(result)
        else:
            shown, colors = np.where(scribble >= 0, scribble, result), m.face_colors(index)
        k = len(m.label_set)
        alpha = np.array([self.label_opacity(j) for j in range(k)] + [1.0])  # the last: unlabeled
        if self.only_current and m.current_label >= 0:  # (with the eraser, every label shows)
            alpha[:k] = np.arange(k) == m.current_label
        a = alpha[np.where(shown >= 0, shown, k)][:, None]
        if (a < 1).any():
            colors = a * colors + (1 - a) * SURFACE
        return colors

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
        confidence = m.shapes[i].confidence
        if confidence is not None and face < len(confidence):
            text += f", confidence {confidence[face]:.2f}"
        suggestion = m.suggestion
        if suggestion is not None and suggestion.index == i and np.isin(face, suggestion.faces):
            text += " (hatched: paint here next)"
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
        self.highlight = None
        self.opacity.clear()
        self._label_count = len(self.model.label_set)
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
