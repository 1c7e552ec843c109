"""Patch descriptors: histograms of AGD, SDF, curvature and a bag of SI-HKS words.

Bin ranges and the SI-HKS codebook are fit on the whole collection
(:func:`fit_patch_encoder`), so descriptors of different shapes are comparable.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d

from scribbleseg_core.signatures.features import FEATURE_NAMES

SCALAR_COLUMNS = (0, 1, 2)  # agd, sdf, gauss
HKS_COLUMNS = slice(3, len(FEATURE_NAMES))


@dataclass(frozen=True)
class PatchEncoder:
    """Collection-wide histogram ranges and SI-HKS codebook.

    Attributes
    ----------
    lo, hi : (3,) float64 ndarray
        Histogram ranges of AGD, SDF, curvature (0.5 and 99.5 percentiles).
    hks_mean, hks_std : (19,) float64 ndarray
        Standardization of SI-HKS before coding.
    codebook : (B, 19) float64 ndarray
        k-means centers (standardized space).
    bins : int
    smooth : float
        Gaussian blur of histograms, in bins (0: none); makes histograms of small
        patches comparable.
    """

    lo: np.ndarray
    hi: np.ndarray
    hks_mean: np.ndarray
    hks_std: np.ndarray
    codebook: np.ndarray
    bins: int = 100
    smooth: float = 1.5

    @property
    def dim(self) -> int:
        return 3 * self.bins + len(self.codebook)

    def encode(self, X: np.ndarray, area: np.ndarray, patch: np.ndarray) -> np.ndarray:
        """Descriptor of every patch of one shape.

        Parameters
        ----------
        X : (m, 22) float64 ndarray
            Face features.
        area : (m,) float64 ndarray
            Face areas (histogram weights).
        patch : (m,) int ndarray
            Patch id per face, ``0 .. p-1``.

        Returns
        -------
        D : (p, 3·bins + B) float64 ndarray
            Concatenated area-weighted histograms, each summing to 1.
        """
        p = int(patch.max()) + 1
        parts = []
        for c in range(3):
            t = (X[:, SCALAR_COLUMNS[c]] - self.lo[c]) / max(self.hi[c] - self.lo[c], 1e-12)
            b = np.clip((t * self.bins).astype(np.int64), 0, self.bins - 1)
            parts.append(_histograms(patch, b, area, p, self.bins, self.smooth))
        words = self.assign_words(X)
        parts.append(_histograms(patch, words, area, p, len(self.codebook), 0.0))
        return np.concatenate(parts, axis=1)

    def assign_words(self, X: np.ndarray) -> np.ndarray:
        """Nearest codebook word per face, (m,) int64."""
        Z = (X[:, HKS_COLUMNS] - self.hks_mean) / self.hks_std
        d2 = (Z**2).sum(1)[:, None] - 2 * Z @ self.codebook.T + (self.codebook**2).sum(1)[None]
        return np.argmin(d2, axis=1)


def _histograms(patch, bin_index, weight, p, bins, smooth) -> np.ndarray:
    H = np.bincount(patch * bins + bin_index, weight, minlength=p * bins).reshape(p, bins)
    if smooth > 0:
        H = gaussian_filter1d(H, smooth, axis=1, mode="nearest")
    return H / np.maximum(H.sum(axis=1, keepdims=True), 1e-300)


def fit_patch_encoder(
    features: list[np.ndarray], *, bins: int = 100, words: int = 100, seed: int = 0, max_samples: int = 20000
) -> PatchEncoder:
    """Fit histogram ranges and the SI-HKS codebook on a collection.

    Parameters
    ----------
    features : list of (m_s, 22) float64 ndarray
        Face features of every shape.
    bins, words : int
    seed : int
        For the face sample and k-means.
    """
    from scipy.cluster.vq import kmeans2

    rng = np.random.default_rng(seed)
    X = np.concatenate(features)
    sample = X[rng.choice(len(X), size=min(max_samples, len(X)), replace=False)]
    lo = np.percentile(sample[:, list(SCALAR_COLUMNS)], 0.5, axis=0)
    hi = np.percentile(sample[:, list(SCALAR_COLUMNS)], 99.5, axis=0)
    H = sample[:, HKS_COLUMNS]
    mean, std = H.mean(0), H.std(0) + 1e-9
    Z = (H - mean) / std
    k = min(words, len(np.unique(Z, axis=0)))
    codebook, _ = kmeans2(Z, k, minit="++", seed=int(seed), iter=20)
    return PatchEncoder(lo, hi, mean, std, codebook, bins)


def feature_delta(descriptors: list[np.ndarray], adjacency: list[np.ndarray]) -> float:
    """The δ of the pairwise term: ``δ² = mean ‖f_i − f_j‖²`` over adjacent patches.

    With this choice ``exp(−‖f_i − f_j‖²/δ²)`` is ``1/e`` for a typical neighbouring pair,
    near 1 for similar patches and near 0 for very different ones, on any collection.
    """
    d2 = [((D[P[:, 0]] - D[P[:, 1]]) ** 2).sum(1) for D, P in zip(descriptors, adjacency) if len(P)]
    d2 = np.concatenate(d2) if d2 else np.ones(1)
    return float(np.sqrt(max(d2.mean(), 1e-12)))
