"""How alike the rest of the surface is to each face, at several geodesic distances.

Parts that come in several copies have look-alikes far away: a leg of a four-legged animal
resembles the other three legs, a wing the other wing, a tentacle the other seven, while a
tail, a head or a neck resembles only the surface near it. A face's own descriptor does not
say this; the distance to the nearest look-alike in each band of geodesic distance does, and
it carries over between shapes whose proportions differ, since both the descriptors and the
distances are compared within one shape.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.distance import cdist

from scribbleseg_core.signatures.geodesic import SourceDistances

#: Edges of the geodesic distance bands, in units of the shape's mean geodesic distance.
BANDS = (0.0, 0.15, 0.4, 0.8, 1.5, np.inf)
#: Values per face: one per band.
NUM_BANDS = len(BANDS) - 1
#: Faces sampled (by area) as the candidate look-alikes.
NUM_SAMPLES = 512
#: Added to the descriptor distance before its logarithm (descriptors are standardized).
FLOOR = 0.05
#: The geodesic distance given to faces of another connected component (in the last band).
FAR_AWAY = 1e30
#: Faces compared at once (memory: CHUNK × NUM_SAMPLES doubles per array).
CHUNK = 4096


def self_similarity(descriptor: np.ndarray, area: np.ndarray, dist: SourceDistances,
                    num_samples: int = NUM_SAMPLES) -> np.ndarray:
    """Log distance from each face to its most similar sampled face in each geodesic band.

    The descriptors are standardized on the shape (area-weighted mean and deviation of each
    column); the descriptor distance is the root mean square of the differences. Geodesic
    distances between a face and a sampled face are bounded from below by the sources of
    `dist` (``max_s |d(s, f) − d(s, h)|``, exact when a source lies beyond one of them along
    a geodesic) in units of the shape's mean geodesic distance
    (:meth:`~scribbleseg_core.signatures.geodesic.SourceDistances.normalized`); faces
    of another connected component lie in the last band. A band with no sampled face takes
    the largest distance found on the shape.

    Parameters
    ----------
    descriptor : (m, d) float64 ndarray
        Per-face values compared between faces (the signatures diffused at the smallest
        context scale in :func:`~scribbleseg_core.engine.shape.network_input`).
    area : (m,) float64 ndarray
        Face areas.
    dist : SourceDistances
        Geodesic distances from the shape's sources to every face (the label context's).
    num_samples : int
        Candidate look-alikes, drawn by area with a generator seeded by m (deterministic).

    Returns
    -------
    (m, NUM_BANDS) float64 ndarray
        ``log(distance + FLOOR)`` per band of :data:`BANDS`.
    """
    X = np.asarray(descriptor, dtype=np.float64)
    m = len(X)
    w = np.asarray(area, dtype=np.float64) / max(float(np.sum(area)), 1e-300)
    mu = w @ X
    sd = np.sqrt(w @ (X - mu) ** 2)
    Z = (X - mu) / np.where(sd > 1e-12, sd, 1.0) / np.sqrt(X.shape[1])
    Dn, reach, _ = dist.normalized(area)
    G = Dn.T  # (m, S): distances in mean geodesic distances
    component = np.argmax(reach, axis=0)  # faces of one component reach the same sources
    rng = np.random.default_rng(m)
    h = np.sort(rng.choice(m, min(num_samples, int(np.count_nonzero(w))), replace=False, p=w))
    out = np.empty((m, NUM_BANDS))
    for start in range(0, m, CHUNK):
        rows = slice(start, min(m, start + CHUNK))
        geo = cdist(G[rows], G[h], "chebyshev")
        geo[component[rows, None] != component[None, h]] = FAR_AWAY
        d = cdist(Z[rows], Z[h], "euclidean")
        for j in range(NUM_BANDS):
            inside = (geo >= BANDS[j]) & (geo < BANDS[j + 1])
            out[rows, j] = np.where(inside, d, np.inf).min(axis=1)
    found = np.isfinite(out)
    out[~found] = out[found].max() if found.any() else 1.0
    return np.log(out + FLOOR)
