"""Scale-invariant heat kernel signature (SI-HKS), Bronstein & Kokkinos 2010."""

from __future__ import annotations

import numpy as np

from scribbleseg_core.geometry.laplacian import eigenpairs, laplacian

#: Default log-time grid: t = 2**tau, tau from -10 to 6 in steps of 0.2 (81 samples).
#: On the unit-area mesh this spans the time scales the first ~100 eigenpairs resolve
#: (1/lambda_100 ~ 1e-3) to beyond the slowest mode's decay (1/lambda_1 ~ 1); the paper's
#: tau in [1, 20] assumes unnormalized units and underflows to a constant here.
TAU_MIN, TAU_MAX, TAU_STEP = -10.0, 6.0, 0.2


def heat_kernel_signature(evals: np.ndarray, evecs: np.ndarray, times: np.ndarray) -> np.ndarray:
    """HKS ``h(x, t) = Σ_k exp(-λ_k t) φ_k(x)²``.

    Parameters
    ----------
    evals : (K,) float64 ndarray
    evecs : (n, K) float64 ndarray
    times : (T,) float64 ndarray

    Returns
    -------
    H : (n, T) float64 ndarray, positive
    """
    return (evecs**2) @ np.exp(-np.outer(evals, times))


def si_hks_from_spectrum(
    evals: np.ndarray,
    evecs: np.ndarray,
    *,
    alpha: float = 2.0,
    tau: np.ndarray | None = None,
    frequencies: tuple[int, int] = (1, 20),
) -> np.ndarray:
    """SI-HKS per vertex from a Laplacian spectrum.

    Parameters
    ----------
    evals, evecs : (K,), (n, K) float64 ndarray
    alpha : float
        Log-time base: ``t = alpha ** tau``.
    tau : (T,) float64 ndarray, optional
        Log-time samples; default ``arange(TAU_MIN, TAU_MAX + step/2, TAU_STEP)``.
    frequencies : (int, int)
        Half-open range of FFT bins kept. The default drops the DC bin and keeps 19 bins,
        MATLAB's ``2:20`` in Bronstein & Kokkinos' code.

    Returns
    -------
    S : (n, f) float64 ndarray
        ``|FFT_τ(∂_τ log h(x, alpha**τ))|`` at the kept frequencies.

    Notes
    -----
    Scaling a shape by ``s`` scales its eigenvalues by ``1/s²``, which shifts ``log h``
    along τ; the derivative removes the additive term, and the magnitude of the Fourier
    transform removes the shift. Shapes here are also normalized to unit area.

    References
    ----------
    M. Bronstein, I. Kokkinos, "Scale-invariant heat kernel signatures for non-rigid shape
    recognition", CVPR 2010.
    """
    if tau is None:
        tau = np.arange(TAU_MIN, TAU_MAX + TAU_STEP / 2, TAU_STEP)
    H = heat_kernel_signature(evals, evecs, alpha**tau)
    logH = np.log(np.maximum(H, np.finfo(float).tiny))
    dlog = np.diff(logH, axis=1)
    spectrum = np.abs(np.fft.fft(dlog, axis=1))
    lo, hi = frequencies
    return spectrum[:, lo:hi]


def si_hks(V: np.ndarray, F: np.ndarray, *, num_eigenpairs: int = 100) -> np.ndarray:
    """SI-HKS per vertex of mesh (V, F); see :func:`si_hks_from_spectrum`.

    Returns
    -------
    S : (n, 19) float64 ndarray
    """
    L, M = laplacian(V, F)
    evals, evecs = eigenpairs(L, M, num_eigenpairs)
    return si_hks_from_spectrum(evals, evecs)
