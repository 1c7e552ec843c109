"""The alternating optimization (the paper's Section 3.2) as a generator of snapshots.

``E(Y, θ) = Σ_shapes [E_scr(Y) + E_neu(Y; θ) + E_smooth(Y)]`` is minimized alternately:
with the labels Y fixed, the network θ is trained on them; with θ fixed, a multi-label graph
cut finds the labels. The scribbled shapes' labels of the last cut are the result; the model
(which segments the shapes without scribbles and new shapes) is the networks trained on them,
and every snapshot's energy is that of the labels it carries.

Two variants (:attr:`SegmentParams.method`):

``"face"`` (default)
    On the faces (:class:`~scribbleseg_core.engine.propagate.FaceEnergy`): the scribbles
    are hard, the scribble term elsewhere is the crease-aware distance to each label's
    strokes (and, beside the network, the random walk from them, which may stop on the way
    and take the model's label there: :class:`~scribbleseg_core.engine.propagate.RandomWalk`), the smoothness is a Potts
    term cheap across concave creases. The initial labels are the cut without the network
    (the scribble propagation). Shapes without scribbles are segmented at every cut by that
    round's model, as new shapes are (:func:`~scribbleseg_core.engine.predict.predict_shape`);
    their labels train nothing and count in no energy.
``"paper"``
    The paper as written, on primitive patches: eq. 1 initial cut, then the alternation
    with eq. 1–4 (:mod:`~scribbleseg_core.engine.energy`) on the patch graph, scribbled
    shapes only.

Additions to the paper in ``"face"``, each measured on its own in ``docs/benchmarks.md``:
a first round that learns mostly the faces the strokes decide (:attr:`SegmentParams.decided`),
cross-fitted network term (:class:`_Networks`), the random-walker term with the model as its prior, the SDF contrast and the
convex-crease weight of the smoothness (:class:`~scribbleseg_core.engine.propagate.PropagateParams`),
the multi-scale context and local shape among the network's inputs (:attr:`SegmentParams.context_scales`,
:attr:`SegmentParams.local_shape`), the label-context stage of the learner
(:attr:`SegmentParams.label_context`, :mod:`~scribbleseg_core.engine.learner`), the learned
boundary term that smooths shapes without scribbles (:mod:`~scribbleseg_core.engine.boundary`),
and those shapes segmented at every cut, so that the whole collection's labels stream while
the painted shapes are optimized.

No GUI code here: the app runs the generator in a worker process.
"""

from __future__ import annotations

import copy
import time
from collections.abc import Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np

from scribbleseg_core.engine.boundary import BoundaryClassifier, edge_features, label_boundaries
from scribbleseg_core.engine.energy import (
    EnergyTerms,
    energy_terms,
    feature_weights,
    network_unary,
    scribble_unary,
)
from scribbleseg_core.engine.graphcut import alpha_expansion
from scribbleseg_core.engine.learner import Learner, context_input
from scribbleseg_core.engine.network import FaceClassifier, NetworkParams, torch_threads
from scribbleseg_core.engine.patch_features import PatchEncoder, feature_delta, fit_patch_encoder
from scribbleseg_core.engine.propagate import FaceEnergy, PropagateParams
from scribbleseg_core.engine.shape import ShapeData
from scribbleseg_core.signatures.context import DEFAULT_SCALES

Method = Literal["face", "paper"]
METHODS: tuple[str, ...] = ("face", "paper")
Phase = Literal["init", "train", "graphcut", "done"]
#: The alternation has converged when a round lowers the total energy by less than this fraction.
TOLERANCE = 1e-3


#: The share of the faces the strokes do not decide that the first round's networks learn
#: (:attr:`SegmentParams.decided`): where the propagation's guess is a part no stroke reached
#: (three legs of four labeled body) it teaches the networks too little to outweigh the
#: painted leg; where the guess is right but the decided faces are not a fair sample of their
#: part (only the middle of a large flat part lies near its stroke), the networks still see
#: the rest of it.
UNDECIDED_SHARE = 0.1


