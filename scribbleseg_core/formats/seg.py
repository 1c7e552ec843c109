"""PSB ``.seg`` label files: one integer label per face per line, in the file's face order."""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from scribbleseg_core.errors import ScribbleFileError
from scribbleseg_core.infra.atomic import atomic_write_text


def write_seg(path: str | os.PathLike, labels: np.ndarray) -> Path:
    """PSB ``.seg``: one integer label per face per line."""
    buf = io.StringIO()
    np.savetxt(buf, np.asarray(labels, dtype=np.int64), fmt="%d")
    atomic_write_text(path, buf.getvalue())
    return Path(path)


def read_seg(path: str | os.PathLike, num_faces: int | None = None) -> np.ndarray:
    """Read a ``.seg`` file: (m,) int64 labels.

    Raises
    ------
    ScribbleFileError
        Unreadable, non-integer lines, or a face count other than `num_faces`.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
        tokens = text.split()
        labels = np.array([int(t) for t in tokens], dtype=np.int64)
    except FileNotFoundError:
        raise ScribbleFileError("file not found", path) from None
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise ScribbleFileError(f"not a .seg file of integers ({e})"[:200], path) from None
    if num_faces is not None and labels.size != num_faces:
        raise ScribbleFileError(f"holds {labels.size} labels but the mesh has {num_faces} faces", path)
    return labels
