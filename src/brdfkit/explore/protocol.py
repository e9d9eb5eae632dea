"""The messages between the explorer's front end and its server (or notebook kernel).

The front end sends JSON text; every message is checked here before anything acts on it, and a
bad one gets an error reply naming what was wrong, never a crash. Replies carry a JSON header and
binary arrays: over a WebSocket one frame ``[uint32 header length][header][arrays]`` with each
array 8-byte aligned (:func:`encode_frame`); in a notebook the header is the message and the
arrays are its buffers.

Messages from the front end::

    {"type": "render", "seq": 3, "state": {"entries": [...], "view": {...}}}
    {"type": "checks", "seq": 4, "entry": {...}}

An entry is ``{"id": "b1", "visible": true, "source": S}`` with ``S`` one of ``{"spec": "ggx"}``,
``{"tree": {...}}`` (:mod:`brdfkit.explore.model_tree`) or ``{"file": "name"}`` (a file the server
was given). The view holds the angles of :class:`~brdfkit.explore.views.ViewState`, and for
the lit object its switch ``lit``, its ``mesh`` (``bundled:NAME`` or an uploaded mesh's name)
and the orbiting camera's ``azimuth`` and ``elevation`` (degrees); ``preview`` is true while a
slider or the light is dragged (:attr:`~brdfkit.explore.views.ViewState.sphere_resolution`).

References
----------
.. [1] I. Fette, A. Melnikov, "The WebSocket Protocol", RFC 6455, IETF, 2011.
"""

from __future__ import annotations

import json
import math
import struct
from dataclasses import dataclass
from typing import Any

import numpy as np

from brdfkit.errors import BrdfkitError
from brdfkit.explore.views import ELEVATION_RANGE, ViewState

MAX_MESSAGE_BYTES = 1 << 20
"""The largest message the front end may send (a spec holds at most 100 000 characters)."""

MAX_ENTRIES = 8
"""The most BRDFs shown at once."""

MAX_INTEGER = 2**53
"""The largest integer a message may hold: every integer up to it is exactly a float (a 400-digit
integer, valid JSON, overflowed every float conversion after it)."""

RESOLUTIONS = (64, 128, 256, 512)
"""Sphere resolutions the front end may ask for."""

_ANGLES = {
    "theta_i": (0.0, 89.9),
    "phi_i": (-360.0, 360.0),
    "theta_h": (0.0, 90.0),
    "theta_d": (0.0, 90.0),
    "phi_d": (-360.0, 360.0),
    "azimuth": (-360.0, 360.0),
    "elevation": ELEVATION_RANGE,
}


class ProtocolError(BrdfkitError, ValueError):
    """A message that is not JSON, too large, or not of the documented form."""


@dataclass(frozen=True)
class Entry:
    """One BRDF of the state: its id, visibility and source (``kind`` spec, tree or file)."""

    id: str
    visible: bool
    kind: str
    value: Any


@dataclass(frozen=True)
class Message:
    """A checked message: its type, sequence number, entries and view."""

    type: str
    seq: int
    entries: tuple[Entry, ...]
    view: ViewState


def parse_message(data: str | bytes) -> Message:
    """Check and decode one message from the front end.

    Raises
    ------
    ProtocolError
        Naming the field and what it must be; for a message over :data:`MAX_MESSAGE_BYTES`,
        that is not a JSON object, or that holds a number no float can hold (an integer beyond
        :data:`MAX_INTEGER`, ``1e400``, ``NaN``).

    Examples
    --------
    >>> parse_message("not json")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    brdfkit.explore.protocol.ProtocolError: message is not JSON: Expecting value: ...
    >>> parse_message('{"type": "render", "seq": -1}')
    Traceback (most recent call last):
    ...
    brdfkit.explore.protocol.ProtocolError: seq must be a non-negative integer
    >>> parse_message('{"type": "render", "seq": 1' + "0" * 400 + '}')  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    brdfkit.explore.protocol.ProtocolError: numbers in a message are at most 2**53 in ...
    """
    if len(data) > MAX_MESSAGE_BYTES:
        raise ProtocolError(f"message holds {len(data)} bytes; at most {MAX_MESSAGE_BYTES}")
    try:
        raw = json.loads(
            data, parse_int=_integer, parse_float=_finite, parse_constant=_not_a_number
        )
    except ProtocolError:
        raise
    except (ValueError, RecursionError) as error:
        raise ProtocolError(f"message is not JSON: {str(error)[:80]}") from None
    return parse_object(raw)