@dataclass(frozen=True)
class SegmentParams:
    """Parameters of the whole pipeline.

    Attributes
    ----------
    method : {"face", "paper"}
        ``"face"`` (default): the alternation on faces with the crease-aware energy of
        :class:`~scribbleseg_core.engine.propagate.FaceEnergy`; ``"paper"``: the paper's
        patch-level alternation (eq. 1–4).
    rounds : int
        Network/graph-cut rounds at most (the paper converges in about 4); the alternation
        stops earlier when no label changes or a round lowers the total energy by less than
        :data:`TOLERANCE`, and a training that would raise the energy is undone and ends the
        run. The model learns every face: where the kept networks are the first round's,
        which learn mostly the faces the strokes decide, the networks that learned the
        scribbled shapes' final labels on every face (those of an undone second training; or
        one more training, within `rounds`) become the model, and they cut the shapes without
        scribbles again. Default 3.
    lam : float
        ``"paper"`` only: λ of the feature term (the paper: 1).
    context_scales : tuple of float
        Diffusion times of the context added to the network's input (the 22 signatures
        diffused over the surface, :mod:`scribbleseg_core.signatures.context`), in units of
        the unit-area mesh; ``()`` gives the paper's 22 inputs. Default (0.002, 0.01, 0.05).
    local_shape : bool
        The network also reads the local extrinsic shape at each context scale
        (:func:`~scribbleseg_core.signatures.context.local_shape`; 5 values a scale).
        Default True.
    label_context : bool
        ``"face"`` only: the learner has a second stage that also reads, for every label,
        how far the faces the first stage gives that label lie from the face
        (:mod:`~scribbleseg_core.engine.learner`); it trains one more network a round.
        Default True.
    cross_fit : float
        ``"face"`` only: the share of held-out networks in a scribbled shape's network term,
        ``log((1 − a) P_all + a P_fold)``: its probabilities also come from a network trained
        on the other folds of the shapes (:func:`fold_count`), one that never saw its labels,
        so the term is not only the echo of them. The model for new shapes is the network
        trained on all shapes. 0 turns it off (then, without the label-context stage, each
        round trains one first-stage network instead of one plus one a fold). Default 0.7.
    decided : float
        ``"face"`` only: the first round's networks learn the faces of each scribbled shape
        that the strokes decide, and only a share :data:`UNDECIDED_SHARE` of the others,
        drawn at random (the same draw for every network seed). A face is decided when the
        random walk from it meets a stroke before it stops with at least this chance
        (:meth:`RandomWalk.reached
        <scribbleseg_core.engine.propagate.RandomWalk.reached>`, with the reach
        ``propagation.walk_reach``). Elsewhere the initial labels are the propagation's guess
        (the nearest stroke's label: body for the three legs of four left unpainted), which
        the networks would learn; from the second round they learn every face, labeled by
        the cut that their model joined. 0, or a walk without a reach: every face from the
        first round. Default 0.5.
    network : NetworkParams
        The classifier and its training.
    propagation : PropagateParams
        The face energy's weights (``"face"``).
    """

    method: Method = "face"
    rounds: int = 3
    lam: float = 1.0
    context_scales: tuple[float, ...] = DEFAULT_SCALES
    local_shape: bool = True
    label_context: bool = True
    cross_fit: float = 0.7
    decided: float = 0.5
    network: NetworkParams = field(default_factory=NetworkParams)
    propagation: PropagateParams = field(default_factory=PropagateParams)

    def __post_init__(self):
        if not 0 <= self.cross_fit < 1:
            raise ValueError(f"cross_fit must lie in [0, 1); got {self.cross_fit}")
        if not 0 <= self.decided <= 1:
            raise ValueError(f"decided must lie in [0, 1]; got {self.decided}")
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {', '.join(map(repr, METHODS))}; got {self.method!r}")
        if self.rounds < 1:
            raise ValueError(f"rounds must be at least 1; got {self.rounds}")
        if not self.lam >= 0:
            raise ValueError(f"lam must not be negative; got {self.lam}")
        if any(not t > 0 for t in self.context_scales):
            raise ValueError(f"context_scales must be positive; got {self.context_scales}")

    def network_input(self, shape: ShapeData) -> np.ndarray:
        """The network's input per face of `shape` under these parameters (context scales,
        local shape): :meth:`ShapeData.network_input`, (m, d) float64."""
        return shape.network_input(self.context_scales, self.local_shape)

    @property
    def uses_label_context(self) -> bool:
        """Whether the learner has its label-context stage (``"face"`` with :attr:`label_context`)."""
        return self.method == "face" and self.label_context


@dataclass(frozen=True, eq=False)
class TrainedModel:
    """What prediction on new shapes needs.

    Attributes
    ----------
    learner : Learner
    label_names : tuple of str
    params : SegmentParams
    encoder : PatchEncoder or None
        ``"paper"`` only: the patch descriptors' ranges and codebook.
    delta : float or None
        ``"paper"`` only: δ of the feature term.
    fold_nets : tuple of FaceClassifier
        The first-stage networks each trained without one fold of the scribbled shapes
        (cross-fitting, :func:`fold_count`), for a later run to continue
        (``segment_collection(warm=)``); not saved with the model.
    boundary : BoundaryClassifier or None
        ``"face"`` only: where labels meet (:mod:`~scribbleseg_core.engine.boundary`), learned
        from the scribbled shapes' labels with the networks; the smoothness of shapes without
        scribbles. None where those labels hold no boundary (then the crease rule).
    """

    learner: Learner
    label_names: tuple[str, ...]
    params: SegmentParams
    encoder: PatchEncoder | None = None
    delta: float | None = None
    fold_nets: tuple[FaceClassifier, ...] = ()
    boundary: BoundaryClassifier | None = None

    def with_threads(self, threads: int | None) -> TrainedModel:
        """This model predicting on `threads` threads (torch and the boundary trees; None: the
        cores this process may use); it shares the weights, and this one is left as it is."""
        return replace(self, learner=self.learner.with_threads(threads),
                       params=replace(self.params, network=replace(self.params.network, threads=threads)))

    def boundary_proba(self, shape: ShapeData) -> np.ndarray | None:
        """(q,) probability of a label boundary across each face pair of `shape`, or None
        without a boundary classifier."""
        if self.boundary is None:
            return None
        x = self.params.network_input(shape)
        return self.boundary.proba(edge_features(shape.graph, shape.X, x), self.params.network.threads)

    def log_proba(self, shape: ShapeData) -> np.ndarray:
        """The learner's log label probabilities for the faces of `shape`, (m, k) float64."""
        x = self.params.network_input(shape)
        if self.learner.stage2 is None:
            return self.learner.log_proba(x)
        return self.learner.log_proba(x, shape.label_context)


