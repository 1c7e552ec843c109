"""The main window: the collection's shapes and labels beside a polyscope viewport."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from PySide6.QtCore import QObject, Qt, QTimer, Signal
from PySide6.QtGui import QAction, QColor, QIcon, QKeySequence, QPixmap, QShortcut
from PySide6.QtWidgets import (
    QCheckBox,
    QColorDialog,
    QComboBox,
    QFileDialog,
    QHBoxLayout,
    QInputDialog,
    QLabel,
    QListWidget,
    QListWidgetItem,
    QMainWindow,
    QMessageBox,
    QProgressBar,
    QPushButton,
    QSlider,
    QVBoxLayout,
    QWidget,
)
from scribbleseg_app.energy_plot import EnergyPlot
from scribbleseg_app.model import CollectionModel

from scribbleseg_core import __version__
from scribbleseg_core.infra.user_dirs import default_state_dir

#: Default collection when none is given: the bundled demo creatures.
DEFAULT_COLLECTION = Path(__file__).resolve().parents[1] / "assets" / "Quadruped"
FRAME_MS = 16
#: What the surface shows ("Show" menu); features are the columns of ``face_features``.
SHOW_MODES = ("Labels and scribbles", "Scribbles only", "Result only",
              "Feature: AGD", "Feature: SDF", "Feature: Gaussian curvature", "Feature: SI-HKS (band 1)")
FEATURE_COLUMN = {"Feature: AGD": 0, "Feature: SDF": 1, "Feature: Gaussian curvature": 2, "Feature: SI-HKS (band 1)": 3}


class _Bridge(QObject):
    """Carries results from worker threads onto the main thread (queued signal)."""

    preview_done = Signal(object)


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


def _swatch(rgb) -> QIcon:
    pm = QPixmap(14, 14)
    pm.fill(QColor.fromRgbF(*[float(c) for c in rgb]))
    return QIcon(pm)


def warm_imports() -> None:
    """Import the engine's heavy modules now, on the main thread. Imported first inside a
    worker, torch alone holds the interpreter for about a second, and the viewport freezes
    mid-run."""
    import maxflow  # noqa: F401
    import potpourri3d  # noqa: F401
    import scipy.sparse.linalg  # noqa: F401
    import torch  # noqa: F401

    import scribbleseg_core.engine.optimize  # noqa: F401
    import scribbleseg_core.engine.pipeline  # noqa: F401


class MainWindow(QMainWindow):
    """Top-level window; the viewport is polyscope's own window (it cannot be embedded).

    Parameters
    ----------
    path : str, optional
        A collection folder or one mesh; default :data:`DEFAULT_COLLECTION`.
    viewport : PolyscopeViewport, optional
        Made on first use when not given (tests pass their own).
    autosave_dir : str, optional
        Where scribbles are saved after every stroke; default the user state folder.
    """

    def __init__(self, path: str | None = None, viewport=None, autosave_dir=None):
        super().__init__()
        warm_imports()
        self.setWindowTitle(f"scribbleseg {__version__}")
        self.resize(460, 720)
        if autosave_dir is None:
            autosave_dir = default_state_dir() / "autosave"
        self.model = CollectionModel(autosave_dir)
        self._viewport = None
        if viewport is not None:
            self._attach(viewport)
        self._build_widgets()
        self._connect()
        self.timer = QTimer(self)
        self.timer.timeout.connect(self._on_frame)
        self.timer.start(FRAME_MS)
        self.model.open(path or DEFAULT_COLLECTION)

    # ---------------------------------------------------------------- layout

    def _build_widgets(self) -> None:
        self.shape_list = QListWidget()
        self.label_list = QListWidget()
        self.add_label_button = QPushButton("Add label")
        self.color_button = QPushButton("Color…")
        self.delete_label_button = QPushButton("Delete")
        self.paint_box = QCheckBox("Paint: left-drag on the shape (drag elsewhere or Shift+drag to orbit)")
        self.eraser_box = QCheckBox("Eraser")
        self.preview_box = QCheckBox("Live preview after each stroke")
        self.preview_box.setChecked(True)
        self.brush_slider = QSlider(Qt.Orientation.Horizontal)
        self.brush_slider.setRange(1, 100)
        self.brush_slider.setValue(20)
        panel = QWidget()
        layout = QVBoxLayout(panel)
        layout.addWidget(QLabel("Shapes"))
        layout.addWidget(self.shape_list, 3)
        layout.addWidget(QLabel("Labels (keys 1–9; double-click to rename)"))
        layout.addWidget(self.label_list, 2)
        row = QHBoxLayout()
        row.addWidget(self.add_label_button)
        row.addWidget(self.color_button)
        row.addWidget(self.delete_label_button)
        layout.addLayout(row)
        layout.addWidget(self.paint_box)
        row = QHBoxLayout()
        row.addWidget(self.eraser_box)
        row.addWidget(QLabel("Brush ([ ])"))
        row.addWidget(self.brush_slider)
        layout.addLayout(row)
        layout.addWidget(self.preview_box)
        self.show_combo = QComboBox()
        self.show_combo.addItems(SHOW_MODES)
        row = QHBoxLayout()
        row.addWidget(QLabel("Show"))
        row.addWidget(self.show_combo, 1)
        layout.addLayout(row)
        self.run_button = QPushButton("Segment collection")
        self.stop_button = QPushButton("Stop")
        self.stop_button.setEnabled(False)
        self.predict_button = QPushButton("Predict unlabeled")
        self.predict_button.setToolTip("Segment the shapes that have neither scribbles nor a result with the trained network")
        self.export_button = QPushButton("Export all…")
        row = QHBoxLayout()
        row.addWidget(self.run_button)
        row.addWidget(self.stop_button)
        layout.addLayout(row)
        row = QHBoxLayout()
        row.addWidget(self.predict_button)
        row.addWidget(self.export_button)
        layout.addLayout(row)
        self.progress = QProgressBar()
        self.progress.setFormat("%v / %m")
        layout.addWidget(self.progress)
        self.energy_plot = EnergyPlot()
        layout.addWidget(self.energy_plot)
        self.setCentralWidget(panel)
        self.worker = None
        self._bridge = _Bridge(self)
        self._preview_worker = None
        self._preview_generation = 0
        self._done_generation = 0
        self.last_preview_seconds: float | None = None
        self._features: dict[tuple[int, int], np.ndarray] = {}
        self._features_pending: set[int] = set()
        self._collection_generation = 0
        self._run_generation = 0
        self._quitting = False  # set once the user chose to quit (skips the unsaved-work question)
        self._last_frame: float | None = None
        self.run_max_frame_gap = 0.0  # longest time between two frames during the last run (s)
        self.run_seconds = 0.0
        self._run_started = 0.0
        self._placed = False
        # Application-wide: one main window, and text fields still take their own keys.
        app_wide = Qt.ShortcutContext.ApplicationShortcut
        self.undo_action = QAction("Undo", self, shortcut=QKeySequence.StandardKey.Undo, triggered=self.model_undo)
        self.redo_action = QAction("Redo", self, shortcut=QKeySequence("Ctrl+Shift+Z"), triggered=self.model_redo)
        file_menu = self.menuBar().addMenu("&File")
        for text, key, slot in (
            ("Open collection…", QKeySequence.StandardKey.Open, self._on_open_collection),
            ("Open session…", None, self._on_open_session),
            ("Add meshes…", None, self._on_add_meshes),
            ("Save session", QKeySequence.StandardKey.Save, self.save_session),
            ("Save session as…", QKeySequence.StandardKey.SaveAs, self._on_save_session_as),
            ("Export current shape…", None, self._on_export_current),
            ("Export all…", None, self._on_export),
            ("Quit", QKeySequence.StandardKey.Quit, self.close),  # asks about unsaved work first
        ):
            action = QAction(text, self, triggered=slot)
            if key is not None:
                action.setShortcut(key)
            file_menu.addAction(action)
        edit = self.menuBar().addMenu("&Edit")
        for action in (self.undo_action, self.redo_action):
            action.setShortcutContext(app_wide)
            edit.addAction(action)
        keys = [(str(k), lambda k=k: self._choose_label(k - 1)) for k in range(1, 10)]
        keys += [("[", lambda: self._grow_brush(-5)), ("]", lambda: self._grow_brush(5))]
        for key, slot in keys:
            QShortcut(QKeySequence(key), self, activated=slot, context=app_wide)

    def _connect(self) -> None:
        m = self.model
        self.shape_list.currentRowChanged.connect(m.set_current)
        self.label_list.currentRowChanged.connect(self._on_label_row)
        self.label_list.itemDoubleClicked.connect(self._on_rename)
        self.add_label_button.clicked.connect(self._on_add_label)
        self.color_button.clicked.connect(self._on_recolor)
        self.delete_label_button.clicked.connect(self._on_delete_label)
        self.show_combo.currentIndexChanged.connect(lambda _: self._refresh_colors())
        self.predict_button.clicked.connect(self.predict_unlabeled)
        self.paint_box.toggled.connect(self._on_paint_toggled)
        self.eraser_box.toggled.connect(lambda on: m.set_current_label(-1 if on else max(self.label_list.currentRow(), 0)))
        self.brush_slider.valueChanged.connect(lambda v: setattr(m, "brush_radius", v / 1000.0))
        self.run_button.clicked.connect(self.run_collection)
        self.stop_button.clicked.connect(self.stop_run)
        self.export_button.clicked.connect(self._on_export)
        m.collection_changed.connect(self._on_collection_changed)
        m.unsaved_changed.connect(lambda _unsaved: self._update_title())
        m.current_changed.connect(self._on_current_changed)
        m.labels_changed.connect(self._on_labels_changed)
        m.scribbles_changed.connect(self._on_scribbles_changed)
        m.state_changed.connect(self._on_state_changed)
        m.edit_committed.connect(self.request_preview)
        m.shapes_added.connect(self._on_shapes_added)
        m.restore_available.connect(lambda n: QTimer.singleShot(0, lambda: self._offer_restore(n)))
        self._bridge.preview_done.connect(self._on_preview_done)
        self.preview_box.toggled.connect(lambda on: on and self.model.current >= 0 and self.request_preview(self.model.current))
        m.error.connect(self._on_error)

    @property
    def viewport(self):
        if self._viewport is None:
            from scribbleseg_app.viewport import PolyscopeViewport

            self._attach(PolyscopeViewport())
        return self._viewport

    def _attach(self, viewport) -> None:
        """Make `viewport` this window's: its strokes go to this window's model."""
        self._viewport = viewport
        viewport.paint_mode = False
        viewport.set_paint_handlers(self.model.begin_stroke, self.model.paint_at, self.model.end_stroke)
        viewport.set_key_handler(self._on_viewport_key)
        viewport.set_hover_handler(self._on_hover)

    # ---------------------------------------------------------------- handlers

    def model_undo(self) -> None:
        self.model.undo()

    def model_redo(self) -> None:
        self.model.redo()

    def _grow_brush(self, step: int) -> None:
        self.brush_slider.setValue(self.brush_slider.value() + step)

    def _on_viewport_key(self, command: str) -> None:
        """The same keys as the window's shortcuts, pressed in polyscope's window."""
        if command == "undo":
            self.model_undo()
        elif command == "redo":
            self.model_redo()
        elif command.startswith("label "):
            self._choose_label(int(command.split()[1]))
        elif command in ("brush -", "brush +"):
            self._grow_brush(-5 if command == "brush -" else 5)

    def _choose_label(self, label: int) -> None:
        if 0 <= label < self.label_list.count():
            self.eraser_box.setChecked(False)
            self.label_list.setCurrentRow(label)

    def _on_label_row(self, row: int) -> None:
        if row >= 0 and not self.eraser_box.isChecked():
            self.model.set_current_label(row)

    def _on_add_label(self) -> None:
        name, ok = QInputDialog.getText(self, "Add label", "Name of the new label:")
        if ok:
            try:
                k = self.model.add_label(name)
            except ValueError as e:
                self._on_error(str(e))
                return
            self.label_list.setCurrentRow(k)

    def _on_rename(self, item: QListWidgetItem) -> None:
        row = self.label_list.row(item)
        name, ok = QInputDialog.getText(self, "Rename label", "New name:", text=self.model.label_set.names[row])
        if ok:
            try:
                self.model.rename_label(row, name)
            except ValueError as e:
                self._on_error(str(e))

    def _on_recolor(self) -> None:
        row = self.label_list.currentRow()
        if row < 0:
            return
        color = QColorDialog.getColor(QColor.fromRgbF(*self.model.label_set.colors[row]), self)
        if color.isValid():
            self.model.recolor_label(row, (color.redF(), color.greenF(), color.blueF()))

    def _on_paint_toggled(self, on: bool) -> None:
        self.viewport.paint_mode = on

    def _on_collection_changed(self) -> None:
        self._collection_generation += 1
        if self.worker is not None:  # its shapes and labels are the previous collection's
            self.worker.quit()
        self._features.clear()
        self._features_pending.clear()
        self._preview_generation += 1  # a pending preview belongs to the old collection
        self._update_title()
        self.shape_list.clear()
        for entry in self.model.shapes:
            self.shape_list.addItem(QListWidgetItem(f"{entry.name}   [{entry.state}]"))
        self._on_labels_changed()
        if self.label_list.count():
            self.label_list.setCurrentRow(0)
        self.statusBar().showMessage(f"{self.model.folder}: {len(self.model.shapes)} shapes")

    def _on_labels_changed(self) -> None:
        row = self.label_list.currentRow()
        self.label_list.clear()
        for i, (name, rgb) in enumerate(zip(self.model.label_set.names, self.model.label_set.colors)):
            self.label_list.addItem(QListWidgetItem(_swatch(rgb), f"{i + 1}  {name}"))
        if 0 <= row < self.label_list.count():
            self.label_list.setCurrentRow(row)

    def _on_current_changed(self, index: int) -> None:
        if self.shape_list.currentRow() != index:
            self.shape_list.setCurrentRow(index)
        entry = self.model.shapes[index]
        self._on_state_changed(index)
        if entry.state == "error":
            return
        mesh = entry.mesh()
        self.viewport.show(mesh.V_file, mesh.F_file, self.shown_colors(index))
        self.statusBar().showMessage(f"{entry.name}: {mesh.report.summary()}")

    def _on_scribbles_changed(self, index: int, faces: np.ndarray) -> None:
        if index == self.model.current:
            self._refresh_colors()

    def _on_state_changed(self, index: int) -> None:
        entry = self.model.shapes[index]
        self.shape_list.item(index).setText(f"{entry.name}   [{entry.state}]")

    # ---------------------------------------------------------------- inspect

    def shown_colors(self, index: int) -> np.ndarray:
        """Face colors of shape `index` for the chosen "Show" mode, (m0, 3) float64."""
        m = self.model
        mode = self.show_combo.currentText()
        if mode == "Scribbles only":
            return m.label_set.face_colors(m.layer(index).labels)
        if mode == "Result only":
            labels = m.shown_labels(index)
            return m.label_set.face_colors(labels if labels is not None else np.full(m.shapes[index].mesh().num_file_faces, -1))
        if mode in FEATURE_COLUMN:
            values = self._feature_values(index, FEATURE_COLUMN[mode])
            if values is not None:
                return value_colors(values)
        return m.face_colors(index)

    def _refresh_colors(self) -> None:
        i = self.model.current
        if i >= 0 and self.model.shapes[i].state != "error":
            self.viewport.set_colors(self.shown_colors(i))

    def _feature_values(self, index: int, column: int) -> np.ndarray | None:
        """Per file face feature `column` of shape `index`, or None while it is computed in
        the background (the view refreshes when it is ready)."""
        key = (index, column)
        if key in self._features:
            return self._features[key]
        if index in self._features_pending:
            return None
        from superqt.utils import thread_worker

        from scribbleseg_core.signatures.features import cached_face_features

        mesh = self.model.shapes[index].mesh()
        self._features_pending.add(index)
        self.statusBar().showMessage(f"{mesh.name}: computing shape signatures…")

        generation = self._collection_generation

        def done(X, index=index, mesh=mesh):
            if generation != self._collection_generation:
                return  # another collection was opened meanwhile
            self._features_pending.discard(index)
            for c in set(FEATURE_COLUMN.values()):
                self._features[(index, c)] = mesh.labels_to_file(X[:, c])
            self.statusBar().showMessage(f"{mesh.name}: signatures ready")
            if index == self.model.current:
                self._refresh_colors()

        worker = thread_worker(cached_face_features, start_thread=False)(mesh.V, mesh.F)
        worker.returned.connect(done)
        worker.errored.connect(lambda e, index=index: (self._features_pending.discard(index), self._on_error(f"{mesh.name}: signatures failed: {e}")))
        worker.start()
        return None

    def _on_hover(self, face: int) -> None:
        m = self.model
        i = m.current
        if face < 0 or i < 0:
            return
        names = m.label_set.names
        scribble = int(m.layer(i).labels[face]) if face < len(m.layer(i).labels) else -1
        labels = m.shown_labels(i)
        label = int(labels[face]) if labels is not None and face < len(labels) else -1
        text = f"{m.shapes[i].name}  face {face}: label {names[label] if 0 <= label < len(names) else '—'}"
        if scribble >= 0:
            text += f", scribbled {names[scribble] if scribble < len(names) else scribble}"
        mode = self.show_combo.currentText()
        if mode in FEATURE_COLUMN and (i, FEATURE_COLUMN[mode]) in self._features:
            text += f", {mode[9:]} = {self._features[(i, FEATURE_COLUMN[mode])][face]:.4g}"
        self.statusBar().showMessage(text)

    # ---------------------------------------------------------------- preview

    def request_preview(self, index: int) -> None:
        """Re-propagate shape `index`'s labels in the background; older requests go stale."""
        if not self.preview_box.isChecked() or self.model.shapes[index].state == "error":
            return
        from scribbleseg_app.preview import PreviewRequest, PreviewWorker

        if self._preview_worker is None:
            self._preview_worker = PreviewWorker(self._bridge.preview_done.emit)
        m = self.model
        model = m.trained_model
        if model is not None and len(model.label_names) != len(m.label_set):
            model = None  # labels were added or deleted since the run
        self._preview_generation += 1
        self._preview_worker.request(
            PreviewRequest(self._preview_generation, index, m.shapes[index].mesh(), m.layer(index).labels.copy(),
                           max(len(m.label_set), 1), model, time.perf_counter())
        )

    def _on_preview_done(self, result) -> None:
        self._done_generation = max(self._done_generation, result.generation)
        if result.generation != self._preview_generation:
            return  # a newer stroke made this one stale
        if result.error:
            self.statusBar().showMessage(result.error)
            return
        entry = self.model.shapes[result.index]
        entry.preview = result.file_labels
        if result.index == self.model.current:
            self._refresh_colors()
        self.last_preview_seconds = result.seconds
        self.statusBar().showMessage(f"{entry.name}: preview in {result.seconds * 1000:.0f} ms")

    def preview_idle(self) -> bool:
        """True when the latest requested preview has arrived (tests wait on this)."""
        return self._done_generation == self._preview_generation

    # ---------------------------------------------------------------- run

    def run_collection(self) -> None:
        """Segment the collection (the shapes without scribbles take part as well), in a worker thread."""
        from scribbleseg_app.runner import LazyMeshes, collection_run

        m = self.model
        usable = [i for i, e in enumerate(m.shapes) if e.state != "error"]
        scribbles = [m.scribble_labels(i) for i in usable]
        if not any(s is not None and (s >= 0).any() for s in scribbles):
            self._on_error("paint at least one stroke before segmenting")
            return
        self.energy_plot.clear()
        meshes = LazyMeshes([m.shapes[i].mesh for i in usable])  # loaded by the worker
        self._start_worker(collection_run, (meshes, scribbles, m.label_set.names), usable,
                           "segmentation", "computing shape signatures…")

    def predict_unlabeled(self) -> None:
        """Segment the shapes with neither scribbles nor a result (e.g. meshes added after
        the run) with the trained network, in a worker thread."""
        from scribbleseg_app.runner import LazyMeshes, predict_run

        m = self.model
        if m.trained_model is None:
            self._on_error("no trained network yet: paint some shapes and run 'Segment collection' first")
            return
        if len(m.trained_model.label_names) != len(m.label_set):
            self._on_error("the labels changed since the network was trained: run 'Segment collection' again")
            return
        targets = [i for i, e in enumerate(m.shapes) if e.state == "untouched" and not m.has_scribbles(i)]
        if not targets:
            self.statusBar().showMessage("every shape already has scribbles or a result")
            return
        meshes = LazyMeshes([m.shapes[i].mesh for i in targets])
        self._start_worker(predict_run, (m.trained_model, meshes), targets, "prediction", f"predicting {len(targets)} shapes…")

    def _start_worker(self, generator, args: tuple, indices: list[int], what: str, status: str) -> None:
        """Run `generator(*args)` in a worker thread; its messages (about the shapes
        `indices`, in order) land in :meth:`_on_run_message` on this thread."""
        from scribbleseg_app.runner import limit_threads
        from superqt.utils import thread_worker

        limit_threads(1)
        self._run_indices = indices
        self.progress.setRange(0, len(indices))
        self.progress.setValue(0)
        self.worker = thread_worker(generator, start_thread=False)(*args)
        # a message from a run of another collection (opened since) is dropped, not applied to this one
        generation = self._run_generation = self._collection_generation
        self.worker.yielded.connect(
            lambda msg: self._on_run_message(msg) if generation == self._collection_generation else None)
        self.worker.errored.connect(lambda e: self._on_error(f"{what} failed: {e}"))
        self.worker.finished.connect(self._on_run_finished)
        self._set_running(True)
        self.statusBar().showMessage(status)
        self.worker.start()

    def _set_running(self, on: bool) -> None:
        # label ids must not change under a running worker: its results use the old ones
        for b in (self.run_button, self.predict_button, self.add_label_button, self.delete_label_button):
            b.setEnabled(not on)
        self.stop_button.setEnabled(on)
        if on:
            self.run_max_frame_gap, self._run_started = 0.0, time.perf_counter()

    def stop_run(self) -> None:
        if self.worker is not None:
            self.worker.quit()  # stops between two steps; labels so far stay

    def _on_run_message(self, msg) -> None:
        from scribbleseg_app.runner import FeaturesDone, Predicted, StepDone

        m = self.model
        if isinstance(msg, FeaturesDone):
            self.progress.setValue(msg.done)
            return
        if isinstance(msg, StepDone):
            snap = msg.snapshot
            for j, labels in zip(msg.indices, msg.file_labels):
                index = self._run_indices[j]
                self._set_result(index, labels, "labeled" if m.has_scribbles(index) else "predicted")
            if snap.iteration >= 1 and snap.phase in ("train", "graphcut"):
                self.energy_plot.add(snap.energy.total)
            if snap.done:
                m.trained_model = snap.model
            self.statusBar().showMessage(f"iteration {snap.iteration}: {snap.phase} ({snap.seconds:.1f} s)")
        elif isinstance(msg, Predicted):
            self._set_result(self._run_indices[msg.index], msg.file_labels, "predicted")

    def _set_result(self, index: int, labels, state: str) -> None:
        self.model.set_result(index, labels, state)

    def _on_run_finished(self) -> None:
        self._set_running(False)
        self.worker = None
        self.run_seconds = time.perf_counter() - self._run_started
        if self._run_generation != self._collection_generation:
            self.statusBar().showMessage("the run was stopped: another collection was opened")
            return
        self.statusBar().showMessage(
            f"finished in {self.run_seconds:.1f} s (longest frame gap {self.run_max_frame_gap * 1000:.0f} ms)"
        )

    # ---------------------------------------------------------------- files

    def _update_title(self) -> None:
        m = self.model
        where = m.session_path or m.folder
        self.setWindowTitle(f"scribbleseg {__version__}" + (f" — {where.name}" if where else "") + (" *" if m.unsaved else ""))

    def _on_open_collection(self) -> None:
        if not self.keep_unsaved_work():
            return
        folder = QFileDialog.getExistingDirectory(self, "Open a folder of meshes")
        if folder:
            self.model.open(folder)

    def _on_open_session(self) -> None:
        if not self.keep_unsaved_work():
            return
        folder = QFileDialog.getExistingDirectory(self, "Open a session folder")
        if folder:
            self.model.open_session(folder)

    def keep_unsaved_work(self, *, can_cancel: bool = True) -> bool:
        """Before the collection goes away: offer to save a session if there are unsaved
        changes. Returns False if the user cancelled (or the save failed): stay."""
        if not self.model.unsaved or not self.model.shapes:
            return True
        answer = self._ask_unsaved(can_cancel)
        if answer == "save":
            return self.save_session() or not can_cancel
        return answer == "discard"

    def _ask_unsaved(self, can_cancel: bool) -> str:
        """'save', 'discard' or 'cancel' (tests replace this)."""
        buttons = QMessageBox.StandardButton.Save | QMessageBox.StandardButton.Discard
        if can_cancel:
            buttons |= QMessageBox.StandardButton.Cancel
        answer = QMessageBox.question(
            self, "Unsaved changes",
            "Save the results, labels and scribbles as a session?\n(Scribbles are autosaved either way "
            "and offered again when this collection is opened; results and label changes are not.)",
            buttons, QMessageBox.StandardButton.Save,
        )
        return {QMessageBox.StandardButton.Save: "save", QMessageBox.StandardButton.Discard: "discard"}.get(answer, "cancel")

    def _on_add_meshes(self) -> None:
        paths, _ = QFileDialog.getOpenFileNames(self, "Add meshes", "", "Meshes (*.off *.obj *.ply *.stl *.glb *.gltf)")
        if paths:
            self.model.add_meshes(paths)

    def _on_shapes_added(self, indices) -> None:
        for i in indices:
            entry = self.model.shapes[i]
            self.shape_list.addItem(QListWidgetItem(f"{entry.name}   [{entry.state}]"))
        self.statusBar().showMessage(f"added {len(indices)} shapes; 'Predict unlabeled' segments them")

    def save_session(self) -> bool:
        """Save to the open session's folder, or ask for one."""
        if self.model.session_path is None:
            return self._on_save_session_as()
        return self._save_session(self.model.session_path)

    def _on_save_session_as(self) -> bool:
        folder = QFileDialog.getExistingDirectory(self, "Save the session into a folder")
        return bool(folder) and self._save_session(Path(folder))

    def _save_session(self, folder: Path) -> bool:
        from scribbleseg_core.errors import ScribblesegError

        try:
            skipped = self.model.save_session(folder)
        except (OSError, ScribblesegError) as e:
            self._on_error(f"{folder}: saving the session failed: {e}")
            return False
        self._update_title()
        note = f" (left out, their mesh did not load: {', '.join(skipped)})" if skipped else ""
        self.statusBar().showMessage(f"session saved to {folder}{note}")
        return True

    def _confirm(self, title: str, text: str) -> bool:
        """Ask yes or no (tests replace this)."""
        answer = QMessageBox.question(self, title, text)
        return answer == QMessageBox.StandardButton.Yes

    def _offer_restore(self, count: int) -> None:
        folder = self.model.autosave_folder()
        if self._confirm("Restore scribbles?", f"{count} shape(s) have autosaved scribbles that differ from the ones "
                         f"opened (the app closed before they were saved).\nRestore them? (No sets the autosave aside in {folder.parent})"):
            restored = self.model.restore_autosave()
            self.statusBar().showMessage(f"restored the scribbles of {len(restored)} shapes (Ctrl+Z undoes each)")
        else:
            self.model.discard_autosave()

    def _on_delete_label(self) -> None:
        row = self.label_list.currentRow()
        if row < 0:
            return
        name = self.model.label_set.names[row]
        if self._confirm("Delete label", f"Delete label '{name}'? Its scribbles are erased and its result faces unlabeled."):
            erased = self.model.delete_label(row)
            self.statusBar().showMessage(f"deleted '{name}' ({erased} scribbled faces erased)")

    # ---------------------------------------------------------------- export

    def _on_export_current(self) -> None:
        folder = QFileDialog.getExistingDirectory(self, "Export the current shape to")
        if folder and self.model.current >= 0:
            self.export_all(folder, only=[self.model.current])

    def _on_export(self) -> None:
        folder = QFileDialog.getExistingDirectory(self, "Export labeled meshes to")
        if folder:
            self.export_all(folder)

    def export_all(self, folder, only=None) -> list:
        """Write every shape (or those in `only`) that has a result or scribbles as PLY,
        SEG, OBJ, GLB and JSON; what the user sees is what is written."""
        from scribbleseg_core.errors import ScribblesegError
        from scribbleseg_core.formats.export import export_labeled_mesh

        written = []
        for i, entry in enumerate(self.model.shapes):
            if entry.state == "error" or (only is not None and i not in only):
                continue
            labels = self.model.shown_labels(i)
            labels = labels if labels is not None else self.model.layer(i).labels
            if not (labels >= 0).any():  # neither a result nor scribbles
                continue
            mesh = entry.mesh()
            try:
                written += export_labeled_mesh(folder, entry.name, mesh.V_file, mesh.F_file, labels, self.model.label_set)
            except (OSError, ScribblesegError) as e:
                self._on_error(f"{entry.name}: export failed: {e}")
        self.statusBar().showMessage(f"exported {len(written)} files to {folder}")
        return written

    def _on_error(self, message: str) -> None:
        self.statusBar().showMessage(message)
        box = QMessageBox(QMessageBox.Icon.Warning, "scribbleseg", message, parent=self)
        box.setModal(False)
        box.show()

    def showEvent(self, event) -> None:
        super().showEvent(event)
        if not self._placed:
            self._placed = True
            self.place_beside_viewport()

    def place_beside_viewport(self) -> None:
        """Polyscope opens its window near the top-left corner and cannot be moved from
        here: size it to leave room, and put this window to its right."""
        screen = self.screen().availableGeometry() if self.screen() else None
        width = int(min(1280, screen.width() - self.width() - 50)) if screen is not None else 0
        if width < 640:  # too small a screen to share: leave both windows as they are
            return
        height = int(min(screen.height() - 60, width * 0.75))
        self.viewport.set_window_size(width, height)
        self.move(screen.x() + 20 + width + 10, screen.y())

    def closeEvent(self, event) -> None:
        if not self._quitting and not self.keep_unsaved_work():
            event.ignore()
            return
        if self._preview_worker is not None:
            self._preview_worker.close()
        if self.worker is not None:
            self.worker.quit()
        super().closeEvent(event)

    def _on_frame(self) -> None:
        now = time.perf_counter()
        if self.worker is not None and self._last_frame is not None:
            self.run_max_frame_gap = max(self.run_max_frame_gap, now - self._last_frame)
        self._last_frame = now
        if self._viewport is not None:
            self._viewport.tick()
            if self._viewport.close_requested:  # closing the viewport window quits the app
                self.timer.stop()
                self.keep_unsaved_work(can_cancel=False)  # polyscope cannot take the close back
                self._quitting = True
                self.close()
