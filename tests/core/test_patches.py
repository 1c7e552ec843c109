"""Primitive patches: connected, one per component at least, boundaries on creases, scribble labels never mixed."""

from __future__ import annotations

import numpy as np
import trimesh

from scribbleseg_core.engine.patches import nearest_scribble_labels, over_segment, patch_adjacency
from scribbleseg_core.geometry.dual_graph import dual_graph
from scribbleseg_core.geometry.topology import label_components


def _box():
    """A closed box remeshed finely: six flat sides meeting at 90° convex creases."""
    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0)).subdivide_to_size(0.08)
    return np.asarray(box.vertices, np.float64), np.asarray(box.faces, np.int64)


def _is_partition_into_connected_patches(graph, patch) -> bool:
    relabeled = label_components(graph.pairs, patch)
    return len(np.unique(relabeled)) == len(np.unique(patch)) and patch.min() == 0 and np.array_equal(
        np.unique(patch), np.arange(patch.max() + 1))


def test_patches_are_connected_and_about_as_many_as_asked():
    V, F = _box()
    g = dual_graph(V, F)
    for asked in (6, 20, 50):
        patch = over_segment(g, asked)
        assert patch.shape == (len(F),)
        assert _is_partition_into_connected_patches(g, patch)
        assert asked <= patch.max() + 1 <= 2 * asked  # one per seed, more only where a cell is split


def test_every_component_gets_a_patch_even_beyond_the_count_asked():
    V, F = _box()
    soup_V = np.concatenate([V + [3.0 * i, 0, 0] for i in range(8)])
    soup_F = np.concatenate([F + len(V) * i for i in range(8)])
    g = dual_graph(soup_V, soup_F)
    patch = over_segment(g, 4)  # fewer patches asked than there are components
    assert _is_partition_into_connected_patches(g, patch)
    component = np.repeat(np.arange(8), len(F))
    # no patch spans two components, and each component has its own
    assert all(len(np.unique(component[patch == p])) == 1 for p in np.unique(patch))
    assert len(np.unique(patch)) >= 8


def test_a_patch_never_holds_scribbles_of_two_labels():
    V, F = _box()
    g = dual_graph(V, F)
    scribble = np.full(len(F), -1)
    C = V[F].mean(1)
    scribble[np.argsort(C[:, 0])[:5]] = 0  # two strokes close together on one side
    scribble[np.argsort(C[:, 0])[5:10]] = 1
    patch = over_segment(g, 4, scribble_labels=scribble)
    painted = scribble >= 0
    for p in np.unique(patch[painted]):
        assert len(np.unique(scribble[painted & (patch == p)])) == 1


def test_adjacency_lists_each_shared_border_once_with_its_length():
    V, F = _box()
    g = dual_graph(V, F)
    patch = (V[F].mean(1)[:, 2] > 0).astype(np.int64)  # top half / bottom half
    pairs, boundary = patch_adjacency(g, patch)
    np.testing.assert_array_equal(pairs, [[0, 1]])
    np.testing.assert_allclose(boundary, [4.0], rtol=1e-9)  # the box's equator: 4 sides of length 1


def test_nearest_scribble_labels_reach_each_component_with_a_stroke_only():
    V, F = _box()
    two_V, two_F = np.concatenate([V, V + [3.0, 0, 0]]), np.concatenate([F, F + len(V)])
    g = dual_graph(two_V, two_F)
    scribble = np.full(len(two_F), -1)
    scribble[0], scribble[1] = 2, 2
    near = nearest_scribble_labels(g, scribble)
    np.testing.assert_array_equal(near[: len(F)], 2)
    np.testing.assert_array_equal(near[len(F):], -1)
    np.testing.assert_array_equal(nearest_scribble_labels(g, np.full(len(two_F), -1)), -1)
