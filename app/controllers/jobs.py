"""Background jobs and the hop of their results onto the main thread.

A :class:`Job` runs a function (or a generator, whose items stream out as they come) on its
own thread. Everything it reports (items, the error, the end) is handed to a
:class:`Dispatcher`, whose ``post(fn)`` makes ``fn()`` run on the main thread: a Qt queued
signal in the app, a queue the test drains (:class:`QueueDispatcher`) in tests.
"""

from __future__ import annotations

import inspect
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
