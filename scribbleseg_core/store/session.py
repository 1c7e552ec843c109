"""Sessions: a collection's meshes, labels, scribbles, results and model as plain files.

A session folder holds::

    session.json            format, version, labels (names, colors), shapes (mesh path,
                            state, file stems), the current shape
    scribbles/<stem>.json   scribble format v1, per shape with scribbles
    results/<stem>.seg      one label per file face (-1 unlabeled), per shape with a result
    model/                  the trained model (:mod:`scribbleseg_core.store.model_file`), if any

Mesh paths are stored relative to the session folder when they lie under it or beside
it, so a session moved together with its meshes still opens. Nothing is pickled.
"""

from __future__ import annotations

import json
import os
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from scribbleseg_core.errors import ScribblesegError, SessionFileError
from scribbleseg_core.formats.labels import LabelSet
from scribbleseg_core.formats.scribbles import (
    Scribbles,
    read_scribbles,
    write_scribbles,
)
from scribbleseg_core.formats.seg import read_seg, write_seg
from scribbleseg_core.infra.atomic import atomic_write_text

FORMAT = "scribbleseg-session"
VERSION = 1
STATES = ("untouched", "scribbled", "labeled", "predicted")


@dataclass
class SessionShape:
    """One shape of a session.

    Attributes
    ----------
    mesh : Path
        Absolute path of the mesh file.
    num_faces : int
        Faces in the mesh file (scribbles and results index them).
    scribble : (num_faces,) int64 ndarray or None
        Scribble label per file face, -1 unscribbled.
    labels : (num_faces,) int64 ndarray or None
        The result per file face, -1 unlabeled.
    state : str
        One of :data:`STATES`.
    """

    mesh: Path
    num_faces: int
    scribble: np.ndarray | None = None
    labels: np.ndarray | None = None
    state: str = "untouched"


@dataclass
class Session:
    label_set: LabelSet
    shapes: list[SessionShape] = field(default_factory=list)
    current: int = 0
    model: object = None  # TrainedModel or None
    problems: list[str] = field(default_factory=list)  # what did not load, for the user


def _stems(shapes: list[SessionShape]) -> list[str]:
    stems = [s.mesh.stem for s in shapes]
    if len(set(stems)) == len(stems):
        return stems
    return [f"{i:04d}_{stem}" for i, stem in enumerate(stems)]


def _portable(mesh: Path, folder: Path) -> str:
    """`mesh` relative to the session `folder` if it lies under the folder's parent
    (inside the session or beside it), else absolute."""
    mesh, base = mesh.resolve(), folder.parent
    try:
        mesh.relative_to(base)
    except ValueError:
        return str(mesh)
    return os.path.relpath(mesh, folder)


def save_session(folder: str | os.PathLike, session: Session) -> Path:
    """Write `session` into `folder` (created if needed). Every file is written atomically,
    ``session.json`` last, so an interrupted save leaves the previous session readable.

    Returns
    -------
    Path
        The ``session.json`` written.
    """
    folder = Path(folder).resolve()
    stems = _stems(session.shapes)
    names = session.label_set.names
    entries = []
    for shape, stem in zip(session.shapes, stems):
        entry = {"mesh": _portable(shape.mesh, folder), "num_faces": int(shape.num_faces), "state": shape.state, "stem": stem}
        if shape.scribble is not None and (shape.scribble >= 0).any():
            write_scribbles(folder / "scribbles" / f"{stem}.json", Scribbles.from_face_labels(shape.mesh.name, shape.scribble, names))
            entry["scribbles"] = f"scribbles/{stem}.json"
        if shape.labels is not None:
            write_seg(folder / "results" / f"{stem}.seg", shape.labels)
            entry["result"] = f"results/{stem}.seg"
        entries.append(entry)
    if session.model is not None:
        from scribbleseg_core.store.model_file import save_model

        save_model(folder / "model", session.model)
    elif (folder / "model" / "model.json").is_file():
        shutil.rmtree(folder / "model")  # a stale model of an older save
    doc = {"format": FORMAT, "version": VERSION, **session.label_set.to_json(), "current": int(session.current),
           "shapes": entries, "model": "model" if session.model is not None else None}
    path = folder / "session.json"
    atomic_write_text(path, json.dumps(doc, indent=1) + "\n")
    return path


