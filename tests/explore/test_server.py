"""The explorer server's guard (token, Host, Origin), its handling of bad messages, and its
faults: every message answered, the connection kept, memory bounded, uploads named as the page
knows them."""

from __future__ import annotations

import json
import logging
import threading
import urllib.error
import urllib.parse
import urllib.request

import numpy as np
import pytest

pytest.importorskip("starlette")
pytest.importorskip("uvicorn")
websockets_sync = pytest.importorskip("websockets.sync.client")

from brdfkit.brdf import parse  # noqa: E402
from brdfkit.explore.protocol import MAX_MESSAGE_BYTES, decode_frame, parse_object  # noqa: E402
from brdfkit.explore.server import ExplorerServer  # noqa: E402
from brdfkit.explore.session import MAX_ENTRY_VALUES, Session, entry_values  # noqa: E402
from brdfkit.explore.views import ViewState  # noqa: E402
from brdfkit.render import render_sphere  # noqa: E402

RENDER = {
    "type": "render",
    "seq": 1,
    "state": {
        "entries": [{"id": "a", "visible": True, "source": {"spec": "ggx(alpha=0.3)"}}],
        "view": {"theta_i": 30, "resolution": 64},
    },
}


@pytest.fixture(scope="module")
def server():
    srv = ExplorerServer(Session(), ["lambertian"]).start()
    yield srv
    srv.stop()


def status(url: str, headers: dict[str, str] | None = None, data: bytes | None = None) -> int:
    request = urllib.request.Request(url, headers=headers or {}, data=data)
    try:
        with urllib.request.urlopen(request, timeout=60) as response:
            return response.status
    except urllib.error.HTTPError as error:
        return error.code


def connect(server, path: str = "ws", origin: str | None = "same", **kw):
    origin = f"http://127.0.0.1:{server.port}" if origin == "same" else origin
    return websockets_sync.connect(
        f"ws://127.0.0.1:{server.port}/{server.token}/{path}",
        origin=origin,
        max_size=2**26,
        open_timeout=30,
        **kw,
    )


def receive(ws) -> dict:
    message = ws.recv(timeout=20)
    if isinstance(message, bytes):
        return decode_frame(message)[0]
    return json.loads(message)


def test_the_page_needs_the_token(server):
    assert status(server.url) == 200
    assert status(server.url + "static/explorer.js") == 200
    assert status(f"http://127.0.0.1:{server.port}/") == 403
    assert status(f"http://127.0.0.1:{server.port}/static/explorer.js") == 403
    wrong = server.token[:-1] + ("A" if server.token[-1] != "A" else "B")
    assert status(f"http://127.0.0.1:{server.port}/{wrong}/") == 403


def test_a_foreign_host_is_refused(server):
    # DNS rebinding: a page of evil.example resolved to 127.0.0.1 sends its own Host
    assert status(server.url, {"Host": f"evil.example:{server.port}"}) == 403
    assert status(server.url, {"Host": f"localhost:{server.port}"}) == 200


def test_uploads_need_the_page_origin(server):
    url = server.url + "upload?name=x.binary"
    assert status(url, data=b"123") == 403  # no Origin
    assert status(url, {"Origin": "http://evil.example"}, data=b"123") == 403
    origin = {"Origin": f"http://127.0.0.1:{server.port}"}
    assert status(url, origin, data=b"not a MERL table") == 400  # read, and refused as data
    assert status(server.url + "upload?name=x.py", origin, data=b"print(1)") == 400


def test_websocket_needs_token_and_origin(server):
    from websockets.exceptions import InvalidStatus

    for kwargs in ({"origin": "http://evil.example"}, {"origin": None}):
        with pytest.raises(InvalidStatus) as refused:
            connect(server, **kwargs)
        assert refused.value.response.status_code == 403
    with pytest.raises(InvalidStatus) as refused:
        websockets_sync.connect(
            f"ws://127.0.0.1:{server.port}/ws", origin=f"http://127.0.0.1:{server.port}"
        )
    assert refused.value.response.status_code == 403


def sphere_image(arrays: list, views: dict, name: str = "sphere") -> np.ndarray:
    """The lit sphere's image from a frame: its float16 values placed on its disc's bits."""
    bits = arrays[views["disc"]]
    resolution = bits.shape[0]
    mask = np.unpackbits(bits, axis=1)[:, :resolution].astype(bool)
    values = arrays[views[name]]
    image = np.zeros((resolution, resolution, values.shape[-1]))
    image[mask] = values
    return image


