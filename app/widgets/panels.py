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
    QRadioButton,
    QSlider,
    QVBoxLayout,
    QWidget,
)
from scribbleseg_app.controllers.tools import FILL_BOUNDS
from scribbleseg_app.controllers.view import SHOW_MODES
from scribbleseg_app.widgets.energy_plot import EnergyPlot


def hbox(*items) -> QHBoxLayout:
    """A horizontal row of widgets; an item ``(widget, stretch)`` stretches."""
    out = QHBoxLayout()
    for item in items:
        widget, stretch = item if isinstance(item, tuple) else (item, 0)
        out.addWidget(widget, stretch)
    return out


def swatch(rgb) -> QIcon:
    pm = QPixmap(14, 14)
    pm.fill(QColor.fromRgbF(*[float(c) for c in rgb]))
    return QIcon(pm)


class ShapesPanel(QWidget):
    """The collection's shapes with their state and, after a run, their mean confidence; a
    shape the last round changed is marked ●. Choosing a row shows that shape; the rows can be
    sorted by confidence, least confident first."""

    def __init__(self, model, runs, parent=None):
        super().__init__(parent)
        self.model, self.runs = model, runs
        self.list = QListWidget()
        self.sort_box = QCheckBox("Least confident first")
        self.order: list[int] = []  # shape index of each row
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addLayout(hbox((QLabel("Shapes (● changed in the last round)"), 1), self.sort_box))
        layout.addWidget(self.list)
        self.list.currentRowChanged.connect(lambda r: 0 <= r < len(self.order) and model.set_current(self.order[r]))
        self.sort_box.toggled.connect(lambda on: self.rebuild())
        model.collection_changed.connect(self.rebuild)
        model.shapes_added.connect(lambda indices: self.rebuild())
        model.state_changed.connect(self.update_row)
        model.confidence_changed.connect(self._on_confidence)
        model.current_changed.connect(self._select)
        runs.step.connect(lambda snap: self.update_rows())

    def text(self, index: int) -> str:
        entry = self.model.shapes[index]
        mark = " ●" if index in self.runs.changed else ""
        conf = f"  confidence {entry.mean_confidence:.2f}" if entry.mean_confidence is not None else ""
        return f"{entry.name}   [{entry.state}]{conf}{mark}"

    def rebuild(self) -> None:
        shapes = self.model.shapes
        self.order = list(range(len(shapes)))
        if self.sort_box.isChecked():
            self.order.sort(key=lambda i: (shapes[i].mean_confidence is None, shapes[i].mean_confidence or 0.0))
        self.list.blockSignals(True)
        self.list.clear()
        for i in self.order:
            self.list.addItem(QListWidgetItem(self.text(i)))
        if self.model.current >= 0:
            self.list.setCurrentRow(self.order.index(self.model.current))
        self.list.blockSignals(False)

    def update_row(self, index: int) -> None:
        item = self.list.item(self.order.index(index)) if index in self.order else None
        if item is not None:
            item.setText(self.text(index))

    def update_rows(self) -> None:
        for i in self.order:
            self.update_row(i)

    def _on_confidence(self, index: int) -> None:
        if self.sort_box.isChecked():
            self.rebuild()
        else:
            self.update_row(index)

    def _select(self, index: int) -> None:
        row = self.order.index(index) if index in self.order else -1
        if self.list.currentRow() != row:
            self.list.blockSignals(True)
            self.list.setCurrentRow(row)
            self.list.blockSignals(False)


