"""Shared fixtures: the real-data folder and the array backends every function must run on."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]


def data_root() -> Path:
    """``$BRDFKIT_DATA`` or ``../shared/data`` beside the repository."""
    return Path(os.environ.get("BRDFKIT_DATA", REPO.parent / "shared" / "data"))


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The shared real-data folder; tests that need it skip with the reason when it is absent."""
    root = data_root()
    if not root.is_dir():
        pytest.skip(f"real data not found at {root} (set BRDFKIT_DATA to the shared/data folder)")
    return root


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
