"""One polyscope viewport (real EGL pixels) for every app test in the process."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def viewport():
    pytest.importorskip("PySide6")
    from app.viewport import PolyscopeViewport

    return PolyscopeViewport("openGL3_egl")
