"""The grid that ``scripts/render_export.py`` lays its renderings out in."""

import importlib.util
from pathlib import Path

import numpy as np

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "render_export.py"


def _module():
    spec = importlib.util.spec_from_file_location("render_export", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_grid_crops_to_the_shapes_and_captions_each_tile():
    grid = _module()._grid
    tiles = []
    for offset in (20, 40, 60):
        tile = np.full((100, 120, 3), 255, np.uint8)
        tile[30:50, offset : offset + 10] = (200, 0, 0)
        tiles.append(tile)
    sheet = np.asarray(grid(tiles, ["a", "b", "c"], columns=2))
    # the common box: rows 30..49 and columns 20..69, padded by 8 on each side
    h, w = 20 + 16, 50 + 16
    assert sheet.shape == (2 * (h + 24), 2 * w + 24, 3)
    red = (sheet[..., 0] == 200) & (sheet[..., 1] == 0)
    assert red[:h, :w].sum() == red[:h, w + 24 : 2 * w + 24].sum() == red[h + 24 : 2 * h + 24, :w].sum() == 200
    captions = sheet[h : h + 24] < 128  # dark text under the first row
    assert captions[:, :w].any() and captions[:, w + 24 :].any()