def test_a_render_reply_holds_every_view(server):
    with connect(server) as ws:
        ws.send(json.dumps(RENDER))
        frame = ws.recv(timeout=20)
        header, arrays = decode_frame(frame)
        assert header["type"] == "frame" and header["seq"] == 1
        views = header["views"]["a"]
        assert arrays[views["sphere"]].dtype == np.float16
        assert arrays[views["disc"]].shape == (64, 8)
        # the visible pixels and the disc are the sphere, to float16's rounding
        state = ViewState(theta_i=30, resolution=64)
        expected = render_sphere(parse("ggx(alpha=0.3)"), state.light(), resolution=64)
        np.testing.assert_allclose(sphere_image(arrays, views), expected, rtol=2**-11)
        assert expected.max() > 0.1
        assert arrays[views["theta_v"]].shape == (181, 1)
        assert header["entries"][0]["spec"].startswith("ggx(alpha=0.3")
        assert receive(ws)["type"] == "albedo"


def test_the_difference_of_two_spheres_is_exact_where_they_nearly_agree(server):
    """|first − second| comes from the float64 values: two models 1e-4 apart differ by
    their difference to float32's rounding (not by the float16 rounding of each sphere)."""
    specs = ["lambertian(rho=0.5) + ggx(alpha=0.3)", "lambertian(rho=0.50005) + ggx(alpha=0.3)"]
    entries = [{"id": i, "source": {"spec": spec}} for i, spec in zip("ab", specs, strict=True)]
    with connect(server) as ws:
        for seq in (1, 2):  # the first alone, then both
            state = {"entries": entries[:seq], "view": RENDER["state"]["view"]}
            ws.send(json.dumps({"type": "render", "seq": seq, "state": state}))
            header, arrays = decode_frame(ws.recv(timeout=20))
            assert receive(ws)["type"] == "albedo"
    views = header["views"]
    assert "difference" in views["a"] and "difference" not in views["b"]
    # one disc, sent again (the first sphere held it, the second did not)
    assert ["a", "disc"] not in header["held"] and ["a", "sphere"] in header["held"]
    assert views["a"]["disc"] == views["b"]["disc"]
    state = ViewState(theta_i=30, resolution=64)
    a, b = (render_sphere(parse(s), state.light(), resolution=64) for s in specs)
    difference = sphere_image(arrays, views["a"], "difference")
    np.testing.assert_allclose(difference, np.abs(a - b), rtol=1e-6, atol=1e-12)
    assert difference.max() > 1e-6


def test_a_moving_light_gets_previews_and_no_new_albedo(server):
    def render(seq: int, theta_i: float, preview: bool) -> dict:
        message = json.loads(json.dumps(RENDER))
        message["seq"] = seq
        message["state"]["view"] |= {"theta_i": theta_i, "resolution": 128, "preview": preview}
        return message

    with connect(server) as ws:
        ws.send(json.dumps(render(1, 30, False)))
        header, arrays = decode_frame(ws.recv(timeout=20))
        assert arrays[header["views"]["a"]["disc"]].shape == (128, 16)
        assert not header["preview"]
        assert receive(ws)["type"] == "albedo"
        replies = []
        for seq, (theta_i, preview) in enumerate([(35, True), (40, False)], start=2):
            ws.send(json.dumps(render(seq, theta_i, preview)))
            header, arrays = decode_frame(ws.recv(timeout=20))
            disc = arrays[header["views"]["a"]["disc"]]
            replies.append((header["seq"], header["preview"], disc.shape))
            # the views the light leaves as they are: not sent again (the page holds them)
            assert sorted(header["held"]) == [["a", "slice"], ["a", "theta_d"], ["a", "theta_h"]]
            assert len(arrays) == len(header["arrays"]) == 3 + 4  # axes, sphere, disc, θv, lobe
        assert replies == [(2, True, (64, 8)), (3, False, (128, 16))]
        ws.send(
            json.dumps(
                {**render(4, 40, False), "type": "checks", "entry": RENDER["state"]["entries"][0]}
            )
        )
        assert receive(ws)["type"] == "checks"  # the next reply: no albedo for the moved light


@pytest.mark.parametrize(
    ("message", "expected"),
    [
        ("not json", "not JSON"),
        ("[1, 2]", "JSON object"),
        ('{"type": "exec", "seq": 1}', "message type"),
        ('{"type": "render", "seq": -1, "state": {}}', "seq"),
        ('{"type": "render", "seq": 1, "state": {"view": {"theta_i": 1e308}}}', "theta_i"),
        ('{"type": "render", "seq": 1, "state": {"view": {"resolution": 100000}}}', "resolution"),
        ('{"type": "render", "seq": 1, "state": {"entries": [{"id": "a"}]}}', "source"),
        ("[" * 100_000 + "]" * 100_000, "not JSON"),
    ],
)
def test_malformed_messages_get_an_error_and_the_channel_lives(server, message, expected):
    with connect(server) as ws:
        ws.send(message)
        reply = receive(ws)
        assert reply["type"] == "error" and expected in reply["message"]
        ws.send(json.dumps(RENDER))  # the channel still works
        assert receive(ws)["type"] == "frame"


