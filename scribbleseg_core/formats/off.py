"""A strict, vectorized reader for OFF files (the PSB format).

Strict where trimesh is lenient: a file with fewer vertices or faces than its header
announces is reported as truncated, not silently shortened.
"""

from __future__ import annotations

import numpy as np

from scribbleseg_core.errors import MeshLoadError


def _tokens(data: bytes, path) -> list[bytes]:
    lines = []
    for raw in data.splitlines():
        line = raw.split(b"#", 1)[0].strip()
        if line:
            lines.append(line)
    if not lines:
        raise MeshLoadError("empty file", path)
    return lines


def read_off(data: bytes, path=None) -> tuple[np.ndarray, list[np.ndarray]]:
    """Parse an OFF file.

    Parameters
    ----------
    data : bytes
        The file's contents.
    path : str, optional
        For error messages.

    Returns
    -------
    V : (n, 3) float64 ndarray
    faces : list of int64 ndarray
        One (m, 3) array when every face is a triangle, else one 1-D array of corner
        indices per polygon, in file order (see :func:`fan_triangulate`).
    """
    if b"\x00" in data[:4096]:
        raise MeshLoadError("binary OFF is not supported (or the file is not OFF)", path)
    try:
        text_lines = _tokens(data, path)
    except UnicodeDecodeError as e:  # pragma: no cover - bytes path never decodes
        raise MeshLoadError(f"not a text OFF file ({e})", path) from None
    head = text_lines[0].split()
    keyword = head[0].upper() if head else b""
    if keyword not in (b"OFF", b"COFF", b"NOFF", b"CNOFF", b"STOFF"):
        raise MeshLoadError(f"not an OFF file: first line is {text_lines[0][:40]!r}", path)
    if keyword != b"OFF":
        raise MeshLoadError(f"{keyword.decode()} variant is not supported, only plain OFF", path)
    counts = head[1:]
    body = text_lines[1:]
    if not counts:
        if not body:
            raise MeshLoadError("truncated: no vertex/face counts after 'OFF'", path)
        counts, body = body[0].split(), body[1:]
    try:
        n_v, n_f = int(counts[0]), int(counts[1])
    except (ValueError, IndexError):
        raise MeshLoadError(f"bad counts line {b' '.join(counts)[:60]!r}", path) from None
    if n_v < 0 or n_f < 0:
        raise MeshLoadError(f"negative counts (vertices {n_v}, faces {n_f})", path)
    if n_v == 0 or n_f == 0:
        raise MeshLoadError(f"empty mesh ({n_v} vertices, {n_f} faces)", path)
    if len(body) < n_v + n_f:
        raise MeshLoadError(
            f"truncated: header announces {n_v} vertices and {n_f} faces, "
            f"the file holds {len(body)} data lines",
            path,
        )
    V = _parse_vertices(body[:n_v], path)
    faces = _parse_faces(body[n_v : n_v + n_f], n_v, path)
    return V, faces


def _parse_vertices(lines: list[bytes], path) -> np.ndarray:
    try:
        rows = [line.split()[:3] for line in lines]
        V = np.array(rows, dtype=np.float64)
    except ValueError:
        raise MeshLoadError("a vertex line does not hold three numbers", path) from None
    if V.ndim != 2 or V.shape[1] != 3:
        raise MeshLoadError("a vertex line does not hold three numbers", path)
    return V


def _parse_faces(lines: list[bytes], n_v: int, path) -> list[np.ndarray]:
    """Return faces as a list of int64 arrays, one per face (fast path for all-triangles)."""
    try:
        first = [line.split() for line in lines]
        sizes = np.array([int(tok[0]) for tok in first], dtype=np.int64)
    except (ValueError, IndexError):
        raise MeshLoadError("a face line does not start with its corner count", path) from None
    if (sizes < 3).any():
        bad = int(np.flatnonzero(sizes < 3)[0])
        raise MeshLoadError(f"face {bad} has {sizes[bad]} corners (need at least 3)", path)
    try:
        if (sizes == 3).all():
            arr = np.array([tok[1:4] for tok in first], dtype=np.int64)
            if arr.shape != (len(lines), 3):
                raise ValueError
            faces = [arr]
        else:
            faces = []
            for i, tok in enumerate(first):
                idx = np.array(tok[1 : 1 + sizes[i]], dtype=np.int64)
                if idx.size != sizes[i]:
                    raise ValueError
                faces.append(idx)
    except ValueError:
        raise MeshLoadError("a face line holds fewer indices than its corner count", path) from None
    flat = np.concatenate([f.ravel() for f in faces])
    if flat.size and (flat.min() < 0 or flat.max() >= n_v):
        raise MeshLoadError(
            f"face index out of range: indices span [{flat.min()}, {flat.max()}], "
            f"the mesh has {n_v} vertices",
            path,
        )
    return faces


def fan_triangulate(faces: list[np.ndarray]) -> np.ndarray:
    """Triangulate polygons as fans, keeping file order.

    Parameters
    ----------
    faces : list of int64 ndarray
        Either one (m, 3) array, or one 1-D array of corners per polygon.

    Returns
    -------
    F : (m, 3) int64 ndarray
        Triangles; a polygon with j corners becomes j - 2 consecutive triangles.
    """
    if len(faces) == 1 and faces[0].ndim == 2:
        return faces[0]
    tris = []
    for poly in faces:
        j = poly.size
        tris.append(np.stack([np.full(j - 2, poly[0]), poly[1:-1], poly[2:]], axis=1))
    return np.concatenate(tris).astype(np.int64)