def _integer(text: str) -> int:
    """A JSON integer, refused beyond :data:`MAX_INTEGER` (its digits counted before any
    conversion)."""
    digits = text.lstrip("-")
    if len(digits) > 16 or int(digits) > MAX_INTEGER:
        raise ProtocolError(
            f"numbers in a message are at most 2**53 in magnitude; got an integer of "
            f"{len(digits)} digits ({text[:20]}…)"
        )
    return int(text)


def _finite(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ProtocolError(f"numbers in a message must be finite floats; got {text[:40]}")
    return value


def _not_a_number(text: str) -> float:
    raise ProtocolError(f"numbers in a message must be finite floats; got {text}")


def parse_object(raw: Any) -> Message:
    """:func:`parse_message` of an already decoded JSON value (a notebook's message)."""
    if not isinstance(raw, dict):
        raise ProtocolError(f"message must be a JSON object; got {type(raw).__name__}")
    kind = raw.get("type")
    seq = raw.get("seq", 0)
    if not isinstance(seq, int) or isinstance(seq, bool) or not 0 <= seq < 2**53:
        raise ProtocolError("seq must be a non-negative integer")
    if kind == "render":
        state = _object(raw, "state")
        entries = state.get("entries", [])
        if not isinstance(entries, list) or len(entries) > MAX_ENTRIES:
            raise ProtocolError(f"state.entries must be a list of at most {MAX_ENTRIES} entries")
        view = _view(state.get("view", {}))
        return Message("render", seq, tuple(_entry(e, i) for i, e in enumerate(entries)), view)
    if kind == "checks":
        return Message("checks", seq, (_entry(raw.get("entry"), 0),), ViewState())
    raise ProtocolError(f"message type must be 'render' or 'checks'; got {str(kind)[:40]!r}")


def _object(raw: dict[str, Any], key: str) -> dict[str, Any]:
    value = raw.get(key)
    if not isinstance(value, dict):
        raise ProtocolError(f"{key} must be a JSON object")
    return value


def _entry(raw: Any, index: int) -> Entry:
    where = f"entries[{index}]"
    if not isinstance(raw, dict):
        raise ProtocolError(f"{where} must be an object")
    entry_id = raw.get("id")
    if not isinstance(entry_id, str) or not 0 < len(entry_id) <= 32 or not entry_id.isprintable():
        raise ProtocolError(f"{where}.id must be a printable string of 1 to 32 characters")
    visible = raw.get("visible", True)
    if not isinstance(visible, bool):
        raise ProtocolError(f"{where}.visible must be true or false")
    source = raw.get("source")
    if not isinstance(source, dict) or len(source) != 1:
        raise ProtocolError(f"{where}.source must be one of {{spec}}, {{tree}}, {{file}}")
    ((kind, value),) = source.items()
    if kind in ("spec", "file") and not isinstance(value, str):
        raise ProtocolError(f"{where}.source.{kind} must be a string")
    if kind not in ("spec", "tree", "file"):
        raise ProtocolError(f"{where}.source must be one of {{spec}}, {{tree}}, {{file}}")
    return Entry(entry_id, visible, kind, value)


def _view(raw: Any) -> ViewState:
    if not isinstance(raw, dict):
        raise ProtocolError("state.view must be an object")
    unknown = set(raw) - {*_ANGLES, "resolution", "irradiance", "envmap", "lit", "mesh", "preview"}
    if unknown:
        raise ProtocolError(f"state.view has unknown fields {sorted(unknown)[:5]}")
    values: dict[str, Any] = {}
    for name, (lo, hi) in _ANGLES.items():
        if name in raw:
            values[name] = _number(f"view.{name}", raw[name], lo, hi)
    if "resolution" in raw:
        if raw["resolution"] not in RESOLUTIONS or isinstance(raw["resolution"], bool):
            raise ProtocolError(f"view.resolution must be one of {RESOLUTIONS}")
        values["resolution"] = int(raw["resolution"])
    for flag in ("envmap", "lit", "preview"):
        if flag in raw:
            if not isinstance(raw[flag], bool):
                raise ProtocolError(f"view.{flag} must be true or false")
            values[flag] = raw[flag]
    if "mesh" in raw:
        mesh = raw["mesh"]
        if not isinstance(mesh, str) or not 0 < len(mesh) <= 80 or not mesh.isprintable():
            raise ProtocolError("view.mesh must be a printable string of 1 to 80 characters")
        values["mesh"] = mesh
    if "irradiance" in raw:
        values["irradiance"] = _number("view.irradiance", raw["irradiance"], 0.0, 1e6)
    return ViewState(**values)


def _number(name: str, value: Any, lo: float, hi: float) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not lo <= value <= hi:
        raise ProtocolError(f"{name} must be a number in [{lo}, {hi}]; got {str(value)[:40]}")
    return float(value)  # within [lo, hi]: finite


def array_table(arrays: list[np.ndarray]) -> tuple[list[dict[str, Any]], list[bytes]]:
    """The description (dtype, shape) of each array and its little-endian C-order bytes."""
    table, buffers = [], []
    for array in arrays:
        a = np.ascontiguousarray(array, dtype=array.dtype.newbyteorder("<"))
        table.append({"dtype": a.dtype.name, "shape": list(a.shape)})
        buffers.append(a.tobytes())
    return table, buffers


HALF_MAX = float(np.finfo(np.float16).max)
"""The largest finite float16 (65504): :func:`half_floats` clamps to it."""


def half_floats(values: np.ndarray) -> np.ndarray:
    """``values`` as float16 for the wire (a quarter of float64's bytes): rounded to 2⁻¹¹
    relative, which moves a value's 8-bit display code (sRGB, γ 2.2 or linear, at any
    exposure) by less than a quarter of a level, so that the page shows what float64 shows
    within 8-bit quantisation; magnitudes clamped to :data:`HALF_MAX`, which is white at
    any exposure the page offers (2⁻¹⁰ · 65504 > 1). NaN stays NaN.

    Examples
    --------
    >>> half_floats(np.array([0.1, 1e-6, 1e9, -1e9])).tolist()
    [0.0999755859375, 1.0132789611816406e-06, 65504.0, -65504.0]
    """
    return np.clip(values, -HALF_MAX, HALF_MAX).astype(np.float16)


def encode_frame(header: dict[str, Any], buffers: list[bytes]) -> bytes:
    """One binary WebSocket frame: the header (with each buffer's offset added) and the buffers,
    each starting at a multiple of 8 bytes from the frame's start."""
    offsets, position = [], 0
    for b in buffers:
        offsets.append(position)
        position += -(-len(b) // 8) * 8
    text = json.dumps({**header, "offsets": offsets}, allow_nan=False).encode()
    start = -(-(4 + len(text)) // 8) * 8
    out = bytearray(struct.pack("<I", len(text)) + text)
    out += b" " * (start - len(out))
    for b in buffers:
        out += b + b"\0" * (-len(b) % 8)
    return bytes(out)


def decode_frame(frame: bytes) -> tuple[dict[str, Any], list[np.ndarray]]:
    """Inverse of :func:`encode_frame` (for tests and Python clients).

    Examples
    --------
    >>> import numpy as np
    >>> table, buffers = array_table([np.arange(3, dtype=np.float32)])
    >>> frame = encode_frame({"type": "render", "arrays": table}, buffers)
    >>> header, arrays = decode_frame(frame)
    >>> header["arrays"], header["offsets"], arrays[0].tolist(), len(frame) % 8
    ([{'dtype': 'float32', 'shape': [3]}], [0], [0.0, 1.0, 2.0], 0)
    """
    (length,) = struct.unpack_from("<I", frame)
    header = json.loads(frame[4 : 4 + length])
    start = -(-(4 + length) // 8) * 8
    arrays = []
    for spec, offset in zip(header.get("arrays", []), header["offsets"], strict=True):
        dtype = np.dtype(spec["dtype"]).newbyteorder("<")
        count = math.prod(spec["shape"])
        a = np.frombuffer(frame, dtype, count, start + offset).reshape(spec["shape"])
        arrays.append(a)
    return header, arrays


__all__ = [
    "HALF_MAX",
    "MAX_ENTRIES",
    "MAX_INTEGER",
    "MAX_MESSAGE_BYTES",
    "RESOLUTIONS",
    "Entry",
    "Message",
    "ProtocolError",
    "array_table",
    "decode_frame",
    "encode_frame",
    "half_floats",
    "parse_message",
    "parse_object",
]