def test_an_unknown_file_or_a_bad_spec_is_an_entry_error(server):
    state = {
        "entries": [
            {"id": "f", "source": {"file": "/etc/passwd"}},
            {"id": "s", "source": {"spec": "__import__('os').system('id')"}},
            {"id": "t", "source": {"tree": {"model": "ggx", "params": {"alpha": "0.1); x=("}}}},
        ]
    }
    with connect(server) as ws:
        ws.send(json.dumps({"type": "render", "seq": 2, "state": state}))
        header = receive(ws)
        errors = {e["id"]: e.get("error", "") for e in header["entries"]}
        assert "no file named" in errors["f"]
        assert "not allowed" in errors["s"]
        assert "alpha" in errors["t"]
        assert header["views"] == {}


def test_an_oversized_message_closes_the_channel_not_the_server(server):
    from websockets.exceptions import ConnectionClosed

    with connect(server) as ws:
        ws.send("x" * (MAX_MESSAGE_BYTES + 10))
        with pytest.raises(ConnectionClosed):
            ws.recv(timeout=10)
    with connect(server) as ws:  # the server still serves
        ws.send(json.dumps(RENDER))
        assert receive(ws)["type"] == "frame"


def test_a_fit_json_upload_gives_its_spec(server):
    origin = {"Origin": f"http://127.0.0.1:{server.port}"}
    url = server.url + "upload?name=fit.json"
    body = json.dumps({"file": "gold.binary", "spec": "ggx(alpha=0.3, material='Au')"}).encode()
    request = urllib.request.Request(url, headers=origin, data=body)
    with urllib.request.urlopen(request, timeout=60) as response:
        spec = json.loads(response.read())["spec"]
    assert spec.startswith("ggx(alpha=0.3") and "'Au'" in spec
    for bad in (b"{", b'{"spec": 3}', b'{"spec": "__import__(1)"}'):
        assert status(url, origin, data=bad) == 400


def test_an_upload_over_64_mib_is_refused_with_its_size(server):
    """Refused from its Content-Length before a byte is read, or as soon as a stream without
    one passes the limit (the ASGI app driven directly, chunk by chunk); nothing is kept."""
    import asyncio

    from brdfkit.explore.server import build_app
    from brdfkit.explore.session import MAX_UPLOAD_BYTES

    size = MAX_UPLOAD_BYTES + 1
    origin = {"Origin": f"http://127.0.0.1:{server.port}"}
    request = urllib.request.Request(
        server.url + "upload?name=big.binary",
        headers={**origin, "Content-Length": str(size)},
        data=b"\0",  # the header alone decides
    )
    with pytest.raises(urllib.error.HTTPError) as refused:
        urllib.request.urlopen(request, timeout=60)
    assert refused.value.code == 413
    message = json.loads(refused.value.read())["error"]
    assert f"'big.binary' holds {size} bytes; an upload holds at most 64 MiB" in message

    session = Session()
    app = build_app(session, "tok", 8123, [])
    chunks = [b"\0" * (1 << 20)] * (size >> 20) + [b"\0"] * 8
    sent, read = [], [0]

    async def receive():
        read[0] += 1
        return {"type": "http.request", "body": chunks[read[0] - 1], "more_body": True}

    async def send(event):
        sent.append(event)

    scope = {
        "type": "http", "method": "POST", "path": "/tok/upload", "raw_path": b"/tok/upload",
        "root_path": "", "scheme": "http", "query_string": b"name=big.binary",
        "server": ("127.0.0.1", 8123), "client": ("127.0.0.1", 1), "http_version": "1.1",
        "headers": [(b"host", b"127.0.0.1:8123"), (b"origin", b"http://127.0.0.1:8123")],
    }  # fmt: skip
    asyncio.run(app(scope, receive, send))
    assert sent[0]["status"] == 413
    assert read[0] == (size >> 20) + 1  # stopped at the first chunk past the limit
    message = json.loads(sent[1]["body"])["error"]
    assert f"holds more than {MAX_UPLOAD_BYTES} bytes; an upload holds at most 64 MiB" in message
    assert session.files == []


# -- faults ----------------------------------------------------------------------------------------

HUGE = "1" + "0" * 400  # a 400-digit integer: valid JSON, beyond every float


