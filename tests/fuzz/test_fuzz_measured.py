"""Fuzz the measured-BRDF readers (MERL, RGL, Cornell) with byte-level mutations of valid files.

Each case writes the mutated bytes to a temporary file and reads it: the reader either returns
a BRDF, which must then evaluate to finite, non-negative values on random directions (zero
below the surface), or raises a documented error (:func:`_fuzzing.run_case` lets through only
:class:`brdfkit.errors.BrdfkitError`). Seeds: for MERL a table written by :func:`write_merl`
(no real MERL file is available here), for RGL and Cornell the real files of the shared data,
plus short Cornell files (the header and a few rows) so that mutations often hit the header.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from _fuzzing import fuzz_settings, mutated, run_case
from hypothesis import given
from hypothesis import strategies as st

from brdfkit.brdf import parse
from brdfkit.measured import read_cornell, read_merl, read_rgl, write_merl

CORNELL_NAMES = ("acryl_blue", "cayman", "garnet_red", "krylon_blue")
CORNELL_SHAPE = (8, 8, 8)
"""A coarse resampling grid: the fuzzed code is the parser and the scattered interpolation,
whose cost the default 32³ grid would multiply."""


def _directions(n: int, seed: int) -> np.ndarray:
    """``n`` random unit vectors on the whole sphere (half of them below the surface)."""
    v = np.random.default_rng(seed).normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


WI, WO = _directions(64, 1), _directions(64, 2)


def _read_and_eval(reader: Callable[[Path], Any], data: bytes, suffix: str) -> np.ndarray:
    """Write ``data`` to a temporary ``*suffix`` file, read it and evaluate it at (WI, WO)."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"fuzzed{suffix}"
        path.write_bytes(data)
        brdf = reader(path)
    return np.asarray(brdf.eval(WI, WO))


def _check(f: np.ndarray | None) -> None:
    """A read BRDF evaluates to finite, non-negative values, 0 below the surface."""
    if f is None:
        return
    assert np.all(np.isfinite(f)) and np.all(f >= 0), f"eval gave {f[~(np.isfinite(f) & (f >= 0))]}"
    below = (WI[:, 2] <= 0) | (WO[:, 2] <= 0)
    assert np.all(f[below] == 0)


@pytest.fixture(scope="module")
def merl_seeds(tmp_path_factory) -> list[bytes]:
    path = tmp_path_factory.mktemp("merl") / "seed.binary"
    write_merl(path, parse("lambertian(rho=[0.2, 0.3, 0.4]) + ward(kd=0, ks=0.05, alpha_x=0.12)"))
    return [path.read_bytes()]  # below-horizon nodes hold MERL's -1 marker


@pytest.fixture(scope="module")
def rgl_seeds(shared_data) -> list[bytes]:
    path = shared_data / "measured" / "rgl" / "acrylic_felt_green_rgb.bsdf"
    if not path.exists():
        pytest.skip(f"the RGL seed {path} is absent")
    return [path.read_bytes()]


@pytest.fixture(scope="module")
def cornell_seeds(shared_data) -> list[bytes]:
    paths = [shared_data / "measured" / "cornell" / f"{name}.brdf" for name in CORNELL_NAMES]
    missing = [str(p) for p in paths if not p.exists()]
    if missing:
        pytest.skip(f"the Cornell seeds {missing} are absent")
    full = [p.read_bytes() for p in paths]
    return full + [_shortened(data, rows) for data, rows in zip(full, (5, 8, 12, 20), strict=True)]


def _shortened(data: bytes, rows: int) -> bytes:
    """A Cornell file cut after its header and first ``rows`` rows (one per line)."""
    lines = data.split(b"\n")
    first = next(k for k, line in enumerate(lines) if len(line.split()) > 30)
    return b"\n".join(lines[: first + rows]) + b"\n"


@given(data=st.data())
@fuzz_settings(ci_cases=40)
def test_fuzz_merl(merl_seeds, data):
    _check(run_case("merl", _read_and_eval, read_merl, data.draw(mutated(merl_seeds)), ".binary"))


@given(data=st.data())
@fuzz_settings(ci_cases=300)
def test_fuzz_rgl(rgl_seeds, data):
    _check(run_case("rgl", _read_and_eval, read_rgl, data.draw(mutated(rgl_seeds)), ".bsdf"))


def _read_cornell(path: Path) -> Any:
    return read_cornell(path, CORNELL_SHAPE)


@given(data=st.data())
@fuzz_settings(ci_cases=60)
def test_fuzz_cornell(cornell_seeds, data):
    raw = data.draw(mutated(cornell_seeds, text=True))
    _check(run_case("cornell", _read_and_eval, _read_cornell, raw, ".brdf"))
