"""Shared fixtures: the real-data folder and the array backends every function must run on."""

from __future__ import annotations

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
