"""The energy plot draws every term on its own scale: a small term's convergence shows beside
a large, nearly flat one."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("PySide6")


def _rows_with(image, color: str) -> np.ndarray:
    """Rows of a QImage that hold a pixel of `color` (#rrggbb)."""
    from PySide6.QtGui import QColor

    w, h = image.width(), image.height()
    ptr = image.constBits()
    px = np.frombuffer(ptr, np.uint8).reshape(h, image.bytesPerLine())[:, : 4 * w].reshape(h, w, 4)
    c = QColor(color)
    hit = (np.abs(px[..., 2].astype(int) - c.red()) < 8) & (np.abs(px[..., 1].astype(int) - c.green()) < 8) \
        & (np.abs(px[..., 0].astype(int) - c.blue()) < 8)
    return np.flatnonzero(hit.any(axis=1))


def test_each_term_spans_the_plot_on_its_own_scale(qtbot):
    from PySide6.QtGui import QImage
    from scribbleseg_app.controllers.run import EnergyHistory, EnergyStep
    from scribbleseg_app.widgets.energy_plot import LINES, EnergyPlot

    from scribbleseg_core.engine.energy import EnergyTerms

    history = EnergyHistory()
    history.mark("round 1")
    for i in range(6):  # scribbles fall from 40 to 15; smoothness stays near 2550
        history.steps.append(EnergyStep(1 + i // 2, "graphcut", EnergyTerms(40.0 - 5 * i, float("nan"), 2550.0 + i)))
    plot = EnergyPlot()
    qtbot.addWidget(plot)
    plot.resize(300, 260)  # narrow: the legend wraps
    plot.set_history(history)
    image = QImage(plot.size(), QImage.Format.Format_ARGB32)
    plot.render(image)
    colors = {attr: color for attr, _, color in LINES}
    top, bottom = plot.area.top(), plot.area.bottom()
    assert bottom - top > 100
    for attr in ("scribble", "smoothness"):
        rows = _rows_with(image, colors[attr])
        rows = rows[(rows >= top - 3) & (rows <= bottom + 3)]
        assert rows.max() - rows.min() > 0.8 * (bottom - top)  # from the bottom of the plot to its top
