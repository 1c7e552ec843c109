"""Render an exported collection in a grid (polyscope, headless EGL), faces in their labels'
colors, and print each shape's Rand Index error against the ground truth where that is known.

``python scripts/render_export.py EXPORT_DIR OUT.png [--truth assets/Quadruped/labels]
[--painted NAME ...]`` reads every ``<name>.ply`` (and ``<name>.labels.json`` for the colors) that *Export
all* or ``scribbleseg segment`` wrote; the shapes named by ``--painted`` are marked as painted in
the printed table. What docs/demo_predicted.png shows.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("export", type=Path)
    ap.add_argument("out", type=Path)
    ap.add_argument("--truth", type=Path, help="folder of <name>.seg ground truth")
    ap.add_argument("--painted", nargs="*", default=[], help="names of the shapes the user painted")
    ap.add_argument("--columns", type=int, default=5)
    a = ap.parse_args(argv)

    import polyscope as ps

    from scribbleseg_core.evaluation.metrics import rand_index_error
    from scribbleseg_core.formats.export import read_ply_labels
    from scribbleseg_core.formats.labels import LabelSet
    from scribbleseg_core.formats.mesh import load_mesh
    from scribbleseg_core.formats.seg import read_seg

    plys = sorted(a.export.glob("*.ply"))
    if not plys:
        raise SystemExit(f"error: {a.export}: no .ply files")
    ps.set_allow_headless_backends(True)
    ps.init()
    ps.set_ground_plane_mode("none")
    rows = -(-len(plys) // a.columns)
    ps.set_window_size(1600, 300 * rows)
    ps.set_up_dir("z_up")
    errors = []
    for i, path in enumerate(plys):
        mesh = load_mesh(path)
        labels = read_ply_labels(path)
        sidecar = path.with_name(f"{path.stem}.labels.json")
        if sidecar.is_file():
            doc = json.loads(sidecar.read_text())
            label_set = LabelSet.from_names(doc["label_names"], doc["label_colors"])
        else:  # scribbleseg segment writes no sidecar: the default colors, as in the app
            label_set = LabelSet.from_names([str(i) for i in range(max(int(labels.max()) + 1, 1))])
        row, col = divmod(i, a.columns)
        V = mesh.V_file - mesh.V_file.mean(0)
        V = V / np.abs(V).max() + np.array([col * 2.6, 0, -row * 2.4])
        m = ps.register_surface_mesh(path.stem, V, mesh.F_file, smooth_shade=False)
        m.add_color_quantity("labels", label_set.face_colors(labels), defined_on="faces", enabled=True)
        err = None
        if a.truth is not None and (a.truth / f"{path.stem}.seg").is_file():
            err = rand_index_error(labels, read_seg(a.truth / f"{path.stem}.seg", len(labels)))
        errors.append(err)
        kind = "painted" if path.stem in a.painted else "predicted"
        print(f"{path.stem:16s} {kind:9s} " + ("" if err is None else f"Rand Index error {err:.3f}"))
    center = np.array([(a.columns - 1) * 1.3, 0.0, -(rows - 1) * 1.2])
    ps.look_at(center + np.array([0.0, -(3.6 + 2.4 * rows), 2.0]), center)  # from the front: x runs left to right
    a.out.parent.mkdir(parents=True, exist_ok=True)
    ps.screenshot(str(a.out), transparent_bg=False)
    predicted = [e for e, p in zip(errors, plys) if e is not None and p.stem not in a.painted]
    if predicted:
        print(f"predicted shapes: mean Rand Index error {np.mean(predicted):.4f} over {len(predicted)}")
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
