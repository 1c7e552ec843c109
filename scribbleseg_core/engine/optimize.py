"""The alternating optimization (the paper's Section 3.2) as a generator of snapshots.

``segment_collection`` yields a frozen :class:`Snapshot` after every step (initial graph
cut, each network training, each graph cut, the refinement); the caller may stop between
any two. No GUI code here: the app wraps the generator in a worker thread.
"""

from __future__ import annotations

import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np

from scribbleseg_core.engine.cores import CoreParams
from scribbleseg_core.engine.energy import (
    EnergyTerms,
    energy_terms,
    feature_weights,
    network_unary,
    scribble_unary,
)
from scribbleseg_core.engine.graphcut import alpha_expansion
from scribbleseg_core.engine.network import FaceClassifier, NetworkParams
from scribbleseg_core.engine.patch_features import (
    PatchEncoder,
    feature_delta,
    fit_patch_encoder,
)
from scribbleseg_core.engine.patches import nearest_scribble_labels
from scribbleseg_core.engine.propagate import (
    PropagateParams,
    propagate_shape,
    scribble_distances,
)
from scribbleseg_core.engine.refine import RefineParams
from scribbleseg_core.engine.shape import ShapeData
from scribbleseg_core.signatures.context import DEFAULT_SCALES

Phase = Literal["graphcut", "train", "refine", "retrain", "crossfit", "done"]


@dataclass(frozen=True)
class SegmentParams:
    """Parameters of the whole pipeline (the engine's public settings).

    Attributes
    ----------
    lam : float
        λ of the feature term (the paper: 1).
    context_scales : tuple of float
        Beyond the paper: diffusion times of the context added to the network's input (the 22
        signatures diffused over the surface, :mod:`scribbleseg_core.signatures.context`);
        ``()`` gives the paper's 22 inputs. Default (0.002, 0.01, 0.05), in units of the
        unit-area mesh.
    local_shape : bool
        Beyond the paper: the network also reads the local extrinsic shape at each context
        scale (:func:`~scribbleseg_core.signatures.context.local_shape`: local PCA, normal
        agreement, signed multi-scale mean curvature; 5 values a scale). Default True.
    max_iterations : int
        Network/graph-cut rounds at most (the paper converges in about 4). Default 6.
    tolerance : float
        Stop when the total energy falls by less than this fraction. Default 1e-3.
    refine : bool
        Face-level result after the alternation: on scribbled shapes the scribble propagation
        (:mod:`~scribbleseg_core.engine.propagate`), on unseen shapes
        :func:`~scribbleseg_core.engine.refine.refine_labels` and then, with `cores`, the
        propagation from part cores. False keeps the paper's patch-level result.
    init : {"propagate", "geodesic", "paper"}
        The initial graph cut: ``"paper"`` uses eq. 1 alone; the others add, for this cut
        only, the area fraction of each patch whose faces a scribble-made labeling gives
        another label: the scribble propagation (``"propagate"``, default) or each face's
        nearest scribble (``"geodesic"``). Eq. 1 alone has graph cuts' shrinking bias.
    retrain : bool
        After the refinement, train the network afresh on the refined face labels (the model
        for unseen shapes) and propagate the scribbles once more with its log-probabilities
        (weight ``propagation.network``). Default True.
    retrain_near : float, optional
        Retrain only on each shape's faces whose crease-aware distance to the nearest stroke
        is within this quantile (0.5: the nearer half). Default None (all faces).
    network : NetworkParams
    refinement : RefineParams
    propagation : PropagateParams
    cores : CoreParams, optional
        Unseen shapes, after the refinement: take the confident cores of the predicted parts
        as scribbles and propagate from them (:mod:`~scribbleseg_core.engine.cores`). None
        stops at the refinement.
    cross_fit : float
        Scribbled shapes, with `retrain`: the final propagation's network term is
        ``log((1 − a) P + a P_others)``, a = `cross_fit` (default 0.7), P the retrained
        network's probabilities and P_others the mean of those of networks trained the same
        way on the other shapes only. 0 turns it off; it needs 2 scribbled shapes and costs
        ``cross_fit_repeats · cross_fit_folds`` trainings on part of the collection. It
        changes neither the model nor the unseen shapes.
    cross_fit_folds : int
        Folds of the cross-fitting (at most one per shape). Default 2.
    cross_fit_repeats : int
        Cross-fit this many times with different splits of the shapes
        (:func:`cross_fit_folds`) and average the held-out probabilities. Default 2.
    stroke_network : float
        With `refine` and `retrain`: the model for unseen shapes learns the scribble
        propagation plus this weight (default 0.05) times the −log-probabilities of a *stroke
        network*, trained on the stroke faces of all scribbled shapes only. The scribbled
        shapes' own labels never see it. 0 turns it off.
    stroke_network_min_accuracy : float
        Use the stroke network only where it carries over between shapes: its held-out
        accuracy on the strokes (:func:`stroke_network_accuracy`; no ground truth) must
        reach this. Default 0.8.
    """

    lam: float = 1.0
    context_scales: tuple[float, ...] = DEFAULT_SCALES
    local_shape: bool = True
    max_iterations: int = 6
    tolerance: float = 1e-3
    refine: bool = True
    init: Literal["propagate", "geodesic", "paper"] = "propagate"
    retrain: bool = True
    retrain_near: float | None = None
    network: NetworkParams = field(default_factory=NetworkParams)
    refinement: RefineParams = field(default_factory=RefineParams)
    propagation: PropagateParams = field(default_factory=PropagateParams)
    cores: CoreParams | None = field(default_factory=CoreParams)
    cross_fit: float = 0.7
    cross_fit_folds: int = 2
    cross_fit_repeats: int = 2
    stroke_network: float = 0.05
    stroke_network_min_accuracy: float = 0.8

    def network_input(self, shape: ShapeData) -> np.ndarray:
        """The network's input per face of `shape` under these parameters (context scales,
        local shape): :meth:`ShapeData.network_input`, (m, d) float64."""
        return shape.network_input(self.context_scales, self.local_shape)


