"""The polyscope viewport. Every polyscope call happens here, on the main thread."""

from __future__ import annotations

import numpy as np

STRUCTURE = "shape"
COLORS = "labels"


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
        ps.init(backend) if backend else ps.init()
        ps.set_ground_plane_mode("shadow_only")
        ps.set_up_dir("z_up")
        self.frames = 0

    def show(self, V: np.ndarray, F: np.ndarray, colors: np.ndarray) -> None:
        """Replace the shown mesh (V (n, 3), F (m, 3)) colored by `colors` (m, 3)."""
        ps = self._ps
        ps.remove_all_structures()
        mesh = ps.register_surface_mesh(STRUCTURE, V, F, smooth_shade=False, edge_width=0.0)
        mesh.add_color_quantity(COLORS, colors, defined_on="faces", enabled=True)
        # a three-quarter view from above, framing the bounding box
        lo, hi = V.min(axis=0), V.max(axis=0)
        center, size = (lo + hi) / 2, float(np.linalg.norm(hi - lo))
        ps.look_at(center + size * np.array([0.7, 1.0, 0.55]), center)

    def set_colors(self, colors: np.ndarray) -> None:
        """Update the face colors of the shown mesh in place, (m, 3)."""
        self._ps.get_surface_mesh(STRUCTURE).add_color_quantity(COLORS, colors, defined_on="faces", enabled=True)

    def tick(self) -> None:
        self._ps.frame_tick()
        self.frames += 1

    def screenshot(self, path: str) -> None:
        self._ps.screenshot(path, transparent_bg=False)
