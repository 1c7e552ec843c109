"""Where scribbleseg keeps files of its own: the cache and the state (autosaves) folders.

Both follow the platform's conventions (platformdirs) unless an environment variable
names the folder; tests point both at a temporary folder.
"""

from __future__ import annotations

import os
from pathlib import Path

#: Environment variable overriding the cache folder (signatures, context).
CACHE_ENV = "SCRIBBLESEG_CACHE_DIR"
#: Environment variable overriding the state folder (the app's autosaves).
STATE_ENV = "SCRIBBLESEG_STATE_DIR"


def default_cache_dir() -> Path:
    """``$SCRIBBLESEG_CACHE_DIR``, else the user cache folder (e.g. ``~/.cache/scribbleseg``)."""
    return _folder(CACHE_ENV, "user_cache_dir")


def default_state_dir() -> Path:
    """``$SCRIBBLESEG_STATE_DIR``, else the user state folder (e.g. ``~/.local/state/scribbleseg``)."""
    return _folder(STATE_ENV, "user_state_dir")


def _folder(env: str, kind: str) -> Path:
    value = os.environ.get(env)
    if value:
        return Path(value)
    import platformdirs

    return Path(getattr(platformdirs, kind)("scribbleseg"))
