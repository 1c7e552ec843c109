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
    import json

    import numpy as np
    import trimesh

    from scribbleseg_core.formats.export import read_ply_labels, read_vtp_cell_data
    from scribbleseg_core.formats.scribbles import Scribbles, Stroke, write_scribbles
    from scribbleseg_core.formats.seg import read_seg
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
    for k in (1, 2, 3):  # 1, 2 scribbled; 3 without scribbles, labeled in the same run
        labels = read_seg(out / f"{k}.seg", len(gts[k]))
        assert (labels == gts[k]).mean() > (0.9 if k < 3 else 0.85)
        np.testing.assert_array_equal(read_ply_labels(out / f"{k}.ply"), labels)
    assert (out / "model" / "model.json").is_file()
    r = _run_env(env, "predict", str(out / "model"), str(data / "3.off"), "--out", str(tmp_path / "pred"), "--quiet")
    assert r.returncode == 0, r.stderr
    np.testing.assert_array_equal(read_seg(tmp_path / "pred" / "3.seg"), read_seg(out / "3.seg"))
    # with --confidence: the same labels, and the confidence in the PLY, the JSON summary and a VTP
    r = _run_env(env, "predict", str(out / "model"), str(data / "3.off"), "--out", str(tmp_path / "conf"),
                 "--quiet", "--confidence")
    assert r.returncode == 0, r.stderr
    labels = read_seg(tmp_path / "conf" / "3.seg")
    np.testing.assert_array_equal(labels, read_seg(out / "3.seg"))
    ply = trimesh.load(tmp_path / "conf" / "3.ply", process=False).metadata["_ply_raw"]["face"]["data"]
    conf = np.asarray(ply["confidence"]).ravel()
    assert conf.shape == labels.shape and 0 <= conf.min() and conf.max() <= 1 and conf.mean() > 0.5
    cells = read_vtp_cell_data(tmp_path / "conf" / "3.vtp")
    np.testing.assert_array_equal(cells["Label"], labels)
    np.testing.assert_allclose(cells["Confidence"], conf)
    summary = json.loads((tmp_path / "conf" / "3.labels.json").read_text())["confidence"]
    assert summary["unconfident_faces"] == int((conf < 0.5).sum())
    assert set(summary["per_label"]) == {str(v) for v in np.unique(labels)}
    # a model folder that is not one is one clear line
    r = _run_env(env, "predict", str(data), str(data / "3.off"), "--out", str(tmp_path / "x"))
    assert r.returncode == 2 and "no model.json" in r.stderr and "Traceback" not in r.stderr


def _run_env(env, *args):
    import os

    return subprocess.run([sys.executable, "-m", "scribbleseg_core.cli", *args], capture_output=True, text=True,
                          env={**os.environ, **env})


def test_bench_refuses_out_of_range_options_before_running(tmp_path):
    for option, value, message in [("--convex", "1.5", "must lie in [0, 1]"),
                                   ("--rounds", "0", "must be at least 1"),
                                   ("--decided", "2", "must lie in [0, 1]"),
                                   ("--walk", "-1", "must not be negative"),
                                   ("--folds", "1", "must be at least 2")]:
        r = _run("bench", str(tmp_path), option, value, "--out", str(tmp_path / "out"))
        assert r.returncode == 2 and "Traceback" not in r.stderr
        assert f"argument {option}: {message}" in r.stderr
        assert not (tmp_path / "out").exists()


def test_bench_options_reach_the_engine():

    from scribbleseg_core.cli import _bench_params, build_parser
    from scribbleseg_core.engine.optimize import SegmentParams

    parse = build_parser().parse_args
    default = _bench_params(parse(["bench", "data", "--out", "o"]))
    assert default == SegmentParams()
    params = _bench_params(parse(["bench", "data", "--out", "o", "--network-seed", "3", "--threads", "1",
                                  "--walk", "0", "--convex", "0.1", "--contrast", "0", "--no-local-shape",
                                  "--method", "paper", "--rounds", "2", "--decided", "0"]))
    assert (params.network.seed, params.network.threads, params.method, params.rounds) == (3, 1, "paper", 2)
    assert params.decided == 0 and default.decided > 0
    assert (params.propagation.walk, params.propagation.convex, params.propagation.contrast) == (0, 0.1, 0)
    assert not params.local_shape
    with pytest.raises(SystemExit):
        parse(["bench", "data", "--out", "o", "--walk", "-0.5"])


