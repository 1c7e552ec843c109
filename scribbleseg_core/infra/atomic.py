"""Atomic file writes: a crash mid-save never leaves a half-written file behind."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Literal


@contextlib.contextmanager
def atomic_write(
    path: str | os.PathLike, mode: Literal["w", "wb"] = "w", *, encoding: str = "utf-8"
) -> Iterator[IO]:
    """Open a temporary file beside `path`; on success, flush, fsync and rename it over `path`.

    If the body raises, the temporary file is removed and `path` is left as it was.

    Parameters
    ----------
    path : str or os.PathLike
        The destination. Its folder is created if missing.
    mode : {"w", "wb"}
        Text or binary.
    encoding : str
        Text encoding (text mode only).

    Examples
    --------
    >>> with atomic_write(tmp / "a.txt") as f:   # doctest: +SKIP
    ...     f.write("hello")
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"mode must be 'w' or 'wb'; got {mode!r}")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        kwargs = {"encoding": encoding, "newline": "\n"} if mode == "w" else {}
        with os.fdopen(fd, mode, **kwargs) as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write `data` to `path` atomically."""
    with atomic_write(path, "wb") as f:
        f.write(data)


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write `text` (UTF-8) to `path` atomically."""
    with atomic_write(path, "w") as f:
        f.write(text)
