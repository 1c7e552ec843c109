"""The project's exception types: every bad input surfaces as one of these.

Each error names the file and the problem in its message, so the CLI and the app can
show ``str(error)`` as it is, never a traceback.
"""

from __future__ import annotations

import os


class ScribblesegError(Exception):
    """Base class of every error scribbleseg raises on bad input.

    Parameters
    ----------
    message : str
        What is wrong, in words a user can act on.
    path : str or os.PathLike, optional
        The file the problem is in; prefixed to the message.
    """

    def __init__(self, message: str, path: str | os.PathLike | None = None):
        self.path = None if path is None else os.fspath(path)
        self.problem = message
        super().__init__(f"{self.path}: {message}" if self.path else message)


class MeshLoadError(ScribblesegError):
    """A mesh file is missing, unreadable, truncated or holds no usable triangles."""


class ScribbleFileError(ScribblesegError):
    """A scribble or label file is malformed or does not fit its mesh."""


class ModelFileError(ScribblesegError):
    """A saved model is from another version, another label set, or is not ours."""


class SessionFileError(ScribblesegError):
    """A session folder is not ours, from a newer version, or its files do not fit."""