@dataclass(frozen=True, eq=False)
class Snapshot:
    """The state after one step.

    Attributes
    ----------
    iteration : int
        0 for the initial labels, then the round 1, 2, ...
    phase : {"init", "train", "graphcut", "done"}
    energy : EnergyTerms
        Summed over the scribbled shapes (``network`` NaN before training): the energy of
        their `labels` under the network of this step (for the last step, under the network
        of the last cut). The labels of shapes without scribbles are the model's prediction
        and count in no energy.
    labels : tuple of (m_s,) int64 ndarray
        Face labels per shape (repaired faces), in the order of the shapes given; -1 for a
        shape not labeled yet (a shape without scribbles before the first network).
    changed : tuple of bool
        Per shape: did this step change its labels?
    seconds : float
        Time this step took; for the last step, the whole run.
    model : TrainedModel or None
        The network of this step (from the first training on); later steps train a copy.
        The last step's is the model: networks that learned the scribbled shapes' final
        labels on every face (see :attr:`SegmentParams.rounds`).
    held_out : tuple of ((m_s, k) float64 ndarray or None) or None
        The last step only: per shape, log label probabilities from a first-stage network
        that did not see the shape's labels (trained on the other folds of the collection),
        None where there is none (a collection of one shape, method ``"paper"``). What the
        confidence of a collection's shape is measured with
        (:func:`~scribbleseg_core.engine.guidance.label_confidence`).
    """

    iteration: int
    phase: Phase
    energy: EnergyTerms
    labels: tuple[np.ndarray, ...]
    changed: tuple[bool, ...]
    seconds: float
    model: TrainedModel | None = None
    held_out: tuple[np.ndarray | None, ...] | None = None

    @property
    def done(self) -> bool:
        return self.phase == "done"


def segment_collection(
    shapes: Sequence[ShapeData],
    label_names: Sequence[str],
    params: SegmentParams = SegmentParams(),
    *,
    warm: TrainedModel | None = None,
) -> Iterator[Snapshot]:
    """Minimize the energy over a collection, alternating network training and graph cuts.

    Parameters
    ----------
    shapes : sequence of ShapeData
        The collection. The scribbled shapes are optimized; they alone train the networks.
        With ``method="face"`` the shapes without scribbles are segmented by each round's
        model at its cut (as :func:`~scribbleseg_core.engine.predict.predict_shape` would),
        from the first cut that has a network: trained on their own predicted labels, the
        networks would learn their mistakes again. With ``"paper"`` they get -1 labels;
        segment them with :func:`~scribbleseg_core.engine.predict.predict_shape`.
    label_names : sequence of str
        k names; scribble ids index them.
    params : SegmentParams
    warm : TrainedModel, optional
        A model from an earlier run on this collection: when it has the same labels, inputs
        and stages, its networks (the learner and the cross-fitting fold networks) continue training
        (``NetworkParams.warm_epochs``) instead of starting over, so a run after a few
        corrections is faster. Otherwise ignored.

    Yields
    ------
    Snapshot
        After every step; the last has phase ``"done"`` and carries the model.

    Raises
    ------
    ValueError
        No shape has scribbles.
    """
    if not any(s.is_scribbled for s in shapes):
        raise ValueError("no shape has scribbles: paint at least one stroke")
    if params.method == "paper":
        yield from _alternate(_PatchProblem(shapes, label_names, params), params, warm)
    else:
        yield from _alternate(_FaceProblem(shapes, label_names, params), params, warm)


