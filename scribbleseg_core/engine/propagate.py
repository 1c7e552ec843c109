"""Scribble propagation on faces: a graph cut with crease-aware smoothness.

Each face prefers the label of its nearest scribble in the crease-aware dual metric
(:meth:`DualGraph.crease_distance`), scribbled faces are hard constraints, and the Potts
smoothness is cheap across concave creases and dear elsewhere, so labels stop at creases.
Optional network log-probabilities join the unary term, and with them the random-walker
probabilities from the strokes (:func:`random_walk_probabilities`). Without the network it
needs no features, so it is fast enough for the app's live preview after every stroke; the
engine uses it for the final labels of scribbled shapes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as sla
from scipy.sparse.csgraph import connected_components, dijkstra

from scribbleseg_core.engine.graphcut import INF, alpha_expansion
from scribbleseg_core.geometry.dual_graph import CONVEX_FACTOR, DualGraph


@dataclass(frozen=True)
class PropagateParams:
    """Weights of the propagation energy.

    ``U(f, l) = distance · (d_l(f) − min_j d_j(f)) / d̄ − network · log P(l | f)``, where
    ``d_l`` is the crease-aware geodesic distance to the nearest scribble of label l and
    ``d̄`` the median distance of a face to its nearest scribble; on every shared edge
    ``smoothness · (ℓ / mean ℓ) · exp(−concavity / crease)``.

    Defaults tuned on the 12 PSB categories with their fixed scribbles (all 20 shapes
    scribbled, Rand Index error, mean over categories; so these figures are fit, not held
    out): distance 0.1 beat 0.3, 0.5 and 2 (Chair 0.016 vs 0.041 at 0.3); over crease
    0.01–0.15 and smoothness 1–64, crease 0.03 with smoothness 16 was best (mean 0.064;
    0.075 at crease 0.05 with smoothness 4). Categories differ: Bust wants smoothness 48
    (0.121), Plier 8 (0.055); convex creases counting 0.1 of concave ones beat 0.3 and 1
    (0.02 came later; see ``convex`` below).
    The network term helps only when the network was trained on propagated labels: with
    a network trained on the paper's patch-level labels it made 5 of 6 categories worse
    (Mech 0.028 → 0.044), with one trained on these labels weight 0.5 beat 0, 0.05, 0.1 and
    0.2 (Plier 0.077 → 0.059, Glasses 0.058 → 0.046, FourLeg 0.114 → 0.108, Bust 0.138 →
    0.141); a second round did not help.

    ``contrast`` makes the smoothness cheaper where the shape diameter changes (a limb
    meeting a torso with no crease between them): each edge's weight is multiplied by
    ``floor + (1 − floor) · exp(−contrast · Δ² / mean Δ²)``, Δ the difference of the two
    faces' standardized SDF, ``floor`` = ``contrast_floor``; it acts only when the caller
    passes the SDF. Contrast 1 with floor 0.5 was the best of 8 settings (SDF alone beat all
    22 signatures; no floor was worse), chosen on the same 12 categories. Full PSB benchmark
    against contrast 0: scribbled shapes 0.060 → 0.057 (FourLeg 0.108 → 0.095, Plier 0.059 →
    0.044; Vase 0.071 → 0.083 worse), unseen shapes 0.110 → 0.105 (better on 9 of 12:
    Plier 0.070 → 0.053, Glasses 0.053 → 0.041; Mech 0.137 → 0.145 worse), because the
    network carries over better from these training labels.

    ``walk`` adds ``walk · −log P_rw(l | f)``, the random-walker probabilities of
    :func:`random_walk_probabilities` (Grady 2006; Lai et al. 2008 on meshes): the chance
    that a walk from f, crossing concave creases rarely, first reaches a stroke of label
    l. Unlike the distance to the nearest stroke it sees every path and the whole stroke,
    so a boundary settles where the crease-weighted "flow" between two strokes is
    narrowest rather than midway between them. Chosen on cached final network
    log-probabilities of the 12 categories (all shapes scribbled; fit, not held out):
    walk 0.25 / 0.5 / 1 gave 0.0549 / 0.0540 / 0.0529 against 0.0569 without (Bust 0.145
    → 0.123, FourLeg 0.095 → 0.084, Plier 0.044 → 0.037; Glasses 0.039 → 0.041 worse);
    walk 2 made Glasses (0.042) and Octopus (0.032) worse again. It acts only beside the
    network term (`log_proba` given, ``network > 0``): alone, with the weak distance term,
    it made the labels worse at every weight tried (walk 1: Glasses 0.046 → 0.069, Chair
    0.011 → 0.020; 0.2: Glasses 0.048), and those labels are what the network is
    retrained on, so the unseen shapes are unchanged by it. Full PSB benchmark (all shapes
    scribbled): 0.057 → 0.053, better on 8 of 12 categories; worse on Glasses, Table,
    Chair (0.010 → 0.011) and Octopus (by 0.0005). The live preview pays for
    it with one sparse factorization per stroke (8k faces: +20–60 ms).

    ``convex`` is how much a convex crease (a ridge) counts against a concave one (a
    valley) in the smoothness and the walk (:meth:`DualGraph.concavity`); the dual graph's
    metric, which the distance term, the patches and the unseen shapes' refinement use,
    keeps ``CONVEX_FACTOR`` (0.1). At 0.1 a 90° ridge cost 0.036 of a smooth edge, so on
    machined shapes every box edge was a cheap place to end a label: on PSB Mech a part's
    label ran over the fillet at its foot and onto the neighbouring box's top face, up to
    the box's edge, and the network learned it (propagated labels 98.3% right, yet the
    unseen shapes 0.139 against 0.077 from ground-truth training labels, mean of 3
    seeds). At 0.02 (a 90° ridge 0.51 of a smooth edge) the Mech labels are 99.2% right.
    Measured on unseen shapes (the networks trained on these labels, seed 0; fit, not
    held out), against 0.1: Mech 0.143 → 0.078, Plier 0.0585 → 0.0588, Vase 0.144 →
    0.146, Octopus 0.031 → 0.036; also lowering it in the distance term's metric gave Mech 0.075 but Plier 0.072 and Vase
    0.158, so it stays in the smoothness only; 0.05 gave Mech 0.137, almost no gain, and 0
    gave 0.0921 on all 12 categories against 0.0918 at 0.02 (Mech 0.084, Bird 0.096). Full
    PSB benchmark against 0.1: scribbled shapes 0.0490 → 0.0469 (Mech 0.029 → 0.010, Bird
    0.060 → 0.056), unseen shapes 0.0952 → 0.0918 (Mech 0.143 → 0.078, Bird 0.105 → 0.102;
    worse: Bust 0.289 → 0.301, Octopus 0.031 → 0.036, Chair 0.0195 → 0.024).
    """

    distance: float = 0.1
    smoothness: float = 16.0
    crease: float = 0.03
    network: float = 0.5
    contrast: float = 1.0
    contrast_floor: float = 0.5
    walk: float = 1.0
    convex: float = 0.02
    max_sweeps: int = 4


def scribble_distances(graph: DualGraph, scribble: np.ndarray, k: int) -> np.ndarray:
    """Crease-aware geodesic distance of every face to the scribbles of every label.

    Parameters
    ----------
    graph : DualGraph
    scribble : (m,) int ndarray
        Label per face, -1 where unscribbled.
    k : int
        Number of labels.

    Returns
    -------
    D : (m, k) float64 ndarray
        ``inf`` for labels not scribbled here and for faces their scribbles cannot reach.
    """
    scribble = np.asarray(scribble)
    D = np.full((graph.num_faces, k), np.inf)
    for label in np.unique(scribble[scribble >= 0]):
        D[:, label] = dijkstra(graph.crease_matrix, directed=False, indices=np.flatnonzero(scribble == label), min_only=True)
    return D


def propagate_scribbles(
    graph: DualGraph,
    scribble: np.ndarray,
    k: int,
    *,
    log_proba: np.ndarray | None = None,
    sdf: np.ndarray | None = None,
    params: PropagateParams = PropagateParams(),
) -> np.ndarray:
    """Label every face from the scribbles (and a network's log-probabilities).

    Parameters
    ----------
    graph : DualGraph
    scribble : (m,) int ndarray
        Label per face, -1 where unscribbled; at least one face scribbled.
    k : int
        Number of labels; scribble ids are below it.
    log_proba : (m, k) float ndarray, optional
        Network log-probabilities per face.
    sdf : (m,) float ndarray, optional
        Shape diameter per face, for ``params.contrast`` (ignored when that is 0).
    params : PropagateParams

    Returns
    -------
    labels : (m,) int64 ndarray
        Faces in components without scribbles take the network's label, else the most
        scribbled label.
    """
    scribble = np.asarray(scribble, dtype=np.int64)
    if scribble.shape != (graph.num_faces,):
        raise ValueError(f"scribble has shape {scribble.shape}, expected ({graph.num_faces},)")
    s = np.flatnonzero(scribble >= 0)
    if s.size == 0:
        raise ValueError("no face is scribbled")
    if scribble.max() >= k:
        raise ValueError(f"scribble label {scribble.max()} out of range for {k} labels")
    D = scribble_distances(graph, scribble, k)
    nearest = D.min(axis=1)
    reached = np.isfinite(nearest)
    scale = max(float(np.median(nearest[reached])), 1e-12)
    U = np.zeros((graph.num_faces, k))
    scribbled = np.isfinite(D[reached].min(axis=0)) if reached.any() else np.zeros(k, bool)
    Dr = D[reached] - nearest[reached, None]
    finite = np.isfinite(Dr)
    U[reached] = np.where(finite, params.distance * np.where(finite, Dr, 0.0) / scale, INF)
    if log_proba is not None and params.network > 0:
        U += params.network * -np.maximum(np.asarray(log_proba, dtype=np.float64), -30.0)
        U[reached] = np.where(scribbled[None, :], U[reached], INF)  # near scribbles: their labels
        if params.walk > 0:  # only beside the network: see PropagateParams.walk
            U += params.walk * -np.log(np.maximum(random_walk_probabilities(graph, scribble, k, params.crease, params.convex), 1e-6))
    else:
        U[~reached] = np.where(np.arange(k) == np.bincount(scribble[s], minlength=k).argmax(), 0.0, 1.0)
    U[s] = INF
    U[s, scribble[s]] = 0.0
    w = graph.crease_potts_weights(params.smoothness, params.crease, params.convex)
    if params.contrast > 0 and sdf is not None:
        w = w * contrast_factor(graph, sdf, params.contrast, params.contrast_floor)
    return alpha_expansion(U, graph.pairs, w, init=np.argmin(U, axis=1), max_sweeps=params.max_sweeps)


def propagate_shape(shape, k: int, params: PropagateParams = PropagateParams(),
                    log_proba: np.ndarray | None = None) -> np.ndarray:
    """:func:`propagate_scribbles` of a :class:`~scribbleseg_core.engine.shape.ShapeData`'s
    scribbles on its dual graph, with its SDF for the contrast term; (m,) int64 face labels."""
    return propagate_scribbles(shape.graph, shape.scribble, k, log_proba=log_proba, sdf=shape.sdf, params=params)


def random_walk_probabilities(graph: DualGraph, scribble: np.ndarray, k: int, crease: float,
                              convex: float = CONVEX_FACTOR) -> np.ndarray:
    """Random-walker label probabilities from the scribbles (a harmonic field per label).

    Solves ``L_uu X_u = −L_us X_s`` on the face graph with edge weights ``(ℓ / centroid
    distance) · exp(−concavity / crease)``: X_s one-hot on scribbled faces, so X(f, l) is
    the probability that a random walk from f reaches a stroke of label l first. Faces in
    components without scribbles get 0 for every label.

    Parameters
    ----------
    graph : DualGraph
    scribble : (m,) int ndarray
        Label per face, -1 where unscribbled.
    k : int
        Number of labels.
    crease : float
        Concavity scale of the edge weights (as in :meth:`DualGraph.crease_potts_weights`).
    convex : float
        Weight of convex creases in the concavity (:meth:`DualGraph.concavity`).

    Returns
    -------
    P : (m, k) float64 ndarray
        Rows sum to 1 where reached; columns of labels not scribbled are 0.
    """
    scribble = np.asarray(scribble, dtype=np.int64)
    m = graph.num_faces
    w = graph.diffusion_weights * np.exp(-graph.concavity(convex) / crease)
    L = graph.laplacian(np.maximum(w, 1e-9 * max(float(w.sum()) / max(w.size, 1), 1e-300)))  # sharp creases: weak, never cut off
    seeded = scribble >= 0
    P = np.zeros((m, k))
    P[seeded, scribble[seeded]] = 1.0
    # only components holding a stroke are solved (elsewhere the system is singular)
    _, comp = connected_components(L, directed=False)
    live = np.isin(comp, comp[seeded])
    u, s = np.flatnonzero(live & ~seeded), np.flatnonzero(seeded)
    present = np.unique(scribble[s])
    if u.size == 0 or present.size == 0:
        return P
    Lu = L[u]
    rhs = -(Lu[:, s] @ P[np.ix_(s, present)])
    P[np.ix_(u, present)] = sla.splu(Lu[:, u].tocsc()).solve(np.ascontiguousarray(rhs))
    return np.clip(P, 0.0, 1.0)


def contrast_factor(graph: DualGraph, values: np.ndarray, contrast: float, floor: float) -> np.ndarray:
    """Per face pair, ``floor + (1 − floor) · exp(−contrast · Δ² / mean Δ²)`` with Δ the
    difference of the standardized `values` (m,) across the pair: 1 where they agree, down
    to `floor` where they jump.

    Returns
    -------
    (q,) float64 ndarray
    """
    v = np.asarray(values, dtype=np.float64)
    if v.shape != (graph.num_faces,):
        raise ValueError(f"values has shape {v.shape}, expected ({graph.num_faces},)")
    z = (v - v.mean()) / (v.std() + 1e-12)
    i, j = graph.pairs.T
    d2 = (z[i] - z[j]) ** 2
    return floor + (1.0 - floor) * np.exp(-contrast * d2 / max(float(d2.sum()) / max(d2.size, 1), 1e-12))