def _soup(path, count: int, seed: int = 0) -> None:
    """An OFF file of `count` disconnected random triangles (a triangle soup)."""
    import numpy as np

    from tests.conftest import write_off

    rng = np.random.default_rng(seed)  # fixed: the same soup every run
    V = (rng.random((count, 1, 3)) * 10 + rng.normal(scale=0.1, size=(count, 3, 3))).reshape(-1, 3)
    write_off(path, V, np.arange(3 * count).reshape(count, 3))


def test_segment_processes_a_triangle_soup(tmp_path):
    """Every triangle its own component: more components than patches."""
    from scribbleseg_core.formats.scribbles import Scribbles, Stroke, write_scribbles
    from scribbleseg_core.formats.seg import read_seg

    data, count = tmp_path / "soup", 600
    data.mkdir()
    _soup(data / "soup.off", count)
    strokes = (Stroke(0, (0,)), Stroke(1, (1,)))
    write_scribbles(data / "soup.json", Scribbles("soup.off", count, ("a", "b"), strokes))
    r = _run("segment", str(data), "--out", str(tmp_path / "out"), "--quiet")
    assert r.returncode == 0, r.stderr
    labels = read_seg(tmp_path / "out" / "soup.seg", count)
    assert labels[0] == 0 and labels[1] == 1 and set(labels.tolist()) <= {0, 1}


def test_segment_into_an_existing_file_is_one_line(tmp_path):
    from scribbleseg_core.formats.scribbles import Scribbles, Stroke, write_scribbles

    data = tmp_path / "data"
    data.mkdir()
    _soup(data / "soup.off", 4)
    write_scribbles(data / "soup.json", Scribbles("soup.off", 4, ("a",), (Stroke(0, (0,)),)))
    taken = tmp_path / "taken.txt"
    taken.write_text("the user's file\n")
    r = _run("segment", str(data), "--out", str(taken))
    assert r.returncode == 2 and r.stderr.strip() == f"error: {taken}: exists and is not a folder; choose another --out"
    assert taken.read_text() == "the user's file\n"


def test_a_coordinate_too_large_to_process_is_named(tmp_path):
    from tests.conftest import write_off

    path = tmp_path / "huge.off"
    write_off(path, [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1e308]], [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    r = _run("info", str(path))
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.strip() == f"error: {path}: vertex 3 has a coordinate too large to process (1e+308; at most 1e+30 in magnitude)"


def test_the_app_without_its_extra_says_what_to_install():
    code = ("import sys; sys.modules['PySide6'] = None; from scribbleseg_app.main import main; "
            "raise SystemExit(main([]))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.startswith("error: the app needs its extra (pip install 'scribbleseg[app]')")


def test_segment_trains_on_fully_labeled_shapes(tmp_path):
    """`segment --labels FOLDER`: shapes with a .seg there train on every face's label."""
    import numpy as np

    from scribbleseg_core.formats.seg import read_seg, write_seg
    from tests.conftest import write_off
    from tests.core.planted import LABELS, creature

    data, labels = tmp_path / "data", tmp_path / "labels"
    labels.mkdir(parents=True)
    gts = {}
    for i, (limb, head) in enumerate([(1.6, 0.9), (1.2, 0.7), (2.0, 1.1)]):
        mesh, gt = creature(limb, head, seed=i)
        write_off(data / f"{i + 1}.off", mesh.V, mesh.F)
        gts[i + 1] = mesh.labels_to_file(gt)
    for k in (1, 2):  # ids in reverse order, named by label_names.txt
        write_seg(labels / f"{k}.seg", len(LABELS) - 1 - gts[k])
    (labels / "label_names.txt").write_text("".join(f"{i} {n}\n" for i, n in enumerate(reversed(LABELS))))
    env = {"SCRIBBLESEG_CACHE_DIR": str(tmp_path / "cache")}
    out = tmp_path / "out"
    r = _run_env(env, "segment", str(data), "--out", str(out), "--labels", str(labels), "--quiet")
    assert r.returncode == 0, r.stderr
    for k in (1, 2):  # every face's label is hard
        np.testing.assert_array_equal(read_seg(out / f"{k}.seg"), len(LABELS) - 1 - gts[k])
    assert (read_seg(out / "3.seg") == len(LABELS) - 1 - gts[3]).mean() > 0.85
    # a label file that does not fit its mesh is one line naming it
    write_seg(labels / "1.seg", np.zeros(5, np.int64))
    r = _run_env(env, "segment", str(data), "--out", str(out), "--labels", str(labels))
    assert r.returncode == 2 and "1.seg: holds 5 labels" in r.stderr and "Traceback" not in r.stderr
    write_seg(labels / "1.seg", np.full(len(gts[1]), 7))
    r = _run_env(env, "segment", str(data), "--out", str(out), "--labels", str(labels))
    assert r.returncode == 2 and "only 0 to 2 have names" in r.stderr
