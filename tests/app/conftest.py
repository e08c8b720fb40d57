"""The dashboard's tests that build pages in this process, without the server: the patches of Panel and Bokeh the
server's start-up installs (app.serving.patches) are installed here once, as the server has them."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session", autouse=True)
def _server_patches() -> None:
    from app.serving import patches

    patches.install()
