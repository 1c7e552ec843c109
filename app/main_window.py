"""The main window: the collection's shapes beside a polyscope viewport.

This first slice browses a collection: pick a shape, see it with its scribbles and labels.
Painting, the optimization worker and exports are not built yet.
"""

from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import QTimer
from PySide6.QtWidgets import QLabel, QListWidget, QListWidgetItem, QMainWindow, QMessageBox, QVBoxLayout, QWidget

from app.model import CollectionModel
from scribbleseg_core import __version__

#: Default collection when none is given: the bundled demo creatures.
DEFAULT_COLLECTION = Path(__file__).resolve().parents[1] / "assets" / "Quadruped"
FRAME_MS = 16


class MainWindow(QMainWindow):
    """Top-level window; the viewport is polyscope's own window (it cannot be embedded).

    Parameters
    ----------
    path : str, optional
        A collection folder or one mesh; default :data:`DEFAULT_COLLECTION`.
    viewport : PolyscopeViewport, optional
        Made on first use when not given (tests pass their own).
    """

    def __init__(self, path: str | None = None, viewport=None):
        super().__init__()
        self.setWindowTitle(f"scribbleseg {__version__}")
        self.resize(460, 560)
        self.model = CollectionModel()
        self._viewport = viewport
        self.shape_list = QListWidget()
        self.labels_info = QLabel()
        self.labels_info.setWordWrap(True)
        panel = QWidget()
        layout = QVBoxLayout(panel)
        layout.addWidget(QLabel("Shapes"))
        layout.addWidget(self.shape_list)
        layout.addWidget(self.labels_info)
        note = QLabel("Browsing only: painting and segmentation in the app are not built yet; "
                      "use `scribbleseg segment` meanwhile.")
        note.setWordWrap(True)
        layout.addWidget(note)
        self.setCentralWidget(panel)
        self.shape_list.currentRowChanged.connect(self._on_row_changed)
        self.model.collection_changed.connect(self._on_collection_changed)
        self.model.current_changed.connect(self._on_current_changed)
        self.model.error.connect(self._on_error)
        self.timer = QTimer(self)
        self.timer.timeout.connect(self._on_frame)
        self.timer.start(FRAME_MS)
        self.model.open(path or DEFAULT_COLLECTION)

    @property
    def viewport(self):
        if self._viewport is None:
            from app.viewport import PolyscopeViewport

            self._viewport = PolyscopeViewport()
        return self._viewport

    def _on_collection_changed(self) -> None:
        self.shape_list.clear()
        for entry in self.model.shapes:
            self.shape_list.addItem(QListWidgetItem(f"{entry.name}   [{entry.state}]"))
        names = ", ".join(self.model.label_set.names) or "none yet"
        self.labels_info.setText(f"Labels: {names}")
        self.statusBar().showMessage(f"{self.model.folder}: {len(self.model.shapes)} shapes")

    def _on_row_changed(self, row: int) -> None:
        self.model.set_current(row)

    def _on_current_changed(self, index: int) -> None:
        if self.shape_list.currentRow() != index:
            self.shape_list.setCurrentRow(index)
        entry = self.model.shapes[index]
        self.shape_list.item(index).setText(f"{entry.name}   [{entry.state}]")
        if entry.state == "error":
            return
        mesh = entry.mesh()
        self.viewport.show(mesh.V_file, mesh.F_file, self.model.face_colors(index))
        self.statusBar().showMessage(f"{entry.name}: {mesh.report.summary()}")

    def _on_error(self, message: str) -> None:
        self.statusBar().showMessage(message)
        box = QMessageBox(QMessageBox.Icon.Warning, "scribbleseg", message, parent=self)
        box.setModal(False)
        box.show()

    def _on_frame(self) -> None:
        if self._viewport is not None:
            self._viewport.tick()
