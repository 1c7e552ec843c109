"""What a benchmark's errors are made of: wrong part names or misplaced boundaries.

For every category of one or more ``scribbleseg bench`` output folders, reads the predicted
``.seg`` files of one mode and prints the mean Rand Index error as predicted, with every
predicted region given its right name, and with every true part given the name our labels
give most of it (:func:`~scribbleseg_core.evaluation.metrics.error_anatomy`). The first
repair leaves the boundaries where we put them; the second puts them where the ground truth
has them. Where the second falls far below the first, boundaries, not names, make the error.

Usage::

    python scripts/error_anatomy.py BENCH_OUT [BENCH_OUT ...] [--mode test] [--data PSB]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from scribbleseg_core.evaluation.metrics import error_anatomy
from scribbleseg_core.evaluation.psb import default_psb_dir
from scribbleseg_core.formats.mesh import load_mesh
from scribbleseg_core.formats.seg import read_seg

COLUMNS = ("error", "names_right", "boundaries_right")


def category_anatomy(folder: Path, data: Path) -> dict[str, float]:
    """Mean of :func:`error_anatomy` over the ``.seg`` files in `folder` (one category's mode),
    against the ground truth in ``data/<category>/labels``."""
    cat = folder.parent.name
    rows = []
    for seg in sorted(folder.glob("*.seg")):
        mesh = load_mesh(data / cat / f"{seg.stem}.off")
        n = mesh.num_file_faces
        rows.append(error_anatomy(mesh.F_file, read_seg(seg, n), read_seg(data / cat / "labels" / seg.name, n)))
    if not rows:
        raise SystemExit(f"error: {folder}: no .seg files")
    return {c: float(np.mean([r[c] for r in rows])) for c in COLUMNS}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("outputs", nargs="+", type=Path, help="output folders of scribbleseg bench")
    ap.add_argument("--mode", default="test", help="the mode's folder name (test, train, collection_5, ...)")
    ap.add_argument("--data", type=Path, default=None, help="PSB folder (default ../shared/psb)")
    a = ap.parse_args(argv)
    data = a.data or default_psb_dir()
    if data is None:
        ap.error("no PSB data: pass --data or set SCRIBBLESEG_PSB")
    folders = sorted((f for out in a.outputs for f in out.glob(f"*/{a.mode}") if f.is_dir()), key=lambda f: f.parent.name)
    if not folders:
        ap.error(f"no <category>/{a.mode} folders in {', '.join(map(str, a.outputs))}")
    table = {}
    print(f"| category | {' | '.join(COLUMNS)} |\n|---|{'---|' * len(COLUMNS)}")
    for f in folders:
        table[f.parent.name] = row = category_anatomy(f, data)
        print(f"| {f.parent.name} | {' | '.join(f'{row[c]:.3f}' for c in COLUMNS)} |", flush=True)
    means = {c: np.mean([r[c] for r in table.values()]) for c in COLUMNS}
    print(f"| **mean** ({len(table)}) | {' | '.join(f'**{means[c]:.4f}**' for c in COLUMNS)} |")


if __name__ == "__main__":
    main()
