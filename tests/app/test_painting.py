"""Strokes, undo/redo and the brush, without Qt."""

from __future__ import annotations

import numpy as np
from scribbleseg_app.painting import ERASE, Brush, ScribbleLayer

from scribbleseg_core.formats.mesh import repair


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


def _slab(n=60, thickness=0.01):
    """A thin closed slab, 1 × 1 × `thickness`: two sheets close together, joined at the rim."""
    import trimesh

    box = trimesh.creation.box(extents=(1.0, 1.0, thickness))
    for _ in range(5):
        box = box.subdivide()
    return repair(np.asarray(box.vertices), np.asarray(box.faces))


def test_fast_drags_leave_no_gaps_and_the_brush_stays_on_its_sheet():
    mesh = _slab()
    brush = Brush(mesh)
    C = mesh.V_file[mesh.F_file].mean(axis=1)
    top = C[:, 2] > 0
    a, b = np.array([-0.4, 0.0, 0.005]), np.array([0.4, 0.0, 0.005])
    faces = brush.faces_along(b, a, radius=0.02)  # r = 0.02 · diagonal ≈ 0.028
    assert top[faces].all()  # a ball of that radius would take the sheet 0.01 below too
    covered = np.sort(C[faces, 0])
    assert covered.min() <= -0.38 and covered.max() >= 0.38
    assert np.all(np.diff(covered) < 0.05)  # contiguous along the drag
    assert np.abs(C[faces, 1]).max() < 0.03 + 0.02
    one = brush.faces_along(np.array([0.0, 0.0, 0.005]), None, 0.02)
    assert 0 < len(one) < len(faces) and top[one].all()


def test_a_stroke_can_give_each_face_its_own_label():
    layer = ScribbleLayer(np.array([-1, -1, 2, 2]))
    layer.begin()
    changed = layer.paint([3, 0, 1, 2, 0], np.array([2, 1, 0, 2, 1]))
    np.testing.assert_array_equal(changed, [0, 1])  # 2 and 3 already had their labels
    assert layer.end()
    np.testing.assert_array_equal(layer.labels, [1, 0, 2, 2])
    layer.undo()
    np.testing.assert_array_equal(layer.labels, [-1, -1, 2, 2])
