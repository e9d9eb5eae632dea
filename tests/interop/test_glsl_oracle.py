"""The translator against a real GLSL compiler: BRDF Explorer shaders and the constructs file
run by OpenGL (Mesa's llvmpipe through a headless EGL context, in float32) give the values
brdfkit computes, to the accuracy GLSL promises in float32.

GLSL 4.10 §4.7.1 bounds the error of the float32 built-ins: a few ULP for arithmetic, ``sqrt``,
``exp`` and ``pow``, but 4096 ULP (2.4e-4 relative) for ``asin``, ``acos`` and ``atan``. Shaders
without inverse trigonometry must agree to 1e-5 of their largest value (2e-5 for the
constructs, whose transcendental group sums twenty built-ins); those built on ``acos`` to 1e-3.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from brdfkit.interop.brdf_explorer import read_brdf_explorer

moderngl = pytest.importorskip("moderngl", reason="the glsl-oracle extra is not installed")

from _opengl import opengl_values  # noqa: E402

CONSTRUCTS = Path(__file__).parent / "data" / "constructs.brdf"


@pytest.fixture(scope="module")
def gl():
    try:
        ctx = moderngl.create_standalone_context(backend="egl", require=430)
    except Exception as error:  # moderngl raises a bare Exception where EGL or GL 4.3 is missing
        pytest.skip(f"no headless OpenGL 4.3 context: {error}")
    yield ctx
    ctx.release()


def _directions(n: int, seed: int) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2]) + 0.05
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    return v.astype(np.float32).astype(np.float64)  # the directions OpenGL sees


WI, WO = _directions(256, 5), _directions(256, 6)


def _error(brdf, gl) -> float:
    """max |OpenGL − brdfkit| / max |brdfkit| over the pairs."""
    ours = brdf.shader_value(WI, WO)
    theirs = opengl_values(gl, brdf, WI, WO)
    assert np.all(np.isfinite(theirs)) and np.all(np.isfinite(ours))
    return float(np.max(np.abs(theirs - ours)) / np.max(np.abs(ours)))


def test_every_construct_computes_what_opengl_does(gl):
    brdf = read_brdf_explorer(CONSTRUCTS)
    for which in range(7):
        for flip in (False, True):
            assert _error(brdf.with_values(which=float(which), flip=flip), gl) < 2e-5, which


@pytest.mark.parametrize(
    ("name", "values", "tolerance"),
    [
        ("disney", {"metallic": 0.3, "subsurface": 0.4, "anisotropic": 0.6, "sheen": 0.7,
                    "clearcoat": 0.6}, 1e-5),
        ("ward", {"alpha_x": 0.1, "alpha_y": 0.3, "Cs": [0.9, 0.5, 0.1]}, 1e-5),
        ("ashikhman_shirley", {"isotropic": False, "nu": 10.0, "nv": 200.0}, 1e-5),
        ("cooktorrance", {"m": 0.2}, 1e-5),
        ("orennayar", {"sigma": 40.0}, 1e-3),
        ("showAngles", {"show_phiD": True}, 1e-3),
    ],
)  # fmt: skip
def test_brdf_explorer_files_compute_what_opengl_does(shared_data, gl, name, values, tolerance):
    path = shared_data / "brdf_explorer" / f"{name}.brdf"
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    assert _error(read_brdf_explorer(path, **values), gl) < tolerance
