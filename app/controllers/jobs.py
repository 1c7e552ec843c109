"""Background jobs and the hop of their results onto the main thread.

A :class:`Job` runs a function (or a generator, whose items stream out as they come) on its
own thread. Everything it reports (items, the error, the end) is handed to a
:class:`Dispatcher`, whose ``post(fn)`` makes ``fn()`` run on the main thread: a Qt queued
signal in the app, a queue the test drains (:class:`QueueDispatcher`) in tests.
"""

from __future__ import annotations

import inspect
import pickle
import queue
import threading
from collections.abc import Callable


class Dispatcher:
    """Runs callables on the main thread; ``post`` may be called from any thread."""

    def post(self, fn: Callable[[], None]) -> None:  # pragma: no cover - interface
        raise NotImplementedError


class QueueDispatcher(Dispatcher):
    """Collects posted calls; :meth:`drain` runs them on the calling thread (tests, scripts)."""

    def __init__(self) -> None:
        self._queue: queue.SimpleQueue = queue.SimpleQueue()

    def post(self, fn: Callable[[], None]) -> None:
        self._queue.put(fn)

    def drain(self) -> int:
        """Run every call posted so far; returns how many ran."""
        n = 0
        while True:
            try:
                fn = self._queue.get_nowait()
            except queue.Empty:
                return n
            fn()
            n += 1


class Cancelled(Exception):
    """Raised inside a job's thread by :meth:`Job.check` once the job was cancelled."""


class Job:
    """`fn(*args)` on a daemon thread; a generator function's items stream to `on_item`.

    Every callback runs through `dispatcher` (on the main thread), and none runs after
    :meth:`cancel`: a cancelled job's late results are dropped, not applied.

    Parameters
    ----------
    fn : callable
        A function (its return value goes to `on_done`), or one that returns a generator
        (each item goes to `on_item`; the generator is closed between two items once cancelled).
    args : tuple
    dispatcher : Dispatcher
    on_item, on_done, on_error, on_finished : callable, optional
        ``on_item(item)``, ``on_done(result)``, ``on_error(exception)``, and ``on_finished()``
        last in every case but cancellation (then :meth:`cancel`'s caller knows already).
    name : str
        The thread's name.
    """

    def __init__(self, fn, args=(), *, dispatcher: Dispatcher, on_item=None, on_done=None, on_error=None,
                 on_finished=None, name: str = "scribbleseg-job") -> None:
        self._fn, self._args = fn, tuple(args)
        self._dispatcher = dispatcher
        self._on_item, self._on_done, self._on_error, self._on_finished = on_item, on_done, on_error, on_finished
        self._cancelled = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def start(self) -> Job:
        self._thread.start()
        return self

    @property
    def cancelled(self) -> bool:
        return self._cancelled.is_set()

    @property
    def running(self) -> bool:
        return self._thread.is_alive()

    def cancel(self) -> None:
        """Stop at the next item (a generator) and drop whatever the job still reports."""
        self._cancelled.set()

    def join(self, timeout: float | None = None) -> bool:
        """Wait for the thread; True when it ended."""
        if self._thread.ident is not None:
            self._thread.join(timeout)
        return not self._thread.is_alive()

    def check(self) -> None:
        """For `fn` itself: raise :class:`Cancelled` once the job was cancelled."""
        if self._cancelled.is_set():
            raise Cancelled

    def _post(self, callback, *args) -> None:
        if callback is None:
            return

        def call():
            if not self._cancelled.is_set():
                callback(*args)

        self._dispatcher.post(call)

    def _run(self) -> None:
        try:
            result = self._fn(*self._args)
            if inspect.isgenerator(result):
                gen = result
                try:
                    for item in gen:
                        if self._cancelled.is_set():
                            break
                        self._post(self._on_item, item)
                finally:
                    gen.close()
            else:
                self._post(self._on_done, result)
        except Cancelled:
            pass
        except Exception as e:  # reported on the main thread; a job never takes the app down
            self._post(self._on_error, e)
        self._post(self._on_finished)


def _child(fn, args, out) -> None:
    """The child process of a :class:`ProcessJob`: run `fn`, send what it gives through `out`.
    Items go as plain pickles (bytes): the queue's own pickler would hand torch tensors over in
    shared memory that vanishes with the child."""
    import inspect as _inspect
    import pickle

    try:
        result = fn(*args)
        if _inspect.isgenerator(result):
            for item in result:
                out.put(("item", pickle.dumps(item, protocol=pickle.HIGHEST_PROTOCOL)))
        else:
            out.put(("done", pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL)))
    except Exception as e:  # sent as text: an exception object need not pickle
        out.put(("error", f"{type(e).__name__}: {e}" if not str(e).startswith(type(e).__name__) else str(e)))
    out.put(("end", None))


class ProcessJob(Job):
    """A :class:`Job` whose function runs in a child process (``spawn``), so that its work
    never holds this process's interpreter lock: the viewport keeps its frames while C
    extensions that do not release the lock (graph cuts, geodesics, ray casts) run.

    `fn` and `args` cross to the child by pickling: `fn` must be a module-level function and
    `args` plain data (paths rather than open meshes). Items and the result cross back the
    same way. :meth:`cancel` ends the child at once; a job that dies without finishing reports
    an error.
    """

    def __init__(self, fn, args=(), **kwargs) -> None:
        import multiprocessing

        super().__init__(fn, args, **kwargs)
        ctx = multiprocessing.get_context("spawn")
        self._out = ctx.Queue()
        self._process = ctx.Process(target=_child, args=(fn, self._args, self._out), daemon=True,
                                    name=self._thread.name)
        self._thread = threading.Thread(target=self._read, name=f"{self._thread.name}-reader", daemon=True)

    def start(self) -> ProcessJob:
        self._process.start()
        self._thread.start()
        return self

    def cancel(self) -> None:
        super().cancel()
        if self._process.is_alive():
            self._process.terminate()

    def join(self, timeout: float | None = None) -> bool:
        self._process.join(timeout)
        return super().join(timeout) and not self._process.is_alive()

    def _read(self) -> None:
        try:
            self._read_all()
        except Exception as e:  # e.g. an item that does not unpickle: end the child, report it
            if self._process.is_alive():
                self._process.terminate()
            self._post(self._on_error, e)
            self._post(self._on_finished)

    def _read_all(self) -> None:
        while True:
            try:
                kind, value = self._out.get(timeout=0.2)
            except queue.Empty:
                if self._process.is_alive():
                    continue
                if not self._cancelled.is_set():
                    code = self._process.exitcode
                    self._post(self._on_error, RuntimeError(f"the worker process ended unexpectedly (exit code {code})"))
                    self._post(self._on_finished)
                return
            if kind == "item":
                self._post(self._on_item, pickle.loads(value))  # from our own child process
            elif kind == "done":
                self._post(self._on_done, pickle.loads(value))
            elif kind == "error":
                self._post(self._on_error, RuntimeError(value))
            else:  # "end"
                self._post(self._on_finished)
                self._process.join(5)
                return
