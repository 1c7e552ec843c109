"""Regions of faces grown over the dual graph: what a fill click and a surface brush select."""

from __future__ import annotations

import numpy as np
from scipy.sparse.csgraph import breadth_first_order, connected_components, dijkstra

from scribbleseg_core.engine.patches import over_segment
from scribbleseg_core.geometry.dual_graph import DualGraph, pair_matrix

#: Patches a :class:`RegionFill` splits a shape into; their borders are where creases are averaged.
FILL_PATCHES = 100
#: A single concave edge this many times sharper than a fill's threshold stops it too.
EDGE_FACTOR = 5.0


class RegionFill:
    """The fill tool's regions on one shape, built once and queried per click.

    A crease fill spreads from face to face across shared edges, and stops at two kinds of
    crease: the border between two primitive patches
    (:func:`~scribbleseg_core.engine.patches.over_segment`, whose borders settle on concave
    creases) whose mean concave dihedral angle (weighted by edge length; convex ridges count 0)
    exceeds the threshold, and a single concave edge sharper than :data:`EDGE_FACTOR` times it.
    Averaging over a whole border tells a valley spread over several faces from a smooth
    surface, where one edge's angle cannot; the single-edge test catches a sharp crease that a
    patch happens to straddle. Meshes with creases (furniture, machine parts, a head joined to a
    body) fill part by part at a few degrees; smooth organic shapes (bodies, animals) have few
    creases to stop a fill, where a fill bounded by labels serves.

    Parameters
    ----------
    graph : DualGraph
    num_patches : int
        Patches to split the shape into. Default :data:`FILL_PATCHES`.
    """

    def __init__(self, graph: DualGraph, num_patches: int = FILL_PATCHES):
        self.graph = graph
        self.patch = over_segment(graph, num_patches)
        p = int(self.patch.max()) + 1
        a, b = self.patch[graph.pairs[:, 0]], self.patch[graph.pairs[:, 1]]
        border = a != b
        self.angle = np.where(graph.concave, crease_angle_deg(graph), 0.0)
        length = graph.length + 1e-300
        key = np.minimum(a, b) * p + np.maximum(a, b)
        _, inv = np.unique(key[border], return_inverse=True)
        mean = np.bincount(inv, (self.angle * length)[border]) / np.bincount(inv, length[border])
        self.border_angle = np.zeros(len(graph.pairs))  # per face pair: its patch border's mean angle, 0 inside a patch
        self.border_angle[border] = mean[inv]

    def by_crease(self, seed: int, crease_deg: float) -> np.ndarray:
        """Faces reached from face `seed` across no patch border whose mean concave angle
        exceeds `crease_deg` degrees and no edge sharper than ``EDGE_FACTOR · crease_deg``;
        sorted (k,) int64."""
        return _reached(self.graph, (self.border_angle <= crease_deg) & (self.angle <= EDGE_FACTOR * crease_deg), seed)


def fill_by_labels(graph: DualGraph, seed: int, labels: np.ndarray) -> np.ndarray:
    """The connected region of face `seed` among the faces of its label; sorted (k,) int64.

    Parameters
    ----------
    graph : DualGraph
    seed : int
    labels : (m,) int ndarray
        Per-face labels (-1 counts as a label of its own).
    """
    labels = np.asarray(labels)
    if labels.shape != (graph.num_faces,):
        raise ValueError(f"labels has shape {labels.shape}, expected ({graph.num_faces},)")
    return _reached(graph, labels[graph.pairs[:, 0]] == labels[graph.pairs[:, 1]], seed)


def crease_angle_deg(graph: DualGraph) -> np.ndarray:
    """Dihedral angle between the normals of each adjacent face pair, degrees in [0, 180], (q,)."""
    return np.degrees(np.arccos(np.clip(1.0 - graph.bend, -1.0, 1.0)))


def surface_disc(graph: DualGraph, seeds, radius: float) -> np.ndarray:
    """Faces whose centroid lies within `radius` of the `seeds` faces, measured along the
    surface (shortest paths between adjacent face centroids), so a brush over a thin part
    does not reach the surface behind it.

    Parameters
    ----------
    graph : DualGraph
    seeds : int or sequence of int
        Faces at the brush's center (several along a fast drag).
    radius : float
        In the units of the graph's mesh.

    Returns
    -------
    faces : (k,) int64 ndarray
        Sorted; the seeds among them.
    """
    seeds = np.atleast_1d(np.asarray(seeds, dtype=np.int64))
    if seeds.size == 0:
        return np.zeros(0, np.int64)
    d = dijkstra(graph.centroid_matrix, directed=False, indices=seeds, min_only=True,
                 limit=float(radius))
    return np.flatnonzero(np.isfinite(d)).astype(np.int64)


def components(graph: DualGraph, mask: np.ndarray) -> np.ndarray:
    """Connected components of the faces in `mask` (across shared edges), (m,) int64 numbered
    from 0, -1 outside the mask."""
    mask = np.asarray(mask, bool)
    keep = mask[graph.pairs[:, 0]] & mask[graph.pairs[:, 1]]
    _, comp = connected_components(pair_matrix(graph.pairs[keep], 1.0, graph.num_faces),
                                   directed=False)
    out = np.full(graph.num_faces, -1, np.int64)
    _, out[mask] = np.unique(comp[mask], return_inverse=True)
    return out


def _reached(graph: DualGraph, keep: np.ndarray, seed: int) -> np.ndarray:
    """Faces reached from face `seed` across the face pairs where `keep` (q,) holds; sorted (k,) int64."""
    if not 0 <= seed < graph.num_faces:
        raise ValueError(f"seed face {seed} out of range for {graph.num_faces} faces")
    reached = breadth_first_order(pair_matrix(graph.pairs[keep], 1.0, graph.num_faces), int(seed),
                                  directed=False, return_predecessors=False)
    return np.sort(reached).astype(np.int64)

