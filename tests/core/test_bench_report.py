"""The benchmark report on a small planted PSB-style folder: modes, files, self-verification."""

from __future__ import annotations

import json

import numpy as np
import pytest

from scribbleseg_core.engine.network import NetworkParams
from scribbleseg_core.engine.optimize import SegmentParams
from scribbleseg_core.evaluation.benchmark import bench, keep_coverage, keep_strokes, verify
from scribbleseg_core.formats.scribbles import Scribbles, Stroke, write_scribbles
from scribbleseg_core.formats.seg import write_seg
from tests.conftest import write_off
from tests.core.planted import LABELS, creature, stroke_faces

FAST = SegmentParams(network=NetworkParams(epochs=20, faces_per_epoch=1000))


@pytest.fixture(scope="module")
def planted_root(tmp_path_factory):
    root = tmp_path_factory.mktemp("psb")
    cat = root / "Planted"
    (cat / "labels").mkdir(parents=True)
    (cat / "scribbles").mkdir()
    human = {}
    for i, (limb, head) in enumerate([(1.6, 0.9), (1.2, 0.7), (2.0, 1.1), (1.4, 0.8)]):
        mesh, gt = creature(limb, head, seed=i)
        name = str(i + 1)
        write_off(cat / f"{name}.off", mesh.V, mesh.F)
        write_seg(cat / "labels" / f"{name}.seg", gt)
        strokes = tuple(Stroke(lab, stroke_faces(mesh, gt, lab)) for lab in range(len(LABELS)))
        write_scribbles(cat / "scribbles" / f"{name}.json", Scribbles(f"{name}.off", len(gt), LABELS, strokes))
        human[f"{name}_0"] = gt.astype(np.int16)
    np.savez(cat / "benchmark_seg.npz", **human)
    (cat / "labels" / "label_names.txt").write_text("".join(f"{i} {n}\n" for i, n in enumerate(LABELS)))
    return root


def test_train_test_collection_report(tmp_path, planted_root):
    out = tmp_path / "out"
    report = bench(planted_root, out, modes=("train", "test", "collection"), folds=2, scribbled=(2,),
                   params=FAST)
    entry = report["categories"]["Planted"]
    assert report["verified"] is True
    assert report["settings"]["network"]["seed"] == FAST.network.seed
    assert entry["train"]["summary"]["ri_error"] < 0.08
    assert entry["train"]["summary"]["scored_shapes"] == 4
    assert entry["test"]["summary"]["scored_shapes"] == 4  # every shape predicted once
    assert entry["collection_2"]["summary"]["scored_shapes"] == 2  # one run on all 4, the 2 unpainted scored
    # a human segmentation equal to the truth, split into components, scores like the label map
    assert entry["train"]["summary"]["ri_error_human"] >= entry["train"]["summary"]["ri_error"] - 1e-9
    for key in ("gce", "lce", "hamming", "cut_discrepancy", "accuracy_area", "ri_error_area"):
        assert np.isfinite(entry["train"]["summary"][key])
    md = (out / "report.md").read_text()
    assert md.count("| Planted |") == 7  # a row per mode, the cost table, and a row per mode of the time table
    seconds = entry["test"]["summary"]["seconds"]
    assert seconds["training"] > 0 and seconds["prediction"] > 0 and seconds["shapes"] > 0
    assert json.loads((out / "report.json").read_text())["verified"] is True
    assert (out / "Planted" / "test" / "3.seg").is_file()
    pytest.importorskip("matplotlib")
    assert (out / "chart.png").stat().st_size > 1000


def test_verification_catches_a_tampered_seg(tmp_path, planted_root):
    out = tmp_path / "out"
    report = bench(planted_root, out, modes=("train",), params=FAST)
    seg = out / "Planted" / "train" / "1.seg"
    labels = np.loadtxt(seg, dtype=int)
    half = len(labels) // 2  # (renaming all labels would not change the Rand Index)
    labels[:half] = (labels[:half] + 1) % 3
    write_seg(seg, labels)
    with pytest.raises(AssertionError, match="Planted/train/1"):
        verify(planted_root, out, report)


def test_keep_coverage_keeps_the_middle_of_every_stroke():
    scr = Scribbles("m.off", 100, ("a",), (Stroke(0, np.arange(10)), Stroke(0, np.arange(50, 53))))
    cut = keep_coverage(scr, 0.4)
    np.testing.assert_array_equal(cut.strokes[0].faces, [3, 4, 5, 6])
    assert len(cut.strokes[1].faces) == 1
    assert keep_coverage(scr, 1.0) is scr


def test_keep_strokes_keeps_the_longest_stroke_of_every_label():
    a, b, c, d = (Stroke(0, np.arange(3)), Stroke(1, np.arange(10, 12)), Stroke(0, np.arange(20, 25)),
                  Stroke(0, np.arange(30, 35)))
    scr = Scribbles("m.off", 100, ("a", "b"), (a, b, c, d))
    one = keep_strokes(scr, "one")
    assert one.strokes == (b, c)  # painting order kept; of equals, the first
    assert keep_strokes(scr, "all") is scr
    assert keep_strokes(None, "one") is None
    with pytest.raises(ValueError, match="strokes"):
        keep_strokes(scr, "two")


