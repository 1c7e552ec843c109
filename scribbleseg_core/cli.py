"""The ``scribbleseg`` command line.

Every bad input ends as one line ``error: <file>: <problem>`` and exit status 2, never a
traceback.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from scribbleseg_core import __version__
from scribbleseg_core.errors import ScribblesegError


def _cmd_info(args) -> int:
    from scribbleseg_core.mesh_io import load_mesh
    from scribbleseg_core.scribbles import read_scribbles

    status = 0
    for p in args.files:
        try:
            if Path(p).suffix.lower() == ".json":
                scr = read_scribbles(p)
                n = sum(len(s.faces) for s in scr.strokes)
                print(f"{p}: scribbles on {scr.mesh!r}: {len(scr.strokes)} strokes, {n} faces, "
                      f"labels {', '.join(scr.label_names)}")
            else:
                mesh = load_mesh(p)
                print(f"{p}: {mesh.report.summary()}")
        except ScribblesegError as e:
            print(f"error: {e}", file=sys.stderr)
            status = 2
    return status


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="scribbleseg", description="Scribble-based segmentation of 3D shape collections."
    )
    parser.add_argument("--version", action="version", version=f"scribbleseg {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("info", help="report what a mesh or scribble file holds and what was repaired")
    p.add_argument("files", nargs="+", help="mesh (.off .obj .ply .stl .glb .gltf) or scribble (.json) files")
    p.set_defaults(func=_cmd_info)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except ScribblesegError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
