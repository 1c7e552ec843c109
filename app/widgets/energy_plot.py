"""The energy of a run, step by step: the total and each of its terms, with the rounds marked."""

from __future__ import annotations

import math

from PySide6.QtCore import QPointF, QRectF, Qt
from PySide6.QtGui import QColor, QPainter, QPen
from PySide6.QtWidgets import QWidget

#: (attribute of EnergyTerms, legend, colour) per line.
LINES = (("total", "total", "#1f3b73"), ("scribble", "scribbles", "#d62728"),
         ("network", "network", "#2ca02c"), ("smoothness", "smoothness", "#9467bd"))


class EnergyPlot(QWidget):
    """Draws an :class:`~scribbleseg_app.controllers.run.EnergyHistory`: one line per term over
    the steps (x: step; y: each term on its own scale, from its lowest to its highest value in
    the run, so a small term's convergence shows beside a large one; the legend gives each
    term's latest value), a dashed line where each round and a prediction began."""

    def __init__(self, parent=None):
        super().__init__(parent)
        self.history = None
        self.area = QRectF()  # where the lines were last drawn
        self.setMinimumHeight(150)

    def set_history(self, history) -> None:
        self.history = history
        self.update()

    def paintEvent(self, event) -> None:  # noqa: N802 (Qt name)
        p = QPainter(self)
        p.setRenderHint(QPainter.RenderHint.Antialiasing)
        p.fillRect(self.rect(), Qt.GlobalColor.white)
        fm = p.fontMetrics()
        steps = self.history.steps if self.history is not None else []
        title = "energy"
        if steps:
            s = steps[-1]
            title += f": round {s.iteration} ({s.phase}), total {s.energy.total:.1f}"
        p.setPen(Qt.GlobalColor.black)
        p.drawText(4, fm.ascent() + 2, title)
        legend_y = 2 * fm.height() + 2
        x = 4
        last = steps[-1].energy if steps else None
        for attr, name, color in LINES:
            if last is not None and not math.isnan(getattr(last, attr)):
                name = f"{name} {getattr(last, attr):.1f}"
            if x > 4 and x + 18 + fm.horizontalAdvance(name) > self.width() - 4:  # wrap the legend
                x, legend_y = 4, legend_y + fm.height()
            p.setPen(QPen(QColor(color), 2))
            p.drawLine(x, legend_y - fm.ascent() // 2, x + 14, legend_y - fm.ascent() // 2)
            p.setPen(Qt.GlobalColor.black)
            p.drawText(x + 18, legend_y, name)
            x += 24 + fm.horizontalAdvance(name)
        values = [getattr(s.energy, a) for s in steps for a, _, _ in LINES]
        values = [v for v in values if not math.isnan(v)]
        label_w = 8
        self.area = area = QRectF(label_w, legend_y + 6, self.width() - label_w - 8,
                                  self.height() - legend_y - 8 - fm.height())
        p.setPen(QPen(Qt.GlobalColor.gray, 1))
        p.drawLine(area.bottomLeft(), area.bottomRight())
        p.drawLine(area.bottomLeft(), area.topLeft())
        p.drawText(int(area.left()), int(area.bottom() + fm.ascent() + 2), "step; each term on its own scale")
        if not values:
            p.drawText(area.adjusted(6, 0, 0, 0), Qt.AlignmentFlag.AlignCenter, "run 'Segment collection' to see it converge")
            return
        n = max(len(steps), 2)

        def px(i: float) -> float:
            return area.left() + area.width() * i / (n - 1)

        marks = self.history.marks if self.history is not None else []
        dash = QPen(QColor("#999999"), 1, Qt.PenStyle.DashLine)
        for row, (at, text) in enumerate(marks):
            xm = px(min(max(at - 0.5, 0), n - 1))
            p.setPen(dash)
            p.drawLine(QPointF(xm, area.top()), QPointF(xm, area.bottom()))
            p.setPen(QColor("#555555"))  # alternate rows, so that close marks do not overlap
            p.drawText(QPointF(xm + 2, area.top() + fm.ascent() + (row % 2) * fm.height()), text)
        for attr, _, color in LINES:
            term = [(i, getattr(s.energy, attr)) for i, s in enumerate(steps) if not math.isnan(getattr(s.energy, attr))]
            if not term:
                continue
            lo, hi = min(v for _, v in term), max(v for _, v in term)
            pts = [QPointF(px(i), area.bottom() - area.height() * ((v - lo) / (hi - lo) if hi > lo else 0.5))
                   for i, v in term]
            p.setPen(QPen(QColor(color), 3.5 if attr == "total" else 1.5))  # the total shows beside a term it follows
            for a, b in zip(pts, pts[1:]):
                p.drawLine(a, b)
            for q in pts:
                p.drawEllipse(q, 2, 2)
