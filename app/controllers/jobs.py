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


def _outcomes(fn, args):
    """Run ``fn(*args)``: ``("item", x)`` for each item of the generator it returns, or one
    ``("done", result)``. Closing this closes that generator."""
    result = fn(*args)
    if not inspect.isgenerator(result):
        yield "done", result
        return
    try:
        for item in result:
            yield "item", item
    finally:
        result.close()


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

    def _post(self, callback, *args) -> None:
        if callback is None:
            return

        def call():
            if not self._cancelled.is_set():
                callback(*args)

        self._dispatcher.post(call)

    def _run(self) -> None:
        try:
            outcomes = _outcomes(self._fn, self._args)
            try:
                for kind, value in outcomes:
                    if self._cancelled.is_set():
                        break
                    self._post(self._on_item if kind == "item" else self._on_done, value)
            finally:
                outcomes.close()
        except Exception as e:  # reported on the main thread; a job never takes the app down
            self._post(self._on_error, e)
        self._post(self._on_finished)


#: How much lower a child process's scheduling priority is (Unix ``nice``): the renderer gets
#: the cores first, the run whatever it leaves (ray casting and software GL both use every core).
CHILD_NICENESS = 10


def _send(out, kind: str, value) -> None:
    """One message of a child process: its length, then the pickle of (kind, value)."""
    data = pickle.dumps((kind, value), protocol=pickle.HIGHEST_PROTOCOL)
    out.write(len(data).to_bytes(8, "little"))
    out.write(data)
    out.flush()


