"""Render the bundled demo families to docs/families.png (polyscope, headless EGL).

``python scripts/render_families.py`` — shapes in a grid, faces colored by their
ground-truth part, with each shape's scribbles drawn darker.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main(out: Path = ROOT / "docs" / "families.png", per_family: int = 5) -> None:
    import polyscope as ps

    from scribbleseg_core.evaluation.psb import read_label_names
    from scribbleseg_core.formats.labels import LabelSet
    from scribbleseg_core.formats.mesh import find_meshes, load_mesh
    from scribbleseg_core.formats.scribbles import read_scribbles
    from scribbleseg_core.formats.seg import read_seg

    ps.set_allow_headless_backends(True)
    ps.init()
    ps.set_ground_plane_mode("none")
    ps.set_window_size(1600, 700)
    ps.set_up_dir("z_up")
    for row, family in enumerate(["Quadruped", "Chair"]):
        folder = ROOT / "assets" / family
        ls = LabelSet.from_names(read_label_names(folder / "labels" / "label_names.txt"))
        for col, path in enumerate(find_meshes(folder)[:per_family]):
            mesh = load_mesh(path)
            V = mesh.V_file - mesh.V_file.mean(0)
            V = V / np.abs(V).max() + np.array([col * 2.6, 0, -row * 2.4])
            colors = ls.face_colors(read_seg(folder / "labels" / f"{path.stem}.seg"))
            scr_file = folder / "scribbles" / f"{path.stem}.json"
            if scr_file.exists():
                scr = read_scribbles(scr_file).face_labels()
                colors[scr >= 0] *= 0.35
            m = ps.register_surface_mesh(f"{family}{col}", V, mesh.F_file, smooth_shade=False)
            m.add_color_quantity("parts", colors, defined_on="faces", enabled=True)
    # a three-quarter view from the front (+y: chairs' fronts, +x: creatures' heads), above
    center = np.array([(per_family - 1) * 1.3, 0.0, -1.2])
    ps.look_at(center + np.array([2.6, 8.2, 2.8]), center)
    out.parent.mkdir(parents=True, exist_ok=True)
    ps.screenshot(str(out), transparent_bg=False)
    print(f"wrote {out}")


if __name__ == "__main__":
    main(*(Path(a) for a in sys.argv[1:2]))
