"""The main window: the collection's shapes and labels beside a polyscope viewport."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import time

from PySide6.QtCore import QObject, Qt, QTimer, Signal
from PySide6.QtGui import QAction, QColor, QIcon, QKeySequence, QPixmap, QShortcut
from PySide6.QtWidgets import (
    QCheckBox,
    QFileDialog,
    QColorDialog,
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

from app.energy_plot import EnergyPlot
from app.model import CollectionModel
from scribbleseg_core import __version__

#: Default collection when none is given: the bundled demo creatures.
DEFAULT_COLLECTION = Path(__file__).resolve().parents[1] / "assets" / "Quadruped"
FRAME_MS = 16


class _Bridge(QObject):
    """Carries results from worker threads onto the main thread (queued signal)."""

    preview_done = Signal(object)


def _swatch(rgb) -> QIcon:
    pm = QPixmap(14, 14)
    pm.fill(QColor.fromRgbF(*[float(c) for c in rgb]))
    return QIcon(pm)


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
        self.setWindowTitle(f"scribbleseg {__version__}")
        self.resize(460, 720)
        if autosave_dir is None:
            import platformdirs

            autosave_dir = Path(platformdirs.user_state_dir("scribbleseg")) / "autosave"
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
        layout.addLayout(row)
        layout.addWidget(self.paint_box)
        row = QHBoxLayout()
        row.addWidget(self.eraser_box)
        row.addWidget(QLabel("Brush ([ ])"))
        row.addWidget(self.brush_slider)
        layout.addLayout(row)
        layout.addWidget(self.preview_box)
        self.run_button = QPushButton("Segment collection")
        self.stop_button = QPushButton("Stop")
        self.stop_button.setEnabled(False)
        self.export_button = QPushButton("Export all…")
        row = QHBoxLayout()
        row.addWidget(self.run_button)
        row.addWidget(self.stop_button)
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
        # Application-wide: one main window, and text fields still take their own keys.
        app_wide = Qt.ShortcutContext.ApplicationShortcut
        self.undo_action = QAction("Undo", self, shortcut=QKeySequence.StandardKey.Undo, triggered=self.model_undo)
        self.redo_action = QAction("Redo", self, shortcut=QKeySequence("Ctrl+Shift+Z"), triggered=self.model_redo)
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
        self.paint_box.toggled.connect(self._on_paint_toggled)
        self.eraser_box.toggled.connect(lambda on: m.set_current_label(-1 if on else max(self.label_list.currentRow(), 0)))
        self.brush_slider.valueChanged.connect(lambda v: setattr(m, "brush_radius", v / 1000.0))
        self.run_button.clicked.connect(self.run_collection)
        self.stop_button.clicked.connect(self.stop_run)
        self.export_button.clicked.connect(self._on_export)
        m.collection_changed.connect(self._on_collection_changed)
        m.current_changed.connect(self._on_current_changed)
        m.labels_changed.connect(self._on_labels_changed)
        m.scribbles_changed.connect(self._on_scribbles_changed)
        m.state_changed.connect(self._on_state_changed)
        m.edit_committed.connect(self.request_preview)
        self._bridge.preview_done.connect(self._on_preview_done)
        self.preview_box.toggled.connect(lambda on: on and self.model.current >= 0 and self.request_preview(self.model.current))
        m.error.connect(self._on_error)

    @property
    def viewport(self):
        if self._viewport is None:
            from app.viewport import PolyscopeViewport

            self._attach(PolyscopeViewport())
        return self._viewport

    def _attach(self, viewport) -> None:
        """Make `viewport` this window's: its strokes go to this window's model."""
        self._viewport = viewport
        viewport.paint_mode = False
        viewport.set_paint_handlers(self.model.begin_stroke, self.model.paint_at, self.model.end_stroke)
        viewport.set_key_handler(self._on_viewport_key)

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
        self.viewport.show(mesh.V_file, mesh.F_file, self.model.face_colors(index))
        self.statusBar().showMessage(f"{entry.name}: {mesh.report.summary()}")

    def _on_scribbles_changed(self, index: int, faces: np.ndarray) -> None:
        if index == self.model.current:
            self.viewport.set_colors(self.model.face_colors(index))

    def _on_state_changed(self, index: int) -> None:
        entry = self.model.shapes[index]
        self.shape_list.item(index).setText(f"{entry.name}   [{entry.state}]")

    # ---------------------------------------------------------------- preview

    def request_preview(self, index: int) -> None:
        """Re-propagate shape `index`'s labels in the background; older requests go stale."""
        if not self.preview_box.isChecked() or self.model.shapes[index].state == "error":
            return
        from app.preview import PreviewRequest, PreviewWorker

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
            self.viewport.set_colors(self.model.face_colors(result.index))
        self.last_preview_seconds = result.seconds
        self.statusBar().showMessage(f"{entry.name}: preview in {result.seconds * 1000:.0f} ms")

    def preview_idle(self) -> bool:
        """True when the latest requested preview has arrived (tests wait on this)."""
        return self._done_generation == self._preview_generation

    # ---------------------------------------------------------------- run

    def run_collection(self) -> None:
        """Segment the scribbled shapes and predict the others, in a worker thread."""
        from superqt.utils import thread_worker

        from app.runner import collection_run, limit_threads

        m = self.model
        usable = [i for i, e in enumerate(m.shapes) if e.state != "error"]
        scribbles = [m.layer(i).labels.copy() for i in usable]
        if not any((s >= 0).any() for s in scribbles):
            self._on_error("paint at least one stroke before segmenting")
            return
        limit_threads(1)
        meshes = [m.shapes[i].mesh() for i in usable]
        self._run_indices = usable
        self.energy_plot.clear()
        self.progress.setRange(0, len(usable))
        self.progress.setValue(0)
        self.worker = thread_worker(collection_run, start_thread=False)(meshes, scribbles, m.label_set.names)
        self.worker.yielded.connect(self._on_run_message)
        self.worker.errored.connect(lambda e: self._on_error(f"segmentation failed: {e}"))
        self.worker.finished.connect(self._on_run_finished)
        self.run_button.setEnabled(False)
        self.stop_button.setEnabled(True)
        self.statusBar().showMessage("computing shape signatures…")
        self.worker.start()

    def stop_run(self) -> None:
        if self.worker is not None:
            self.worker.quit()  # stops between two steps; labels so far stay

    def _on_run_message(self, msg) -> None:
        from app.runner import FeaturesDone, Predicted, StepDone

        m = self.model
        if isinstance(msg, FeaturesDone):
            self.progress.setValue(msg.done)
            return
        if isinstance(msg, StepDone):
            snap = msg.snapshot
            for j, labels in zip(msg.indices, msg.file_labels):
                self._set_result(self._run_indices[j], labels, "labeled")
            if snap.iteration >= 1 and snap.phase in ("train", "graphcut"):
                self.energy_plot.add(snap.energy.total)
            if snap.done:
                m.trained_model = snap.model
            self.statusBar().showMessage(f"iteration {snap.iteration}: {snap.phase} ({snap.seconds:.1f} s)")
        elif isinstance(msg, Predicted):
            self._set_result(self._run_indices[msg.index], msg.file_labels, "predicted")

    def _set_result(self, index: int, labels, state: str) -> None:
        entry = self.model.shapes[index]
        entry.labels = labels
        entry.preview = None  # the run's labels are newer
        entry.state = state
        self._on_state_changed(index)
        if index == self.model.current:
            self.viewport.set_colors(self.model.face_colors(index))

    def _on_run_finished(self) -> None:
        self.run_button.setEnabled(True)
        self.stop_button.setEnabled(False)
        self.worker = None
        self.statusBar().showMessage("segmentation finished")

    # ---------------------------------------------------------------- export

    def _on_export(self) -> None:
        folder = QFileDialog.getExistingDirectory(self, "Export labeled meshes to")
        if folder:
            self.export_all(folder)

    def export_all(self, folder) -> list:
        """Write every shape that has a result (or scribbles) as PLY, SEG, OBJ, GLB, JSON."""
        from scribbleseg_core.errors import ScribblesegError
        from scribbleseg_core.export import export_labeled_mesh

        written = []
        for i, entry in enumerate(self.model.shapes):
            if entry.state == "error":
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

    def closeEvent(self, event) -> None:
        if self._preview_worker is not None:
            self._preview_worker.close()
        if self.worker is not None:
            self.worker.quit()
        super().closeEvent(event)

    def _on_frame(self) -> None:
        if self._viewport is not None:
            self._viewport.tick()
