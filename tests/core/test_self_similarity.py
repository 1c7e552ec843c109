"""Self-similarity at a distance: repeated parts have look-alikes far away."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from scribbleseg_core.engine.shape import network_input_width, prepare_shape
from scribbleseg_core.formats.mesh import load_mesh
from scribbleseg_core.geometry.measures import face_areas, face_normals
from scribbleseg_core.signatures.geodesic import source_distances
from scribbleseg_core.signatures.self_similarity import BANDS, FLOOR, NUM_BANDS, self_similarity
from tests.conftest import icosphere

QUADRUPED = Path(__file__).resolve().parents[2] / "assets" / "Quadruped"


def test_legs_have_far_look_alikes_and_the_tail_does_not():
    mesh = load_mesh(QUADRUPED / "quadruped_01.ply")
    names = [line.split()[1] for line in (QUADRUPED / "labels" / "label_names.txt").read_text().splitlines()]
    truth = np.loadtxt(QUADRUPED / "labels" / "quadruped_01.seg", dtype=np.int64)[mesh.proc_to_file]
    shape = prepare_shape(mesh)
    x = shape.network_input((0.002, 0.01, 0.05), True)
    assert x.shape == (len(truth), network_input_width(3, True))
    sim = x[:, -NUM_BANDS:]
    assert np.isfinite(sim).all()
    far = {name: sim[truth == names.index(name), 3].mean() for name in ("leg", "tail", "head")}
    # the other legs lie 0.8–1.5 mean geodesic distances away; nothing like the tail or the head does
    assert far["leg"] < far["tail"] - 0.5 and far["leg"] < far["head"] - 0.2
    # near its own face, every face has a look-alike
    assert sim[:, 0].mean() < sim[:, 3].mean()
    # deterministic, and the same from the cache
    assert np.array_equal(sim, prepare_shape(mesh).network_input((0.002, 0.01, 0.05), True)[:, -NUM_BANDS:])


def test_a_copy_in_another_component_is_the_farthest_band():
    V, F = icosphere(2)
    V2, F2 = np.vstack([V, V + [5.0, 0, 0]]), np.vstack([F, F + len(V)])
    n = face_normals(V2, F2)
    area = face_areas(V2, F2)
    sim = self_similarity(n, area, source_distances(V2, F2, num_sources=16), num_samples=len(F2))
    assert sim.shape == (len(F2), NUM_BANDS) and BANDS[-1] == np.inf
    # every face's twin on the other sphere is an exact look-alike, in the last band
    assert np.allclose(sim[:, -1], np.log(FLOOR))
    # on one sphere the normal turns with the distance: no exact look-alike beyond the first band
    assert (sim[:, 2] > np.log(FLOOR) + 0.5).all()
