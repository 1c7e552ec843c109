"""Render an exported collection in a grid (polyscope, headless EGL), faces in their labels'
colors, each captioned with its name, painted or predicted, and its Rand Index error against the
ground truth where that is known (also printed).

``python scripts/render_export.py EXPORT_DIR OUT.png [--truth assets/Quadruped/labels]
[--painted NAME ...]`` reads every ``<name>.ply`` (and ``<name>.labels.json`` for the colors) that *Export
all* or ``scribbleseg segment`` wrote; the shapes named by ``--painted`` are marked as painted in
the captions and the printed table. What docs/demo_creatures.png shows.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

TILE = (480, 360)  # pixels of one shape's rendering


def _grid(tiles: list[np.ndarray], captions: list[str], columns: int):
    """The renderings (``(h, w, 3)`` uint8 each), cropped to a common box around what differs
    from the background, laid out ``columns`` to a row with a caption under each."""
    from PIL import Image, ImageDraw, ImageFont

    stack = np.stack(tiles)
    ink = np.any(stack != stack[:, :1, :1], axis=(0, 3))  # any tile differs from its corner colour
    rows_, cols_ = np.flatnonzero(ink.any(1)), np.flatnonzero(ink.any(0))
    pad = 8
    r0, r1 = max(rows_[0] - pad, 0), min(rows_[-1] + pad + 1, ink.shape[0])
    c0, c1 = max(cols_[0] - pad, 0), min(cols_[-1] + pad + 1, ink.shape[1])
    h, w, text_h, gap = r1 - r0, c1 - c0, 24, 24
    n_rows = -(-len(tiles) // columns)
    width = (w + gap) * min(columns, len(tiles)) - gap
    sheet = Image.new("RGB", (width, (h + text_h) * n_rows), tuple(int(v) for v in stack[0, 0, 0]))
    draw = ImageDraw.Draw(sheet)
    font = ImageFont.load_default(size=15)
    for i, (tile, caption) in enumerate(zip(tiles, captions)):
        row, col = divmod(i, columns)
        x = col * (w + gap)
        sheet.paste(Image.fromarray(tile[r0:r1, c0:c1]), (x, row * (h + text_h)))
        draw.text((x + w / 2, row * (h + text_h) + h + 2), caption, fill=(40, 40, 40), font=font, anchor="ma")
    return sheet


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
    ps.set_window_size(TILE[0], TILE[1])
    ps.set_up_dir("z_up")
    tiles, errors, captions = [], [], []
    for path in plys:
        mesh = load_mesh(path)
        labels = read_ply_labels(path)
        sidecar = path.with_name(f"{path.stem}.labels.json")
        if sidecar.is_file():
            doc = json.loads(sidecar.read_text())
            label_set = LabelSet.from_names(doc["label_names"], doc["label_colors"])
        else:  # scribbleseg segment writes no sidecar: the default colors, as in the app
            label_set = LabelSet.from_names([str(i) for i in range(max(int(labels.max()) + 1, 1))])
        V = mesh.V_file - mesh.V_file.mean(0)
        V = V / np.abs(V).max()
        ps.remove_all_structures()
        m = ps.register_surface_mesh(path.stem, V, mesh.F_file, smooth_shade=False)
        m.add_color_quantity("labels", label_set.face_colors(labels), defined_on="faces", enabled=True)
        ps.look_at((0.0, -3.4, 1.2), (0.0, 0.0, 0.0))  # from the front: x runs left to right
        tiles.append(np.asarray(ps.screenshot_to_buffer(transparent_bg=False))[..., :3])
        err = None
        if a.truth is not None and (a.truth / f"{path.stem}.seg").is_file():
            err = rand_index_error(labels, read_seg(a.truth / f"{path.stem}.seg", len(labels)))
        errors.append(err)
        kind = "painted" if path.stem in a.painted else "predicted"
        print(f"{path.stem:16s} {kind:9s} " + ("" if err is None else f"Rand Index error {err:.3f}"))
        captions.append(f"{path.stem}, {kind}" + ("" if err is None else f", error {err:.3f}"))
    a.out.parent.mkdir(parents=True, exist_ok=True)
    _grid(tiles, captions, a.columns).save(a.out)
    predicted = [e for e, p in zip(errors, plys) if e is not None and p.stem not in a.painted]
    if predicted:
        print(f"predicted shapes: mean Rand Index error {np.mean(predicted):.4f} over {len(predicted)}")
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
