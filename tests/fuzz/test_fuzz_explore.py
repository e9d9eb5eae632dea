"""Fuzz the explorer's protocol through its real WebSocket: every message is answered.

Messages are valid render messages (specs, model trees, files, any view) with 0–3 of their
values replaced by hostile ones (integers of 400 digits, 1e308, NaN, negative, empty, huge lists
of channels, deep nesting, wrong types), sometimes then cut or bit-flipped as text. Each is sent
on one connection and must get its answer (a frame or an error) before the next is sent: a
message without an answer is a silent failure, and fails the test. After the campaign the same
connection still renders, and no worker was logged as dead. Outcomes are counted per reply type
(``benchmarks/bench_faults.py`` runs 10,000 of them).
"""

from __future__ import annotations

import copy
import json
import logging

import pytest
from _fuzzing import OUTCOMES, fuzz_settings
from hypothesis import given
from hypothesis import strategies as st

pytest.importorskip("starlette")
pytest.importorskip("uvicorn")
websockets_sync = pytest.importorskip("websockets.sync.client")

from brdfkit.explore.protocol import decode_frame  # noqa: E402
from brdfkit.explore.server import ExplorerServer  # noqa: E402
from brdfkit.explore.session import Session  # noqa: E402

SOURCES = [
    {"spec": "lambertian(albedo=0.5)"},
    {"spec": "ggx(alpha=0.2) + lambertian"},
    {"spec": "ggx(alpha=[0.1, 0.2, 0.3, 0.4, 0.5])"},
    {"tree": {"model": "ggx", "params": {"alpha": 0.3, "material": "Au"}}},
    {"tree": {"sum": [{"model": "lambertian"}, {"scaled": 0.5, "inner": {"model": "beckmann"}}]}},
    {"file": "none.binary"},
]
"""Entry sources the mutations start from."""

HOSTILE = [
    10**400, -(10**400), 2**53 + 1, 1e308, -1e308, 5e-324, -1, 0, 0.5, 1e6, "", "x" * 200,
    "__import__('os')", None, True, [], {}, [0.1] * 3000, [[[[[]]]]], {"model": "ggx"},
]  # fmt: skip
"""Values a mutation puts in place of one in a valid message."""

RESOLUTION = 64
"""The base messages' resolution (a mutation may change it)."""


def _paths(node, prefix=()):
    """Every path to a value inside a JSON value."""
    yield prefix
    if isinstance(node, dict):
        for key, value in node.items():
            yield from _paths(value, (*prefix, key))
    elif isinstance(node, list):
        for index, value in enumerate(node):
            yield from _paths(value, (*prefix, index))


def _replaced(message, path, value):
    if not path:
        return value
    out = copy.deepcopy(message)
    node = out
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return out


@st.composite
def messages(draw: st.DrawFn) -> str:
    """A render message's text, mutated (see the module docstring)."""
    entries = [
        {"id": f"e{k}", "visible": draw(st.booleans()), "source": draw(st.sampled_from(SOURCES))}
        for k in range(draw(st.integers(0, 3)))
    ]
    view = {
        "theta_i": draw(st.floats(0, 89.9)),
        "phi_i": draw(st.floats(-360, 360)),
        "theta_h": draw(st.floats(0, 90)),
        "resolution": RESOLUTION,
        "envmap": False,
    }
    message = {"type": "render", "seq": 1, "state": {"entries": entries, "view": view}}
    for _ in range(draw(st.integers(0, 3))):
        path = draw(st.sampled_from(list(_paths(message))))
        message = _replaced(message, path, draw(st.sampled_from(HOSTILE)))
    text = json.dumps(message)
    kind = draw(st.sampled_from(["json", "json", "json", "cut", "flip", "nan"]))
    where = draw(st.integers(0, max(len(text) - 1, 0)))
    if kind == "cut":
        text = text[:where]
    elif kind == "flip" and text:
        text = (
            text[:where] + chr(ord(text[where]) ^ 1 << draw(st.integers(0, 6))) + text[where + 1 :]
        )
    elif kind == "nan":
        text = text.replace("0.5", draw(st.sampled_from(["NaN", "Infinity", "1e999", "-0"])), 1)
    return text


@pytest.fixture(scope="module")
def channel():
    """One connection to a served session, kept through the campaign; afterwards it must still
    render, and no worker may have died."""
    import scipy.stats  # noqa: F401  (the albedo worker's lazy import, done here first: a
    # first import on a worker thread beside pytest's import hook on this one can fail, a race
    # of CPython 3.11's ast module that no user of the server meets)

    session = Session()
    session.warm_up = lambda specs, files=(): session.warmed.set()  # no kernels built ahead
    server = ExplorerServer(session, []).start()
    records: list[logging.LogRecord] = []
    handler = logging.Handler(logging.ERROR)
    handler.emit = records.append  # type: ignore[method-assign]
    logging.getLogger("brdfkit.explore").addHandler(handler)
    try:
        with websockets_sync.connect(
            f"ws://127.0.0.1:{server.port}/{server.token}/ws",
            origin=f"http://127.0.0.1:{server.port}",
            max_size=2**26,
            open_timeout=30,
        ) as ws:
            yield ws
            ws.send(json.dumps({"type": "render", "seq": 7, "state": {"entries": [
                {"id": "a", "source": SOURCES[0]}]}}))  # fmt: skip
            assert answer(ws)["type"] == "frame"
    finally:
        server.stop()
        logging.getLogger("brdfkit.explore").removeHandler(handler)
    dead = [r.getMessage() for r in records if "worker failed" in r.getMessage()]
    assert dead == []


def answer(ws) -> dict:
    """The answer to the message just sent (a frame or an error); albedo curves are skipped.
    None in time is a silent failure."""
    while True:
        try:
            frame = ws.recv(timeout=60)
        except TimeoutError:
            OUTCOMES["explore protocol"]["SILENT"] += 1
            raise AssertionError("a message got no answer within 60 s") from None
        header = decode_frame(frame)[0]
        if header["type"] in ("frame", "error"):
            return header


def test_every_message_is_answered(channel):
    @fuzz_settings(ci_cases=40)
    @given(text=messages())
    def check(text: str) -> None:
        channel.send(text)
        header = answer(channel)
        errors = [e for e in header.get("entries", []) if "error" in e]
        outcome = header["type"] if not errors else "frame with entry errors"
        if "internal error" in header.get("message", ""):
            outcome = "internal error"
        OUTCOMES["explore protocol"][outcome] += 1
        assert outcome != "internal error", header["message"]

    check()
