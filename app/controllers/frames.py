"""When the viewport renders a frame, and how long the longest gap between frames was.

Rendering a frame costs about 20 ms of CPU under software GL (STACK.md), so the app renders at
the full rate only while something moves: for :attr:`FrameClock.active_s` after input or a
change, and every :attr:`FrameClock.busy_interval` while a run streams results; otherwise it
renders (and so polls the viewport window's input) every :attr:`FrameClock.idle_interval`.
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
        Seconds between frames while :attr:`busy` (a run under way). Default 0.05.
    idle_interval : float
        Seconds between frames otherwise. Default 0.4.
    """

    def __init__(self, clock: Callable[[], float] = time.perf_counter, active_s: float = 1.5,
                 busy_interval: float = 0.05, idle_interval: float = 0.4) -> None:
        self.clock = clock
        self.active_s, self.busy_interval, self.idle_interval = active_s, busy_interval, idle_interval
        self.busy = False
        self.frames = 0
        self.max_gap = 0.0  # longest time between two frames since :meth:`reset_gap` (s)
        self._active_until = -float("inf")
        self._last: float | None = None

    def wake(self) -> None:
        """Something changed or the user is acting: render at the full rate for a while."""
        self._active_until = self.clock() + self.active_s

    def due(self) -> bool:
        """Whether to render at this tick."""
        now = self.clock()
        if self._last is None or now < self._active_until:
            return True
        return now - self._last >= (self.busy_interval if self.busy else self.idle_interval)

    def rendered(self) -> None:
        """A frame was rendered now."""
        now = self.clock()
        if self._last is not None:
            self.max_gap = max(self.max_gap, now - self._last)
        self._last = now
        self.frames += 1

    def reset_gap(self) -> None:
        self.max_gap = 0.0
