"""Run a batch job on Dask: a local cluster of worker processes, or an existing cluster.

:func:`predict_many` segments many meshes with one trained model; :func:`signatures_many`
fills the signature cache for many meshes. Both submit one task per mesh
(:mod:`~scribbleseg_core.scale.tasks`), take results as they finish, and go on past a mesh
that fails; a worker that dies has its tasks run again elsewhere (Dask's
``distributed.scheduler.allowed-failures``, default 3, after which the shape is recorded as
failed). Outputs are written atomically by the tasks and recorded in the output folder's
manifest (:mod:`~scribbleseg_core.scale.manifest`) by this process alone.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from scribbleseg_core.errors import ScribblesegError
from scribbleseg_core.infra.atomic import atomic_write_text
from scribbleseg_core.infra.cpu import usable_cores
from scribbleseg_core.scale.inputs import Source
from scribbleseg_core.scale.manifest import Manifest, job_fingerprint
from scribbleseg_core.scale.tasks import predict_task, signature_task

ERRORS_NAME = "errors.json"
#: Output formats of :func:`predict_many` (see :mod:`scribbleseg_core.formats.export`).
DEFAULT_FORMATS: tuple[str, ...] = ("seg", "ply")
#: What ``confidence=True`` writes: the confidence in the PLY, a JSON summary and a VTP.
CONFIDENCE_FORMATS: tuple[str, ...] = ("seg", "ply", "json", "vtp")


@dataclass
class BatchSummary:
    """What a batch job did.

    Attributes
    ----------
    done, skipped, failed : int
        Shapes processed now, skipped as already done, and failed.
    seconds : float
        Wall time of the job, cluster start included.
    errors : list of dict
        ``{"file", "message"}`` per failed shape.
    peak_memory_mb : float
        The largest peak resident memory a worker reported (0 when none did).
    """

    done: int = 0
    skipped: int = 0
    failed: int = 0
    seconds: float = 0.0
    errors: list[dict] = field(default_factory=list)
    peak_memory_mb: float = 0.0

    @property
    def ok(self) -> bool:
        return self.failed == 0

    @property
    def shapes_per_minute(self) -> float:
        return 60.0 * self.done / self.seconds if self.seconds > 0 else 0.0

    def table(self) -> str:
        """A two-line table for a terminal."""
        head = (f"{'shapes':>7} {'done':>6} {'skipped':>8} {'failed':>7} {'minutes':>8} {'shapes/min':>11} "
                f"{'worker peak MB':>15}")
        total = self.done + self.skipped + self.failed
        row = (f"{total:>7} {self.done:>6} {self.skipped:>8} {self.failed:>7} {self.seconds / 60:>8.2f} "
               f"{self.shapes_per_minute:>11.1f} {self.peak_memory_mb:>15.0f}")
        return head + "\n" + row


@contextlib.contextmanager
def dask_client(workers: int | None = None, scheduler: str | None = None) -> Iterator:
    """A ``distributed.Client``: on the cluster at `scheduler`, or on a new ``LocalCluster``
    of `workers` processes (default: one per core this process may use) with one thread
    each; a local cluster is closed on exit."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:  # pragma: no cover - a dependency
        raise ScribblesegError("dask.distributed is not installed: pip install 'dask[distributed]'") from None
    if scheduler:
        try:
            client = Client(scheduler, timeout="20s")
        except OSError as e:
            raise ScribblesegError(f"cannot reach the Dask scheduler ({e})", scheduler) from None
        try:
            yield client
        finally:
            client.close()
        return
    n = workers or usable_cores()
    # One thread per worker, and the nanny gives each worker OMP/MKL/OpenBLAS one thread too
    # (distributed.nanny.pre-spawn-environ), which torch_threads() follows. The workers' scratch
    # space is a temporary folder, not a dask-scratch-space/ left in the user's folder.
    with tempfile.TemporaryDirectory(prefix="scribbleseg-dask-") as scratch:
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                               silence_logs=logging.ERROR, local_directory=scratch)
        client = Client(cluster)
        try:
            yield client
        finally:
            client.close()
            cluster.close()


def _run_tasks(client, calls: list[tuple[str, Callable, tuple]], on_result: Callable[[str, dict], None]) -> None:
    """Submit `calls` (key, function, args) and pass each result to `on_result` as it finishes;
    a task whose workers kept dying gives ``{"error": ...}``."""
    from distributed import as_completed

    futures = {client.submit(fn, *args, key=key, pure=False, retries=0): key for key, fn, args in calls}
    for fut in as_completed(futures):
        key = futures[fut]
        if fut.status == "finished":
            result = fut.result()
        else:
            exc = fut.exception()
            result = {"error": f"{type(exc).__name__}: {exc}"}
        fut.release()
        on_result(key, result)


