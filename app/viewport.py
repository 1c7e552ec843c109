"""The polyscope viewport. Every polyscope call happens here, on the main thread."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

import numpy as np

STRUCTURE = "shape"
COLORS = "labels"
#: A full redraw every this many ticks. Polyscope skips drawing a frame in which nothing
#: changed, but under software GL (llvmpipe) part of each skipped frame's work is deferred to the
#: next drawn one: after 9 s of 16 ms ticks, the frame showing a colour change took 3 s.
#: Redrawing every few ticks pays that work as it comes, so a change shows in about one frame's
#: time; while a run streams results every frame is redrawn (``tick(redraw=True)``), which keeps
#: each frame's cost steady (docs/app.md, Responsiveness).
FLUSH_TICKS = 5


@dataclass(frozen=True)
class _MouseInput:
    """The mouse as sampled during one frame (screen pixels)."""

    pos: tuple
    delta: tuple
    wheel: float
    clicked: bool
    down: tuple
    shift: bool
    captured: bool
    keys: tuple = ()  # commands from keys pressed in the viewport window


class PolyscopeViewport:
    """Shows one mesh with per-face colors; ``tick()`` renders a frame (call from a QTimer).

    Parameters
    ----------
    backend : str, optional
        Polyscope backend; default: a window where a display exists, else headless EGL.
    """

    def __init__(self, backend: str | None = None):
        import polyscope as ps

        self._ps = ps
        ps.set_allow_headless_backends(True)
        ps.set_program_name("scribbleseg viewport")
        ps.set_open_imgui_window_for_user_callback(False)
        # the Qt window holds the controls; polyscope's own panels would cover the shape
        # and take the mouse from the brush
        ps.set_build_default_gui_panels(False)
        # Software GL (Mesa llvmpipe) rasterizes on every core by default; one core is the
        # renderer's share, the other the engine's run (docs/app.md, Responsiveness). GPU
        # drivers ignore the variable.
        os.environ.setdefault("LP_NUM_THREADS", "1")
        ps.init(backend) if backend else ps.init()
        # The QTimer paces frames; polyscope's own 60 fps cap would silently skip ticks
        # that come early, and the mouse input of those frames with them.
        ps.set_max_fps(-1)
        # no ground shadow: it made every frame after a color change 3-4x slower on
        # software GL (120 vs 35 ms at 8k faces), which the preview latency pays
        ps.set_ground_plane_mode("none")
        ps.set_up_dir("z_up")
        self.frames = 0
        self.close_requested = False  # the user closed polyscope's window
        self._paint_mode = False
        self._painting = False
        self._handlers = None
        self._orbit = None  # (center (3,), distance, yaw, pitch) of the paint-mode camera
        self._input = None
        self._key_handler = None
        self._hover_handler = None
        self._last_hover = 0.0
        ps.set_user_callback(self._on_frame)

    def set_key_handler(self, handler) -> None:
        """``handler(command)`` for keys pressed while polyscope's window has focus (Qt
        never sees those): the commands of :data:`~scribbleseg_app.keys.KEYS`."""
        self._key_handler = handler

    def set_hover_handler(self, handler) -> None:
        """``handler(face)`` with the file face id under a resting or moving mouse, or -1
        off the shape; called at most every 100 ms, never while painting."""
        self._hover_handler = handler

    @property
    def paint_mode(self) -> bool:
        return self._paint_mode

    @paint_mode.setter
    def paint_mode(self, on: bool) -> None:
        """In paint mode the viewport handles the mouse itself, so that a left drag on the
        shape paints instead of turning the camera (see :meth:`_handle`)."""
        self._paint_mode = bool(on)
        self._ps.set_do_default_mouse_interaction(not on)

    def set_paint_handlers(self, begin, paint, end) -> None:
        """Callbacks for a stroke: ``begin()``, ``paint(point (3,), face)`` per frame (the file
        face under the mouse, -1 if unknown), ``end()``."""
        self._handlers = (begin, paint, end)

    def _pick(self, xy):
        """(point (3,), face) on the shape under screen position `xy`, or None."""
        r = self._ps.pick(screen_coords=(int(xy[0]), int(xy[1])))
        if not (r.is_hit and r.structure_name == STRUCTURE):
            return None
        data = r.structure_data
        face = int(data["index"]) if data.get("element_type") == "face" else -1
        return np.asarray(r.position, dtype=np.float64), face

    def _on_frame(self) -> None:
        """Polyscope's user callback: only samples the mouse. Picking and color updates
        happen in :meth:`tick` once the frame is done, so no polyscope call is nested
        inside a frame."""
        import polyscope.imgui as psim

        io = psim.GetIO()
        self._input = _MouseInput(
            pos=tuple(io.MousePos), delta=tuple(io.MouseDelta), wheel=float(io.MouseWheel),
            clicked=psim.IsMouseClicked(0), down=(psim.IsMouseDown(0), psim.IsMouseDown(1), psim.IsMouseDown(2)),
            shift=bool(io.KeyShift), captured=bool(io.WantCaptureMouse),
            keys=() if io.WantCaptureKeyboard else _key_commands(psim, io),
        )

    def _handle(self, inp: _MouseInput) -> None:
        if self._key_handler is not None:
            for command in inp.keys:
                self._key_handler(command)
        self._handle_mouse(inp)
        self._handle_hover(inp)

    def _handle_hover(self, inp: _MouseInput) -> None:
        if self._hover_handler is None or self._painting or any(inp.down) or inp.captured:
            return
        if inp.delta == (0.0, 0.0) or time.perf_counter() - self._last_hover < 0.1:
            return
        self._last_hover = time.perf_counter()
        r = self._ps.pick(screen_coords=(int(inp.pos[0]), int(inp.pos[1])))
        data = r.structure_data if r.is_hit and r.structure_name == STRUCTURE else {}
        self._hover_handler(int(data["index"]) if data.get("element_type") == "face" else -1)

    def _handle_mouse(self, inp: _MouseInput) -> None:
        """Paint mode: a left drag that starts on the shape paints; a left drag that starts
        elsewhere, Shift+left or right drag orbits, middle drag pans, the wheel zooms."""
        if self._handlers is None or not (self._paint_mode or self._painting):
            return
        begin, paint, end = self._handlers
        if self._painting:
            if inp.down[0]:
                hit = self._pick(inp.pos)
                if hit is not None:
                    paint(*hit)
            else:
                self._painting = False
                end()
            return
        if inp.captured:
            return
        if inp.clicked and not inp.shift:
            hit = self._pick(inp.pos)
            if hit is not None:
                self._painting = True
                begin()
                paint(*hit)
                return
        self._camera(inp)

    def _camera(self, inp: _MouseInput) -> None:
        """Orbit (left off-shape, Shift+left, right), pan (middle), zoom (wheel) in paint mode."""
        if self._orbit is None:
            return
        center, dist, yaw, pitch = self._orbit
        dx, dy = inp.delta
        moved = False
        if (inp.down[0] or inp.down[1]) and (dx or dy):
            yaw -= 0.008 * dx
            pitch = float(np.clip(pitch + 0.008 * dy, -1.5, 1.5))
            moved = True
        if inp.down[2] and (dx or dy):
            right, up = self._camera_axes(yaw, pitch)
            center = center + dist * 0.0015 * (-dx * right + dy * up)
            moved = True
        if inp.wheel:
            dist *= 0.9**inp.wheel
            moved = True
        if moved:
            self._orbit = (center, dist, yaw, pitch)
            self._apply_orbit()

    @staticmethod
    def _camera_axes(yaw, pitch):
        forward = -np.array([np.cos(pitch) * np.cos(yaw), np.cos(pitch) * np.sin(yaw), np.sin(pitch)])
        right = np.cross(forward, [0.0, 0.0, 1.0])
        right /= max(np.linalg.norm(right), 1e-12)
        return right, np.cross(right, forward)

    def _apply_orbit(self) -> None:
        center, dist, yaw, pitch = self._orbit
        offset = dist * np.array([np.cos(pitch) * np.cos(yaw), np.cos(pitch) * np.sin(yaw), np.sin(pitch)])
        self._ps.look_at(center + offset, center)

    def show(self, V: np.ndarray, F: np.ndarray, colors: np.ndarray) -> None:
        """Replace the shown mesh (V (n, 3), F (m, 3)) colored by `colors` (m, 3)."""
        ps = self._ps
        ps.remove_all_structures()
        mesh = ps.register_surface_mesh(STRUCTURE, V, F, smooth_shade=False, edge_width=0.0)
        mesh.set_selection_mode("faces_only")  # a pick names the face under the mouse, never a vertex
        mesh.add_color_quantity(COLORS, colors, defined_on="faces", enabled=True)
        # a three-quarter view from above, framing the bounding box
        lo, hi = V.min(axis=0), V.max(axis=0)
        center, size = (lo + hi) / 2, float(np.linalg.norm(hi - lo))
        d = np.array([0.7, 1.0, 0.55])
        self._orbit = (center, size * float(np.linalg.norm(d)), float(np.arctan2(d[1], d[0])),
                       float(np.arcsin(d[2] / np.linalg.norm(d))))
        self._apply_orbit()

    def focus(self, point: np.ndarray, normal: np.ndarray) -> None:
        """Turn the camera to look at `point` (3,) from the side its surface `normal` (3,)
        faces, at the current distance."""
        if self._orbit is None:
            return
        _, dist, _, _ = self._orbit
        n = np.asarray(normal, dtype=np.float64)
        n = n / max(float(np.linalg.norm(n)), 1e-12)
        self._orbit = (np.asarray(point, dtype=np.float64), dist, float(np.arctan2(n[1], n[0])),
                       float(np.clip(np.arcsin(np.clip(n[2], -1, 1)), -1.5, 1.5)))
        self._apply_orbit()

    def set_colors(self, colors: np.ndarray) -> None:
        """Update the face colors of the shown mesh in place, (m, 3) (the quantity's buffer
        is rewritten; the quantity is not made again)."""
        if not self._ps.has_surface_mesh(STRUCTURE):
            return
        mesh = self._ps.get_surface_mesh(STRUCTURE)
        try:
            mesh.get_quantity_buffer(COLORS, "colors").update_data(np.asarray(colors, dtype=np.float64))
        except ValueError:  # no such quantity yet
            mesh.add_color_quantity(COLORS, colors, defined_on="faces", enabled=True)

    def set_window_size(self, width: int, height: int) -> None:
        self._ps.set_window_size(int(width), int(height))

    def window_size(self) -> tuple[int, int]:
        return tuple(self._ps.get_window_size())

    def tick(self, redraw: bool = False) -> bool:
        """Render one frame, then act on the mouse input it sampled. Returns whether the user
        did something in the viewport window during it (moved, clicked, scrolled, a key).
        `redraw` draws the whole scene even if nothing changed (else every
        :data:`FLUSH_TICKS` frames)."""
        self._input = None
        if redraw or self.frames % FLUSH_TICKS == 0:
            self._ps.request_redraw()
        self._ps.frame_tick()
        self.frames += 1
        self.close_requested = bool(self._ps.window_requests_close())
        inp = self._input
        if inp is None:
            return False
        self._handle(inp)
        return bool(inp.delta != (0.0, 0.0) or any(inp.down) or inp.wheel or inp.clicked or inp.keys)

    def screenshot(self, path: str) -> None:
        self._ps.screenshot(path, transparent_bg=False)


def _key_commands(psim, io) -> tuple:
    """Commands for the keys pressed this frame (:data:`~scribbleseg_app.keys.KEYS`; see
    ``set_key_handler``); the brush keys repeat while held."""
    from scribbleseg_app.keys import KEYS

    out = []
    for key in KEYS:
        if key.imgui is None or key.ctrl != bool(io.KeyCtrl) or key.shift != bool(io.KeyShift):
            continue
        if psim.IsKeyPressed(getattr(psim, f"ImGuiKey_{key.imgui}"), key.command in ("brush -", "brush +")):
            out.append(key.command)
    return tuple(out)
