"""``scribbleseg-app``: the desktop application's entry point."""

from __future__ import annotations

import argparse
import sys


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="scribbleseg-app", description="Paint scribbles, segment a collection.")
    parser.add_argument("path", nargs="?", help="a folder of meshes, one mesh, or a saved session folder (default: the bundled demo creatures)")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)

    try:
        from PySide6.QtWidgets import QApplication
        from scribbleseg_app.main_window import MainWindow
    except ImportError as e:  # installed without the app's extra
        print(f"error: the app needs its extra (pip install 'scribbleseg[app]'): {e}", file=sys.stderr)
        return 2

    qapp = QApplication.instance() or QApplication(sys.argv[:1])
    window = MainWindow(args.path)
    window.show()
    window.runs.prepare()  # the first run's process imports the engine while the user paints
    return qapp.exec()


if __name__ == "__main__":
    raise SystemExit(main())
