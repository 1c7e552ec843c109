"""Scribble propagation on faces: a graph cut with crease-aware smoothness.

Each face prefers the label of its nearest scribble in the crease-aware dual metric
(:meth:`DualGraph.crease_distance`), scribbled faces are hard constraints, and the Potts
smoothness is cheap across concave creases and dear elsewhere, so labels stop at creases.
Optional network log-probabilities join the unary term, and with them the random-walker
probabilities from the strokes, with the network as their prior (:class:`RandomWalk`). Without the network it
needs no features, so it is fast enough for the app's live preview after every stroke; the
engine uses it for the final labels of scribbled shapes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla
from scipy.sparse.csgraph import connected_components, dijkstra

from scribbleseg_core.engine.graphcut import INF, alpha_expansion, coarsen, multilevel_alpha_expansion
from scribbleseg_core.geometry.dual_graph import CONVEX_FACTOR, DualGraph, pair_laplacian, pair_mean

#: Alpha-expansion sweeps at most per cut (each sweep tries every label once).
MAX_SWEEPS = 4
#: Faces per cluster and band width (in face rings) of the multilevel cut (the app's preview).
CLUSTER_SIZE, BAND = 6, 4
#: The smallest factor the SDF contrast applies to an edge's smoothness.
CONTRAST_FLOOR = 0.5


@dataclass(frozen=True)
class PropagateParams:
    """Weights of the propagation energy.

    ``U(f, l) = distance · (d_l(f) − min_j d_j(f)) / d̄ − network · log P(l | f)
    − walk · log P_rw(l | f)``, where ``d_l`` is the crease-aware geodesic distance to the
    nearest scribble of label l, ``d̄`` the median distance of a face to its nearest
    scribble, P the network's probabilities and ``P_rw`` the random-walker probabilities
    (:class:`RandomWalk`, with the model's probabilities as its prior); on every shared edge
    ``smoothness · (ℓ / mean ℓ) · exp(−concavity / crease) · c``, with c the SDF contrast
    factor (:func:`contrast_factor`). The defaults were chosen on the 12 PSB categories
    (``docs/benchmarks.md``).

    Attributes
    ----------
    distance : float
        Weight of the distance term. Default 0.1.
    smoothness : float
        Potts weight of an edge of mean length with no crease. Default 16.
    smoothness_unscribbled : float
        The same for a shape without scribbles, whose only data term is the network: its
        labels need more smoothing to hold parts together. Default 64.
    crease : float
        Concavity at which an edge's weight falls to 1/e. Default 0.03.
    network : float
        Weight of the network's −log-probabilities, when given. Default 0.5.
    contrast : float
        How strongly a jump of the shape diameter between neighbours cheapens the
        smoothness (a limb meeting a torso with no crease), down to :data:`CONTRAST_FLOOR`
        of it; 0 turns it off, and it acts only when the caller passes the SDF. Default 1.
    walk : float
        Weight of the random-walker term (Grady 2006; Lai et al. 2008 on meshes): the
        chance that a walk from a face, crossing concave creases rarely, first reaches a
        stroke of each label. It acts only beside the network term (`log_proba` given,
        ``network > 0``). Default 1.
    convex : float
        How much a convex crease (a ridge) counts against a concave one (a valley) in the
        smoothness and the walk (:meth:`DualGraph.concavity`); the crease-aware distance
        keeps :data:`~scribbleseg_core.geometry.dual_graph.CONVEX_FACTOR`. Default 0.02.
    boundary : float
        On a shape without scribbles, given the learned boundary probabilities P_b of its
        edges (:mod:`~scribbleseg_core.engine.boundary`): the smoothness of an edge is
        ``boundary · (ℓ / mean ℓ) · −log max(P_b, 1e-4)`` in place of the crease rule and the
        contrast. 0 turns it off (the engine then trains no boundary classifier). Default 16.
    walk_reach : float
        With the network, the random walk may stop before it meets a stroke and take the
        network's label where it stops, after crossing about this fraction of the shape's
        width (:class:`RandomWalk`): a part that no stroke of its label reaches (three legs
        of four when one was painted) follows the network rather than the nearest stroke.
        0: the walk always runs to a stroke. Default 0.5.
    """

    distance: float = 0.1
    smoothness: float = 16.0
    smoothness_unscribbled: float = 64.0
    crease: float = 0.03
    network: float = 0.5
    contrast: float = 1.0
    walk: float = 1.0
    convex: float = 0.02
    boundary: float = 16.0
    walk_reach: float = 0.5


def scribble_distances(graph: DualGraph, scribble: np.ndarray, k: int,
                       previous: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Crease-aware geodesic distance of every face to the scribbles of every label.

    Parameters
    ----------
    graph : DualGraph
    scribble : (m,) int ndarray
        Label per face, -1 where unscribbled.
    k : int
        Number of labels.
    previous : (scribble, D), optional
        An earlier call's scribbles and result on the same graph with the same `k`: the
        columns of labels whose faces did not change are reused (one more stroke costs one
        label's distances).

    Returns
    -------
    D : (m, k) float64 ndarray
        ``inf`` for labels not scribbled here and for faces their scribbles cannot reach.
    """
    scribble = np.asarray(scribble)
    D = np.full((graph.num_faces, k), np.inf)
    if previous is not None and (previous[0].shape != scribble.shape or previous[1].shape != D.shape):
        previous = None
    changed = None if previous is None else previous[0] != scribble
    for label in np.unique(scribble[scribble >= 0]):
        faces = scribble == label
        if changed is not None and not (changed & (faces | (previous[0] == label))).any():
            D[:, label] = previous[1][:, label]
            continue
        D[:, label] = dijkstra(graph.crease_matrix, directed=False, indices=np.flatnonzero(faces), min_only=True)
    return D


class FaceEnergy:
    """The face-level energy of one shape, built once and evaluated or minimized many times.

    ``E(y) = Σ_f U_scr(f, y_f) + network · Σ_f −log P(y_f | f) + Σ_(f,g) w_fg [y_f ≠ y_g]``
    (:class:`PropagateParams`): scribbled faces are hard constraints; elsewhere `U_scr` is the
    normalized crease-aware distance to each label's strokes and, beside the network, the
    random-walker term. A shape without scribbles has a uniform scribble term, so its labels
    come from the network and the smoothness alone (it needs `log_proba`; its smoothness is
    ``params.smoothness_unscribbled``).

    Parameters
    ----------
    graph : DualGraph
    scribble : (m,) int ndarray
        Label per face, -1 where unscribbled (all -1: no scribbles).
    k : int
        Number of labels; scribble ids are below it.
    params : PropagateParams
    sdf : (m,) float ndarray, optional
        Shape diameter per face, for ``params.contrast`` (ignored when that is 0).
    boundary_proba : (q,) float ndarray, optional
        Learned probability of a label boundary across each face pair of `graph`
        (:class:`~scribbleseg_core.engine.boundary.BoundaryClassifier`); on a shape without
        scribbles it sets the smoothness (``params.boundary``). Ignored on a scribbled shape,
        whose strokes and creases say where its parts meet.
    distances : (m, k) float ndarray, optional
        :func:`scribble_distances` of `scribble`, when the caller has them.
    clusters : (m,) int ndarray, optional
        Face clusters (:func:`~scribbleseg_core.engine.graphcut.graph_clusters`): the cut is
        then multilevel (:func:`~scribbleseg_core.engine.graphcut.multilevel_alpha_expansion`)
        and the random walk solved on the clusters (:func:`random_walk_probabilities`):
        several times faster on large meshes, at a slightly higher energy (the app's preview,
        docs/app.md).
    """

    def __init__(self, graph: DualGraph, scribble: np.ndarray, k: int, params: PropagateParams = PropagateParams(),
                 sdf: np.ndarray | None = None, boundary_proba: np.ndarray | None = None,
                 distances: np.ndarray | None = None, clusters: np.ndarray | None = None):
        scribble = np.asarray(scribble, dtype=np.int64)
        if scribble.shape != (graph.num_faces,):
            raise ValueError(f"scribble has shape {scribble.shape}, expected ({graph.num_faces},)")
        if scribble.max(initial=-1) >= k:
            raise ValueError(f"scribble label {scribble.max()} out of range for {k} labels")
        self.graph, self.scribble, self.k, self.params = graph, scribble, k, params
        self.clusters = clusters
        self.pairs = graph.pairs
        self.strokes = np.flatnonzero(scribble >= 0)
        if boundary_proba is not None and params.boundary > 0 and not self.strokes.size:
            self.weights = learned_weights(graph, boundary_proba, params.boundary)
        else:
            smoothness = params.smoothness if self.strokes.size else params.smoothness_unscribbled
            w = graph.crease_potts_weights(smoothness, params.crease, params.convex)
            if params.contrast > 0 and sdf is not None:
                w = w * contrast_factor(graph, sdf, params.contrast, CONTRAST_FLOOR)
            self.weights = w
        self._walker: RandomWalk | None = None
        self._walk: tuple[np.ndarray | None, np.ndarray] | None = None
        m = graph.num_faces
        if self.strokes.size == 0:
            self.reached = np.zeros(m, bool)
            self._distance = np.zeros((m, k))
            self._scribbled_labels = np.ones(k, bool)
            return
        D = scribble_distances(graph, scribble, k) if distances is None else distances
        if D.shape != (m, k):
            raise ValueError(f"distances has shape {D.shape}, expected ({m}, {k})")
        nearest = D.min(axis=1)
        self.reached = np.isfinite(nearest)
        scale = max(float(np.median(nearest[self.reached])), 1e-12)
        self._scribbled_labels = np.isfinite(D[self.reached].min(axis=0))
        U = np.zeros((m, k))
        Dr = D[self.reached] - nearest[self.reached, None]
        finite = np.isfinite(Dr)
        U[self.reached] = np.where(finite, params.distance * np.where(finite, Dr, 0.0) / scale, INF)
        self._distance = U

    @property
    def is_scribbled(self) -> bool:
        return self.strokes.size > 0

    def _random_walk(self) -> RandomWalk:
        """This shape's walk, factorized on first use."""
        if self._walker is None:
            self._walker = RandomWalk(self.graph, self.scribble, self.k, self.params.crease, self.params.convex,
                                      self.clusters, self.params.walk_reach)
        return self._walker

    def walk(self, prior: np.ndarray | None = None) -> np.ndarray:
        """(m, k) ``−log`` of the random-walker probabilities from the strokes, with the
        probabilities of the log-probabilities `prior` (m, k) as its prior when
        ``params.walk_reach > 0`` (:class:`RandomWalk`; factorized once, the last prior's
        result kept)."""
        walker = self._random_walk()
        with_prior = self.params.walk_reach > 0
        key = prior if with_prior else None
        if self._walk is None or self._walk[0] is not key:
            P = walker.probabilities(np.exp(np.asarray(prior, dtype=np.float64)) if with_prior else None)
            self._walk = (key, -np.log(np.maximum(P, 1e-6)))
        return self._walk[1]

    def walk_reached(self) -> np.ndarray:
        """(m,) :meth:`RandomWalk.reached` of this shape's walk (``params.walk_reach``)."""
        return self._random_walk().reached()

    def unary(self, log_proba: np.ndarray | None = None, prior: np.ndarray | None = None) -> np.ndarray:
        """(m, k) unary costs, with the network's log-probabilities when given; `prior`
        (m, k), the log-probabilities of the random walk's prior (:meth:`walk`), defaults to
        `log_proba`."""
        p, s = self.params, self.strokes
        U = self._distance.copy()
        if log_proba is not None and p.network > 0:
            U += p.network * -np.maximum(np.asarray(log_proba, dtype=np.float64), -30.0)
            if self.is_scribbled:
                U[self.reached] = np.where(self._scribbled_labels[None, :], U[self.reached], INF)
                if p.walk > 0:  # only beside the network: see PropagateParams.walk
                    U += p.walk * self.walk(log_proba if prior is None else prior)
        elif self.is_scribbled:
            most = np.bincount(self.scribble[s], minlength=self.k).argmax()
            U[~self.reached] = np.where(np.arange(self.k) == most, 0.0, 1.0)
        else:
            raise ValueError("a shape without scribbles needs the network's log-probabilities")
        U[s] = INF
        U[s, self.scribble[s]] = 0.0
        return U

    def cut(self, log_proba: np.ndarray | None = None, init: np.ndarray | None = None,
            prior: np.ndarray | None = None) -> np.ndarray:
        """Labels minimizing the energy by alpha-expansion (multilevel with `clusters`),
        (m,) int64; starts from `init` when given (the energy never rises above it), else
        from the unary argmin. `prior`: :meth:`unary`."""
        U = self.unary(log_proba, prior)
        if self.clusters is not None:
            return multilevel_alpha_expansion(U, self.pairs, self.weights, self.clusters, init=init, band=BAND,
                                              max_sweeps=MAX_SWEEPS)
        start = np.argmin(U, axis=1) if init is None else init
        return alpha_expansion(U, self.pairs, self.weights, init=start, max_sweeps=MAX_SWEEPS)

    def terms(self, labels: np.ndarray, log_proba: np.ndarray | None = None,
              prior: np.ndarray | None = None) -> tuple[float, float, float]:
        """The energy of `labels` split into (scribble, network, smoothness); network is
        NaN without `log_proba`. `prior`: :meth:`unary`."""
        idx = np.arange(len(labels))
        U = self.unary(log_proba, prior)
        network = float("nan")
        if log_proba is not None and self.params.network > 0:
            net = self.params.network * -np.maximum(np.asarray(log_proba, dtype=np.float64)[idx, labels], -30.0)
            net[self.strokes] = 0.0  # a painted face's cost is its constraint alone (see unary)
            network = float(net.sum())
            scribble = float(U[idx, labels].sum()) - network
        else:
            scribble = float(U[idx, labels].sum()) if self.is_scribbled else 0.0
        cut = labels[self.pairs[:, 0]] != labels[self.pairs[:, 1]]
        return scribble, network, float(self.weights[cut].sum())


def propagate_scribbles(
    graph: DualGraph,
    scribble: np.ndarray,
    k: int,
    *,
    log_proba: np.ndarray | None = None,
    sdf: np.ndarray | None = None,
    params: PropagateParams = PropagateParams(),
    init: np.ndarray | None = None,
    clusters: np.ndarray | None = None,
    distances: np.ndarray | None = None,
) -> np.ndarray:
    """Label every face from the scribbles (and a network's log-probabilities): the
    minimum of :class:`FaceEnergy`.

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
    init : (m,) int ndarray, optional
        Labels to start the graph cut from (e.g. the previous result after one more stroke:
        it converges in fewer moves); default the unary argmin.
    clusters : (m,) int ndarray, optional
        Face clusters: a multilevel cut and walk (:class:`FaceEnergy`).
    distances : (m, k) float ndarray, optional
        :func:`scribble_distances` of `scribble`, when the caller has them.

    Returns
    -------
    labels : (m,) int64 ndarray
        Faces in components without scribbles take the network's label, else the most
        scribbled label.
    """
    if not (np.asarray(scribble) >= 0).any():
        raise ValueError("no face is scribbled")
    return FaceEnergy(graph, scribble, k, params, sdf, distances=distances, clusters=clusters).cut(log_proba, init=init)


def propagate_shape(shape, k: int, params: PropagateParams = PropagateParams(),
                    log_proba: np.ndarray | None = None) -> np.ndarray:
    """:func:`propagate_scribbles` of a :class:`~scribbleseg_core.engine.shape.ShapeData`'s
    scribbles on its dual graph, with its SDF for the contrast term; (m,) int64 face labels."""
    return propagate_scribbles(shape.graph, shape.scribble, k, log_proba=log_proba, sdf=shape.sdf, params=params)


def random_walk_probabilities(graph: DualGraph, scribble: np.ndarray, k: int, crease: float,
                              convex: float = CONVEX_FACTOR, clusters: np.ndarray | None = None,
                              prior: np.ndarray | None = None, reach: float = 0.0) -> np.ndarray:
    """Random-walker label probabilities from the scribbles (a harmonic field per label).

    Solves ``L_uu X_u = −L_us X_s`` on the face graph with edge weights ``(ℓ / centroid
    distance) · exp(−concavity / crease)``: X_s one-hot on scribbled faces, so X(f, l) is
    the probability that a random walk from f reaches a stroke of label l first. Faces in
    components without scribbles get 0 for every label. With a `prior` and a `reach`, the
    walk may also stop at every step and take the prior's label there (:class:`RandomWalk`).

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
    clusters : (m,) int ndarray, optional
        Face clusters (:func:`~scribbleseg_core.engine.graphcut.graph_clusters`): the walk is
        solved on the graph of the clusters (each split by the strokes' labels, arc weights
        summed) and every face takes its cluster's probabilities; several times faster on
        large meshes (the app's preview).
    prior : (m, k) float ndarray, optional
        Label probabilities per face, where the walk may stop (:class:`RandomWalk`).
    reach : float
        How far the walk goes before it stops at the prior (:class:`RandomWalk`); 0: never.

    Returns
    -------
    P : (m, k) float64 ndarray
        Rows sum to 1 where reached; columns of labels not scribbled are 0.
    """
    return RandomWalk(graph, scribble, k, crease, convex, clusters, reach).probabilities(prior)


class RandomWalk:
    """The random walker from the strokes of one shape, factorized once, solved for any prior.

    Without a prior (``reach = 0``) a walk from a free face wanders until it meets a stroke and
    takes its label (Grady 2006). With a prior Λ (label probabilities per face, renormalized
    over the labels painted on the shape) it may also stop at every step, with probability
    ``γ / (1 + γ)``, and take a label drawn from the prior where it stops (random walks with
    prior models, Grady 2005): ``(L_uu + γ D_u) X_u = −L_us X_s + γ D_u Λ_u``, D the graph's
    degrees. A walk takes about ``1 / γ`` steps before it stops, and spreads over about the
    square root of that many faces, so ``γ = 1 / (reach² · n)`` for n nodes: it stops after
    crossing about `reach` of a shape's width. Near a stroke the walk still meets it; in a
    part that no stroke of its label reaches (three legs of four when one was painted: from
    them the walk would reach the body's stroke first), the prior decides. ``L_uu + γ D_u``
    does not depend on the prior: it is factorized once.

    Parameters are those of :func:`random_walk_probabilities`.
    """

    def __init__(self, graph: DualGraph, scribble: np.ndarray, k: int, crease: float,
                 convex: float = CONVEX_FACTOR, clusters: np.ndarray | None = None, reach: float = 0.0):
        scribble = np.asarray(scribble, dtype=np.int64)
        w = graph.diffusion_weights * np.exp(-graph.concavity(convex) / crease)
        w = np.maximum(w, 1e-9 * max(pair_mean(w), 1e-300))  # sharp creases: weak, never cut off
        self.k, self.coarse = k, None
        if clusters is None:
            L, seed = graph.laplacian(w), scribble
        else:
            self.coarse, pairs, weights = coarsen(clusters, scribble, graph.pairs, w)
            c = int(self.coarse.max()) + 1 if self.coarse.size else 0
            seed = np.full(c, -1, np.int64)
            seed[self.coarse] = scribble  # a coarse node's faces share their stroke label, or have none
            L = pair_laplacian(pairs, weights, c)
        n = L.shape[0]
        seeded = seed >= 0
        self.base = np.zeros((n, k))
        self.base[seeded, seed[seeded]] = 1.0
        # only components holding a stroke are solved (elsewhere the walk with no prior is singular)
        _, comp = connected_components(L, directed=False)
        live = np.isin(comp, comp[seeded])
        self.u, s = np.flatnonzero(live & ~seeded), np.flatnonzero(seeded)
        self.present = np.unique(seed[s])
        self.gamma = 1.0 / (reach * reach * n) if reach > 0 and n else 0.0
        if self.u.size == 0 or self.present.size == 0:
            return
        Lu = L[self.u]
        self.rhs = -(Lu[:, s] @ self.base[np.ix_(s, self.present)])
        self.stop = self.gamma * L.diagonal()[self.u]
        self._solve = sla.splu((Lu[:, self.u] + sp.diags(self.stop)).tocsc()).solve

    def reached(self) -> np.ndarray:
        """(m,) float64: the chance that the walk from each face meets a stroke before it stops
        (1 on the strokes; 1 everywhere a stroke's component reaches without a reach; 0 in
        components without strokes). Where it is low, no stroke decides the face's label."""
        out = self.base.sum(axis=1)
        if self.u.size and self.present.size:
            out[self.u] = self._solve(np.ascontiguousarray(self.rhs.sum(axis=1)))
        out = np.clip(out, 0.0, 1.0)
        return out if self.coarse is None else out[self.coarse]

    def probabilities(self, prior: np.ndarray | None = None) -> np.ndarray:
        """(m, k) float64 label probabilities of the walk; `prior` (m, k) rows of label
        probabilities (renormalized over the labels painted on the shape), needed when the
        walk has a reach."""
        P = self.base.copy()
        if self.u.size and self.present.size:
            rhs = self.rhs
            if self.gamma > 0:
                if prior is None:
                    raise ValueError("a random walk with a reach needs a prior")
                prior = np.asarray(prior, dtype=np.float64)
                if self.coarse is not None:  # a cluster's prior: the mean of its faces'
                    total = np.zeros((len(self.base), self.k))
                    np.add.at(total, self.coarse, prior)
                    prior = total / np.maximum(np.bincount(self.coarse, minlength=len(self.base)), 1)[:, None]
                lam = prior[np.ix_(self.u, self.present)]
                mass = lam.sum(axis=1, keepdims=True)
                lam = np.where(mass > 0, lam / np.where(mass > 0, mass, 1.0), 1.0 / len(self.present))
                rhs = rhs + self.stop[:, None] * lam
            P[np.ix_(self.u, self.present)] = self._solve(np.ascontiguousarray(rhs))
        P = np.clip(P, 0.0, 1.0)
        return P if self.coarse is None else P[self.coarse]


def learned_weights(graph: DualGraph, boundary_proba: np.ndarray, weight: float) -> np.ndarray:
    """Potts weights ``weight · (ℓ / mean ℓ) · −log max(P_b, 1e-4)`` of the face pairs of
    `graph` from their boundary probabilities P_b (q,); (q,) float64."""
    p = np.asarray(boundary_proba, dtype=np.float64)
    if p.shape != (len(graph.pairs),):
        raise ValueError(f"boundary_proba has shape {p.shape}, expected ({len(graph.pairs)},)")
    return weight * graph.relative_length * -np.log(np.clip(p, 1e-4, 1.0))


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
    return floor + (1.0 - floor) * np.exp(-contrast * d2 / max(pair_mean(d2), 1e-12))
