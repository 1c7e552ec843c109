"""Prediction at scale on a real Dask LocalCluster of 2 worker processes."""

from __future__ import annotations

import json
import os
import signal
import threading

import numpy as np
import pytest

from scribbleseg_core.engine.network import NetworkParams
from scribbleseg_core.engine.optimize import SegmentParams, segment_collection
from scribbleseg_core.engine.predict import predict_shape
from scribbleseg_core.engine.shape import prepare_shape
from scribbleseg_core.errors import ScribblesegError
from scribbleseg_core.formats.mesh import load_mesh
from scribbleseg_core.formats.seg import read_seg
from scribbleseg_core.scale.inputs import gather_sources
from scribbleseg_core.scale.manifest import MANIFEST_NAME
from scribbleseg_core.scale.run import ERRORS_NAME, predict_many
from scribbleseg_core.store.model_file import save_model
from tests.conftest import write_off
from tests.core.planted import LABELS, creature, stroke_faces

distributed = pytest.importorskip("distributed")

FAST = SegmentParams(rounds=1, network=NetworkParams(epochs=15, faces_per_epoch=800, threads=1))
SHAPES = [(1.6, 0.9), (1.2, 0.7), (2.0, 1.1), (1.4, 1.0), (1.8, 0.8), (1.1, 0.6)]


@pytest.fixture(scope="module")
def job(tmp_path_factory):
    """A model trained on two planted creatures, and a folder tree of six more plus a corrupt file."""
    root = tmp_path_factory.mktemp("scale")
    train = []
    for i in range(2):
        mesh, gt = creature(1.5, 0.8, seed=100 + i)
        scr = np.full(len(mesh.F), -1)
        for lab in range(len(LABELS)):
            scr[stroke_faces(mesh, gt, lab)] = lab
        train.append(prepare_shape(mesh, scr))
    *_, last = segment_collection(train, LABELS, FAST)
    save_model(root / "model", last.model)
    data = root / "data"
    for i, (limb, head) in enumerate(SHAPES):
        mesh, _ = creature(limb, head, seed=i)
        write_off(data / ("a" if i % 2 else "b") / f"{i}.off", mesh.V, mesh.F)
    (data / "b" / "broken.off").write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n")
    return root


def _serial(job) -> dict[str, np.ndarray]:
    """Each healthy mesh predicted in this process, one after another: the reference."""
    from scribbleseg_core.store.model_file import load_model

    model = load_model(job / "model")
    out = {}
    for src in gather_sources([job / "data"]):
        if src.path.name != "broken.off":
            mesh = load_mesh(src.path)
            out[src.key] = mesh.labels_to_file(predict_shape(model, prepare_shape(mesh)))
    return out


def test_cluster_matches_the_serial_path_skips_on_rerun_and_records_the_corrupt_mesh(job):
    sources = gather_sources([job / "data"])
    assert [s.key for s in sources] == ["a/1", "a/3", "a/5", "b/0", "b/2", "b/4", "b/broken"]
    out = job / "out"
    seen = []
    summary = predict_many(job / "model", sources, out, workers=2, progress=lambda d, t: seen.append((d, t)))
    assert (summary.done, summary.skipped, summary.failed) == (6, 0, 1)
    assert not summary.ok and seen[-1] == (7, 7)
    errors = json.loads((out / ERRORS_NAME).read_text())
    assert [e["file"] for e in errors] == [str(job / "data" / "b" / "broken.off")]
    assert "truncated" in errors[0]["message"] and errors[0]["message"].startswith(errors[0]["file"])
    for key, labels in _serial(job).items():
        np.testing.assert_array_equal(read_seg(out / f"{key}.seg", len(labels)), labels)
        assert (out / f"{key}.ply").is_file()

    (job / "data" / "b" / "broken.off").unlink()
    again = predict_many(job / "model", gather_sources([job / "data"]), out, workers=2)
    assert (again.done, again.skipped, again.failed) == (0, 6, 0) and again.ok
    assert not (out / ERRORS_NAME).exists()

    # a changed source is redone; --force redoes all
    mesh, _ = creature(1.3, 0.9, seed=42)
    write_off(job / "data" / "a" / "1.off", mesh.V, mesh.F)
    third = predict_many(job / "model", gather_sources([job / "data"]), out, workers=2)
    assert (third.done, third.skipped) == (1, 5)
    assert len(read_seg(out / "a" / "1.seg")) == len(mesh.F)


