"""Which meshes a batch job reads, and the name each one's outputs take.

An input is a mesh file, a folder (searched recursively for mesh files) or a ``.txt`` file
listing one path per line (files or folders; relative paths are read from the list's
folder; blank lines and lines starting with ``#`` are skipped).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from scribbleseg_core.errors import ScribblesegError
from scribbleseg_core.formats.mesh import MESH_EXTENSIONS

#: Suffix of a file listing inputs.
LIST_SUFFIX = ".txt"


@dataclass(frozen=True)
class Source:
    """One mesh of a batch job.

    Attributes
    ----------
    path : Path
        The mesh file.
    key : str
        Its outputs' path inside the output folder, without suffix, in POSIX form: the
        mesh's path relative to the folder it was found in, or its stem when named alone.
    """

    path: Path
    key: str


def gather_sources(inputs: Sequence[str | os.PathLike], *, exclude: Path | None = None) -> list[Source]:
    """The meshes named by `inputs`, sorted by key.

    Parameters
    ----------
    inputs : sequence of path
        Mesh files, folders, and ``.txt`` lists of either.
    exclude : Path, optional
        A folder whose files are never inputs (the output folder, which holds ``.ply``).

    Raises
    ------
    ScribblesegError
        A path that does not exist, a list naming one, a file that is not a mesh, or two
        meshes whose outputs would take the same name.
    """
    found: dict[str, Path] = {}
    skip = None if exclude is None else exclude.resolve()
    for source in _expand(inputs, skip, seen_lists=set()):
        other = found.get(source.key)
        if other is not None and other.resolve() != source.path.resolve():
            raise ScribblesegError(f"its outputs would be named {source.key!r}, as those of {other}; "
                                   "pass the folders that hold them instead", source.path)
        found[source.key] = source.path
    return [Source(path, key) for key, path in sorted(found.items())]


def _expand(inputs: Iterable[str | os.PathLike], skip: Path | None, seen_lists: set) -> Iterable[Source]:
    for item in inputs:
        path = Path(item)
        if path.is_dir():
            yield from _walk(path, skip)
        elif path.suffix.lower() == LIST_SUFFIX and path.is_file():
            if path.resolve() in seen_lists:
                raise ScribblesegError("lists itself, directly or through another list", path)
            yield from _expand(_read_list(path), skip, seen_lists | {path.resolve()})
        elif path.is_file():
            if path.suffix.lower() not in MESH_EXTENSIONS:
                raise ScribblesegError(f"not a mesh file (expected one of {', '.join(MESH_EXTENSIONS)}, "
                                       f"a folder or a {LIST_SUFFIX} list)", path)
            yield Source(path, path.stem)
        else:
            raise ScribblesegError("no such file or folder", path)


def _walk(folder: Path, skip: Path | None) -> Iterable[Source]:
    for root, dirs, files in os.walk(folder):
        here = Path(root)
        dirs[:] = sorted(d for d in dirs if not d.startswith(".") and (skip is None or (here / d).resolve() != skip))
        for name in sorted(files):
            if Path(name).suffix.lower() in MESH_EXTENSIONS and not name.startswith("."):
                path = here / name
                yield Source(path, path.relative_to(folder).with_suffix("").as_posix())


def _read_list(path: Path) -> list[Path]:
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise ScribblesegError(f"cannot read the list ({e})", path) from None
    out = []
    for line in text.splitlines():
        line = line.strip()
        if line and not line.startswith("#"):
            p = Path(line).expanduser()
            out.append(p if p.is_absolute() else path.parent / p)
    return out
