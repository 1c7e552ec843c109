"""When the viewport renders a frame, and how long the longest gap between frames was.

Rendering a frame costs about 20 ms of CPU under software GL (STACK.md), so the app renders at
the full rate only while something moves: for :attr:`FrameClock.active_s` after input or a
change, and every :attr:`FrameClock.busy_interval` while a run streams results; otherwise it
renders (and so polls the viewport window's input) every :attr:`FrameClock.idle_interval`.
While a live preview is being computed, only input keeps the full rate: frames that show nothing
new would take the cores from the preview (docs/app.md, Responsiveness).
"""

from __future__ import annotations

import time
from collections.abc import Callable


class FrameClock:
    """Decides, at each timer tick, whether to render.

    Parameters
    ----------
    clock : callable() -> float
        Seconds (default ``time.perf_counter``).
    active_s : float
        Full rate for this long after :meth:`wake` (input, a change). Default 1.5 s.
    busy_interval : float
        Seconds between frames while :attr:`busy` (a run under way; the viewport then redraws
        each frame in full, see :meth:`PolyscopeViewport.tick`). Default 0.025.
    idle_interval : float
        Seconds between frames otherwise. Default 0.4.
    waiting : callable() -> bool
        Whether a result the user waits for (the live preview) is being computed; then a
        change alone does not keep the full rate, input at the last frame does, and frames
        come every `waiting_interval` otherwise. Default never.
    waiting_interval : float
        Seconds between frames while `waiting` and the user does not act. Default 0.1.
    """

    def __init__(self, clock: Callable[[], float] = time.perf_counter, active_s: float = 1.5,
                 busy_interval: float = 0.025, idle_interval: float = 0.4,
                 waiting: Callable[[], bool] = lambda: False, waiting_interval: float = 0.1) -> None:
        self.clock = clock
        self.active_s, self.busy_interval, self.idle_interval = active_s, busy_interval, idle_interval
        self.waiting, self.waiting_interval = waiting, waiting_interval
        self.busy = False
        self._acting = False  # the user acted in the viewport during the last frame
        self.frames = 0
        self.max_gap = 0.0  # longest time between two frames since :meth:`reset_gap` (s)
        self._active_until = -float("inf")
        self._last: float | None = None
        self._gap_from = -float("inf")  # when :meth:`reset_gap` was called

    def wake(self) -> None:
        """Something changed or the user is acting: render at the full rate for a while."""
        self._active_until = self.clock() + self.active_s

    def due(self) -> bool:
        """Whether to render at this tick."""
        now = self.clock()
        if self._last is None or self._acting:
            return True
        waiting = self.waiting()
        if now < self._active_until and not waiting:
            return True
        if self.busy:
            return now - self._last >= self.busy_interval
        return now - self._last >= (self.waiting_interval if waiting else self.idle_interval)

    def rendered(self, acting: bool = False) -> None:
        """A frame was rendered now; `acting`: the user did something in the viewport during
        it (then it also calls :meth:`wake`)."""
        self._acting = acting
        if acting:
            self.wake()
        now = self.clock()
        if self._last is not None:
            self.max_gap = max(self.max_gap, now - max(self._last, self._gap_from))
        self._last = now
        self.frames += 1

    def reset_gap(self) -> None:
        """Measure :attr:`max_gap` from now (a run starts): the wait for the first frame counts
        from here, not from the last frame of an idle window."""
        self.max_gap = 0.0
        self._gap_from = self.clock()
