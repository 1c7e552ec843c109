"""A minimal event: callbacks connected to a model, emitted on change (no Qt needed)."""

from __future__ import annotations

from collections.abc import Callable


class Event:
    """``connect(callback)``; ``emit(*args)`` calls every callback in connection order."""

    def __init__(self) -> None:
        self._callbacks: list[Callable] = []

    def connect(self, callback: Callable) -> Callable:
        self._callbacks.append(callback)
        return callback

    def disconnect(self, callback: Callable) -> None:
        self._callbacks.remove(callback)

    def emit(self, *args) -> None:
        for cb in list(self._callbacks):
            cb(*args)
