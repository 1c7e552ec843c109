"""The labeling tools: the surface brush and the region fill, and the region shown under the mouse.

A stroke in the viewport arrives as ``begin()``, ``at(point, face)`` per frame, ``end()``. With the
brush it paints the faces within the brush radius along the surface
(:class:`~scribbleseg_app.painting.Brush`); with the fill, the click paints in one undo step the
region around the face clicked (:class:`~scribbleseg_core.engine.regions.RegionFill`): bounded by
concave creases sharper than :attr:`ToolsController.crease_deg`, or by the labels shown. While the
mouse rests on the shape with the fill chosen, the region it would fill is highlighted.
"""

from __future__ import annotations

import numpy as np
from scribbleseg_app.controllers.jobs import Dispatcher, Job
from scribbleseg_app.events import Event

TOOLS = ("brush", "fill")
#: What stops a fill: concave creases, or a change of the label shown (result, else scribbles).
FILL_BOUNDS = ("creases", "labels")
#: Default crease threshold of the fill, degrees (mean concave angle along a patch border).
FILL_CREASE_DEG = 3.0


class ToolsController:
    """The active tool and the fill's settings; builds each shape's fill regions in the background.

    Events
    ------
    highlight_changed(index, faces)
        File faces (k,) of shape `index` to highlight as the region a click would fill, or
        None to clear it.
    status(message)

    Parameters
    ----------
    model : CollectionModel
    dispatcher : Dispatcher
    """

    def __init__(self, model, dispatcher: Dispatcher) -> None:
        self.model = model
        self.dispatcher = dispatcher
        self.tool = "brush"
        self.fill_bound = "creases"
        self.crease_deg = FILL_CREASE_DEG
        self.highlight_changed, self.status = Event(), Event()
        self._fills: dict[int, object] = {}  # shape -> RegionFill
        self._building: dict[int, Job] = {}
        self._stroke_tool: str | None = None  # the tool of the stroke under way
        self._filled = False  # the fill of this click is done
        self._hover = (-1, -1)  # (shape, file face) under the mouse
        model.collection_changed.connect(self._on_collection_changed)
        model.current_changed.connect(lambda index: self.clear_highlight())

    # ------------------------------------------------------------------ settings

    def set_tool(self, tool: str) -> None:
        if tool not in TOOLS:
            raise ValueError(f"unknown tool {tool!r}; one of {', '.join(TOOLS)}")
        self.tool = tool
        if tool == "fill" and self.model.current >= 0:
            self.regions(self.model.current)  # start building now
        self._rehover()

    def set_fill_bound(self, bound: str) -> None:
        if bound not in FILL_BOUNDS:
            raise ValueError(f"unknown fill bound {bound!r}; one of {', '.join(FILL_BOUNDS)}")
        self.fill_bound = bound
        self._rehover()

    def set_crease(self, degrees: float) -> None:
        self.crease_deg = float(degrees)
        self._rehover()

    # ------------------------------------------------------------------ regions

    def regions(self, index: int):
        """Shape `index`'s :class:`RegionFill`, or None while it is built in the background."""
        if index in self._fills:
            return self._fills[index]
        if index not in self._building:
            from scribbleseg_core.engine.regions import RegionFill

            generation = self.model.generation
            brush = self.model.brush

            def done(fill, index=index):
                self._building.pop(index, None)
                if generation == self.model.generation:
                    self._fills[index] = fill
                    self._rehover()

            def failed(e, index=index):
                self._building.pop(index, None)
                self.status.emit(f"{self.model.shapes[index].name}: fill regions failed: {e}")

            self._building[index] = Job(lambda: RegionFill(brush(index).graph), dispatcher=self.dispatcher,
                                        on_done=done, on_error=failed, name="scribbleseg-fill").start()
        return None

    def fill_region(self, index: int, face: int) -> np.ndarray | None:
        """File faces a fill clicked on file face `face` of shape `index` would paint, (k,)
        int64; None while the shape's regions (and face graph) are built in the background."""
        m = self.model
        mesh = m.shapes[index].mesh()
        if not 0 <= face < mesh.num_file_faces:
            return np.zeros(0, np.int64)
        seed = int(mesh.file_to_proc[face])
        fill = self.regions(index)  # its job also builds the shape's face graph (the brush's)
        if fill is None:
            return None
        brush = m.brush(index)
        if self.fill_bound == "labels":
            from scribbleseg_core.engine.regions import fill_by_labels

            shown = m.shown_labels(index)
            labels = shown if shown is not None else m.layer(index).labels
            return mesh.faces_to_file(fill_by_labels(brush.graph, seed, mesh.labels_from_file(labels)))
        return mesh.faces_to_file(fill.by_crease(seed, self.crease_deg))

    def fill(self, face: int) -> int:
        """Fill from file face `face` of the current shape with the current label (the eraser
        clears), one undo step. Returns the faces that changed; -1 if the regions are not
        built yet (try again in a moment)."""
        m = self.model
        i = m.current
        if i < 0 or m.shapes[i].state == "error":
            return 0
        if m.current_label >= 0 and not len(m.label_set):
            m.error.emit("add a label before painting")
            return 0
        faces = self.fill_region(i, face)
        if faces is None:
            self.status.emit("the fill regions of this shape are being computed; click again in a moment")
            return -1
        changed = m.paint_faces(i, faces, m.current_label)
        self.clear_highlight()
        return int(len(changed))

    # ------------------------------------------------------------------ strokes and hover

    def begin(self) -> None:
        self._stroke_tool, self._filled = self.tool, False
        if self.tool == "brush":
            self.model.begin_stroke()

    def at(self, point: np.ndarray, face: int) -> None:
        """A stroke sample at 3D `point` on file face `face` of the current shape."""
        if self._stroke_tool == "brush":
            self.model.paint_at(point)
        elif self._stroke_tool == "fill" and not self._filled:
            self._filled = True  # one fill per click, however long the drag
            self.fill(face)

    def end(self) -> None:
        if self._stroke_tool == "brush":
            self.model.end_stroke()
        self._stroke_tool = None

    def hover(self, face: int) -> None:
        """The mouse rests on file face `face` of the current shape (-1: off the shape)."""
        self._hover = (self.model.current, face)
        self._rehover()

    def clear_highlight(self) -> None:
        self.highlight_changed.emit(self.model.current, None)

    def _rehover(self) -> None:
        index, face = self._hover
        if self.tool != "fill" or index != self.model.current or index < 0 or face < 0:
            self.clear_highlight()
            return
        faces = self.fill_region(index, face)
        if faces is not None:
            self.highlight_changed.emit(index, faces)

    def _on_collection_changed(self) -> None:
        for job in self._building.values():
            job.cancel()
        self._building.clear()
        self._fills.clear()
        self._hover = (-1, -1)

    def shutdown(self, timeout: float = 5.0) -> None:
        jobs = list(self._building.values())
        for job in jobs:
            job.cancel()
        for job in jobs:
            job.join(timeout)
