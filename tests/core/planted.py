"""A planted collection: bodies with a head and four limbs, ground truth known by construction."""

from __future__ import annotations

import numpy as np

from scribbleseg_core.formats.mesh import Mesh, repair
from tests.conftest import icosphere

LABELS = ("body", "limb", "head")
HEAD = np.array([0.0, 0.0, 1.0])
LIMBS = np.array([[1, 0, -0.5], [-1, 0, -0.5], [0, 1, -0.5], [0, -1, -0.5]], float)
LIMBS /= np.linalg.norm(LIMBS, axis=1, keepdims=True)


def creature(limb_length: float = 1.6, head_size: float = 0.9, seed: int = 0) -> tuple[Mesh, np.ndarray]:
    """One shape (about 5k faces) and its ground-truth face labels.

    Lobes are radial bumps of the unit sphere: thin long limbs, a round head.
    """
    V, F = icosphere(4)
    rng = np.random.default_rng(seed)
    axes = LIMBS + rng.normal(0, 0.05, LIMBS.shape)
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    r = np.ones(len(V))
    cos_limb = V @ axes.T
    limb_bump = np.clip((cos_limb - 0.93) / 0.07, 0, None) ** 0.5  # thin, steep
    r += limb_length * limb_bump.max(axis=1)
    cos_head = V @ HEAD
    head_bump = np.clip((cos_head - 0.8) / 0.2, 0, None) ** 0.35
    r += head_size * head_bump
    Vd = V * r[:, None]
    face_cos_limb = (V[F].mean(1) / np.linalg.norm(V[F].mean(1), axis=1, keepdims=True)) @ axes.T
    face_cos_head = (V[F].mean(1) / np.linalg.norm(V[F].mean(1), axis=1, keepdims=True)) @ HEAD
    gt = np.zeros(len(F), np.int64)
    gt[face_cos_limb.max(axis=1) > 0.93] = 1
    gt[face_cos_head > 0.8] = 2
    return repair(Vd, F), gt


def stroke_faces(mesh: Mesh, gt: np.ndarray, label: int, n: int = 6) -> np.ndarray:
    """A short stroke per connected part of `label`: its n faces nearest the part's centroid."""
    from scribbleseg_core.engine.regions import components
    from scribbleseg_core.geometry.dual_graph import dual_graph

    comp = components(dual_graph(mesh.V, mesh.F), gt == label)
    C = mesh.V[mesh.F].mean(1)
    out = []
    for c in range(comp.max() + 1):
        part = np.flatnonzero(comp == c)
        out.append(part[np.argsort(np.linalg.norm(C[part] - C[part].mean(0), axis=1))[:n]])
    return np.concatenate(out)
