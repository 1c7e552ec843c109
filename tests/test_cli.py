"""The CLI reports bad input in one line, never a traceback."""

from __future__ import annotations

import subprocess
import sys

import pytest


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


def test_segment_then_predict_a_planted_folder(tmp_path):
    """`segment DIR --out OUT` on meshes + scribbles/ (the PSB layout), then `predict`."""
    import numpy as np

    from scribbleseg_core.export import read_ply_labels, read_seg
    from scribbleseg_core.scribbles import Scribbles, Stroke, write_scribbles
    from tests.conftest import write_off
    from tests.core.planted import LABELS, creature, stroke_faces

    data = tmp_path / "data"
    (data / "scribbles").mkdir(parents=True)
    gts = {}
    for i, (limb, head) in enumerate([(1.6, 0.9), (1.2, 0.7), (2.0, 1.1)]):
        mesh, gt = creature(limb, head, seed=i)
        name = f"{i + 1}.off"
        write_off(data / name, mesh.V, mesh.F)
        gts[i + 1] = gt
        if i < 2:
            strokes = tuple(Stroke(lab, stroke_faces(mesh, gt, lab)) for lab in range(len(LABELS)))
            write_scribbles(data / "scribbles" / f"{i + 1}.json", Scribbles(name, len(mesh.F), LABELS, strokes))
    out = tmp_path / "out"
    env = {"SCRIBBLESEG_CACHE_DIR": str(tmp_path / "cache")}
    r = _run_env(env, "segment", str(data), "--out", str(out), "--quiet")
    assert r.returncode == 0, r.stderr
    for k in (1, 2, 3):  # 1, 2 scribbled; 3 predicted
        labels = read_seg(out / f"{k}.seg", len(gts[k]))
        assert (labels == gts[k]).mean() > 0.9
        np.testing.assert_array_equal(read_ply_labels(out / f"{k}.ply"), labels)
    assert (out / "model" / "model.json").is_file()
    r = _run_env(env, "predict", str(out / "model"), str(data / "3.off"), "--out", str(tmp_path / "pred"), "--quiet")
    assert r.returncode == 0, r.stderr
    np.testing.assert_array_equal(read_seg(tmp_path / "pred" / "3.seg"), read_seg(out / "3.seg"))
    # a model folder that is not one is one clear line
    r = _run_env(env, "predict", str(data), str(data / "3.off"), "--out", str(tmp_path / "x"))
    assert r.returncode == 2 and "no model.json" in r.stderr and "Traceback" not in r.stderr


def _run_env(env, *args):
    import os

    return subprocess.run([sys.executable, "-m", "scribbleseg_core.cli", *args], capture_output=True, text=True,
                          env={**os.environ, **env})


def test_bench_refuses_out_of_range_options_before_running(tmp_path):
    for option, value, message in [("--cross-fit", "1.5", "must lie in [0, 1]"),
                                   ("--cross-fit-repeats", "0", "must be at least 1"),
                                   ("--folds", "1", "must be at least 2")]:
        r = _run("bench", str(tmp_path), option, value, "--out", str(tmp_path / "out"))
        assert r.returncode == 2 and "Traceback" not in r.stderr
        assert f"argument {option}: {message}" in r.stderr
        assert not (tmp_path / "out").exists()


def test_bench_options_reach_the_engine():
    from scribbleseg_core.cli import _bench_params, build_parser
    from scribbleseg_core.optimize import SegmentParams

    parse = build_parser().parse_args
    default = _bench_params(parse(["bench", "data", "--out", "o"]))
    assert default.network.seed == SegmentParams().network.seed
    assert default.cross_fit == SegmentParams().cross_fit and default.cores is not None
    params = _bench_params(parse(["bench", "data", "--out", "o", "--network-seed", "3", "--threads", "1",
                                  "--cross-fit", "0.5", "--no-cores", "--walk", "0", "--convex", "0.1",
                                  "--stroke-network", "0", "--no-local-shape"]))
    assert (params.network.seed, params.network.threads, params.cross_fit) == (3, 1, 0.5)
    assert params.cores is None and params.propagation.walk == 0 and params.propagation.convex == 0.1
    assert default.propagation.convex == SegmentParams().propagation.convex
    assert params.stroke_network == 0 and default.stroke_network == SegmentParams().stroke_network > 0
    assert not params.local_shape and default.local_shape == SegmentParams().local_shape
    with pytest.raises(SystemExit):
        parse(["bench", "data", "--out", "o", "--stroke-network", "-0.05"])