def is_session(path: str | os.PathLike) -> bool:
    """True if `path` is a session folder or its ``session.json``."""
    path = Path(path)
    return (path / "session.json").is_file() if path.is_dir() else path.name == "session.json"


def load_session(path: str | os.PathLike) -> Session:
    """Read a session folder (or its ``session.json``).

    Meshes are not loaded here; a shape whose mesh is missing is still listed (the app
    reports it when shown). A model that cannot be loaded (another version, corrupt) is
    left out and named in ``Session.problems``; the rest of the session still opens.

    Raises
    ------
    SessionFileError
        Not a session, a newer version, malformed fields, or scribble/result files that do
        not fit their shape. The message names the file.
    """
    path = Path(path)
    doc_path = path / "session.json" if path.is_dir() else path
    folder = doc_path.parent.resolve()
    try:
        doc = json.loads(doc_path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise SessionFileError("not a scribbleseg session (no session.json)", folder) from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise SessionFileError(f"unreadable ({e})", doc_path) from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise SessionFileError("not a scribbleseg session file", doc_path)
    version = doc.get("version")
    if not isinstance(version, int) or version < 1:
        raise SessionFileError(f"bad session version {version!r}", doc_path)
    if version > VERSION:
        raise SessionFileError(f"session version {version} is newer than this scribbleseg reads ({VERSION}); upgrade", doc_path)
    try:
        label_set = LabelSet.from_names(doc["label_names"], doc.get("label_colors"))
        entries = doc["shapes"]
        if not isinstance(entries, list):
            raise TypeError("'shapes' must be a list")
        shapes = []
        for i, e in enumerate(entries):
            mesh = Path(e["mesh"])
            mesh = mesh if mesh.is_absolute() else (folder / mesh).resolve()
            n = e["num_faces"]
            if not isinstance(n, int) or isinstance(n, bool) or n <= 0:
                raise ValueError(f"shape {i}: bad num_faces {n!r}")
            state = e.get("state", "untouched")
            if state not in STATES:
                raise ValueError(f"shape {i}: unknown state {state!r}")
            shapes.append(SessionShape(mesh, n, state=state))
            if e.get("scribbles"):
                scr = read_scribbles(folder / e["scribbles"], num_faces=n)
                if len(scr.label_names) > len(label_set):
                    raise ValueError(f"{e['scribbles']}: {len(scr.label_names)} labels, the session has {len(label_set)}")
                shapes[-1].scribble = scr.face_labels()
            if e.get("result"):
                labels = read_seg(folder / e["result"], n)
                if labels.max(initial=-1) >= len(label_set) or labels.min(initial=0) < -1:
                    raise ValueError(f"{e['result']}: labels outside 0..{len(label_set) - 1}")
                shapes[-1].labels = labels
        current = doc.get("current", 0)
        current = current if isinstance(current, int) and 0 <= current < len(shapes) else 0
    except ScribblesegError as e:
        raise SessionFileError(f"session file {e}", doc_path) from None
    except (KeyError, TypeError, ValueError) as e:
        raise SessionFileError(f"malformed session ({type(e).__name__}: {e})", doc_path) from None
    model, problems = None, []
    if doc.get("model"):
        from scribbleseg_core.store.model_file import load_model

        try:
            model = load_model(folder / str(doc["model"]), expected_labels=label_set.names)
        except ScribblesegError as e:  # the scribbles and results are still worth having
            problems.append(f"the trained model was not loaded: {e}")
    return Session(label_set, shapes, current, model, problems)
