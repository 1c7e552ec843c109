"""Strokes, undo/redo and the brush, without Qt."""

from __future__ import annotations

import numpy as np
from scribbleseg_app.painting import ERASE, Brush, ScribbleLayer


def test_one_stroke_is_one_undo_step():
    layer = ScribbleLayer(np.full(10, -1))
    layer.begin()
    layer.paint([1, 2], 0)
    layer.paint([2, 3], 0)
    layer.paint([3], 1)  # painted twice within the stroke
    assert layer.end()
    np.testing.assert_array_equal(layer.labels[:5], [-1, 0, 0, 1, -1])
    layer.begin()
    layer.paint([2, 3, 4], ERASE)
    layer.end()
    np.testing.assert_array_equal(layer.labels[:5], [-1, 0, -1, -1, -1])
    layer.undo()
    np.testing.assert_array_equal(layer.labels[:5], [-1, 0, 0, 1, -1])
    layer.undo()
    assert (layer.labels == -1).all() and not layer.can_undo
    layer.redo()
    np.testing.assert_array_equal(layer.labels[:5], [-1, 0, 0, 1, -1])
    layer.begin()
    layer.paint([9], 2)
    layer.end()
    assert not layer.can_redo  # a new stroke clears the redo history


def test_a_stroke_that_changes_nothing_is_no_undo_step():
    layer = ScribbleLayer(np.array([0, 0, -1]))
    layer.begin()
    layer.paint([0, 1], 0)
    assert not layer.end() and not layer.can_undo
    layer.begin()
    layer.paint([2], 1)
    layer.paint([2], -1)  # and back
    assert not layer.end() and not layer.can_undo


def test_fast_drags_leave_no_gaps():
    x = np.linspace(0, 10, 1001)
    centroids = np.stack([x, np.zeros_like(x), np.zeros_like(x)], axis=1)
    brush = Brush(centroids, scale=10.0)
    faces = brush.faces_along(np.array([9.0, 0, 0]), np.array([1.0, 0, 0]), radius=0.01)  # r = 0.1
    covered = centroids[faces, 0]
    assert covered.min() <= 0.91 and covered.max() >= 9.09
    assert np.all(np.diff(np.sort(covered)) < 0.011)  # contiguous
    assert len(brush.faces_along(np.array([5.0, 0, 0]), None, 0.0105)) == 21  # 4.90 .. 5.10
