"""All 240 PSB meshes load, and their labels and scribbles fit them."""

from __future__ import annotations

import pytest

from scribbleseg_core.formats.mesh import find_meshes, load_mesh
from scribbleseg_core.formats.scribbles import read_scribbles
from scribbleseg_core.formats.seg import read_seg


@pytest.mark.psb
def test_every_psb_mesh_loads_with_its_labels_and_scribbles(psb_dir):
    paths = [p for cat in sorted(psb_dir.iterdir()) if cat.is_dir() for p in find_meshes(cat)]
    assert len(paths) == 240
    for path in paths:
        mesh = load_mesh(path)
        m0 = mesh.num_file_faces
        assert len(read_seg(path.parent / "labels" / f"{path.stem}.seg", m0)) == m0
        read_scribbles(path.parent / "scribbles" / f"{path.stem}.json", num_faces=m0)
