"""The main window. The full painting GUI lands with the app issue; this shell starts."""

from __future__ import annotations

from PySide6.QtWidgets import QLabel, QMainWindow

from scribbleseg_core import __version__


class MainWindow(QMainWindow):
    """Top-level window of scribbleseg."""

    def __init__(self, path: str | None = None):
        super().__init__()
        self.setWindowTitle(f"scribbleseg {__version__}")
        self.resize(420, 240)
        text = "scribbleseg: the painting interface is not built yet.\n"
        if path:
            text += f"Requested: {path}"
        label = QLabel(text)
        label.setWordWrap(True)
        self.setCentralWidget(label)
        self.statusBar().showMessage("ready")
