"""Rigid co-alignment: shapes turned every which way end up in one frame."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from scribbleseg_core.engine.shape import align_collection, prepare_shape
from scribbleseg_core.formats.mesh import repair
from scribbleseg_core.geometry.align import PrincipalCloud, align_to, own_map
from scribbleseg_core.infra.cache import ArrayCache
from tests.core.planted import creature

HEAD = 2


def _head_center(shape, reference, gt) -> np.ndarray:
    p = shape.positions(reference)
    head = gt == HEAD
    return (p[head] * shape.area[head, None]).sum(0) / shape.area[head].sum()


@pytest.fixture(scope="module")
def turned(tmp_path_factory):
    """Five creatures, each under its own random rotation, and their head labels."""
    cache = ArrayCache(tmp_path_factory.mktemp("cache"))
    out = []
    for i, (limb, head) in enumerate([(1.6, 0.9), (1.2, 0.7), (2.0, 1.1), (1.4, 0.8), (1.8, 1.0)]):
        mesh, gt = creature(limb, head, seed=i)
        R = Rotation.random(random_state=10 + i).as_matrix()
        turned = repair(mesh.V @ R.T, mesh.F)
        out.append((prepare_shape(turned, cache=cache), gt[turned.proc_to_file]))
    return out


def test_co_alignment_puts_every_head_in_one_place(turned):
    shapes = [s for s, _ in turned[:4]]
    raw = np.array([(s.mesh.normalized()[s.mesh.F].mean(1)[gt == HEAD]).mean(0) for s, gt in turned[:4]])
    assert np.linalg.norm(raw - raw.mean(0), axis=1).max() > 0.3  # the rotations move the heads apart
    reference = align_collection(shapes)
    assert reference.shape == (4, shapes[0].principal_cloud.points.shape[0], 3)
    heads = np.array([_head_center(s, reference, gt) for s, gt in turned[:4]])
    assert np.linalg.norm(heads - heads.mean(0), axis=1).max() < 0.1
    # a shape the reference has not seen is aligned to it
    new, gt = turned[4]
    assert np.linalg.norm(_head_center(new, reference, gt) - heads.mean(0)) < 0.15


def test_a_shape_of_the_reference_keeps_its_map(turned):
    shapes = [s for s, _ in turned[:3]]
    reference = align_collection(shapes)
    before = shapes[1].positions(reference)
    loaded = reference.copy()  # as from a model file: another array, the same clouds
    np.testing.assert_allclose(shapes[1].positions(loaded), before, atol=1e-9)
    assert own_map(turned[4][0].principal_cloud.points, reference) is None


def test_principal_cloud_and_alignment_are_deterministic_and_orthogonal(turned):
    s = turned[0][0]
    a = PrincipalCloud.of(s.mesh.normalized(), s.mesh.F, s.area)
    b = PrincipalCloud.of(s.mesh.normalized(), s.mesh.F, s.area)
    np.testing.assert_array_equal(a.points, b.points)
    assert abs(np.sqrt((a.points ** 2).sum(1).mean()) - 1.0) < 0.1  # units of the RMS radius
    M = align_to(a.points, [turned[1][0].principal_cloud.points])
    np.testing.assert_allclose(M @ M.T, np.eye(3), atol=1e-9)
    with pytest.raises(ValueError, match="at least one reference"):
        align_to(a.points, [])
