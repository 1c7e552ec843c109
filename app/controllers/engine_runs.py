"""What a run's child process executes: the core's :func:`collection_run` and
:func:`predict_run`, on one torch thread so the renderer keeps the other core.

Re-exports the pipeline's messages so the controllers import them from one place.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from dataclasses import replace

import numpy as np

from scribbleseg_core.engine.optimize import SegmentParams
from scribbleseg_core.engine.pipeline import FeaturesDone, Predicted, Scored, StepDone, Suggested
from scribbleseg_core.engine.pipeline import collection_run as _collection_run
from scribbleseg_core.engine.pipeline import predict_run as _predict_run
from scribbleseg_core.formats.mesh import Mesh, load_mesh

__all__ = ["FeaturesDone", "MeshFiles", "Predicted", "Scored", "StepDone", "Suggested", "collection_run",
           "limit_threads", "predict_run", "warm_up"]


def limit_threads(n: int = 1) -> None:
    """Keep BLAS and torch to `n` threads so the renderer keeps a core (STACK.md)."""
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, str(n))
    try:
        from threadpoolctl import threadpool_limits

        threadpool_limits(n)
    except ImportError:
        pass


def warm_up() -> None:
    """What a run's child process does before its run arrives: this module's imports are done
    (the engine, scipy, maxflow), and one tiny network is trained on one thread, which imports
    torch and what its first optimizer step needs (:func:`~scribbleseg_core.engine.network.warm_up`)."""
    from scribbleseg_core.engine.network import warm_up as warm_network

    limit_threads(1)
    warm_network()


class MeshFiles(Sequence):
    """Meshes read from `paths` on first access (and kept), in the process that asks: a run's
    child process reads its own copies, so only paths cross to it."""

    def __init__(self, paths: Sequence[str | os.PathLike]) -> None:
        self.paths = [str(p) for p in paths]
        self._meshes: dict[int, Mesh] = {}

    def __len__(self) -> int:
        return len(self.paths)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(len(self)))]
        if i not in self._meshes:
            self._meshes[i] = load_mesh(self.paths[i])
        return self._meshes[i]

    def __getstate__(self):
        return {"paths": self.paths, "_meshes": {}}


def collection_run(
    meshes: Sequence[Mesh],
    scribbles: Sequence[np.ndarray | None],
    label_names: Sequence[str],
    params: SegmentParams = SegmentParams(),
    warm=None,
) -> Iterator[FeaturesDone | StepDone | Predicted | Scored | Suggested]:
    """:func:`scribbleseg_core.engine.pipeline.collection_run` with torch on one thread, so the
    renderer keeps the other core; `warm`: the previous run's model to continue training. A
    generator function itself (``yield from``), so that its job streams the messages."""
    limit_threads(1)
    params = replace(params, network=replace(params.network, threads=1))
    yield from _collection_run(meshes, scribbles, label_names, params, warm=warm)


def predict_run(model, meshes: Sequence[Mesh]) -> Iterator[FeaturesDone | Predicted | Scored]:
    """:func:`scribbleseg_core.engine.pipeline.predict_run` on one torch thread (see above)."""
    limit_threads(1)
    yield from _predict_run(model.with_threads(1), meshes)
