"""Per-face signatures: analytic truths, invariances, robustness, determinism."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from scribbleseg_core.signatures.agd import average_geodesic_distance
from scribbleseg_core.signatures.curvature import (
    angle_defect,
    face_gaussian_curvature,
    gaussian_curvature,
)
from scribbleseg_core.signatures.features import (
    FEATURE_NAMES,
    FeatureParams,
    face_features,
)
from scribbleseg_core.signatures.hks import si_hks
from scribbleseg_core.signatures.sdf import (
    raw_sdf,
    ray_pattern,
    ray_weights,
    robust_weighted_mean,
)
from tests.conftest import icosphere

FAST = FeatureParams(num_eigenpairs=40, sdf_rays=30, agd_sources=16)


@pytest.mark.parametrize("subdiv,radius", [(2, 1.0), (3, 0.1), (4, 7.0)])
def test_gauss_bonnet_sphere(subdiv, radius):
    V, F = icosphere(subdiv, radius)
    K, A = gaussian_curvature(V, F)
    assert np.isclose((K * A).sum(), 4 * np.pi, rtol=1e-9)
    assert np.isclose(angle_defect(V, F).sum(), 4 * np.pi)
    # pointwise: K = 1/r² on a fine sphere
    if subdiv >= 3:
        np.testing.assert_allclose(np.median(K), 1 / radius**2, rtol=0.02)


@pytest.mark.parametrize("sections", [(24, 12), (48, 24)])
def test_gauss_bonnet_torus_is_zero(sections):
    t = trimesh.creation.torus(major_radius=1.0, minor_radius=0.3, major_sections=sections[0], minor_sections=sections[1])
    V, F = np.asarray(t.vertices), np.asarray(t.faces)
    K, A = gaussian_curvature(V, F)
    assert abs((K * A).sum()) < 1e-9
    # positive outside, negative inside the hole
    assert K.max() > 0 > K.min()


def test_open_disk_has_no_boundary_curvature():
    V = np.array([[0, 0, 0]] + [[np.cos(a), np.sin(a), 0] for a in np.linspace(0, 2 * np.pi, 13)[:-1]], float)
    F = np.array([[0, i, i % 12 + 1] for i in range(1, 13)])
    np.testing.assert_allclose(angle_defect(V, F), 0, atol=1e-12)


def test_sdf_of_sphere_is_mean_chord_of_the_ray_pattern():
    """Each ray from a sphere point at angle θ to the inward normal travels 2r·cos θ."""
    D = ray_pattern(30)
    chords = 2 * D[:, 2]  # r = 1
    expected = robust_weighted_mean(chords[None], ray_weights(D), np.ones((1, 30), bool))[0]
    V, F = icosphere(5, 1.0)
    sdf1 = raw_sdf(V, F)
    assert np.isfinite(sdf1).all()
    assert abs(np.mean(sdf1) - expected) / expected < 0.02
    assert np.std(sdf1) / np.mean(sdf1) < 0.01
    sdf2 = raw_sdf(*icosphere(5, 2.0))
    np.testing.assert_allclose(np.mean(sdf2) / np.mean(sdf1), 2.0, rtol=1e-3)


def test_sdf_separates_thick_from_thin():
    """A fat box with a thin slab: the slab's SDF is far smaller."""
    box = trimesh.creation.box(extents=(1, 1, 1))
    slab = trimesh.creation.box(extents=(0.1, 1, 1))
    slab.apply_translation((1.0, 0, 0))
    body = trimesh.util.concatenate([box, slab])
    body = body.subdivide().subdivide().subdivide()
    sdf = raw_sdf(np.asarray(body.vertices), np.asarray(body.faces))
    c = body.triangles_center
    inner_slab = (c[:, 0] > 0.96) & (c[:, 0] < 1.04)  # the slab's big faces (normals ±x)
    fat = c[:, 0] < -0.49
    thin = np.nanmedian(sdf[inner_slab])
    assert 0.1 <= thin < 0.15  # thickness 0.1, slightly more along slanted rays
    assert np.nanmedian(sdf[fat]) > 5 * thin


