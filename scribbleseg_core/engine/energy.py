"""The paper's energy (eq. 1–4) on the patch graph of one shape."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scribbleseg_core.engine.graphcut import INF


@dataclass(frozen=True)
class EnergyTerms:
    """The terms of the energy (``network`` is NaN before a network exists).

    Attributes
    ----------
    scribble : float
        E_scr: the scribbles (with the face method, their distance and random-walk terms).
    network : float
        E_neu: the network's −log-probabilities (weighted).
    smoothness : float
        The pairwise term: the face method's crease-aware Potts term, or the paper's λ·E_fea.
    """

    scribble: float
    network: float
    smoothness: float

    @property
    def total(self) -> float:
        return self.scribble + (0.0 if np.isnan(self.network) else self.network) + self.smoothness

    def __add__(self, other: EnergyTerms) -> EnergyTerms:
        return EnergyTerms(self.scribble + other.scribble, self.network + other.network,
                           self.smoothness + other.smoothness)


def scribble_unary(patch: np.ndarray, scribble: np.ndarray, allowed: np.ndarray, num_labels: int) -> np.ndarray:
    """E_scr per patch and label (eq. 1).

    0 for a scribbled patch's own label and INF for any other; ``−log(1/|allowed|)`` for
    an unscribbled patch over the labels `allowed` on this shape, INF outside them.

    Parameters
    ----------
    patch : (m,) int ndarray
    scribble : (m,) int ndarray
        -1 where unscribbled. A patch holds at most one scribble label.
    allowed : (a,) int ndarray
        Labels this shape may take (its scribbled labels when scribbled).
    num_labels : int

    Returns
    -------
    U : (p, k) float64 ndarray
    """
    p = int(patch.max()) + 1
    U = np.full((p, num_labels), INF)
    U[:, allowed] = np.log(max(len(allowed), 1))
    s = scribble >= 0
    if s.any():
        sp_ = np.unique(np.stack([patch[s], scribble[s]], axis=1), axis=0)
        if len(np.unique(sp_[:, 0])) != len(sp_):
            raise ValueError("a patch holds scribbles of two labels; split patches by scribble first")
        U[sp_[:, 0]] = INF
        U[sp_[:, 0], sp_[:, 1]] = 0.0
    return U


def network_unary(patch_matrix, log_proba: np.ndarray) -> np.ndarray:
    """E_neu per patch and label (eq. 2): ``−Σ_{f ∈ patch} log P(label | f)``, (p, k)."""
    return -(patch_matrix @ log_proba)


def feature_weights(D: np.ndarray, pairs: np.ndarray, delta: float, lam: float = 1.0) -> np.ndarray:
    """λ·E_fea weights (eq. 3): ``λ exp(−‖f_i − f_j‖²/δ²)`` per adjacent pair, (r,)."""
    if len(pairs) == 0:
        return np.zeros(0)
    d2 = ((D[pairs[:, 0]] - D[pairs[:, 1]]) ** 2).sum(1)
    return lam * np.exp(-d2 / delta**2)


def energy_terms(
    labels: np.ndarray, U_scr: np.ndarray, U_neu: np.ndarray | None, pairs: np.ndarray, weights: np.ndarray
) -> EnergyTerms:
    """Each term of eq. 4 for patch `labels` (p,)."""
    idx = np.arange(len(labels))
    e_neu = float(U_neu[idx, labels].sum()) if U_neu is not None else float("nan")
    cut = labels[pairs[:, 0]] != labels[pairs[:, 1]] if len(pairs) else np.zeros(0, bool)
    return EnergyTerms(float(U_scr[idx, labels].sum()), e_neu, float(weights[cut].sum()))
