"""The panels of the main window: shapes, labels, tools, run."""

from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtGui import QColor, QIcon, QPixmap
from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QHBoxLayout,
    QLabel,
    QListWidget,
    QListWidgetItem,
    QProgressBar,
    QPushButton,
    QSlider,
    QVBoxLayout,
    QWidget,
)
from scribbleseg_app.controllers.view import SHOW_MODES
from scribbleseg_app.widgets.energy_plot import EnergyPlot


def swatch(rgb) -> QIcon:
    pm = QPixmap(14, 14)
    pm.fill(QColor.fromRgbF(*[float(c) for c in rgb]))
    return QIcon(pm)


class ShapesPanel(QWidget):
    """The collection's shapes with their state; a shape the last round changed is marked ●.
    Choosing a row shows that shape."""

    def __init__(self, model, runs, parent=None):
        super().__init__(parent)
        self.model, self.runs = model, runs
        self.list = QListWidget()
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(QLabel("Shapes (● changed in the last round)"))
        layout.addWidget(self.list)
        self.list.currentRowChanged.connect(model.set_current)
        model.collection_changed.connect(self.rebuild)
        model.shapes_added.connect(lambda indices: self.rebuild())
        model.state_changed.connect(self.update_row)
        model.current_changed.connect(self._select)
        runs.step.connect(lambda snap: self.update_rows())

    def text(self, index: int) -> str:
        entry = self.model.shapes[index]
        mark = " ●" if index in self.runs.changed else ""
        return f"{entry.name}   [{entry.state}]{mark}"

    def rebuild(self) -> None:
        self.list.blockSignals(True)
        self.list.clear()
        for i in range(len(self.model.shapes)):
            self.list.addItem(QListWidgetItem(self.text(i)))
        if self.model.current >= 0:
            self.list.setCurrentRow(self.model.current)
        self.list.blockSignals(False)

    def update_row(self, index: int) -> None:
        item = self.list.item(index)
        if item is not None:
            item.setText(self.text(index))

    def update_rows(self) -> None:
        for i in range(self.list.count()):
            self.update_row(i)

    def _select(self, index: int) -> None:
        if self.list.currentRow() != index:
            self.list.blockSignals(True)
            self.list.setCurrentRow(index)
            self.list.blockSignals(False)


class LabelsPanel(QWidget):
    """The label set: choose the brush's label, add, recolour, rename (double-click), delete."""

    def __init__(self, model, parent=None):
        super().__init__(parent)
        self.model = model
        self.list = QListWidget()
        self.add_button = QPushButton("Add label")
        self.color_button = QPushButton("Color…")
        self.delete_button = QPushButton("Delete")
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(QLabel("Labels (keys 1–9; double-click to rename)"))
        layout.addWidget(self.list)
        row = QHBoxLayout()
        for b in (self.add_button, self.color_button, self.delete_button):
            row.addWidget(b)
        layout.addLayout(row)
        model.labels_changed.connect(self.rebuild)
        model.collection_changed.connect(self._on_collection)

    def rebuild(self) -> None:
        row = self.list.currentRow()
        self.list.blockSignals(True)
        self.list.clear()
        for i, (name, rgb) in enumerate(zip(self.model.label_set.names, self.model.label_set.colors)):
            self.list.addItem(QListWidgetItem(swatch(rgb), f"{i + 1}  {name}"))
        self.list.blockSignals(False)
        if 0 <= row < self.list.count():
            self.list.setCurrentRow(row)

    def _on_collection(self) -> None:
        self.rebuild()
        if self.list.count():
            self.list.setCurrentRow(0)


class ToolsPanel(QWidget):
    """Brush and view: paint mode, eraser, brush size, live preview, what the surface shows."""

    def __init__(self, parent=None):
        super().__init__(parent)
        self.paint_box = QCheckBox("Paint: left-drag on the shape (drag elsewhere or Shift+drag to orbit)")
        self.eraser_box = QCheckBox("Eraser")
        self.preview_box = QCheckBox("Live preview after each stroke")
        self.preview_box.setChecked(True)
        self.brush_slider = QSlider(Qt.Orientation.Horizontal)
        self.brush_slider.setRange(1, 100)
        self.brush_slider.setValue(20)
        self.show_combo = QComboBox()
        self.show_combo.addItems(SHOW_MODES)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.paint_box)
        row = QHBoxLayout()
        row.addWidget(self.eraser_box)
        row.addWidget(QLabel("Brush ([ ])"))
        row.addWidget(self.brush_slider)
        layout.addLayout(row)
        layout.addWidget(self.preview_box)
        row = QHBoxLayout()
        row.addWidget(QLabel("Show"))
        row.addWidget(self.show_combo, 1)
        layout.addLayout(row)


class RunPanel(QWidget):
    """Segment, stop, predict, export; the progress of the signatures and the energy plot."""

    def __init__(self, runs, parent=None):
        super().__init__(parent)
        self.runs = runs
        self.run_button = QPushButton("Segment collection")
        self.stop_button = QPushButton("Stop")
        self.stop_button.setEnabled(False)
        self.predict_button = QPushButton("Predict unlabeled")
        self.predict_button.setToolTip("Segment the shapes that have neither scribbles nor a result with the trained network")
        self.export_button = QPushButton("Export all…")
        self.progress = QProgressBar()
        self.progress.setFormat("%v / %m")
        self.energy_plot = EnergyPlot()
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        row = QHBoxLayout()
        row.addWidget(self.run_button)
        row.addWidget(self.stop_button)
        layout.addLayout(row)
        row = QHBoxLayout()
        row.addWidget(self.predict_button)
        row.addWidget(self.export_button)
        layout.addLayout(row)
        layout.addWidget(self.progress)
        layout.addWidget(self.energy_plot)
        runs.started.connect(self._on_started)
        runs.progress.connect(self._on_progress)
        runs.step.connect(lambda snap: self.energy_plot.set_history(runs.history))
        runs.finished.connect(lambda message: self.set_running(False))

    def _on_started(self, kind: str) -> None:
        self.progress.setRange(0, max(self.runs.size, 1))
        self.progress.setValue(0)
        self.energy_plot.set_history(self.runs.history)
        self.set_running(True)

    def _on_progress(self, done: int, total: int) -> None:
        self.progress.setRange(0, total)
        self.progress.setValue(done)

    def set_running(self, on: bool) -> None:
        self.run_button.setEnabled(not on)
        self.predict_button.setEnabled(not on)
        self.stop_button.setEnabled(on)