@dataclass(frozen=True, eq=False)
class TrainedModel:
    """What prediction on new shapes needs."""

    classifier: FaceClassifier
    encoder: PatchEncoder
    delta: float
    label_names: tuple[str, ...]
    params: SegmentParams


@dataclass(frozen=True, eq=False)
class Snapshot:
    """The state after one step.

    Attributes
    ----------
    iteration : int
        0 for the initial graph cut, then 1, 2, ...
    phase : {"graphcut", "train", "refine", "retrain", "crossfit", "done"}
    energy : EnergyTerms
        Summed over the collection's scribbled shapes (``network`` NaN before training).
    labels : tuple of (m_s,) int64 ndarray
        Current face labels per shape (repaired faces), refined if the refinement ran.
    patch_labels : tuple of (m_s,) int64 ndarray
        The paper's patch-level result per shape, on faces.
    seconds : float
        Time this step took.
    model : TrainedModel or None
        The trained model (from the first training on). Unlike the label arrays it is not
        a copy: later training steps update it in place, so take it from the last snapshot.
    """

    iteration: int
    phase: Phase
    energy: EnergyTerms
    labels: tuple[np.ndarray, ...]
    patch_labels: tuple[np.ndarray, ...]
    seconds: float
    model: TrainedModel | None = None

    @property
    def done(self) -> bool:
        return self.phase == "done"


def _frozen(arrays) -> tuple[np.ndarray, ...]:
    out = []
    for a in arrays:
        a = np.array(a, dtype=np.int64, copy=True)
        a.flags.writeable = False
        out.append(a)
    return tuple(out)