def _render(seq: int, entries: list, resolution: int = 64) -> dict:
    return {
        "type": "render",
        "seq": seq,
        "state": {"entries": entries, "view": {"theta_i": 30, "resolution": resolution}},
    }


GGX = [{"id": "a", "source": {"spec": "ggx(alpha=0.3)"}}]


def _connect(server):
    return websockets_sync.connect(
        f"ws://127.0.0.1:{server.port}/{server.token}/ws",
        origin=f"http://127.0.0.1:{server.port}",
        max_size=2**26,
        open_timeout=30,
    )


def _answer(ws, seq: int) -> dict:
    """The reply to message ``seq`` (a frame, checks or error), skipping albedo and env."""
    while True:
        header = decode_frame(ws.recv(timeout=30))[0]
        if header["type"] in ("frame", "checks", "error") and header["seq"] in (seq, 0):
            return header


@pytest.mark.parametrize(
    "message",
    [
        # in a model tree: OverflowError in model_tree._literal killed the render worker
        '{"type": "render", "seq": 5, "state": {"entries": [{"id": "a", "source": {"tree": '
        '{"model": "ggx", "params": {"alpha": ' + HUGE + "}}}}]}}",
        # in the view: the connection dropped without a close code
        '{"type": "render", "seq": 5, "state": {"view": {"theta_i": ' + HUGE + "}}}",
        '{"type": "render", "seq": 5, "state": {"view": {"theta_i": 1e400}}}',
        '{"type": "render", "seq": 5, "state": {"view": {"theta_i": NaN}}}',
    ],
)
def test_a_number_no_float_holds_is_an_error_and_the_next_render_is_answered(server, message):
    with _connect(server) as ws:
        ws.send(message)
        reply = _answer(ws, 5)
        assert reply["type"] == "error"
        assert "finite" in reply["message"] or "2**53" in reply["message"]
        ws.send(json.dumps(_render(6, GGX)))
        assert _answer(ws, 6)["type"] == "frame"


def test_a_failing_worker_answers_logs_and_serves_on(server, monkeypatch, caplog):
    """A MemoryError in the render worker killed it with no reply and no log line."""
    calls = []

    def exhausted(message, stale):
        calls.append(message.seq)
        if len(calls) == 1:
            raise MemoryError
        raise RuntimeError("a bug")

    monkeypatch.setattr(server.session, "render", exhausted)
    with caplog.at_level(logging.ERROR, logger="brdfkit.explore.session"), _connect(server) as ws:
        ws.send(json.dumps(_render(1, GGX)))
        assert "not enough memory" in _answer(ws, 1)["message"]
        ws.send(json.dumps(_render(2, GGX)))
        assert "internal error (RuntimeError)" in _answer(ws, 2)["message"]
        monkeypatch.undo()
        ws.send(json.dumps(_render(3, GGX)))
        assert _answer(ws, 3)["type"] == "frame"
    logged = [r.getMessage() for r in caplog.records]
    assert "explorer message 1: out of memory" in logged
    assert "explorer message 2 failed" in logged


def test_entries_beyond_the_memory_budget_are_refused_and_the_rest_rendered(server):
    """Eight entries of 2000 channels at 512 px took the server past 16 GB."""
    wide = "ggx(alpha=[" + ", ".join(["0.1"] * 2000) + "])"
    entries = [{"id": f"w{k}", "source": {"spec": wide}} for k in range(3)]
    with _connect(server) as ws:
        ws.send(json.dumps(_render(9, [*entries, GGX[0]], resolution=512)))
        header = _answer(ws, 9)
    errors = {e["id"]: e.get("error", "") for e in header["entries"]}
    assert all("2000 channels at 512 px" in errors[f"w{k}"] for k in range(3))
    assert set(header["views"]) == {"a"}  # the affordable entry is drawn


def test_the_budget_takes_eight_rgb_entries_at_512_px():
    assert 8 * entry_values(3, 512) <= 8 * MAX_ENTRY_VALUES
    assert entry_values(3, 512) <= MAX_ENTRY_VALUES < entry_values(2000, 64)


def test_the_session_keeps_a_bounded_number_of_view_bytes(monkeypatch):
    import brdfkit.explore.session as session_module

    monkeypatch.setattr(session_module, "MAX_CACHED_BYTES", 10 * 64 * 64 * 4)
    session = Session()
    for k in range(6):
        spec = f"lambertian(albedo={0.1 + 0.1 * k})"
        message = parse_object(_render(k, [{"id": "a", "source": {"spec": spec}}]))
        assert session.render(message) is not None
    assert session._cached_bytes <= 10 * 64 * 64 * 4
    assert session._cached_bytes == sum(a.nbytes for v in session._views.values() for a in v)


