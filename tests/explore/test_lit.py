"""The lit-object view: the session's passes are the library's render, the protocol refuses a
camera out of range, and meshes upload like measured files (through the server:
test_server.py)."""

from __future__ import annotations

import json
import threading

import numpy as np
import pytest

from brdfkit.brdf import parse
from brdfkit.errors import FormatError
from brdfkit.explore import session as session_module
from brdfkit.explore.protocol import Entry, Message, ProtocolError, parse_message
from brdfkit.explore.session import Session
from brdfkit.explore.views import (
    LIT_RESOLUTION,
    LIT_TILE_EVALUATIONS,
    ViewState,
    orbit_camera,
)
from brdfkit.render import progressive
from brdfkit.render.bundled_meshes import object_bounds
from brdfkit.render.mesh import torus_over_plane
from brdfkit.render.mitsuba_frame import mitsuba_oriented

pytest.importorskip("embreex", reason="embreex (the mesh extra) is not installed")

SPEC = "lambertian(albedo=[0.8, 0.4, 0.2]) + ggx(alpha=0.3)"


@pytest.fixture(scope="module")
def session():
    s = Session()
    yield s
    s.close()


def _message(seq: int = 1, **view) -> Message:
    state = ViewState(**{"lit": True, "mesh": "bundled:knot", **view})
    return Message("render", seq, (Entry("b1", True, "spec", SPEC),), state)


def test_the_passes_are_the_librarys_progressive_render(session):
    replies = []
    for header, arrays in session.lit(_message(azimuth=-40.0, elevation=10.0), threading.Event()):
        replies.append((header, arrays[0]))
        if header["samples"] >= 4:
            break
    assert [h["samples"] for h, _ in replies] == [2, 4]
    header, image = replies[-1]
    assert (header["type"], header["mesh"], header["azimuth"], header["elevation"]) == (
        "lit", "bundled:knot", -40.0, 10.0,
    )  # fmt: skip
    scene, bounds = session.mesh("bundled:knot")
    np.testing.assert_array_equal(bounds, object_bounds("knot").ravel())
    g = scene.gbuffer(orbit_camera(object_bounds("knot"), -40.0, 10.0), LIT_RESOLUTION)
    light = mitsuba_oriented(session.envmap)
    expected = list(
        progressive(
            g, parse(SPEC), light, max_samples=4, visibility=scene.visibility(g),
            max_evaluations=LIT_TILE_EVALUATIONS,
        )
    )  # fmt: skip
    assert image.shape == (LIT_RESOLUTION, LIT_RESOLUTION, 3) and image.dtype == np.float32
    np.testing.assert_array_equal(image, expected[-1].image.astype(np.float32))
    assert 0 < header["noise"] < replies[0][0]["noise"]  # refined: less noise
    assert np.all(image[~g.mask] == 0)


def test_nothing_unless_the_view_is_on_and_an_unknown_mesh_is_an_error(session):
    assert list(session.lit(_message(lit=False), threading.Event())) == []
    with pytest.raises(ProtocolError, match=r"no mesh named 'teapot\.obj'"):
        next(session.lit(_message(mesh="teapot.obj"), threading.Event()))


@pytest.mark.parametrize(
    ("field", "value", "expected"),
    [
        ("elevation", 90, r"view.elevation must be a number in \[-30.0, 89.0\]"),
        ("azimuth", -400, r"view.azimuth must be a number in \[-360.0, 360.0\]"),
        ("lit", "yes", "view.lit must be true or false"),
        ("mesh", "", "view.mesh must be a printable string"),
        ("mesh", ["bundled:knot"], "view.mesh must be a printable string"),
    ],
)
def test_the_protocol_refuses_a_camera_out_of_range(field, value, expected):
    message = {"type": "render", "seq": 1, "state": {"view": {field: value}}}
    with pytest.raises(ProtocolError, match=expected):
        parse_message(json.dumps(message))


def _ply() -> bytes:
    return torus_over_plane(sections=8).export(file_type="ply")


def test_a_mesh_uploads_and_is_framed_by_its_bounds(session, monkeypatch):
    name = session.add_upload("../torus.ply", _ply())
    assert name == "torus.ply" and name in session.meshes
    assert session.meshes[:2] == ["bundled:knot", "bundled:shaderball"]
    scene, bounds = session.mesh(name)
    np.testing.assert_allclose(bounds, [-3, 0, -3, 3, scene.vertices[:, 1].max(), 3])
    assert session.add_upload("torus.ply", _ply()) == "torus-2.ply"
    with pytest.raises(ProtocolError, match=r"\.obj, \.ply"):
        session.add_upload("torus.txt", b"")
    monkeypatch.setattr(session_module, "MAX_MESH_FACES", 10)
    with pytest.raises(FormatError, match="holds 66 triangles; the explorer reads 10"):
        session.add_upload("big.ply", _ply())