def predict_many(
    model_folder: str | os.PathLike,
    sources: Sequence[Source],
    out: Path,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    force: bool = False,
    num_patches: int = 50,
    formats: Sequence[str] | None = None,
    confidence: bool = False,
    progress: Callable[[int, int], None] | None = None,
) -> BatchSummary:
    """Segment `sources` with the model in `model_folder`, writing ``out/<key>.<format>``.

    Parameters
    ----------
    model_folder : path
        A model folder written by ``scribbleseg segment`` (read once per worker).
    sources : sequence of Source
        From :func:`~scribbleseg_core.scale.inputs.gather_sources`.
    out : Path
        The output folder (created). It also receives ``manifest.jsonl`` and, when a shape
        failed, ``errors.json`` (``[{"file", "message"}]``, this run's failures).
    workers, scheduler
        See :func:`dask_client`.
    force : bool
        Redo shapes the manifest records as done.
    num_patches : int
        Primitive patches per shape (the paper-faithful models use them).
    formats : sequence of str, optional
        Export formats per shape; default :data:`DEFAULT_FORMATS`, or with `confidence`
        :data:`CONFIDENCE_FORMATS`.
    confidence : bool
        Write each face's confidence into the exports (PLY property ``confidence``, the
        JSON summary per label, VTP cell data ``Confidence``).
    progress : callable(done, total), optional
        Called after each shape (done, skipped or failed) on this process.

    Raises
    ------
    ScribblesegError
        The model folder cannot be read (checked here, before any cluster starts).
    """
    from scribbleseg_core.store.model_file import load_model

    t0 = time.perf_counter()
    model_folder = os.fspath(Path(model_folder).resolve())
    load_model(model_folder)  # a bad model is one error now, not one per shape
    out.mkdir(parents=True, exist_ok=True)
    out = out.resolve()
    formats = tuple(formats or (CONFIDENCE_FORMATS if confidence else DEFAULT_FORMATS))
    job = job_fingerprint(model_folder, {"num_patches": num_patches, "formats": list(formats), "confidence": confidence})
    manifest = Manifest(out)
    manifest.compact()
    todo = [s for s in sources if force or not manifest.is_done(s, job)]
    summary = BatchSummary(skipped=len(sources) - len(todo))
    by_task = {f"predict-{job}-{s.key}": s for s in todo}
    if progress:
        progress(summary.skipped, len(sources))

    def on_result(task_key: str, result: dict) -> None:
        source = by_task[task_key]
        if "error" in result:
            summary.failed += 1
            message, given, resolved = result["error"], os.fspath(source.path), os.fspath(source.path.resolve())
            if message.startswith(resolved):  # the task saw the resolved path; name the file as the user did
                message = given + message[len(resolved):]
            elif not message.startswith(given):
                message = f"{given}: {message}"
            summary.errors.append({"file": os.fspath(source.path), "message": message})
        else:
            manifest.record(source, job, result["outputs"])
            summary.done += 1
            summary.peak_memory_mb = max(summary.peak_memory_mb, result.get("peak_mb", 0.0))
        if progress:
            progress(summary.done + summary.skipped + summary.failed, len(sources))

    if todo:
        with dask_client(workers, scheduler) as client:
            calls = [(task, predict_task, (model_folder, job, os.fspath(s.path.resolve()), s.key, os.fspath(out),
                                           formats, num_patches, confidence)) for task, s in by_task.items()]
            _run_tasks(client, calls, on_result)
    _write_errors(out, summary.errors)
    summary.seconds = time.perf_counter() - t0
    return summary


def signatures_many(
    paths: Sequence[str | os.PathLike],
    *,
    meshes: Sequence | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> BatchSummary:
    """Compute the signatures and geodesic samples of meshes not yet in their caches, in parallel.

    The workers write the cache that this process then reads (``SCRIBBLESEG_CACHE_DIR``, or
    the user's cache folder: on a cluster it must be a shared folder). Meshes that fail are
    counted and listed, not raised: the caller loads them itself and reports the error.
    `meshes`, when given, are the loaded ``paths`` (the cache is checked on them instead of
    reading every file again).
    """
    from scribbleseg_core.formats.mesh import load_mesh
    from scribbleseg_core.signatures.features import cached_face_features
    from scribbleseg_core.signatures.geodesic import cached_source_distances

    t0 = time.perf_counter()
    summary = BatchSummary()
    todo = []
    for i, p in enumerate(paths):
        try:
            mesh = meshes[i] if meshes is not None else load_mesh(p)
        except ScribblesegError:
            todo.append(os.fspath(p))  # the task records the error
            continue
        if (cached_face_features(mesh.V, mesh.F, compute=False) is None
                or cached_source_distances(mesh.normalized(), mesh.F, compute=False) is None):
            todo.append(os.fspath(Path(p).resolve()))
        else:
            summary.skipped += 1

    def on_result(_key: str, result: dict) -> None:
        if "error" in result:
            summary.failed += 1
            summary.errors.append({"file": result.get("source", _key), "message": result["error"]})
        else:
            summary.done += 1
        if progress:
            progress(summary.done + summary.skipped + summary.failed, len(paths))

    if todo:
        with dask_client(workers, scheduler) as client:
            calls = [(f"signatures-{os.getpid()}-{i}", signature_task, (p,)) for i, p in enumerate(todo)]
            _run_tasks(client, calls, on_result)
    summary.seconds = time.perf_counter() - t0
    return summary


def _write_errors(out: Path, errors: list[dict]) -> None:
    path = out / ERRORS_NAME
    if errors:
        atomic_write_text(path, json.dumps(sorted(errors, key=lambda e: e["file"]), indent=1) + "\n")
    elif path.exists():
        path.unlink()  # the failures of an earlier run are done now or retried below