def test_reports_run_apart_merge_into_one(tmp_path, planted_root):
    import shutil

    from scribbleseg_core.errors import ScribblesegError
    from scribbleseg_core.evaluation.benchmark import merge_reports

    root = tmp_path / "psb"
    shutil.copytree(planted_root, root)
    shutil.copytree(root / "Planted", root / "Second")
    a = bench(root, tmp_path / "a", modes=("train",), cats=["Planted"], params=FAST)
    b = bench(root, tmp_path / "b", modes=("train",), cats=["Second"], params=FAST)
    merged = merge_reports(root, [tmp_path / "a", tmp_path / "b"], tmp_path / "m")
    assert list(merged["categories"]) == ["Planted", "Second"]
    assert merged["verified"] is True
    want = np.mean([r["categories"][c]["train"]["summary"]["ri_error"] for r, c in ((a, "Planted"), (b, "Second"))])
    assert merged["average"]["train"]["ri_error"] == pytest.approx(want)
    assert (tmp_path / "m" / "Second" / "train" / "1.seg").is_file()
    assert "| Second |" in (tmp_path / "m" / "report.md").read_text()
    with pytest.raises(ScribblesegError, match="more than one part"):
        merge_reports(root, [tmp_path / "a", tmp_path / "a"], tmp_path / "m2")
    bench(root, tmp_path / "c", modes=("train",), cats=["Second"], folds=3, params=FAST)
    with pytest.raises(ScribblesegError, match="other settings"):
        merge_reports(root, [tmp_path / "a", tmp_path / "c"], tmp_path / "m3")
    # parts may split by mode too: train here, test there, one category
    t = bench(root, tmp_path / "t", modes=("test",), cats=["Second"], folds=3, params=FAST)
    both = merge_reports(root, [tmp_path / "c", tmp_path / "t"], tmp_path / "m5")
    assert both["settings"]["modes"] == ["train", "test"]
    assert set(both["categories"]["Second"]) >= {"train", "test", "shapes"}
    assert both["average"]["test"]["ri_error"] == pytest.approx(t["average"]["test"]["ri_error"])
    assert (tmp_path / "m5" / "Second" / "test").is_dir() and (tmp_path / "m5" / "Second" / "train").is_dir()
    with pytest.raises(ScribblesegError, match=r"Second \(test\) is in more than one part"):
        merge_reports(root, [tmp_path / "t", tmp_path / "t"], tmp_path / "m6")
    # and by collection size: 1 painted here, 2 there
    one = bench(root, tmp_path / "k1", modes=("collection",), cats=["Second"], folds=3, scribbled=(1,), params=FAST)
    bench(root, tmp_path / "k2", modes=("collection",), cats=["Second"], folds=3, scribbled=(2,), params=FAST)
    sizes = merge_reports(root, [tmp_path / "k1", tmp_path / "k2", tmp_path / "t"], tmp_path / "m7")
    assert sizes["settings"]["modes"] == ["collection", "test"] and sizes["settings"]["scribbled"] == [1, 2]
    assert set(sizes["categories"]["Second"]) >= {"collection_1", "collection_2", "test"}
    assert sizes["average"]["collection_1"]["ri_error"] == pytest.approx(one["average"]["collection_1"]["ri_error"])
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "report.json").write_text("{")
    with pytest.raises(ScribblesegError, match="not a benchmark report"):
        merge_reports(root, [tmp_path / "a", tmp_path / "bad"], tmp_path / "m4")


def test_given_mode_scores_painted_and_unpainted_shapes_apart(tmp_path, planted_root):
    import shutil
    import warnings

    root = tmp_path / "psb"
    shutil.copytree(planted_root, root)
    (root / "Planted" / "benchmark_seg.npz").unlink()  # like a user's folder: no human segmentations
    for name in ("2", "4"):
        (root / "Planted" / "scribbles" / f"{name}.json").unlink()
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # no "mean of empty slice" for the missing human scores
        report = bench(root, tmp_path / "out", modes=("given",), params=FAST)
    entry = report["categories"]["Planted"]
    assert report["verified"] is True
    assert sorted(entry["given_scribbled"]["shapes"]) == ["1", "3"]
    assert sorted(entry["given_unscribbled"]["shapes"]) == ["2", "4"]
    assert entry["given_scribbled"]["summary"]["ri_error"] < 0.08
    assert np.isnan(report["average"]["given_unscribbled"]["ri_error_human"])
    assert np.isfinite(report["average"]["given_unscribbled"]["ri_error"])


def test_truth_labels_train_on_every_face_of_the_painted_shapes(tmp_path, planted_root, monkeypatch):
    """``labels="truth"``: the painted shapes are fully labeled shapes (the learner's ceiling)."""
    import scribbleseg_core.evaluation.benchmark as benchmark

    given = []
    real = benchmark.prepare_shape

    def spy(mesh, file_scribble=None, **kwargs):
        given.append(None if file_scribble is None else np.asarray(file_scribble).copy())
        return real(mesh, file_scribble, **kwargs)

    monkeypatch.setattr(benchmark, "prepare_shape", spy)
    report = bench(planted_root, tmp_path / "out", modes=("train",), labels="truth", params=FAST)
    assert report["settings"]["labels"] == "truth"
    assert len(given) == 4 and all(g is not None and (g >= 0).all() for g in given)  # every face labeled
    assert report["categories"]["Planted"]["train"]["summary"]["ri_error"] == 0.0  # hard labels come back as given
    with pytest.raises(ValueError, match="labels must be one of"):
        bench(planted_root, tmp_path / "other", modes=("train",), labels="guess", params=FAST)
