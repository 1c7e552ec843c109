"""A small line plot of the total energy per optimization step."""

from __future__ import annotations

from PySide6.QtCore import QPointF, Qt
from PySide6.QtGui import QPainter, QPen
from PySide6.QtWidgets import QWidget


class EnergyPlot(QWidget):
    """Plots the values given to :meth:`add` (one per step), scaled to fit."""

    def __init__(self, parent=None):
        super().__init__(parent)
        self.values: list[float] = []
        self.setMinimumHeight(70)

    def clear(self) -> None:
        self.values = []
        self.update()

    def add(self, value: float) -> None:
        self.values.append(float(value))
        self.update()

    def paintEvent(self, event) -> None:  # noqa: N802 (Qt name)
        p = QPainter(self)
        p.fillRect(self.rect(), Qt.GlobalColor.white)
        p.setPen(Qt.GlobalColor.gray)
        p.drawText(4, 12, "energy" + (f": {self.values[-1]:.1f}" if self.values else ""))
        if len(self.values) < 2:
            return
        lo, hi = min(self.values), max(self.values)
        span = (hi - lo) or 1.0
        w, h = self.width() - 8, self.height() - 20
        pts = [QPointF(4 + w * i / (len(self.values) - 1), 16 + h * (1 - (v - lo) / span)) for i, v in enumerate(self.values)]
        p.setPen(QPen(Qt.GlobalColor.darkBlue, 2))
        for a, b in zip(pts, pts[1:]):
            p.drawLine(a, b)
