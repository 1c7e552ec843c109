"""The labeling tools through the model and the controllers, without Qt widgets: fill, surface brush,
label visibility, confidence, the suggestion, accept and correct, the keys."""

from __future__ import annotations

import numpy as np
import pytest
from scribbleseg_app.controllers.jobs import QueueDispatcher
from scribbleseg_app.controllers.tools import ToolsController
from scribbleseg_app.controllers.view import FILL_TINT, SUGGESTION_SHADE, SURFACE, ViewController, hatched
from scribbleseg_app.keys import KEYS, sheet
from scribbleseg_app.model import CollectionModel, Suggestion

from tests.app.test_controllers import until
from tests.conftest import write_off
from tests.core.planted import creature


class FakeViewport:
    def __init__(self):
        self.colors = None

    def show(self, V, F, colors):
        self.colors = colors

    def set_colors(self, colors):
        self.colors = colors


@pytest.fixture
def creatures(tmp_path):
    """Two planted creatures (body, four limbs, head) and their ground truth per file face."""
    folder = tmp_path / "c"
    truth = []
    for i in range(2):
        mesh, gt = creature(1.6, 0.9, seed=i)
        write_off(folder / f"c{i}.off", mesh.V_file, mesh.F_file)
        truth.append(mesh.labels_to_file(gt))
    model = CollectionModel(tmp_path / "autosave")
    model.open(folder)
    for name in ("body", "limb", "head"):
        model.add_label(name)
    return model, QueueDispatcher(), truth


def test_a_fill_bounded_by_labels_paints_one_part_in_one_undo_step(creatures):
    model, dispatcher, truth = creatures
    tools = ToolsController(model, dispatcher)
    tools.set_tool("fill")
    tools.set_fill_bound("labels")
    model.set_result(0, truth[0], "predicted")
    limb_face = int(np.flatnonzero(truth[0] == 1)[0])
    model.set_current_label(2)
    assert tools.fill(limb_face) == -1  # the shape's face graph is built in the background first
    until(lambda: tools.regions(0) is not None, dispatcher)
    tools.begin()
    tools.at(np.zeros(3), limb_face)
    tools.at(np.zeros(3), limb_face + 1)  # the rest of the drag fills nothing more
    tools.end()
    layer = model.layer(0)
    painted = np.flatnonzero(layer.labels == 2)
    assert (truth[0][painted] == 1).all() and 0.1 * (truth[0] == 1).sum() < len(painted) < (truth[0] == 1).sum()
    assert layer.can_undo and model.shapes[0].state == "predicted"
    model.undo()
    assert (layer.labels == -1).all() and not layer.can_undo
    with pytest.raises(ValueError, match="unknown tool"):
        tools.set_tool("lasso")


def test_a_crease_fill_is_built_in_the_background_and_its_region_shows_under_the_mouse(creatures):
    model, dispatcher, truth = creatures
    tools = ToolsController(model, dispatcher)
    shown = []
    tools.highlight_changed.connect(lambda index, faces: shown.append((index, faces)))
    tip = int(np.flatnonzero(truth[0] == 1)[0])
    assert tools.fill_region(0, tip) is None  # regions not built yet: a job builds them
    tools.set_tool("fill")
    tools.hover(tip)
    until(lambda: shown and shown[-1][1] is not None, dispatcher)
    index, region = shown[-1]
    assert index == 0 and tip in region and (truth[0][region] == 1).mean() > 0.8
    np.testing.assert_array_equal(region, tools.fill_region(0, tip))
    tools.set_crease(180.0)  # no border stops it: the whole shape
    assert len(shown[-1][1]) == len(truth[0])
    model.set_current_label(1)
    assert tools.fill(tip) == len(truth[0]) and shown[-1][1] is None  # the highlight goes after a fill
    tools.set_tool("brush")
    tools.hover(tip)
    assert shown[-1][1] is None  # the brush shows no region


def test_the_brush_follows_the_surface(creatures):
    model, dispatcher, truth = creatures
    tools = ToolsController(model, dispatcher)
    mesh = model.shapes[0].mesh()
    C = mesh.V_file[mesh.F_file].mean(axis=1)
    tip = int(np.argmax(np.linalg.norm(C, axis=1)))  # the end of a limb
    model.set_brush_radius(0.05)
    tools.begin()
    tools.at(C[tip], tip)
    tools.end()
    painted = np.flatnonzero(model.layer(0).labels == 0)
    assert tip in painted and (truth[0][painted] == 1).all()