def segment_collection(
    shapes: Sequence[ShapeData],
    label_names: Sequence[str],
    params: SegmentParams = SegmentParams(),
    *,
    encoder: PatchEncoder | None = None,
) -> Iterator[Snapshot]:
    """Minimize ``E = E_scr + E_neu + λ E_fea`` over the scribbled shapes, alternately.

    Parameters
    ----------
    shapes : sequence of ShapeData
        Only shapes with scribbles take part; others are for :func:`~scribbleseg_core.engine.predict.predict_shape`.
    label_names : sequence of str
        k names; scribble ids index them.
    params : SegmentParams
    encoder : PatchEncoder, optional
        Fit on these shapes when not given.

    Yields
    ------
    Snapshot
        After every step; the last has phase ``"done"`` and carries the model.
    """
    shapes = [s for s in shapes if s.is_scribbled]
    if not shapes:
        raise ValueError("no shape has scribbles: paint at least one stroke")
    k = len(label_names)
    t0 = time.perf_counter()
    encoder = encoder or fit_patch_encoder([s.X for s in shapes], seed=params.network.seed)
    desc = [encoder.encode(s.X, s.area, s.patch) for s in shapes]
    delta = feature_delta(desc, [s.patch_pairs for s in shapes])
    W = [feature_weights(D, s.patch_pairs, delta, params.lam) for D, s in zip(desc, shapes)]
    U_scr = [scribble_unary(s.patch, s.scribble, s.scribbled_labels, k) for s in shapes]
    P = [s.patch_matrix() for s in shapes]

    # (3a) initial graph cuts without the network term
    if params.init not in ("propagate", "geodesic", "paper"):
        raise ValueError(f"init must be 'propagate', 'geodesic' or 'paper'; got {params.init!r}")
    if not 0.0 <= params.cross_fit <= 1.0 or params.cross_fit_folds < 2 or params.cross_fit_repeats < 1:
        raise ValueError(f"cross_fit must lie in [0, 1], cross_fit_folds be at least 2 and cross_fit_repeats "
                         f"at least 1; got {params.cross_fit}, {params.cross_fit_folds}, {params.cross_fit_repeats}")
    if params.stroke_network < 0:
        raise ValueError(f"stroke_network must not be negative; got {params.stroke_network}")
    propagated = None  # the scribble propagation without the network, made once
    if params.init == "paper":
        U_init = U_scr
    else:
        if params.init == "propagate":
            guide = propagated = [propagate_shape(s, k, params.propagation) for s in shapes]
        else:
            guide = [nearest_scribble_labels(s.graph, s.scribble) for s in shapes]
        U_init = [U + _guide_unary(s, g, k, w) for U, s, g, w in zip(U_scr, shapes, guide, W)]
    y = [alpha_expansion(U, s.patch_pairs, w) for U, s, w in zip(U_init, shapes, W)]
    energy = _total(y, U_scr, None, shapes, W)
    faces = [yi[s.patch] for yi, s in zip(y, shapes)]
    yield Snapshot(0, "graphcut", energy, _frozen(faces), _frozen(faces), time.perf_counter() - t0)

    inputs = [params.network_input(s) for s in shapes]
    clf = FaceClassifier(inputs[0].shape[1], k, params.network)
    model = None
    U_neu = None
    best = np.inf
    it = 0
    for it in range(1, params.max_iterations + 1):
        # (3b) fix Y, train the network on every face with its current label
        t = time.perf_counter()
        previous = None if not clf.trained else _state(clf)
        clf.fit(inputs, faces, warm=clf.trained)
        logp = [clf.log_proba(x) for x in inputs]
        U_new = [network_unary(Pi, lp) for Pi, lp in zip(P, logp)]
        e_train = _total(y, U_scr, U_new, shapes, W)
        if previous is not None and e_train.total > best:
            _restore(clf, previous)  # training did not lower E: keep the old network, stop
            break
        U_neu = U_new
        model = TrainedModel(clf, encoder, delta, tuple(label_names), params)
        yield Snapshot(it, "train", e_train, _frozen(faces), _frozen(faces), time.perf_counter() - t, model)

        # (3c) fix the network, graph cuts with its log-probabilities
        t = time.perf_counter()
        y_new = [alpha_expansion(Us + Un, s.patch_pairs, w, init=yi) for Us, Un, s, w, yi in zip(U_scr, U_neu, shapes, W, y)]
        unchanged = all(np.array_equal(a, b) for a, b in zip(y, y_new))
        y = y_new
        energy = _total(y, U_scr, U_neu, shapes, W)
        faces = [yi[s.patch] for yi, s in zip(y, shapes)]
        yield Snapshot(it, "graphcut", energy, _frozen(faces), _frozen(faces), time.perf_counter() - t, model)
        # Converged when the labels are a fixed point (further training only refits the
        # same labels) or the energy stops decreasing.
        stalled = np.isfinite(best) and energy.total > best * (1 - params.tolerance)
        best = min(best, energy.total)
        if unchanged or stalled:
            break

    patch_faces = faces
    if params.refine and model is not None:
        # face level: propagate the scribbles along creases, retrain the network on those
        # cleaner labels, then propagate again with the network's log-probabilities
        t = time.perf_counter()
        faces = propagated or [propagate_shape(s, k, params.propagation) for s in shapes]
        yield Snapshot(it, "refine", energy, _frozen(faces), _frozen(patch_faces), time.perf_counter() - t, model)
        if params.retrain:
            t = time.perf_counter()
            targets = _near_strokes(shapes, faces, k, params.retrain_near)
            clf.fit(inputs, targets)
            if params.propagation.network > 0:
                logp = [clf.log_proba(x) for x in inputs]
                if params.cross_fit > 0 and len(shapes) >= 2:
                    yield Snapshot(it, "retrain", energy, _frozen(faces), _frozen(patch_faces), time.perf_counter() - t, model)
                    held_out = [[] for _ in shapes]  # log-probabilities from networks that never saw the shape
                    for repeat in range(params.cross_fit_repeats):
                        for held in cross_fit_folds(len(shapes), params.cross_fit_folds, repeat):
                            t = time.perf_counter()
                            for i, lp in _held_out_log_proba(inputs, targets, held, k, params).items():
                                held_out[i].append(lp)
                            yield Snapshot(it, "crossfit", energy, _frozen(faces), _frozen(patch_faces), time.perf_counter() - t, model)
                    t = time.perf_counter()
                    logp = [_mix(lp, others, params.cross_fit) for lp, others in zip(logp, held_out)]
                faces = [propagate_shape(s, k, params.propagation, lp) for s, lp in zip(shapes, logp)]
            yield Snapshot(it, "retrain", energy, _frozen(faces), _frozen(patch_faces), time.perf_counter() - t, model)
            t = time.perf_counter()
            learn = unseen_targets(shapes, inputs, targets, k, params)
            if learn is not targets:  # else the retrained network is the model
                unseen = FaceClassifier(inputs[0].shape[1], k, params.network)
                unseen.fit(inputs, learn)
                model = replace(model, classifier=unseen)
                yield Snapshot(it, "retrain", energy, _frozen(faces), _frozen(patch_faces), time.perf_counter() - t, model)
    yield Snapshot(it, "done", energy, _frozen(faces), _frozen(patch_faces), time.perf_counter() - t0, model)


