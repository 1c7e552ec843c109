"""Find a collection's meshes and scribble files in a folder; unify their label names."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scribbleseg_core.errors import ScribbleFileError
from scribbleseg_core.formats.mesh import find_meshes
from scribbleseg_core.formats.scribbles import (
    FORMAT,
    Scribbles,
    read_scribbles,
    resolve_mesh_path,
)


@dataclass(frozen=True)
class CollectionFiles:
    """Meshes of a folder and the scribbles painted on them.

    Attributes
    ----------
    meshes : list of Path
        Every mesh of the folder, naturally sorted.
    scribbles : dict of Path -> Scribbles
        Mesh path -> its scribbles, stroke labels remapped to `label_names`.
    label_names : tuple of str
        Union over the scribble files, in order of first appearance.
    """

    meshes: list[Path]
    scribbles: dict[Path, Scribbles]
    label_names: tuple[str, ...]

    def face_labels(self, mesh_path: Path) -> np.ndarray | None:
        """Scribble label per file face for `mesh_path`, or None if unscribbled."""
        scr = self.scribbles.get(mesh_path)
        return None if scr is None else scr.face_labels()


def _scribble_files(folder: Path) -> list[Path]:
    files = sorted(folder.glob("*.json")) + sorted((folder / "scribbles").glob("*.json"))
    out = []
    for f in files:
        try:
            head = json.loads(f.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError):
            head = None
        if isinstance(head, dict) and head.get("format") == FORMAT:
            out.append(f)
        elif f.parent.name == "scribbles":  # everything there must be a scribble file
            read_scribbles(f)  # raises the precise error
    return out


def find_collection(folder: str | os.PathLike) -> CollectionFiles:
    """Meshes in `folder` and scribble files in `folder` or `folder/scribbles`.

    Raises
    ------
    ScribbleFileError
        A scribble file is invalid or names a mesh that is not there; two files scribble
        the same mesh.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise ScribbleFileError("not a folder", folder)
    meshes = find_meshes(folder)
    names: list[str] = []
    raw: dict[Path, tuple[Path, Scribbles]] = {}
    for f in _scribble_files(folder):
        scr = read_scribbles(f)
        mesh_path = resolve_mesh_path(f, scr).resolve()
        if mesh_path in raw:
            raise ScribbleFileError(f"{raw[mesh_path][0]} already scribbles {scr.mesh!r}", f)
        raw[mesh_path] = (f, scr)
        names += [n for n in scr.label_names if n not in names]
    scribbles = {}
    for mesh_path, (_, scr) in raw.items():
        remap = np.array([names.index(n) for n in scr.label_names], dtype=np.int64)
        strokes = tuple(type(s)(int(remap[s.label]), s.faces) for s in scr.strokes)
        scribbles[mesh_path] = Scribbles(scr.mesh, scr.num_faces, tuple(names), strokes)
    meshes = [m.resolve() for m in meshes]
    meshes += [m for m in scribbles if m not in meshes]
    return CollectionFiles(meshes, scribbles, tuple(names))
