"""A strict Wavefront OBJ reader that keeps the file's face order.

trimesh may regroup faces by material or split vertices by texture coordinates; face
ids must be the file's, so OBJ is parsed here. Only ``v`` and ``f`` records matter;
``vt``/``vn`` references and other records (``g``, ``o``, ``usemtl``...) are ignored.
"""

from __future__ import annotations

import numpy as np

from scribbleseg_core.errors import MeshLoadError


def read_obj(data: bytes, path=None) -> tuple[np.ndarray, np.ndarray]:
    """Parse an OBJ file into vertices and fan-triangulated faces, in file order.

    Returns
    -------
    V : (n, 3) float64 ndarray
    F : (m, 3) int64 ndarray
    """
    if b"\x00" in data[:4096]:
        raise MeshLoadError("not a text OBJ file (binary content)", path)
    verts: list[list[bytes]] = []
    tris: list[tuple[int, int, int]] = []
    for lineno, raw in enumerate(data.splitlines(), 1):
        line = raw.split(b"#", 1)[0]
        if not line.strip():
            continue
        tok = line.split()
        head = tok[0]
        if head == b"v":
            if len(tok) < 4:
                raise MeshLoadError(f"line {lineno}: a vertex needs 3 coordinates", path)
            verts.append(tok[1:4])
        elif head == b"f":
            if len(tok) < 4:
                raise MeshLoadError(f"line {lineno}: a face needs at least 3 corners", path)
            try:
                idx = [int(t.split(b"/", 1)[0]) for t in tok[1:]]
            except ValueError:
                raise MeshLoadError(f"line {lineno}: bad face index", path) from None
            n_seen = len(verts)
            idx = [i - 1 if i > 0 else n_seen + i for i in idx]  # 1-based or relative
            if any(i == -1 - n_seen or i < 0 for i in idx):
                raise MeshLoadError(f"line {lineno}: face index 0 or before the first vertex", path)
            tris.extend((idx[0], idx[j], idx[j + 1]) for j in range(1, len(idx) - 1))
    if not verts:
        raise MeshLoadError("no vertices ('v' records)", path)
    if not tris:
        raise MeshLoadError("empty mesh: no faces ('f' records)", path)
    try:
        V = np.array(verts, dtype=np.float64)
    except ValueError:
        raise MeshLoadError("a vertex coordinate is not a number", path) from None
    return V, np.array(tris, dtype=np.int64)
