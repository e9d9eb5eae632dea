"""Shared fixtures: the real-data folder and the array backends every function must run on."""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from brdfkit.io import data_path


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The shared real-data folder (:func:`brdfkit.io.data_path`: ``$BRDFKIT_DATA`` or
    ``../shared/data``); tests that need it skip with the reason when it is absent."""
    try:
        return data_path()
    except FileNotFoundError as error:
        pytest.skip(str(error))


def _numpy64(x):
    return np.asarray(x, dtype=np.float64)


def _numpy32(x):
    return np.asarray(x, dtype=np.float32)


def _torch64(x):
    torch = pytest.importorskip("torch")
    return torch.tensor(np.asarray(x), dtype=torch.float64)


BACKENDS = {"numpy64": _numpy64, "numpy32": _numpy32, "torch64": _torch64}


@pytest.fixture(params=list(BACKENDS))
def backend(request):
    """A converter from NumPy data to each backend/dtype under test (numpy f64/f32, torch f64)."""
    return BACKENDS[request.param]


CHROMIUM_FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",  # the machines' closed network refuses its connections
    "--disable-component-update",
    "--disable-sync",
)


@pytest.fixture
def browser_dom(tmp_path) -> Callable[..., str]:
    """``dom(url)``: the DOM of a page after its load event (and ``budget_ms`` of virtual time
    for its scripts), as Debian's headless Chromium sees it; skips when Chromium is absent."""
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        pytest.skip("headless Chromium is not installed (Debian package 'chromium')")

    def dom(url: str, budget_ms: int = 10_000, timeout: float = 180) -> str:
        command = [
            chromium,
            *CHROMIUM_FLAGS,
            f"--virtual-time-budget={budget_ms}",
            f"--user-data-dir={tmp_path / 'chromium-profile'}",
            "--dump-dom",
            url,
        ]
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
        assert done.returncode == 0, f"chromium failed on {url}: {done.stderr[-2000:]}"
        return done.stdout

    return dom


@pytest.fixture(scope="session", autouse=True)
def _kernel_cache(tmp_path_factory):
    """A kernel cache of this session's own (:mod:`brdfkit.compiled.cache`), so that tests
    about building kernels do not depend on what earlier sessions left in the user's."""
    import os

    saved = os.environ.get("BRDFKIT_CACHE_DIR")
    os.environ["BRDFKIT_CACHE_DIR"] = str(tmp_path_factory.mktemp("kernels"))
    yield
    if saved is None:
        os.environ.pop("BRDFKIT_CACHE_DIR", None)
    else:
        os.environ["BRDFKIT_CACHE_DIR"] = saved
