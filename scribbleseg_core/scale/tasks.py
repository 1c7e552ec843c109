"""What one Dask task does with one mesh; runs in the worker processes.

The model is read once per worker process and kept (:func:`worker_model`), so tasks carry
only paths. Each task returns a small dict, never raises for a bad mesh: an error is a
result the driver records, and the job goes on.
"""

from __future__ import annotations

import os
import resource
import time
import traceback
from pathlib import Path

from scribbleseg_core.errors import ScribblesegError

#: Models read in this process, by (folder, job fingerprint).
_MODELS: dict[tuple[str, str], object] = {}


def peak_memory_mb() -> float:
    """Peak resident memory of this process, MB."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def worker_model(folder: str, job: str):
    """The model in `folder`, read on this process's first call with this job fingerprint."""
    from scribbleseg_core.store.model_file import load_model

    key = (folder, job)
    if key not in _MODELS:
        _MODELS.clear()  # one job at a time per worker: drop the previous model
        _MODELS[key] = load_model(folder)
    return _MODELS[key]


def predict_task(model_folder: str, job: str, source: str, key: str, out: str, formats: tuple[str, ...],
                 num_patches: int, confidence: bool = False) -> dict:
    """Segment the mesh `source` with the model and write ``out/<key>.<format>`` atomically;
    with `confidence`, the exports carry each face's confidence
    (:func:`~scribbleseg_core.engine.guidance.label_confidence`).

    Returns
    -------
    dict
        ``{"key", "outputs": [paths relative to out], "faces", "seconds", "peak_mb"}`` (the
        worker process's peak resident memory so far), or
        ``{"key", "error": message}`` when the mesh cannot be read or processed.
    """
    t0 = time.perf_counter()
    try:
        from scribbleseg_core.engine.predict import predict_with_confidence
        from scribbleseg_core.engine.shape import prepare_shape
        from scribbleseg_core.formats.export import export_labeled_mesh
        from scribbleseg_core.formats.labels import LabelSet
        from scribbleseg_core.formats.mesh import load_mesh

        model = worker_model(model_folder, job)
        mesh = load_mesh(source)
        labels, conf = predict_with_confidence(model, prepare_shape(mesh, num_patches=num_patches))
        target = Path(out) / key
        written = export_labeled_mesh(target.parent, target.name, mesh.V_file, mesh.F_file, mesh.labels_to_file(labels),
                                      LabelSet.from_names(model.label_names), formats=formats,
                                      confidence=mesh.labels_to_file(conf) if confidence else None)
        outputs = [p.relative_to(out).as_posix() for p in written]
        return {"key": key, "outputs": outputs, "faces": int(mesh.num_file_faces),
                "seconds": time.perf_counter() - t0, "peak_mb": peak_memory_mb()}
    except Exception as e:  # noqa: BLE001 - a bug on one mesh must not end a job of thousands
        return {"key": key, "error": _failure(source, e)}


def signature_task(source: str) -> dict:
    """Compute the signatures and the geodesic sample of one mesh into their caches (shared
    with the client).

    Returns
    -------
    dict
        ``{"source", "faces", "seconds"}`` or ``{"source", "error": message}``.
    """
    t0 = time.perf_counter()
    try:
        from scribbleseg_core.formats.mesh import load_mesh
        from scribbleseg_core.signatures.features import cached_face_features
        from scribbleseg_core.signatures.geodesic import cached_source_distances

        mesh = load_mesh(source)
        cached_face_features(mesh.V, mesh.F)
        cached_source_distances(mesh.normalized(), mesh.F)  # the learner's label context reads them
        return {"source": source, "faces": int(mesh.num_file_faces), "seconds": time.perf_counter() - t0}
    except Exception as e:  # noqa: BLE001
        return {"source": source, "error": _failure(source, e)}


def _failure(source: str, e: Exception) -> str:
    """One line naming `source` and what went wrong: a bad input's own message, or the
    exception and where it was raised."""
    if isinstance(e, ScribblesegError):
        return str(e) if e.path else f"{source}: {e}"
    if isinstance(e, MemoryError):
        return f"{source}: out of memory"
    last = traceback.extract_tb(e.__traceback__)[-1]
    return f"{source}: {type(e).__name__}: {e} ({os.path.basename(last.filename)}:{last.lineno})"
