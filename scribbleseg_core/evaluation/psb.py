"""Access to the PSB benchmark data laid out as ``../shared/psb`` (read in place)."""

from __future__ import annotations

import os
from pathlib import Path

#: Environment variable overriding where the PSB data lives.
PSB_ENV = "SCRIBBLESEG_PSB"


def default_psb_dir() -> Path | None:
    """``$SCRIBBLESEG_PSB``, else ``../shared/psb`` from the project root; None if absent."""
    env = os.environ.get(PSB_ENV)
    candidates = [Path(env)] if env else []
    candidates.append(Path(__file__).resolve().parents[2] / "shared" / "psb")
    candidates.append(Path.cwd().parent / "shared" / "psb")
    for c in candidates:
        if c.is_dir():
            return c
    return None


def categories(root: Path) -> list[str]:
    """Category folder names under `root`, sorted."""
    return sorted(p.name for p in root.iterdir() if p.is_dir() and (p / "labels").is_dir())


def read_label_names(path: str | os.PathLike) -> list[str]:
    """``labels/label_names.txt``: ``"<id> <name>"`` per line -> names ordered by id."""
    pairs = []
    for line in Path(path).read_text(encoding="utf-8").splitlines():
        if line.strip():
            i, name = line.split(maxsplit=1)
            pairs.append((int(i), name.strip()))
    return [n for _, n in sorted(pairs)]