def test_a_killed_worker_loses_nothing(job, tmp_path):
    from distributed import LocalCluster

    reference = _serial(job)
    sources = [s for s in gather_sources([job / "data"]) if s.path.name != "broken.off"]
    # the test's own cluster, reached through its address as a remote one would be (one client
    # per process, as in the CLI); its nannies know their worker processes
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        pids = [nanny.pid for nanny in cluster.workers.values()]
        assert all(pids)
        killed = threading.Event()

        def kill_one(done, total):  # after the first shape, while the others are in flight
            if done >= 1 and not killed.is_set():
                killed.set()
                os.kill(pids[0], signal.SIGKILL)

        summary = predict_many(job / "model", sources, tmp_path, scheduler=cluster.scheduler_address,
                               progress=kill_one)
    assert killed.is_set()
    assert (summary.done, summary.failed) == (len(sources), 0), summary.errors
    for key, labels in reference.items():
        np.testing.assert_array_equal(read_seg(tmp_path / f"{key}.seg", len(labels)), labels)
    lines = (tmp_path / MANIFEST_NAME).read_text().splitlines()
    assert sorted(json.loads(x)["key"] for x in lines) == sorted(reference)


def test_inputs_lists_folders_and_clashes(tmp_path):
    mesh, _ = creature(seed=1)
    write_off(tmp_path / "x" / "1.off", mesh.V, mesh.F)
    write_off(tmp_path / "y" / "1.off", mesh.V, mesh.F)
    (tmp_path / "x" / "notes.txt").write_text("not a list")
    (tmp_path / "list.txt").write_text("# shapes\nx/1.off\n\n" + str(tmp_path / "y") + "\n")
    with pytest.raises(ScribblesegError, match="outputs would be named '1'"):  # x/1.off and y/'s 1.off
        gather_sources([tmp_path / "list.txt"])
    (tmp_path / "list.txt").write_text("# shapes\nx/1.off\n\n")
    assert [(s.key, s.path) for s in gather_sources([tmp_path / "list.txt"])] == [("1", tmp_path / "x" / "1.off")]
    with pytest.raises(ScribblesegError, match="outputs would be named '1'"):
        gather_sources([tmp_path / "x" / "1.off", tmp_path / "y" / "1.off"])
    assert [s.key for s in gather_sources([tmp_path])] == ["x/1", "y/1"]
    with pytest.raises(ScribblesegError, match="no such file or folder"):
        gather_sources([tmp_path / "missing"])
    (tmp_path / "bad.txt").write_text("missing.off\n")
    with pytest.raises(ScribblesegError, match="missing.off: no such file"):
        gather_sources([tmp_path / "bad.txt"])
    # the output folder inside an input folder is never read back as input
    write_off(tmp_path / "x" / "out" / "9.ply", mesh.V, mesh.F)
    assert [s.key for s in gather_sources([tmp_path / "x"], exclude=tmp_path / "x" / "out")] == ["1"]


def test_signatures_are_computed_once_on_the_cluster(tmp_path, monkeypatch):
    from scribbleseg_core.scale.run import signatures_many
    from scribbleseg_core.signatures.features import cached_face_features

    monkeypatch.setenv("SCRIBBLESEG_CACHE_DIR", str(tmp_path / "cache"))  # the workers inherit it
    paths = []
    for i in range(3):
        mesh, _ = creature(1.2 + 0.2 * i, 0.8, seed=10 + i)
        write_off(tmp_path / f"{i}.off", mesh.V, mesh.F)
        paths.append(tmp_path / f"{i}.off")
    (tmp_path / "bad.off").write_text("OFF\n3 1 0\n")
    summary = signatures_many([*paths, tmp_path / "bad.off"], workers=2)
    assert (summary.done, summary.skipped, summary.failed) == (3, 0, 1)
    assert summary.errors[0]["message"].startswith(str(tmp_path / "bad.off"))
    for p in paths:  # this process now reads what the workers wrote
        mesh = load_mesh(p)
        assert cached_face_features(mesh.V, mesh.F, compute=False) is not None
    again = signatures_many(paths, workers=2)
    assert (again.done, again.skipped) == (0, 3)