def _alternate(problem, params: SegmentParams, warm: TrainedModel | None = None) -> Iterator[Snapshot]:
    """The alternation shared by both variants; `problem` says what a cut and an energy are."""
    t0 = t = time.perf_counter()
    n = len(problem.shapes)
    labels = problem.initial_labels()
    energy = problem.energy(labels, None)
    yield Snapshot(0, "init", energy, _frozen(labels, problem.shapes), tuple(lab is not None for lab in labels),
                   time.perf_counter() - t)
    t = time.perf_counter()  # the network's inputs count into the first training
    inputs = [params.network_input(s) if problem.segments(i) else None for i, s in enumerate(problem.shapes)]
    taught = [s.is_scribbled for s in problem.shapes]  # the shapes whose labels train the networks
    d = next(x.shape[1] for x in inputs if x is not None)
    share = params.cross_fit if params.method == "face" else 0.0
    shapes = problem.shapes
    context_of = (lambda i: shapes[i].label_context) if params.uses_label_context else None
    edges_of = _edges_of(shapes, inputs) if params.method == "face" and params.propagation.boundary > 0 else None
    net = _Networks(d, len(problem.label_names), params.network, share, taught, context_of, edges_of)
    if warm is not None and _continues(warm, net.main, problem.label_names, params):
        net.continue_from(warm, params.network.threads)
    model, logp, prior, best, it = None, None, None, np.inf, 0
    trained_on = None  # the labels the kept networks were trained on
    some_faces = False  # whether they learned only some faces of them
    learned = None  # networks that learned the result's labels on every face where the kept ones did not
    for it in range(1, params.rounds + 1):
        t = t if it == 1 else time.perf_counter()
        previous = net if it > 1 else None  # round 1 starts from no network, or a warm one that did not make these labels
        net = copy.deepcopy(net)  # the snapshots keep the networks they were made with
        # the networks learn from the shapes `taught` only; in round 1 mostly from the faces the strokes decide
        learn = problem.decided(labels) if it == 1 else labels
        net.fit(inputs, labels, learn)
        new_logp, new_prior = net.log_proba(inputs)
        new_model = net.model(problem)
        problem.use(new_model)
        e_train = problem.energy(labels, new_logp, new_prior)
        if previous is not None and e_train.total > energy.total:
            # training did not lower E: the labels stay those the previous learner made; the
            # undone networks become the model if the kept ones learned only some faces
            learned = net if some_faces else None
            net = previous
            problem.use(model)
            break
        logp, prior, energy, model, trained_on = new_logp, new_prior, e_train, new_model, labels
        some_faces = learn is not labels  # round 1: mostly the faces the strokes decide
        yield Snapshot(it, "train", energy, _frozen(labels, problem.shapes), (False,) * n, time.perf_counter() - t,
                       model)
        t = time.perf_counter()
        new = problem.cut(labels, logp, prior)
        changed = _changes(labels, new)
        labels, energy = new, problem.energy(new, logp, prior)
        yield Snapshot(it, "graphcut", energy, _frozen(labels, problem.shapes), changed, time.perf_counter() - t, model)
        converged = (not any(c and painted for c, painted in zip(changed, taught))
                     or energy.total > best * (1 - TOLERANCE))
        best = min(best, energy.total)
        if converged:
            if some_faces and it < params.rounds:
                learned = copy.deepcopy(net)
                learned.fit(inputs, labels)
            break
    changed = (False,) * n
    if learned is not None:  # the model learns every face: the painted shapes' final labels
        net, trained_on = learned, labels
        model = net.model(problem)
        problem.use(model)
        new = problem.cut(labels, *net.log_proba(inputs), painted=False)
        changed = _changes(labels, new)
        labels = [b if b is not None else a for a, b in zip(labels, new)]
    if not net.cuts_need_boundary and trained_on is not None:
        net.fit_boundary(trained_on)  # every shape is painted: only new shapes will use it
        model = net.model(problem)
    yield Snapshot(it, "done", energy, _frozen(labels, problem.shapes), changed, time.perf_counter() - t0,
                   model or net.model(problem), tuple(net.held_out_log_proba(inputs)))


def fit_model(shapes: Sequence[ShapeData], labels: Sequence[np.ndarray], label_names: Sequence[str],
              params: SegmentParams = SegmentParams()) -> TrainedModel:
    """The model of `params` trained once on given labels, without the alternation or cuts.

    What the alternation's training step does with fixed labels: stage 1 on every shape,
    (with label context) stage 2 on stage-1 probabilities from the networks trained on the
    other folds of the shapes, and (``propagation.boundary > 0``) the learned boundary term on
    the labels' boundaries. It compares learners apart from the alternation
    (``scripts/learner_alone.py``).

    Parameters
    ----------
    shapes : sequence of ShapeData
    labels : sequence of (m_s,) int ndarray
        Label per face of each shape (-1: not trained on), ids below ``len(label_names)``.
    label_names : sequence of str
    params : SegmentParams
        Its network, inputs, stages and boundary term (``method="face"``).
    """
    if len(shapes) != len(labels):
        raise ValueError(f"{len(shapes)} shapes but {len(labels)} label arrays")
    inputs = [params.network_input(s) for s in shapes]
    context_of = (lambda i: shapes[i].label_context) if params.uses_label_context else None
    edges_of = _edges_of(shapes, inputs) if params.propagation.boundary > 0 else None
    net = _Networks(inputs[0].shape[1], len(label_names), params.network, 0.0, [True] * len(shapes), context_of,
                    edges_of)
    labels = [np.asarray(lab, dtype=np.int64) for lab in labels]
    net.fit(inputs, labels)
    net.fit_boundary(labels)  # every shape is labeled: fit does not train it
    return TrainedModel(net.main, tuple(label_names), params, fold_nets=tuple(net.fold_nets), boundary=net.boundary)