def _spawn(warm_up: str | None = None):
    """Start a child (:func:`_child_main`) with this process's module path; it runs `warm_up`,
    then waits for its job on stdin."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
    command = [sys.executable, "-m", "scribbleseg_app.controllers.jobs", *(["--warm-up", warm_up] if warm_up else [])]
    return subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, env=env)


def _child_main(argv: list[str]) -> None:
    """A :class:`ProcessJob`'s child (``python -m scribbleseg_app.controllers.jobs [--warm-up
    MODULE:FUNCTION]``): calls the warm-up function if given, then reads the pickled ``(fn,
    args)`` from stdin, runs it, and writes its messages to what was stdout (stdout itself
    then goes to stderr, so a stray print cannot corrupt a message). Ends quietly when stdin
    closes with no job (a spare child the app no longer needs)."""
    import importlib
    import os
    import sys

    out = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)
    if hasattr(os, "nice"):  # the window's frames come first when both want the cores
        os.nice(CHILD_NICENESS)
    if len(argv) == 2 and argv[0] == "--warm-up":
        try:
            module, _, name = argv[1].partition(":")
            getattr(importlib.import_module(module), name)()
        except Exception as e:  # the job still runs; it pays the costs the warm-up would have
            print(f"scribbleseg: warm-up {argv[1]} failed: {type(e).__name__}: {e}", file=sys.stderr)
    data = sys.stdin.buffer.read()
    if not data:
        return
    fn, args = pickle.loads(data)  # from the parent that started this process
    try:
        for kind, value in _outcomes(fn, args):
            _send(out, kind, value)
    except Exception as e:  # sent as text: an exception object need not pickle
        _send(out, "error", f"{type(e).__name__}: {e}")
    _send(out, "end", None)


class SpareProcess:
    """A child process started before the :class:`ProcessJob` that will use it, so that the
    job does not wait for Python to start and import what it needs.

    The child runs `warm_up` (``"module:function"``: imports, first-use costs) at the child's
    low priority as soon as it starts, then waits for its job. :meth:`take` hands the waiting
    child to a job (or starts one if none waits); :meth:`refill` starts the next. Thread safe.

    Parameters
    ----------
    warm_up : str, optional
        ``"module:function"`` the child calls before it waits; a failure is printed to stderr
        and the job runs all the same.
    """

    def __init__(self, warm_up: str | None = None) -> None:
        self.warm_up = warm_up
        self._child = None
        self._closed = False
        self._lock = threading.Lock()

    @property
    def waiting(self) -> bool:
        """Whether a started child waits for a job."""
        with self._lock:
            return self._child is not None and self._child.poll() is None

    @property
    def pid(self) -> int | None:
        """The process id of the child that waits, if any."""
        with self._lock:
            return None if self._child is None else self._child.pid

    def refill(self) -> None:
        """Start a child unless one waits already (nothing once closed)."""
        with self._lock:
            if not self._closed and (self._child is None or self._child.poll() is not None):
                self._child = _spawn(self.warm_up)

    def take(self):
        """The waiting child for a job, or a new one when none waits (or it died); a
        ``subprocess.Popen`` whose stdin takes the job."""
        with self._lock:
            child, self._child = self._child, None
        if child is None or child.poll() is not None:
            child = _spawn(self.warm_up)
        return child

    def close(self) -> None:
        """End the waiting child (it holds nothing of the user's); no more are started."""
        with self._lock:
            child, self._child, self._closed = self._child, None, True
        if child is not None and child.poll() is None:
            child.kill()
            child.wait()


class ProcessJob(Job):
    """A :class:`Job` whose function runs in a child Python process, so that its work never
    holds this process's interpreter lock: the viewport keeps its frames while C extensions
    that do not release the lock (graph cuts, geodesics, ray casts) run.

    `fn` and `args` cross to the child by pickling (`fn` must be a module-level function;
    `args` plain data: paths rather than open meshes), and items and the result cross back the
    same way, between this process and the child it started. :meth:`cancel` ends the child at
    once; a child that dies without finishing is reported as an error.

    With a `spare` (:class:`SpareProcess`), the job runs in its waiting child, and the next
    spare is started once the job has ended.
    """

    def __init__(self, fn, args=(), *, spare: SpareProcess | None = None, **kwargs) -> None:
        super().__init__(fn, args, **kwargs)
        self._process = None
        self._spare = spare
        self._thread = threading.Thread(target=self._read, name=f"{self._thread.name}-reader", daemon=True)

    @property
    def pid(self) -> int | None:
        """The process id of the child running the job (None before :meth:`start`)."""
        return None if self._process is None else self._process.pid

    def start(self) -> ProcessJob:
        self._process = self._spare.take() if self._spare is not None else _spawn()
        self._thread.start()
        return self

    def cancel(self) -> None:
        super().cancel()
        if self._process is not None and self._process.poll() is None:
            self._process.kill()

    def join(self, timeout: float | None = None) -> bool:
        if self._process is not None:
            import subprocess

            try:
                self._process.wait(timeout)
            except subprocess.TimeoutExpired:
                return False
        return super().join(timeout)

    def _read(self) -> None:
        try:
            self._read_all()
        except Exception as e:  # e.g. an item that does not unpickle: end the child, report it
            if self._process.poll() is None:
                self._process.kill()
            self._post(self._on_error, e)
            self._post(self._on_finished)
        finally:
            if self._spare is not None:
                self._spare.refill()

    def _read_all(self) -> None:
        proc = self._process
        proc.stdin.write(pickle.dumps((self._fn, self._args), protocol=pickle.HIGHEST_PROTOCOL))
        proc.stdin.close()
        stream = proc.stdout
        while True:
            head = stream.read(8)
            if len(head) < 8:  # the child ended without saying so: killed, or it crashed
                code = proc.wait()
                if not self._cancelled.is_set():
                    self._post(self._on_error, RuntimeError(f"the worker process ended unexpectedly (exit code {code})"))
                    self._post(self._on_finished)
                return
            kind, value = pickle.loads(stream.read(int.from_bytes(head, "little")))  # from our own child
            if kind == "item":
                self._post(self._on_item, value)
            elif kind == "done":
                self._post(self._on_done, value)
            elif kind == "error":
                self._post(self._on_error, RuntimeError(value))
            else:  # "end"
                self._post(self._on_finished)
                proc.wait()
                return


if __name__ == "__main__":
    import sys

    _child_main(sys.argv[1:])