class LabelsPanel(QWidget):
    """The label set: choose the brush's label, add, recolour, rename (double-click), delete;
    show or hide each label (its check box), fade the current one, or show only it."""

    def __init__(self, model, view, parent=None):
        super().__init__(parent)
        self.model, self.view = model, view
        self.list = QListWidget()
        self.add_button = QPushButton("Add label")
        self.color_button = QPushButton("Color…")
        self.delete_button = QPushButton("Delete")
        self.opacity_slider = QSlider(Qt.Orientation.Horizontal)
        self.opacity_slider.setRange(0, 100)
        self.opacity_slider.setValue(100)
        self.opacity_slider.setToolTip("Opacity of the current label's scribbles and results")
        self.only_box = QCheckBox("Only this label (O)")
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(QLabel("Labels (keys 1–9; double-click to rename; tick to show)"))
        layout.addWidget(self.list)
        layout.addLayout(hbox(QLabel("Opacity"), (self.opacity_slider, 1), self.only_box))
        layout.addLayout(hbox(self.add_button, self.color_button, self.delete_button))
        self.list.itemChanged.connect(self._on_item_changed)
        self.list.currentRowChanged.connect(self._sync_opacity)
        self.opacity_slider.valueChanged.connect(self._on_opacity)
        self.only_box.toggled.connect(view.set_only_current)
        model.labels_changed.connect(self.rebuild)
        model.collection_changed.connect(self._on_collection)

    def rebuild(self) -> None:
        row = self.list.currentRow()
        self.list.blockSignals(True)
        self.list.clear()
        for i, (name, rgb) in enumerate(zip(self.model.label_set.names, self.model.label_set.colors)):
            item = QListWidgetItem(swatch(rgb), f"{i + 1}  {name}")
            item.setFlags(item.flags() | Qt.ItemFlag.ItemIsUserCheckable)
            item.setCheckState(Qt.CheckState.Checked if self.view.label_opacity(i) > 0 else Qt.CheckState.Unchecked)
            self.list.addItem(item)
        self.list.blockSignals(False)
        if 0 <= row < self.list.count():
            self.list.setCurrentRow(row)

    def toggle_visible(self, label: int) -> None:
        """Hide label `label` if shown, else show it (at full opacity)."""
        item = self.list.item(label)
        if item is not None:
            on = item.checkState() != Qt.CheckState.Checked
            item.setCheckState(Qt.CheckState.Checked if on else Qt.CheckState.Unchecked)

    def _on_item_changed(self, item) -> None:
        label = self.list.row(item)
        shown = item.checkState() == Qt.CheckState.Checked
        if shown != (self.view.label_opacity(label) > 0):
            self.view.set_label_opacity(label, 1.0 if shown else 0.0)
            self._sync_opacity(self.list.currentRow())

    def _on_opacity(self, value: int) -> None:
        label = self.list.currentRow()
        if label >= 0:
            self.view.set_label_opacity(label, value / 100.0)
            item = self.list.item(label)
            self.list.blockSignals(True)
            item.setCheckState(Qt.CheckState.Checked if value > 0 else Qt.CheckState.Unchecked)
            self.list.blockSignals(False)

    def _sync_opacity(self, label: int) -> None:
        if label >= 0:
            self.opacity_slider.blockSignals(True)
            self.opacity_slider.setValue(round(100 * self.view.label_opacity(label)))
            self.opacity_slider.blockSignals(False)

    def _on_collection(self) -> None:
        self.rebuild()
        if self.list.count():
            self.list.setCurrentRow(0)


class ToolsPanel(QWidget):
    """Tools and view: paint mode, brush or fill (with what bounds the fill), eraser, brush
    size, live preview, what the surface shows."""

    def __init__(self, parent=None):
        super().__init__(parent)
        self.paint_box = QCheckBox("Paint (P): left-drag on the shape (drag elsewhere or Shift+drag to orbit)")
        self.brush_radio = QRadioButton("Brush (B)")
        self.fill_radio = QRadioButton("Fill (F)")
        self.brush_radio.setChecked(True)
        self.fill_bound_combo = QComboBox()
        self.fill_bound_combo.addItems([f"bounded by {b}" for b in FILL_BOUNDS])
        self.crease_slider = QSlider(Qt.Orientation.Horizontal)
        self.crease_slider.setRange(5, 300)  # tenths of a degree
        self.crease_slider.setValue(30)
        self.crease_label = QLabel()
        self.crease_slider.valueChanged.connect(lambda v: self.crease_label.setText(f"{v / 10:.1f}°"))
        self.crease_label.setText(f"{self.crease_slider.value() / 10:.1f}°")
        self.crease_slider.setToolTip("How sharp a crease (its mean concave angle) must be to stop the fill")
        self.eraser_box = QCheckBox("Eraser (E)")
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
        layout.addLayout(hbox(self.brush_radio, self.fill_radio, (self.fill_bound_combo, 1)))
        layout.addLayout(hbox(QLabel("Crease"), (self.crease_slider, 1), self.crease_label))
        layout.addLayout(hbox(self.eraser_box, QLabel("Brush ([ ])"), self.brush_slider))
        layout.addWidget(self.preview_box)
        layout.addLayout(hbox(QLabel("Show"), (self.show_combo, 1)))


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
        self.accept_button = QPushButton("Accept result (A)")
        self.accept_button.setToolTip("The current shape's result becomes its labels: correct it with the brush "
                                      "or the fill, and the next run trains on it")
        self.suggest_button = QPushButton("Paint here next (N)")
        self.suggest_button.setToolTip("Show the unsure region that weighs most on its shape: area times doubt (after a run)")
        self.suggest_button.setEnabled(False)
        self.progress = QProgressBar()
        self.progress.setFormat("%v / %m")
        self.energy_plot = EnergyPlot()
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addLayout(hbox(self.run_button, self.stop_button))
        layout.addLayout(hbox(self.predict_button, self.export_button))
        layout.addLayout(hbox(self.accept_button, self.suggest_button))
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