def cross_fit_folds(n: int, folds: int, repeat: int = 0) -> list[np.ndarray]:
    """Shape indices held out per fold.

    Repeat r puts shape i in fold ``(i // c**r) mod c``, c = ``min(folds, n)``: repeat 0 is
    ``i mod c``, repeat 1 with 2 folds pairs neighbours (0 1 | 2 3 | ... alternate), so each
    repeat splits the shapes differently.

    Parameters
    ----------
    n : int
        Number of shapes, at least 2.
    folds : int
        At least 2; at most `n` folds are made (leave-one-out when ``folds >= n``).
    repeat : int
        Which assignment. One that leaves fewer than two folds non-empty, or splits the
        shapes as an earlier repeat did, gives ``[]`` (too few shapes for another split).

    Returns
    -------
    list of (n_f,) int64 ndarray
    """
    if n < 2 or folds < 2:
        raise ValueError(f"cross-fitting needs at least 2 shapes and 2 folds; got {n} shapes, {folds} folds")
    count = min(folds, n)

    def split(r: int) -> list[np.ndarray]:
        fold = (np.arange(n) // count**r) % count
        return [np.flatnonzero(fold == f) for f in range(count) if (fold == f).any()]

    held = split(repeat)
    if len(held) < 2:
        return []
    canonical = sorted(tuple(h) for h in held)
    if any(sorted(tuple(h) for h in split(r)) == canonical for r in range(repeat)):
        return []
    return held


def unseen_targets(shapes, inputs, targets: list[np.ndarray], k: int, params: SegmentParams) -> list[np.ndarray]:
    """The face labels the model for unseen shapes learns: the stroke-guided propagation
    (:func:`_stroke_guided_labels`) where the stroke network carries over between shapes,
    else `targets` themselves (the scribble propagation the scribbled shapes' network was
    retrained on; the same list object, so callers can tell)."""
    guided = _stroke_guided_labels(shapes, inputs, k, params)
    return targets if guided is None else _near_strokes(shapes, guided, k, params.retrain_near)


def stroke_network_accuracy(shapes, inputs, k: int, params: SegmentParams) -> float:
    """How well a stroke network carries over between shapes: networks trained on the stroke
    faces of one half of the shapes (:func:`cross_fit_folds`, 2 folds) label the stroke faces
    of the other half; the mean over shapes of the fraction labeled right. Uses the strokes
    only, never a propagated label. ``nan`` with fewer than 2 shapes."""
    if len(shapes) < 2:
        return float("nan")
    strokes = [s.scribble for s in shapes]
    scores = []
    for held in cross_fit_folds(len(shapes), 2):
        for i, logp in _held_out_log_proba(inputs, strokes, held, k, params).items():
            painted = strokes[i] >= 0
            scores.append(float((logp[painted].argmax(1) == strokes[i][painted]).mean()))
    return float(np.mean(scores))


def _stroke_guided_labels(shapes, inputs, k: int, params: SegmentParams) -> list[np.ndarray] | None:
    """The scribble propagation with a *stroke network*'s log-probabilities as a weak unary
    (weight ``params.stroke_network``, no random walk): the network trained on the stroke
    faces of every shape only, so it knows what each part looks like across the collection
    but has never seen a propagated label. ``(m_i,)`` int64 labels per shape, or ``None``
    (use the propagation alone) when the weight is 0 or the stroke network does not carry
    over between shapes (:func:`stroke_network_accuracy` below
    ``params.stroke_network_min_accuracy``, or fewer than 2 shapes)."""
    if params.stroke_network <= 0:
        return None
    if not stroke_network_accuracy(shapes, inputs, k, params) >= params.stroke_network_min_accuracy:  # nan: no
        return None
    clf = FaceClassifier(inputs[0].shape[1], k, params.network)
    clf.fit(inputs, [s.scribble for s in shapes])  # faces without a stroke (-1) are skipped
    guided = replace(params.propagation, network=params.stroke_network, walk=0.0)
    return [propagate_shape(s, k, guided, clf.log_proba(x)) for s, x in zip(shapes, inputs)]


def _held_out_log_proba(inputs, targets, held: np.ndarray, k: int, params: SegmentParams) -> dict[int, np.ndarray]:
    """Train a network on the shapes outside `held`; its log-probabilities on each held-out
    shape i, ``{i: (m_i, k) ndarray}``."""
    others = np.setdiff1d(np.arange(len(inputs)), held)
    clf = FaceClassifier(inputs[0].shape[1], k, params.network)
    clf.fit([inputs[i] for i in others], [targets[i] for i in others])
    return {int(i): clf.log_proba(inputs[i]) for i in held}


def _mix(own: np.ndarray, held_out: list[np.ndarray], a: float) -> np.ndarray:
    """``log((1 − a) P + a P_others)``, P = exp(`own`), P_others the mean of the held-out
    networks' probabilities (`own` unchanged when there are none)."""
    if not held_out:
        return own
    others = np.logaddexp.reduce(np.stack(held_out), axis=0) - np.log(len(held_out))
    with np.errstate(divide="ignore"):  # a = 1: the shape's own network drops out
        return np.logaddexp(np.log1p(-a) + own, np.log(a) + others)


def _near_strokes(shapes, faces, k: int, quantile: float | None) -> list[np.ndarray]:
    """`faces` labels kept where the face is within `quantile` of its shape's distances
    to the nearest stroke, -1 (not trained on) elsewhere; `faces` as they are when
    `quantile` is None (``SegmentParams.retrain_near`` off)."""
    if quantile is None:
        return faces
    out = []
    for s, f in zip(shapes, faces):
        near = scribble_distances(s.graph, s.scribble, k).min(axis=1)
        finite = np.isfinite(near)
        limit = np.quantile(near[finite], quantile) if finite.any() else np.inf
        out.append(np.where(finite & (near <= limit), f, -1))
    return out


def _guide_unary(shape: ShapeData, near: np.ndarray, k: int, weights: np.ndarray) -> np.ndarray:
    """(p, k): area fraction of each patch whose guide label `near` (m,) is not label l,
    times half the patch's weighted degree in the feature term (so the cue and the
    pairwise term are on one scale: a patch leaves its guide's label only where that
    removes at least half its boundary cost). Faces with guide -1 do not count."""
    reached = near >= 0
    A = np.zeros((len(near), k))
    A[np.flatnonzero(reached), near[reached]] = shape.area[reached]
    per_patch = shape.patch_matrix() @ A
    total = per_patch.sum(axis=1, keepdims=True)
    agree = np.divide(per_patch, total, out=np.ones_like(per_patch), where=total > 0)
    degree = np.bincount(shape.patch_pairs.ravel(), np.repeat(weights, 2), minlength=shape.num_patches)
    return (1.0 - agree) * (0.5 * degree + 1e-3)[:, None]


def _total(y, U_scr, U_neu, shapes, W) -> EnergyTerms:
    total = EnergyTerms(0.0, 0.0 if U_neu is not None else float("nan"), 0.0)
    for i, s in enumerate(shapes):
        total = total + energy_terms(y[i], U_scr[i], None if U_neu is None else U_neu[i], s.patch_pairs, W[i])
    return total


def _state(clf: FaceClassifier):
    import copy

    return copy.deepcopy(clf.net.state_dict()), clf.mean.copy(), clf.std.copy()


def _restore(clf: FaceClassifier, state) -> None:
    clf.net.load_state_dict(state[0])
    clf.mean, clf.std = state[1], state[2]