def test_agd_is_nearly_constant_on_a_sphere_and_analytic():
    V, F = icosphere(4, 3.0)
    agd = average_geodesic_distance(V, F)
    assert agd.std() / agd.mean() < 0.01
    # πr/2 divided by sqrt(4πr²)
    np.testing.assert_allclose(agd.mean(), np.pi / 2 / np.sqrt(4 * np.pi), rtol=0.02)


def test_agd_is_larger_at_the_ends_of_an_elongated_shape():
    capsule = trimesh.creation.capsule(height=4.0, radius=0.5, count=[24, 24])
    V, F = trimesh.remesh.subdivide_to_size(capsule.vertices, capsule.faces, max_edge=0.2)
    agd = average_geodesic_distance(V, F)
    z = np.abs(V[:, 2])
    assert agd[z > 2.2].mean() > 1.5 * agd[z < 0.3].mean()


def _features_close(X, Y):
    # SDF is ray-sampled (noisy per face); compare medians and strong correlation.
    for j in range(X.shape[1]):
        x, y = X[:, j], Y[:, j]
        scale = max(np.abs(x).max(), 1e-9)
        assert np.abs(np.median(x) - np.median(y)) < 0.02 * scale, FEATURE_NAMES[j]
        if x.std() > 1e-6 * scale:
            assert np.corrcoef(x, y)[0, 1] > 0.95, FEATURE_NAMES[j]


def _bumpy_shape():
    s = trimesh.creation.capsule(height=2.0, radius=0.5, count=[20, 20])
    V = np.asarray(s.vertices).copy()
    V[:, 0] *= 1 + 0.3 * (V[:, 2] > 0)
    return V, np.asarray(s.faces)


def test_face_features_invariant_to_rigid_motion_and_scale():
    V, F = _bumpy_shape()
    X = face_features(V, F, FAST)
    assert X.shape == (len(F), 22) and np.isfinite(X).all()
    R = trimesh.transformations.rotation_matrix(0.7, [1, 2, 3])[:3, :3]
    Y = face_features(3.5 * V @ R.T + [5, -2, 1], F, FAST)
    _features_close(X, Y)


def test_face_features_deterministic():
    V, F = _bumpy_shape()
    np.testing.assert_array_equal(face_features(V, F, FAST), face_features(V, F, FAST))


def nasty_mesh():
    """Boundaries, 3 components (one tiny), a non-manifold fin, skinny and zero-area faces."""
    s = trimesh.creation.icosphere(3)
    V, F = np.asarray(s.vertices).copy(), np.asarray(s.faces).copy()
    F = F[V[F][:, :, 2].mean(1) < 0.6]  # cut a hole: boundary loop
    # non-manifold fin on an existing edge
    a, b = F[0, 0], F[0, 1]
    V = np.vstack([V, (V[a] + V[b]) / 2 + [0, 0, 0.5]])
    F = np.vstack([F, [a, b, len(V) - 1]])
    # a separate open strip with skinny and zero-area faces
    base = len(V)
    strip = np.array([[3, 0, 0], [4, 0, 0], [3, 1e-4, 0], [4, 1e-4, 0], [5, 0, 0]], float)
    V = np.vstack([V, strip])
    F = np.vstack([F, base + np.array([[0, 1, 2], [1, 3, 2], [0, 1, 4]])])  # last is zero-area
    # a second, closed component
    t = trimesh.creation.box(extents=(0.3, 0.3, 0.3))
    F = np.vstack([F, np.asarray(t.faces) + len(V)])
    V = np.vstack([V, np.asarray(t.vertices) + [0, 3, 0]])
    return V, F


def test_no_nan_or_inf_on_a_nasty_mesh():
    from scribbleseg_core.formats.mesh import repair

    V, F = nasty_mesh()
    report = repair(V, F).report
    assert report.nonmanifold_edges >= 1 and report.boundary_loops >= 2 and report.components == 3
    assert report.zero_area_faces >= 1
    X = face_features(V, F, FAST)
    assert X.shape == (len(F), 22)
    assert np.isfinite(X).all()
    for fn in (lambda: face_gaussian_curvature(V, F), lambda: average_geodesic_distance(V, F),
               lambda: si_hks(V, F, num_eigenpairs=30)):
        assert np.isfinite(fn()).all()