def _upload(server, name: str, data: bytes) -> tuple[int, dict]:
    request = urllib.request.Request(
        server.url + "upload?" + urllib.parse.urlencode({"name": name}),
        headers={"Origin": f"http://127.0.0.1:{server.port}"},
        data=data,
    )
    try:
        with urllib.request.urlopen(request, timeout=60) as response:
            return response.status, json.loads(response.read())
    except urllib.error.HTTPError as error:
        return error.code, json.loads(error.read())


def test_a_long_upload_name_keeps_its_suffix_and_errors_show_no_server_path(server):
    """A name over ~60 characters was cut through its suffix ("….binar: must end in …") and
    the message showed the server's temporary path."""
    name = "a-rather-long-name-of-a-measured-material-from-a-lab-" * 2 + ".binary"
    code, reply = _upload(server, name, b"not a MERL table")
    assert code == 400
    assert "must end in" not in reply["error"]  # the suffix was kept: read, and refused as such
    assert ".binary" in reply["error"] and "brdfkit-explore-" not in reply["error"]
    assert "/tmp" not in reply["error"] and "dimensions" in reply["error"]


def test_two_uploads_of_one_name_at_once_get_distinct_files(monkeypatch):
    import brdfkit.measured
    from brdfkit.brdf import Lambertian

    monkeypatch.setattr(brdfkit.measured, "read", lambda path: Lambertian())  # any table
    session = Session()
    data = b"a measured table"
    names: list[str] = []
    threads = [
        threading.Thread(target=lambda: names.append(session.add_upload("x.binary", data)))
        for _ in range(2)
    ]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    try:
        assert sorted(names) == ["x-2.binary", "x.binary"]
        paths = [session._paths[n] for n in names]
        assert paths[0] != paths[1] and all(p.read_bytes() == data for p in paths)
        assert paths[0].parent == paths[1].parent
    finally:
        session.close()


# -- the lit object ------------------------------------------------------------------------------


def _lit_render(seq: int, **view) -> str:
    entries = [{"id": "b1", "source": {"spec": "lambertian(albedo=0.5) + ggx(alpha=0.3)"}}]
    state = {"entries": entries, "view": {"lit": True, "mesh": "bundled:knot", **view}}
    return json.dumps({"type": "render", "seq": seq, "state": state})


def _next_lit(ws, wanted=lambda header: True) -> dict:
    """The next lit (or error) reply that ``wanted`` accepts, skipping the other views."""
    while True:
        header = decode_frame(ws.recv(timeout=60))[0]
        if header["type"] in ("lit", "error") and wanted(header):
            return header


def test_the_lit_object_restarts_only_when_what_it_shows_changes(server):
    pytest.importorskip("embreex", reason="embreex (the mesh extra) is not installed")
    with _connect(server) as ws:
        ws.send(_lit_render(1))
        assert _next_lit(ws)["seq"] == 1
        ws.send(_lit_render(2, theta_i=10))  # the light of the spheres: the lit view refines on
        second = _next_lit(ws)
        assert (second["seq"], second["samples"]) == (1, 4)
        ws.send(_lit_render(3, azimuth=100))  # the camera: the view starts again
        restarted = _next_lit(ws, lambda h: h["seq"] == 3)
        assert (restarted["samples"], restarted["azimuth"]) == (2, 100)
        ws.send(_lit_render(4, elevation=95))
        error = _next_lit(ws, lambda h: h["type"] == "error")
        assert "view.elevation must be a number in [-30.0, 89.0]" in error["message"]


def test_a_mesh_upload_is_named_as_a_mesh_and_listed(server):
    pytest.importorskip("embreex", reason="embreex (the mesh extra) is not installed")
    from brdfkit.render.mesh import torus_over_plane

    ply = torus_over_plane(sections=8).export(file_type="ply")
    assert _upload(server, "scene.ply", ply) == (200, {"mesh": "scene.ply"})
    with urllib.request.urlopen(server.url + "config", timeout=60) as response:
        assert "scene.ply" in json.loads(response.read())["meshes"]


def test_the_warm_up_freezes_the_objects_made_so_far_out_of_the_collector():
    """After the warm-up the process's objects are frozen (:func:`gc.freeze`): a full
    collection no longer scans them while replies are under way."""
    import gc

    gc.unfreeze()
    session = Session()
    session.warm_up = lambda specs, files: None  # its kernels' builds are not at issue here
    srv = ExplorerServer(session, ["lambertian"]).start()
    srv.stop()  # waits for the warm-up
    assert gc.get_freeze_count() > 1000