def _edges_of(shapes: Sequence[ShapeData], inputs):
    """``edges_of(i, labels)`` for :class:`_Networks`: shape i's
    :func:`~scribbleseg_core.engine.boundary.edge_features` (from its network input
    ``inputs[i]``) and the :func:`~scribbleseg_core.engine.boundary.label_boundaries` of `labels`."""

    def edges_of(i: int, lab: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        g = shapes[i].graph
        return edge_features(g, shapes[i].X, inputs[i]), label_boundaries(g, lab)

    return edges_of


def _continues(warm: TrainedModel, fresh: Learner, label_names, params: SegmentParams) -> bool:
    """Whether `warm`'s learner can go on training in place of `fresh` (same labels, method,
    input width and stages)."""
    a, b = warm.learner, fresh
    return (tuple(warm.label_names) == tuple(label_names) and warm.params.method == params.method
            and a.stage1.num_inputs == b.stage1.num_inputs and (a.stage2 is None) == (b.stage2 is None)
            and (a.stage2 is None or a.stage2.num_inputs == b.stage2.num_inputs))


#: Scribbled shapes' worth of training that the held-out networks of one round may take
#: together (:func:`fold_count`): that of two halves of a 20-shape collection.
FOLD_BUDGET = 20


def fold_count(n: int) -> int:
    """Folds of `n` scribbled shapes for the held-out networks: from 4 shapes on, as many as
    keep their training within that of two halves of 20 shapes, ``(K − 1) n ≤``
    :data:`FOLD_BUDGET`, at least 2: leave one out for 4 and 5 shapes (each network then
    learns from all shapes but one, not from half of a few), 4 folds for 6, 3 from 7 to 10,
    two halves from 11 on. Two halves for 2 and 3 shapes, where leaving one out measured no
    better (``docs/benchmarks.md``); 0 for fewer than 2."""
    if n < 2:
        return 0
    return 2 if n <= 3 else max(2, min(n, 1 + FOLD_BUDGET // n))


class _Networks:
    """The learner the alternation trains, and the network term of the energy it gives.

    The learner (the model) is trained on every labeled scribbled shape. The scribbled shapes
    are dealt into :func:`fold_count` folds in the order given, and one more first-stage
    network a fold is trained on the shapes of the other folds, so that every scribbled shape
    has probabilities from a network that never saw its labels. They serve

    * cross-fitting (``share > 0``): a scribbled shape's probabilities are
      ``(1 − share) P_learner + share P_its fold's network``, so its term is not only the echo of its
      propagated labels (shapes without scribbles use the learner alone, as a new shape would:
      no network saw their labels);
    * the label-context stage (`context_of` given): it is trained on the label distances of
      these held-out probabilities, as it will meet on new shapes.

    Parameters
    ----------
    d, k : int
        Descriptor length, labels.
    params : NetworkParams
    share : float
    mixed : sequence of bool
        Per shape: is it scribbled (trained on, cross-fitted)? Labels given for the others are
        not trained on.
    context_of : callable(int) -> LabelContext, optional
        A shape's label context; None: no label-context stage.
    edges_of : callable(int, labels) -> ((q, e) ndarray, (q,) bool ndarray), optional
        A shape's :func:`~scribbleseg_core.engine.boundary.edge_features` and the
        :func:`~scribbleseg_core.engine.boundary.label_boundaries` of its labels: a boundary
        classifier is trained on the scribbled shapes' labels with the networks. None: none.
    """

    def __init__(self, d: int, k: int, params: NetworkParams, share: float, mixed: Sequence[bool], context_of=None,
                 edges_of=None):
        self.mixed = [bool(b) for b in mixed]
        n = sum(self.mixed)
        self.params = params
        self.context_of, self.edges_of = context_of, edges_of
        self.boundary: BoundaryClassifier | None = None
        stage2 = FaceClassifier(d + 2 * k, k, params) if context_of is not None else None
        self.main = Learner(FaceClassifier(d, k, params), stage2)
        self.share = share if n >= 2 else 0.0
        held_out = n >= 2 and (self.share > 0 or context_of is not None)
        folds = fold_count(n) if held_out else 0
        self.fold_of = (np.cumsum(self.mixed) - 1) % max(folds, 1)  # dealt in turn; unused for the others
        self.fold_nets = [FaceClassifier(d, k, params) for _ in range(folds)]
        self._held: dict[int, tuple[int, np.ndarray]] = {}  # shape -> (id of its input, held-out log P)

    @property
    def trained(self) -> bool:
        return self.main.stage1.trained

    def model(self, problem) -> TrainedModel:
        """The model of these networks: the learner and the boundary classifier, with the fold
        networks for a later run to continue."""
        return replace(problem.model(self.main), fold_nets=tuple(self.fold_nets), boundary=self.boundary)

    def continue_from(self, warm: TrainedModel, threads: int | None) -> None:
        """Start from `warm`'s networks (copies on `threads` torch threads): trainings continue
        with ``warm_epochs``."""
        self.main = copy.deepcopy(warm.learner.with_threads(threads))
        if len(warm.fold_nets) == len(self.fold_nets):
            self.fold_nets = [copy.deepcopy(h.with_threads(threads)) for h in warm.fold_nets]

    @property
    def cuts_need_boundary(self) -> bool:
        """Whether the collection has a shape without scribbles, which every round's cut labels
        with the boundary classifier; otherwise only the final model needs it (:meth:`fit_boundary`
        once)."""
        return self.edges_of is not None and not all(self.mixed)

    @property
    def _two_lanes(self) -> bool:
        """Whether two or more torch threads are there to use: networks then train, and shapes'
        probabilities come, two at a time on one thread each."""
        return (self.params.threads or torch_threads()) >= 2

    def fit_boundary(self, labels) -> None:
        """Train the boundary classifier afresh on the scribbled shapes' `labels`."""
        if self.edges_of is None:
            return
        taught = (self.edges_of(i, lab) for i, lab in enumerate(labels) if lab is not None and self.mixed[i])
        self.boundary = BoundaryClassifier.fit(taught, seed=self.params.seed, threads=self.params.threads)

    def fit(self, inputs, labels, learn=None) -> None:
        """Train on every scribbled shape with labels and inputs, warm when trained before; the
        boundary classifier on the same labels, afresh, when the cuts need it. `learn`: the
        labels the networks learn (-1 on faces they skip), default `labels`.

        With two or more torch threads to use and fold networks to train, the networks train
        in two lanes at once, one torch thread each: the even folds' networks, stage 2's
        inputs on the shapes they hold out, then stage 1; the odd folds' networks, stage 2's
        inputs on theirs, then stage 2 (which needs both). Small networks use a second core
        better this way than through torch's threads within each operation; the networks are
        the same."""
        usable = [i for i, (x, lab) in enumerate(zip(inputs, labels))
                  if x is not None and lab is not None and self.mixed[i]]
        if self.cuts_need_boundary:
            self.fit_boundary(labels)
        labels = labels if learn is None else learn

        def data(which):
            return [inputs[i] for i in which], [labels[i] for i in which]

        folds = [[i for i in usable if self.fold_of[i] != f] for f in range(len(self.fold_nets))]
        self._held = {}
        if self._two_lanes and folds and all(folds):

            def lane(nets) -> dict[int, np.ndarray]:
                for f in nets:
                    self._fit_fold(f, *data(folds[f]), 1)
                return self._context_inputs(inputs, [i for i in usable if self.fold_of[i] in nets], 1)

            with ThreadPoolExecutor(1) as other:  # runs its jobs in order: even folds, their inputs, stage 1
                even = other.submit(lane, range(0, len(folds), 2))
                first = other.submit(self._fit_first, *data(usable), 1)
                X2 = lane(range(1, len(folds), 2))
                X2 |= even.result()
                self._fit_second(X2, labels, usable, 1)
                first.result()
            return
        self._fit_first(*data(usable))
        for f, others in enumerate(folds):
            if others:
                self._fit_fold(f, *data(others))
        self._fit_second(self._context_inputs(inputs, usable), labels, usable)

    def _fit_first(self, X, y, threads: int | None = None) -> None:
        self.main.stage1.fit(X, y, warm=self.main.stage1.trained, threads=threads)

    def _fit_fold(self, f: int, X, y, threads: int | None = None) -> None:
        self.fold_nets[f].fit(X, y, warm=self.fold_nets[f].trained, threads=threads)

    def _context_inputs(self, inputs, which, threads: int | None = None) -> dict[int, np.ndarray]:
        """Stage 2's inputs of shapes `which`: their descriptors and the label distances of
        their held-out probabilities (else stage 1's); {} without a stage 2."""
        if self.main.stage2 is None:
            return {}
        return {i: context_input(inputs[i], self.context_of(i),
                                 self._held_out_log_proba(i, inputs[i], self.main.stage1, threads)) for i in which}

    def _fit_second(self, context_inputs: dict[int, np.ndarray], labels, usable, threads: int | None = None) -> None:
        """Stage 2 on the shapes `usable`, from their :meth:`_context_inputs`."""
        second = self.main.stage2
        if second is None:
            return
        second.fit([context_inputs[i] for i in usable], [labels[i] for i in usable], warm=second.trained,
                   threads=threads)

    def _held_out(self, i: int) -> FaceClassifier | None:
        """The trained first-stage network that did not see shape i's labels, if any (none for
        a shape without scribbles: no network saw its labels)."""
        if not self.fold_nets or not self.mixed[i]:
            return None
        net = self.fold_nets[self.fold_of[i]]
        return net if net.trained else None

    def _held_out_log_proba(self, i: int, x: np.ndarray, fallback: FaceClassifier | None = None,
                            threads: int | None = None) -> np.ndarray | None:
        """Log-probabilities of shape i (input `x`) from its held-out network (else from
        `fallback`, else None), on `threads` torch threads (default the network's); kept
        until the next fit, since training and the energy ask twice."""
        if i in self._held and self._held[i][0] == id(x):
            return self._held[i][1]
        net = self._held_out(i) or fallback
        if net is None:
            return None
        out = (net if threads is None else net.with_threads(threads)).log_proba(x)
        if net is not fallback:
            self._held[i] = (id(x), out)
        return out

    def held_out_log_proba(self, inputs) -> list[np.ndarray | None]:
        """Per shape, the log-probabilities of the trained first-stage network that did not see
        its labels (those the last fit computed, else now); None where there is none."""
        return [None if x is None else self._held_out_log_proba(i, x) for i, x in enumerate(inputs)]

    def log_proba(self, inputs) -> tuple[list[np.ndarray | None], list[np.ndarray | None]]:
        """Per shape, the network term's log-probabilities (m_s, k) (None where no input): the
        learner's, mixed with the held-out network's on scribbled shapes (cross-fitting); and
        the learner's alone, the prior of the random walk
        (:class:`~scribbleseg_core.engine.propagate.RandomWalk`). With two or more torch
        threads, two shapes at a time on one thread each."""
        two = self._two_lanes and sum(x is not None for x in inputs) >= 2
        main = self.main.with_threads(1) if two else self.main
        threads = 1 if two else None

        def one(i: int, x: np.ndarray | None) -> tuple[np.ndarray | None, np.ndarray | None]:
            if x is None:
                return None, None
            own = main.log_proba(x, self.context_of(i) if main.stage2 is not None else None)
            held = self._held_out_log_proba(i, x, threads=threads) if self.share > 0 and self.mixed[i] else None
            if held is None:
                return own, own
            return np.logaddexp(np.log1p(-self.share) + own, np.log(self.share) + held), own

        if not two:
            terms = [one(i, x) for i, x in enumerate(inputs)]
        else:
            with ThreadPoolExecutor(2) as pool:
                terms = list(pool.map(one, range(len(inputs)), inputs))
        return [t[0] for t in terms], [t[1] for t in terms]


class _FaceProblem:
    """The face-level energy of every scribbled shape of the collection (``method="face"``); the
    shapes without scribbles are cut as new shapes are, with the round's model."""

    def __init__(self, shapes, label_names, params: SegmentParams):
        self.shapes, self.label_names = list(shapes), tuple(label_names)
        self.params = params
        k = len(label_names)
        self.energies = [FaceEnergy(s.graph, s.scribble, k, params.propagation, s.sdf) for s in shapes]
        self._boundary: BoundaryClassifier | None = None

    def segments(self, i: int) -> bool:
        """Whether the cuts label shape i (here every shape)."""
        return True

    def initial_labels(self) -> list[np.ndarray | None]:
        return [e.cut() if e.is_scribbled else None for e in self.energies]

    def decided(self, labels) -> list[np.ndarray | None]:
        """`labels` with -1 on the faces of scribbled shapes that the strokes do not decide,
        but for a share :data:`UNDECIDED_SHARE` of them (:attr:`SegmentParams.decided`)."""
        threshold = self.params.decided
        if threshold <= 0:
            return labels
        rng = np.random.default_rng(0)  # the same draw for every network seed
        return [lab if lab is None or not e.is_scribbled else
                np.where((e.walk_reached() >= threshold) | (rng.random(len(lab)) < UNDECIDED_SHARE), lab, -1)
                for lab, e in zip(labels, self.energies)]

    def use(self, model: TrainedModel) -> None:
        """Give the shapes without scribbles the smoothness of `model`'s boundary term (the
        crease rule without one)."""
        if model.boundary is self._boundary:
            return
        self._boundary = model.boundary
        k, p = len(self.label_names), self.params.propagation
        for i, s in enumerate(self.shapes):
            if not s.is_scribbled:
                self.energies[i] = FaceEnergy(s.graph, s.scribble, k, p, s.sdf, model.boundary_proba(s))

    def cut(self, labels, logp, prior, painted: bool = True) -> list[np.ndarray | None]:
        """The scribbled shapes' cuts from their labels (None for them with ``painted=False``);
        the others' from scratch, as :func:`~scribbleseg_core.engine.predict.predict_shape`
        cuts a new shape. `logp` and `prior`: :meth:`_Networks.log_proba`."""
        return [None if e.is_scribbled and not painted else e.cut(lp, init=lab if e.is_scribbled else None, prior=pr)
                for e, lab, lp, pr in zip(self.energies, labels, logp, prior)]

    def energy(self, labels, logp, prior=None) -> EnergyTerms:
        """Summed over the scribbled shapes that have labels."""
        total = EnergyTerms(0.0, 0.0 if logp is not None else float("nan"), 0.0)
        for i, (e, lab) in enumerate(zip(self.energies, labels)):
            if lab is not None and e.is_scribbled:
                terms = e.terms(lab, None if logp is None else logp[i], None if prior is None else prior[i])
                total = total + EnergyTerms(*terms)
        return total

    def model(self, learner: Learner) -> TrainedModel:
        return TrainedModel(learner, self.label_names, self.params)


class _PatchProblem:
    """The paper's patch-level energy (eq. 1–4) of the scribbled shapes (``method="paper"``)."""

    def __init__(self, shapes, label_names, params: SegmentParams):
        self.shapes, self.label_names = list(shapes), tuple(label_names)
        self.params = params
        k = len(label_names)
        scribbled = [s for s in shapes if s.is_scribbled]
        self.encoder = fit_patch_encoder([s.X for s in scribbled], seed=params.network.seed)
        desc = {id(s): self.encoder.encode(s.X, s.area, s.patch) for s in scribbled}
        self.delta = feature_delta(list(desc.values()), [s.patch_pairs for s in scribbled])
        self.W = [feature_weights(desc[id(s)], s.patch_pairs, self.delta, params.lam) if s.is_scribbled else None
                  for s in shapes]
        self.U_scr = [scribble_unary(s.patch, s.scribble, s.scribbled_labels, k) if s.is_scribbled else None
                      for s in shapes]
        self.P = [s.patch_matrix() if s.is_scribbled else None for s in shapes]
        self.y: list[np.ndarray | None] = [None] * len(shapes)

    def segments(self, i: int) -> bool:
        """Whether the cuts label shape i (here the scribbled shapes)."""
        return self.shapes[i].is_scribbled

    def use(self, model: TrainedModel) -> None:
        """Nothing: the patch energy has no learned term besides the network."""

    def initial_labels(self) -> list[np.ndarray | None]:
        self.y = [None if U is None else alpha_expansion(U, s.patch_pairs, w)
                  for U, s, w in zip(self.U_scr, self.shapes, self.W)]
        return self._faces()

    def decided(self, labels) -> list[np.ndarray | None]:
        """`labels` as they are: the paper trains on every face of the initial cut."""
        return labels

    def cut(self, labels, logp, prior=None, painted: bool = True) -> list[np.ndarray | None]:
        if not painted:  # the scribbled shapes are the only ones this variant segments
            return [None] * len(self.shapes)
        self.y = [None if U is None else alpha_expansion(U + network_unary(P, lp), s.patch_pairs, w, init=y)
                  for U, P, lp, s, w, y in zip(self.U_scr, self.P, logp, self.shapes, self.W, self.y)]
        return self._faces()

    def energy(self, labels, logp, prior=None) -> EnergyTerms:
        total = EnergyTerms(0.0, 0.0 if logp is not None else float("nan"), 0.0)
        for i, (U, s, w, y) in enumerate(zip(self.U_scr, self.shapes, self.W, self.y)):
            if U is not None:
                U_neu = None if logp is None else network_unary(self.P[i], logp[i])
                total = total + energy_terms(y, U, U_neu, s.patch_pairs, w)
        return total

    def _faces(self) -> list[np.ndarray | None]:
        return [None if y is None else y[s.patch] for y, s in zip(self.y, self.shapes)]

    def model(self, learner: Learner) -> TrainedModel:
        return TrainedModel(learner, self.label_names, self.params, self.encoder, self.delta)


def _changes(labels, new) -> tuple[bool, ...]:
    """Per shape: does its `new` labels array (None: not cut) differ from its `labels`?"""
    return tuple(b is not None and (a is None or not np.array_equal(a, b)) for a, b in zip(labels, new))


def _frozen(labels, shapes) -> tuple[np.ndarray, ...]:
    """Read-only int64 copies; -1 on every face of a shape not labeled yet (None)."""
    out = []
    for lab, s in zip(labels, shapes):
        a = np.full(s.graph.num_faces, -1, np.int64) if lab is None else np.array(lab, dtype=np.int64, copy=True)
        a.flags.writeable = False
        out.append(a)
    return tuple(out)
