"""The network's context inputs: diffused signatures and the local extrinsic shape."""

from __future__ import annotations

import numpy as np
import trimesh

from scribbleseg_core.geometry.dual_graph import dual_graph
from scribbleseg_core.geometry.measures import face_areas, normalize
from scribbleseg_core.signatures.context import LOCAL_SHAPE_PER_SCALE, local_shape, surface_slopes, tangent_gradients
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


def test_network_input_diffuses_every_signature_at_the_first_scale_and_the_region_ones_beyond(tmp_path):
    from scribbleseg_core.engine.shape import REGION_COLUMNS, network_input, network_input_width
    from scribbleseg_core.infra.cache import ArrayCache
    from scribbleseg_core.signatures.context import diffuse_face_values
    from scribbleseg_core.signatures.self_similarity import NUM_BANDS

    V, F = icosphere(2)
    V = normalize(V, F)[0]
    graph, area = dual_graph(V, F), face_areas(V, F)
    X = np.random.default_rng(0).normal(size=(len(F), 22))
    x = network_input(X, area, graph, SCALES, cache=ArrayCache(tmp_path))
    # without the geodesic sample, no self-similarity bands
    assert x.shape == (len(F), network_input_width(3, False) - NUM_BANDS) == (len(F), 22 + 22 + 2 * len(REGION_COLUMNS))
    full = diffuse_face_values(graph, area, X, SCALES)  # 22 columns a scale
    np.testing.assert_array_equal(x[:, :22], X)
    np.testing.assert_allclose(x[:, 22:44], full[:, :22], atol=1e-12)
    for j in (1, 2):
        got = x[:, 44 + len(REGION_COLUMNS) * (j - 1):][:, :len(REGION_COLUMNS)]
        np.testing.assert_allclose(got, full[:, 22 * j:][:, list(REGION_COLUMNS)], atol=1e-12)
    assert network_input(X, area, graph, (), cache=ArrayCache(tmp_path)).shape == (len(F), network_input_width(0, False))


def test_slopes_measure_the_gradient_along_the_surface():
    # a flat grid carrying a linear function: its gradient, exactly, on every inner face
    n = 12
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    V = np.column_stack([x.ravel(), y.ravel(), np.zeros(n * n)])
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    F = np.vstack([np.column_stack([a, b, d]), np.column_stack([a, d, c])])
    graph = dual_graph(V, F)
    inner = np.bincount(graph.pairs.ravel(), minlength=len(F)) == 3
    C = V[F].mean(axis=1)
    Y = np.column_stack([2 * C[:, 0] + 3 * C[:, 1], np.full(len(F), 5.0), C[:, 0] ** 2])
    G = tangent_gradients(V, F, graph, Y)
    np.testing.assert_allclose(G[inner, :, 0], np.tile([2.0, 3.0, 0.0], (inner.sum(), 1)), atol=1e-6)
    np.testing.assert_allclose(G[:, :, 1], 0, atol=1e-12)
    S = surface_slopes(V, F, graph, Y)
    assert S.shape == Y.shape and np.isfinite(S).all()
    assert np.ptp(S[inner, 0]) < 1e-6 and np.ptp(S[:, 1]) < 1e-9  # even slopes, and none
    right, left = C[:, 0] > 0.8, C[:, 0] < 0.2  # x² grows steeper to the right
    assert S[right, 2].min() > S[left, 2].max()
    # moving the mesh rigidly leaves the slopes; scaling it by 2 halves every gradient
    R = np.linalg.qr(np.random.default_rng(0).normal(size=(3, 3)))[0]
    W = 2 * V @ R.T + 1
    moved = surface_slopes(W, F, dual_graph(W, F), Y)
    np.testing.assert_allclose(moved[:, [0, 2]], S[:, [0, 2]] - np.log(2), atol=1e-9)
