"""The network's context inputs: diffused signatures and the local extrinsic shape."""

from __future__ import annotations

import numpy as np
import trimesh

from scribbleseg_core.geometry.dual_graph import dual_graph
from scribbleseg_core.geometry.measures import face_areas, normalize
from scribbleseg_core.signatures.context import LOCAL_SHAPE_PER_SCALE, local_shape
from tests.conftest import icosphere

SCALES = (0.002, 0.01, 0.05)


def _local_shape(V, F):
    V = normalize(V, F)[0]
    return local_shape(V, F, dual_graph(V, F), face_areas(V, F), SCALES)


def _per_scale(L):
    """(m, scales, 5): 3 spreads, normal agreement, normal offset."""
    return L.reshape(len(L), len(SCALES), LOCAL_SHAPE_PER_SCALE)


def test_sphere_is_round_and_convex_everywhere_inside_out_concave():
    V, F = icosphere(4)
    L = _per_scale(_local_shape(V, F))
    assert L.shape == (len(F), 3, 5) and np.isfinite(L).all()
    spread, agree, offset = L[..., :3], L[..., 3], L[..., 4]
    assert (np.diff(spread, axis=2) >= -1e-12).all()  # ascending eigenvalues
    assert (offset < 0).all()  # the neighbours' mean lies inside a convex surface
    assert (agree < 1).all() and (np.diff(agree, axis=1) < 0).all()  # normals agree less the wider one looks
    assert (np.diff(-offset, axis=1) > 0).all()  # and the surface bends away more
    # symmetric: every face of the sphere looks alike
    assert np.ptp(offset, axis=0).max() < 0.1 * np.abs(offset).min()
    flipped = _per_scale(_local_shape(V, F[:, ::-1]))  # inward normals: a concave shell
    np.testing.assert_allclose(flipped[..., 4], -offset, atol=1e-9)
    np.testing.assert_allclose(flipped[..., :4], L[..., :4], atol=1e-9)


def test_flat_face_of_a_box_is_flat_at_small_scales():
    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0)).subdivide().subdivide().subdivide()
    V, F = np.asarray(box.vertices), np.asarray(box.faces)
    L = _per_scale(_local_shape(V, F))
    center = np.abs(V[F].mean(1)).max(1) == 0.5
    center &= (np.abs(V[F].mean(1)) < 0.2).sum(1) == 2  # middles of the six sides
    assert center.sum() >= 6
    finest = L[center, 0]
    assert (finest[:, 0] < 0.25 * finest[:, 2]).all()  # little spread along the normal (the kernel has long tails)
    sphere = _per_scale(_local_shape(*icosphere(4)))[:, 0]  # a ball of the same area
    assert finest[:, 0].max() < 0.8 * sphere[:, 0].min()  # flatter than the ball
    assert (finest[:, 3] > 0.9).all()
    assert np.abs(finest[:, 4]).max() < 0.25 * np.abs(sphere[:, 4]).min()  # nearly no bend


def test_local_shape_is_invariant_to_rigid_motion_and_scale():
    mesh = trimesh.creation.capsule(height=2.0, radius=0.5, count=[24, 24])
    V, F = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    R = trimesh.transformations.random_rotation_matrix(np.random.default_rng(3).random(3))[:3, :3]
    moved = 2.5 * V @ R.T + np.array([3.0, -1.0, 7.0])
    np.testing.assert_allclose(_local_shape(moved, F), _local_shape(V, F), atol=1e-6)