def test_accept_turns_a_result_into_labels_and_corrections_follow(creatures):
    model, dispatcher, truth = creatures
    model.set_current(1)
    assert model.accept(1) == 0  # no result yet
    wrong = truth[1].copy()
    wrong[truth[1] == 2] = 0  # the head taken for body
    model.set_result(1, wrong, "predicted")
    model.paint_faces(1, [0], 1)
    n = model.accept(1)
    layer = model.layer(1)
    assert n == len(wrong) - 1 and (layer.labels >= 0).all() and layer.labels[0] == 1
    assert model.shapes[1].state == "scribbled" and model.scribble_labels(1) is not None
    model.paint_faces(1, np.flatnonzero(truth[1] == 2), 2)  # the correction
    assert (layer.labels[1:] == truth[1][1:]).all()
    model.undo()
    model.undo()  # the accept is one step
    assert (layer.labels >= 0).sum() == 1
    assert model.accept(1) == n  # again, and a second accept has nothing left
    assert model.accept(1) == 0


def test_the_view_fades_hides_tints_and_shows_the_confidence(creatures):
    model, dispatcher, truth = creatures
    viewport = FakeViewport()
    view = ViewController(model, dispatcher, viewport)
    model.shapes[0].mesh()
    view._show(0)
    model.set_result(0, truth[0], "predicted")
    base = viewport.colors.copy()
    view.set_label_opacity(1, 0.0)
    limb = truth[0] == 1
    assert np.allclose(viewport.colors[limb], SURFACE) and np.allclose(viewport.colors[~limb], base[~limb])
    view.set_label_opacity(1, 0.5)
    assert np.allclose(viewport.colors[limb], 0.5 * base[limb] + 0.5 * SURFACE)
    view.set_label_opacity(1, 1.0)
    view.set_label_opacity(2, 0.0)
    model.add_label("tail")  # ids may move when labels come and go: every label shows again
    assert view.label_opacity(2) == 1.0
    model.set_current_label(2)
    view.set_only_current(True)
    assert np.allclose(viewport.colors[truth[0] != 2], SURFACE) and np.allclose(viewport.colors[truth[0] == 2],
                                                                                 base[truth[0] == 2])
    view.set_only_current(False)
    view.set_highlight(0, np.array([0, 1]))
    assert np.allclose(viewport.colors[:2], 0.4 * base[:2] + 0.6 * FILL_TINT)
    view.set_highlight(0, None)
    np.testing.assert_allclose(viewport.colors, base)
    # confidence: a ramp over [0, 1]; the suggested region tinted
    view.set_mode("Confidence")
    np.testing.assert_allclose(viewport.colors, base)  # no run yet: the labels meanwhile
    conf = np.linspace(0, 1, len(truth[0]))
    model.set_confidence(0, conf, 0.5)
    assert not np.allclose(viewport.colors, base) and np.allclose(viewport.colors[0], [0.267, 0.005, 0.329])
    before = viewport.colors.copy()
    region = np.arange(5, len(truth[0]))
    model.set_suggestion(Suggestion(0, region, 5))
    np.testing.assert_allclose(viewport.colors, before)  # the confidence shows it already
    view.set_mode("Labels and scribbles")
    # hatched: bands of the region darkened, the labels between them, nothing outside it
    dark = region[hatched(model.shapes[0].mesh(), region)]
    light = np.setdiff1d(np.arange(len(truth[0])), dark)
    assert 0.2 * len(region) < len(dark) < 0.8 * len(region)
    np.testing.assert_allclose(viewport.colors[dark], SUGGESTION_SHADE * base[dark])
    np.testing.assert_allclose(viewport.colors[light], base[light])
    for small in ([5], [5, 6, 7]):  # a small region shows too
        assert hatched(model.shapes[0].mesh(), np.array(small)).any()
    assert "confidence 0.00" in view.hover_text(0) and "paint here next" not in view.hover_text(0)
    assert "paint here next" in view.hover_text(5)
    model.paint_faces(1, [0], 0)
    assert model.suggestion is not None  # an edit elsewhere leaves it
    model.paint_faces(0, [5], 0)
    assert model.suggestion is None  # acted on


def test_every_key_is_listed_once():
    import inspect

    from scribbleseg_app.main_window import MainWindow

    keys = [(k.keys, k.command) for k in KEYS]
    handled = inspect.getsource(MainWindow.command)
    assert all(f'"{c}"' in handled or c.startswith("label ") for _, c in keys)  # each does something
    assert len({k for k, _ in keys}) == len(keys) and len({c for _, c in keys}) == len(keys)
    assert len(sheet()) == len(KEYS) - 8  # the nine label keys are one row
    assert all(k.imgui is None or k.imgui for k in KEYS)
