"""Scribble files, format version 1 (``../shared/psb/README.md``).

A scribble file names its mesh, the label vocabulary and the strokes; each stroke is a
label id and the 0-based file face ids it covers.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from scribbleseg_core.errors import ScribbleFileError
from scribbleseg_core.infra.atomic import atomic_write_text

FORMAT = "scribbleseg-scribbles"
VERSION = 1


@dataclass(frozen=True)
class Stroke:
    """One painted stroke: a label id and the file faces it covers, (s,) int64."""

    label: int
    faces: np.ndarray


@dataclass(frozen=True)
class Scribbles:
    """The scribbles of one mesh.

    Attributes
    ----------
    mesh : str
        The mesh file name, relative to the scribble file (or its parent folder).
    num_faces : int
        Face count of that mesh (file faces).
    label_names : tuple of str
    strokes : tuple of Stroke
        In painting order: a later stroke wins on faces painted twice.
    """

    mesh: str
    num_faces: int
    label_names: tuple[str, ...]
    strokes: tuple[Stroke, ...] = field(default_factory=tuple)

    @classmethod
    def from_face_labels(cls, mesh: str, labels: np.ndarray, label_names) -> Scribbles:
        """The inverse of :meth:`face_labels`: one stroke per label present in `labels`
        ((num_faces,) int, -1 unscribbled), in label order."""
        labels = np.asarray(labels, dtype=np.int64)
        strokes = tuple(Stroke(int(lab), np.flatnonzero(labels == lab)) for lab in np.unique(labels[labels >= 0]))
        return cls(mesh, len(labels), tuple(label_names), strokes)

    def face_labels(self) -> np.ndarray:
        """Label per file face, -1 where unscribbled; (num_faces,) int64."""
        out = np.full(self.num_faces, -1, np.int64)
        for s in self.strokes:
            out[s.faces] = s.label
        return out

    @property
    def used_labels(self) -> np.ndarray:
        """Sorted label ids that occur in at least one non-empty stroke."""
        return np.unique([s.label for s in self.strokes if len(s.faces)]).astype(np.int64)


def read_scribbles(path: str | os.PathLike, *, num_faces: int | None = None) -> Scribbles:
    """Read and validate a scribble file.

    Parameters
    ----------
    path : str or os.PathLike
    num_faces : int, optional
        The face count of the mesh it will be applied to; a mismatch is refused.

    Raises
    ------
    ScribbleFileError
        Not JSON, an unknown ``format`` or a newer ``version``, missing fields, a face id
        or label out of range, or a mismatched ``num_faces``.
    """
    path = Path(path)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ScribbleFileError("file not found", path) from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ScribbleFileError(f"not a readable JSON file ({e})", path) from None
    return parse_scribbles(doc, path=path, num_faces=num_faces)


def parse_scribbles(doc, *, path=None, num_faces: int | None = None) -> Scribbles:
    """Validate a decoded scribble document; see :func:`read_scribbles`."""
    if not isinstance(doc, dict):
        raise ScribbleFileError("not a scribble file (top level is not an object)", path)
    if doc.get("format") != FORMAT:
        raise ScribbleFileError(f"unknown format {doc.get('format')!r}; expected {FORMAT!r}", path)
    version = doc.get("version")
    if not isinstance(version, int) or isinstance(version, bool):
        raise ScribbleFileError(f"missing or bad 'version' ({version!r})", path)
    if version > VERSION:
        raise ScribbleFileError(
            f"format version {version} is newer than this scribbleseg reads ({VERSION}); upgrade", path
        )
    if version < 1:
        raise ScribbleFileError(f"bad format version {version}", path)
    mesh = doc.get("mesh")
    if not isinstance(mesh, str) or not mesh:
        raise ScribbleFileError("missing 'mesh' (the mesh file name)", path)
    n = doc.get("num_faces")
    if not _is_int(n) or n <= 0:
        raise ScribbleFileError(f"missing or bad 'num_faces' ({n!r})", path)
    if num_faces is not None and n != num_faces:
        raise ScribbleFileError(
            f"num_faces is {n} but the mesh {mesh!r} has {num_faces} faces: "
            "the scribbles were painted on another mesh",
            path,
        )
    names = doc.get("label_names")
    if not isinstance(names, list) or not all(isinstance(x, str) for x in names):
        raise ScribbleFileError("'label_names' must be a list of strings", path)
    raw = doc.get("strokes", [])
    if not isinstance(raw, list):
        raise ScribbleFileError("'strokes' must be a list", path)
    strokes = []
    for i, s in enumerate(raw):
        if not isinstance(s, dict) or not _is_int(s.get("label")) or not isinstance(s.get("faces"), list):
            raise ScribbleFileError(f"stroke {i} must be an object with an int 'label' and a list 'faces'", path)
        label = s["label"]
        if not 0 <= label < len(names):
            raise ScribbleFileError(
                f"stroke {i}: label {label} out of range (there are {len(names)} label names)", path
            )
        if not all(_is_int(f) for f in s["faces"]):
            raise ScribbleFileError(f"stroke {i}: face ids must be integers", path)
        faces = np.asarray(s["faces"], dtype=np.int64).reshape(-1)
        if faces.size and (faces.min() < 0 or faces.max() >= n):
            bad = int(faces[(faces < 0) | (faces >= n)][0])
            raise ScribbleFileError(
                f"stroke {i}: face id {bad} out of range (the mesh has {n} faces)", path
            )
        strokes.append(Stroke(int(label), faces))
    return Scribbles(mesh, int(n), tuple(names), tuple(strokes))


def _is_int(x) -> bool:
    return isinstance(x, int) and not isinstance(x, bool)


def scribbles_to_json(scr: Scribbles) -> dict:
    """The JSON document of `scr` (format v1)."""
    return {
        "format": FORMAT,
        "version": VERSION,
        "mesh": scr.mesh,
        "num_faces": int(scr.num_faces),
        "label_names": list(scr.label_names),
        "strokes": [{"label": int(s.label), "faces": [int(f) for f in s.faces]} for s in scr.strokes],
    }


def write_scribbles(path: str | os.PathLike, scr: Scribbles) -> None:
    """Write `scr` to `path` atomically (format v1)."""
    atomic_write_text(path, json.dumps(scribbles_to_json(scr), separators=(",", ":")) + "\n")


def resolve_mesh_path(scribble_path: str | os.PathLike, scr: Scribbles) -> Path:
    """The mesh a scribble file names: beside it, else in its parent folder.

    Raises
    ------
    ScribbleFileError
        When neither exists.
    """
    scribble_path = Path(scribble_path)
    for folder in (scribble_path.parent, scribble_path.parent.parent):
        cand = folder / scr.mesh
        if cand.is_file():
            return cand
    raise ScribbleFileError(
        f"its mesh {scr.mesh!r} is neither beside it nor in its parent folder", scribble_path
    )
