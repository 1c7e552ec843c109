"""The face classifier: a 4-layer fully connected network (d → h1 → h2 → c), softmax output."""

from __future__ import annotations

import copy
import os
import threading
from dataclasses import dataclass, replace
from functools import cache

import numpy as np

from scribbleseg_core.infra.cpu import usable_cores

#: Held while seeding torch's global generator and drawing a network's initial weights, so
#: that networks built in concurrent threads get the same weights as built one after another.
_INIT_LOCK = threading.Lock()

#: Faces per optimizer step (fewer when an epoch holds under 8 such batches, so small
#: collections still take 8 steps an epoch); AdamW's peak learning rate (one-cycle
#: schedule) and weight decay.
BATCH_SIZE, LEARNING_RATE, WEIGHT_DECAY = 1024, 3e-3, 1e-4


@dataclass(frozen=True)
class NetworkParams:
    """Architecture and training schedule.

    The loss is the cross-entropy weighted by inverse label frequency; AdamW with a one-cycle
    schedule (:data:`BATCH_SIZE`, :data:`LEARNING_RATE`, :data:`WEIGHT_DECAY`). Training
    that continues from the previous weights (a later round of the alternation) runs a third
    of the epochs.

    Attributes
    ----------
    hidden : (int, int)
        Widths of the two hidden layers (the paper's d → h1 → h2 → k). Default (128, 64).
    dropout : float
        Dropout after each hidden layer, in training only; it is what makes the network
        carry over from the training shapes' labels to unseen shapes. Default 0.3.
    input_dropout : float
        Share of the standardized inputs zeroed afresh for each face of each epoch (the rest
        scaled up to keep their mean), in training only (:func:`drop_inputs`): the network
        cannot rest on any one input to tell the few training shapes' parts apart, so it
        leans on several. Default 0.2.
    epochs : int
        Epochs when training from scratch. Default 30.
    faces_per_epoch : int
        Labeled faces drawn afresh from each shape for every epoch (all of them where a shape
        has fewer). Default 1500.
    seed : int
        Initialization and face sampling. Default 0.
    threads : int, optional
        torch threads while training and predicting. Default None: the cores this process
        may use (:func:`torch_threads`). Processes that share the cores should divide them
        (threads × processes ≤ cores): spinning torch threads starve each other.
    """

    hidden: tuple[int, int] = (128, 64)
    dropout: float = 0.3
    input_dropout: float = 0.2
    epochs: int = 30
    faces_per_epoch: int = 1500
    seed: int = 0
    threads: int | None = None

    def __post_init__(self):
        if len(self.hidden) != 2 or min(self.hidden) < 1:
            raise ValueError(f"hidden must be two positive widths; got {self.hidden}")
        if not 0 <= self.dropout < 1 or not 0 <= self.input_dropout < 1:
            raise ValueError(f"dropout and input_dropout must lie in [0, 1); got {self.dropout}, {self.input_dropout}")
        if self.epochs < 1 or self.faces_per_epoch < 1:
            raise ValueError(f"epochs and faces_per_epoch must be positive; got {self.epochs}, {self.faces_per_epoch}")
        if self.threads is not None and self.threads < 1:
            raise ValueError(f"threads must be positive or None; got {self.threads}")

    @property
    def warm_epochs(self) -> int:
        """Epochs when continuing from the previous weights: a third of :attr:`epochs`."""
        return max(1, -(-self.epochs // 3))


class _EpochSampler:
    """The labeled faces of several shapes, with a fresh draw from each shape for every epoch.

    Parameters
    ----------
    X : list of (m_s, d) ndarray
    y : list of (m_s,) int ndarray
        -1 for faces not to train on.
    per_shape : int
        Faces drawn from each shape per epoch (without replacement; all where fewer).
    seed : int
    """

    def __init__(self, X, y, per_shape: int, seed: int):
        keep = [np.flatnonzero(np.asarray(yi) >= 0) for yi in y]
        used = [i for i, k in enumerate(keep) if len(k)]
        self.X = [X[i] for i in used]
        self.keep = [keep[i] for i in used]
        self.y = [np.asarray(y[i])[keep[i]].astype(np.int64) for i in used]
        self.per_shape = per_shape
        self.rng = np.random.default_rng(seed)

    def __len__(self) -> int:
        """Faces per epoch."""
        return sum(min(len(k), self.per_shape) for k in self.keep)

    def label_counts(self, k: int) -> np.ndarray:
        """(k,) labeled faces per label over all shapes."""
        return sum(np.bincount(yi, minlength=k) for yi in self.y).astype(float)

    def draw(self) -> tuple[np.ndarray, np.ndarray]:
        """This epoch's faces in random order: inputs (N, d) and labels (N,)."""
        rows = [self.rng.choice(len(k), self.per_shape, replace=False) if len(k) > self.per_shape else
                np.arange(len(k)) for k in self.keep]
        Xe = np.concatenate([Xi[k[r]] for Xi, k, r in zip(self.X, self.keep, rows)])
        ye = np.concatenate([yi[r] for yi, r in zip(self.y, rows)])
        order = self.rng.permutation(len(ye))
        return Xe[order], ye[order]


def torch_threads() -> int:
    """Threads for torch: the cores this process may use (:func:`usable_cores`), at most
    ``OMP_NUM_THREADS`` where that is set (as Dask's nanny sets it to 1 for each worker)."""
    cores = usable_cores()
    try:
        return max(1, min(cores, int(os.environ["OMP_NUM_THREADS"])))
    except (KeyError, ValueError):
        return cores


def build_mlp(d: int, c: int, hidden: tuple[int, int], dropout: float = 0.0, seed: int = 0):
    """``Linear(d,h1) ReLU Linear(h1,h2) ReLU Linear(h2,c)``: logits; softmax applied by callers.

    With ``dropout > 0`` a dropout layer follows each ReLU (active in training only; masks
    from a NumPy generator seeded with `seed`, several times cheaper than torch's on the
    CPU); the fully connected structure is unchanged.
    """
    import torch.nn as nn

    h1, h2 = hidden
    rng = np.random.default_rng(seed)
    drop = (lambda: [_dropout_layer()(dropout, rng)]) if dropout > 0 else (lambda: [])
    return nn.Sequential(nn.Linear(d, h1), nn.ReLU(), *drop(), nn.Linear(h1, h2), nn.ReLU(), *drop(),
                         nn.Linear(h2, c))


def drop_inputs(Z: np.ndarray, p: float, rng: np.random.Generator) -> np.ndarray:
    """Zero each value of `Z` with probability p' (`p` rounded to a multiple of 1/256) and
    scale the others by 1 / (1 - p'), so that every input keeps its mean; in place.

    Parameters
    ----------
    Z : (m, d) float32 ndarray
        Standardized inputs of one epoch.
    p : float
        In [0, 1); 0 leaves `Z` as it is and draws nothing from `rng`.
    rng : numpy Generator
        Source of the masks (one byte per value).

    Returns
    -------
    (m, d) float32 ndarray
        `Z` itself.
    """
    threshold = int(round(p * 256))
    if threshold:
        Z *= _keep_mask(rng, Z.shape, threshold)
    return Z


def _keep_mask(rng: np.random.Generator, shape: tuple[int, ...], threshold: int) -> np.ndarray:
    """Dropout's multiplier, float32 of `shape`: 0 with probability `threshold` / 256 (one
    byte of `rng` per value), else 256 / (256 − `threshold`), which keeps the mean."""
    keep = np.frombuffer(rng.bytes(int(np.prod(shape))), dtype=np.uint8).reshape(shape) >= threshold
    return keep * np.float32(256.0 / (256 - threshold))


@cache
def _dropout_layer():
    """The dropout module class (made on first use: torch is imported lazily)."""
    import torch
    import torch.nn as nn

    class MaskDropout(nn.Module):
        """Zero each value with probability ≈ `p` (a multiple of 1/256) and scale the rest."""

        def __init__(self, p: float, rng: np.random.Generator):
            super().__init__()
            self.p, self.rng = p, rng
            self.threshold = int(round(p * 256))

        def forward(self, x):
            if not self.training or self.threshold == 0:
                return x
            return x * torch.from_numpy(_keep_mask(self.rng, tuple(x.shape), self.threshold))

        def __deepcopy__(self, memo):  # a copy draws from its own generator, in the same state
            clone = type(self)(self.p, copy.deepcopy(self.rng, memo))
            clone.training = self.training
            return clone

        def __reduce__(self):  # pickled through a module-level function: the class is made at run time
            return _mask_dropout, (self.p, self.rng, self.training)

    return MaskDropout


def _mask_dropout(p: float, rng: np.random.Generator, training: bool):
    """A dropout module as pickled (see ``MaskDropout.__reduce__``)."""
    module = _dropout_layer()(p, rng)
    module.train(training)
    return module


def warm_up() -> None:
    """Pay torch's first-use costs now: import it and train a tiny network for one epoch on
    one thread (torch's first optimizer step imports its compiler: about 2 s in all with its
    files in the page cache, 6 s without). For a process that will train later."""
    rng = np.random.default_rng(0)
    net = FaceClassifier(4, 2, NetworkParams(epochs=1, faces_per_epoch=64, dropout=0.0, threads=1))
    net.fit([rng.normal(size=(64, 4))], [np.arange(64) % 2])
    net.log_proba(rng.normal(size=(8, 4)))


class FaceClassifier:
    """Network plus the feature standardization it was trained with.

    Parameters
    ----------
    num_inputs : int
        d, the face descriptor length.
    num_labels : int
        c.
    params : NetworkParams
    """

    def __init__(self, num_inputs: int, num_labels: int, params: NetworkParams = NetworkParams()):
        self.params = params
        self.num_inputs = int(num_inputs)
        self.num_labels = int(num_labels)
        self.net = self._new_net()
        self.mean = np.zeros(num_inputs)
        self.std = np.ones(num_inputs)
        self.trained = False

    def _new_net(self):
        import torch

        with _INIT_LOCK:
            torch.manual_seed(self.params.seed)
            return build_mlp(self.num_inputs, self.num_labels, self.params.hidden, self.params.dropout, self.params.seed)

    def fit(self, X: list[np.ndarray], y: list[np.ndarray], *, warm: bool = False, threads: int | None = None) -> float:
        """Train on the faces of several shapes.

        Parameters
        ----------
        X : list of (m_s, d) float64 ndarray
        y : list of (m_s,) int ndarray
            Labels; faces with -1 are skipped.
        warm : bool
            Continue from the current weights with ``warm_epochs``; else start over.
        threads : int, optional
            torch threads for this fit; default ``params.threads`` (:class:`NetworkParams`).
            Fits that run at once in several Python threads pass 1 each (torch's thread
            count is the process's). Training draws nothing from torch's generator, so a
            fit's result does not depend on what runs beside it.

        Returns
        -------
        float
            Mean training cross-entropy of the last epoch.
        """
        import torch

        p = self.params
        torch.set_num_threads(threads or p.threads or torch_threads())
        warm = warm and self.trained
        data = _EpochSampler(X, y, p.faces_per_epoch, p.seed)
        if not warm:
            first, _ = data.draw()
            self.mean, self.std = first.mean(0), first.std(0) + 1e-8
            self.net = self._new_net()
        counts = data.label_counts(self.num_labels)
        w = np.where(counts > 0, counts.sum() / np.maximum(counts, 1) / max((counts > 0).sum(), 1), 0.0)
        weight = torch.from_numpy(w.astype(np.float32))
        opt = torch.optim.AdamW(self.net.parameters(), lr=LEARNING_RATE, weight_decay=WEIGHT_DECAY, fused=True)
        loss_fn = torch.nn.CrossEntropyLoss(weight=weight)
        epochs = p.warm_epochs if warm else p.epochs
        batch = max(1, min(BATCH_SIZE, -(-len(data) // 8)))
        sched = torch.optim.lr_scheduler.OneCycleLR(
            opt, max_lr=LEARNING_RATE, total_steps=epochs * -(-len(data) // batch)
        )
        self.net.train()
        masks = np.random.default_rng(p.seed + 1)
        last = 0.0
        for _ in range(epochs):
            Xe, ye = data.draw()
            Z = drop_inputs(((Xe - self.mean) / self.std).astype(np.float32), p.input_dropout, masks)
            Xt = torch.from_numpy(Z)
            yt = torch.from_numpy(ye)
            total = torch.zeros(())
            for s in range(0, len(yt), batch):
                xb, yb = Xt[s : s + batch], yt[s : s + batch]
                opt.zero_grad()
                loss = loss_fn(self.net(xb), yb)
                loss.backward()
                opt.step()
                sched.step()
                total += loss.detach() * len(yb)
            last = float(total) / max(len(yt), 1)
        self.net.eval()
        self.trained = True
        return last

    def with_threads(self, threads: int | None) -> FaceClassifier:
        """This classifier on `threads` torch threads (None: the cores this process may use);
        it shares the weights, and this one is left as it is."""
        out = copy.copy(self)
        out.params = replace(self.params, threads=threads)
        return out

    def log_proba(self, X: np.ndarray) -> np.ndarray:
        """Log class probabilities per face, (m, c) float64 (log-softmax of the logits)."""
        import torch

        torch.set_num_threads(self.params.threads or torch_threads())
        self.net.eval()  # dropout off, whether trained here or loaded from a file
        with torch.no_grad():
            Z = torch.from_numpy(((np.asarray(X, dtype=np.float64) - self.mean) / self.std).astype(np.float32))
            return torch.log_softmax(self.net(Z), dim=1).numpy().astype(np.float64)
