"""The CLI reports bad input in one line, never a traceback."""

from __future__ import annotations

import subprocess
import sys


def _run(*args):
    return subprocess.run([sys.executable, "-m", "scribbleseg_core.cli", *args], capture_output=True, text=True)


def test_info_on_bad_files_is_one_line_each(tmp_path):
    bad = tmp_path / "bad.off"
    bad.write_text("OFF\n3 1 0\n0 0 0\n")
    r = _run("info", str(bad), str(tmp_path / "missing.ply"))
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 2 and "Traceback" not in r.stderr
    assert lines[0].startswith(f"error: {bad}: truncated")
    assert "missing.ply: file not found" in lines[1]


def test_info_on_a_good_mesh(tmp_path):
    (tmp_path / "t.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    r = _run("info", str(tmp_path / "t.obj"))
    assert r.returncode == 0 and "1 boundary loops" in r.stdout
