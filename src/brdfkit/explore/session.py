"""One explorer session: the BRDFs it may show, and the replies to the front end's messages.

A :class:`Session` is shared by the web server and the notebook widget; it reads only the files
it is given (:meth:`Session.add_file`, :meth:`Session.add_mesh`, the command line) or that are
uploaded (:meth:`Session.add_upload`, written into a temporary folder the session owns and
removes): measured BRDFs, and meshes for the lit-object view (besides the bundled ones).
Every reply is ``(header, arrays)``: :mod:`brdfkit.explore.protocol` frames it.
"""

from __future__ import annotations

import itertools
import logging
import math
import os
import shutil
import tempfile
import threading
import time
from collections import OrderedDict
from collections.abc import Callable, Iterator, Sequence
from functools import lru_cache, partial
from pathlib import Path
from typing import Any

import numpy as np

from brdfkit.brdf.base import BRDF
from brdfkit.brdf.spec import parse
from brdfkit.errors import BrdfkitError, FormatError, ResourceError
from brdfkit.explore import views
from brdfkit.explore.model_tree import brdf_of, controls_of, tree_of
from brdfkit.explore.protocol import Entry, Message, ProtocolError, array_table, half_floats
from brdfkit.render.bundled_meshes import BUNDLED_MESHES, BUNDLED_PREFIX, load_mesh, object_bounds
from brdfkit.render.mesh import MESH_SUFFIXES, MeshScene
from brdfkit.render.passes import Pass

MEASURED_SUFFIXES = (".binary", ".bsdf", ".brdf")
"""Files the explorer reads as measured BRDFs (MERL, RGL, Cornell), with
:func:`brdfkit.measured.read`."""

MAX_UPLOAD_BYTES = 64 << 20
"""The largest file the page may upload (a MERL table holds 35 MB)."""

MAX_FILES = 32
"""The most files one session holds."""

MAX_MESH_FACES = 2_000_000
"""The most triangles of a mesh the lit-object view reads (Embree's structure and the mesh's
arrays then take some 200 MB)."""

MAX_FIT_BYTES = 1 << 20
"""The largest ``fit.json`` (:command:`brdfkit fit`'s result) the explorer reads."""

MAX_ENTRY_VALUES = 1 << 22
"""The most values (channels × points) one entry's views may take: its sphere (resolution²
points), θh×θd slice, lobe and curves (:func:`entry_values`), and its albedo curves. A render
costs some 30–70 bytes per value at its peak, so an entry takes at most about 300 MB; RGB at
512 px takes 0.9 M values, 2000 channels take 28 M already at 64 px (refused)."""

MAX_CACHED_BYTES = 256 << 20
"""The most bytes of views a session keeps to redraw without recomputing."""

_log = logging.getLogger(__name__)

Reply = tuple[dict[str, Any], list[np.ndarray]]
"""A reply to the page: its JSON header and the arrays sent after it as binary frames."""


def fit_spec(data: bytes, where: str) -> str:
    """The fitted model's spec in the bytes of a ``fit.json`` written by ``brdfkit fit``,
    checked by the spec parser.

    Raises
    ------
    FormatError
        Naming ``where``, for bytes over :data:`MAX_FIT_BYTES`, not JSON, or with no ``"spec"``
        string; the parser's errors for a spec it refuses.
    """
    import json

    if len(data) > MAX_FIT_BYTES:
        raise FormatError(where, f"holds {len(data)} bytes; a fit.json has at most {MAX_FIT_BYTES}")
    try:
        record = json.loads(data)
    except (ValueError, RecursionError):
        raise FormatError(where, "is not JSON (a fit.json written by brdfkit fit)") from None
    if not isinstance(record, dict) or not isinstance(record.get("spec"), str):
        raise FormatError(where, 'has no "spec" string (a fit.json written by brdfkit fit)')
    return parse(record["spec"]).to_spec()


class Session:
    """The state behind one explorer page or widget."""

    def __init__(self, envmap: str | os.PathLike | None = None) -> None:
        """``envmap``: the environment map (``.hdr``/``.exr``) of the environment-lit sphere;
        ``None``, the bundled one (:func:`brdfkit.data.default_envmap_path`)."""
        from brdfkit.data import default_envmap_path
        from brdfkit.light.environment import EnvironmentMap

        path = Path(envmap) if envmap is not None else default_envmap_path()
        self.envmap = EnvironmentMap.from_file(path)
        self.envmap_name = path.name
        self._paths: dict[str, Path] = {}
        self._brdfs: dict[str, BRDF] = {}
        self._meshes: dict[str, MeshScene] = {}
        self._cache: OrderedDict[str, BRDF] = OrderedDict()
        self._albedo: OrderedDict[str, tuple[np.ndarray, ...]] = OrderedDict()
        self._views: OrderedDict[tuple[Any, ...], tuple[np.ndarray, ...]] = OrderedDict()
        self._lock = threading.Lock()
        self._uploads: Path | None = None
        self._upload_numbers = itertools.count()
        self._cached_bytes = 0
        self.warmed = threading.Event()
        """Set once :meth:`warm_up` has run."""

    # -- files -------------------------------------------------------------------------------
    @property
    def files(self) -> list[str]:
        """The names of the files this session may show."""
        return list(self._paths)

    def add_file(self, path: str | os.PathLike, name: str | None = None) -> str:
        """Read the measured BRDF at ``path`` now (its errors propagate) and return its name."""
        from brdfkit.interop.load import load

        path = Path(path)
        if path.suffix.lower() not in MEASURED_SUFFIXES:
            raise FormatError(path, f"must end in one of {', '.join(MEASURED_SUFFIXES)}")
        if len(self._paths) >= MAX_FILES:
            raise ProtocolError(f"a session holds at most {MAX_FILES} files")
        brdf = load(path)
        base = name or path.name
        with self._lock:  # two uploads of one name at once get distinct keys
            key, n = base, 1
            while key in self._paths:
                n += 1
                key = f"{Path(base).stem}-{n}{Path(base).suffix}"
            self._paths[key], self._brdfs[key] = path, brdf
        return key

    @property
    def meshes(self) -> list[str]:
        """The meshes the lit-object view may show: the bundled ones, then the files given."""
        return [BUNDLED_PREFIX + name for name in BUNDLED_MESHES] + list(self._meshes)

    def add_mesh(self, path: str | os.PathLike, name: str | None = None) -> str:
        """Read the mesh at ``path`` now (its errors propagate; at most :data:`MAX_MESH_FACES`
        triangles) and return its name."""
        path = Path(path)
        if path.suffix.lower() not in MESH_SUFFIXES:
            raise FormatError(path, f"must end in one of {', '.join(MESH_SUFFIXES)}")
        if len(self._meshes) >= MAX_FILES:
            raise ProtocolError(f"a session holds at most {MAX_FILES} meshes")
        scene = load_mesh(path)
        if len(scene.faces) > MAX_MESH_FACES:
            raise FormatError(
                path, f"holds {len(scene.faces)} triangles; the explorer reads {MAX_MESH_FACES}"
            )
        base = name or path.name
        with self._lock:
            key, n = base, 1
            while key in self._meshes or key.startswith(BUNDLED_PREFIX):
                n += 1
                key = f"{Path(base).stem}-{n}{Path(base).suffix}"
            self._meshes[key] = scene
        return key

    def mesh(self, name: str) -> tuple[MeshScene, tuple[float, ...]]:
        """The mesh named ``name`` (``bundled:NAME`` or a file given) and the bounding box the
        camera frames (a bundled object's, its ground left out), least corner first."""
        if name.startswith(BUNDLED_PREFIX) and name[len(BUNDLED_PREFIX) :] in BUNDLED_MESHES:
            bounds = object_bounds(name[len(BUNDLED_PREFIX) :])
            return load_mesh(name), tuple(bounds.ravel().tolist())
        if name not in self._meshes:
            raise ProtocolError(f"view.mesh: no mesh named {name[:60]!r} in this session")
        scene = self._meshes[name]
        low, high = scene.vertices.min(axis=0), scene.vertices.max(axis=0)
        return scene, (*low.tolist(), *high.tolist())

    def add_upload(self, name: str, data: bytes) -> str:
        """Write uploaded bytes into the session's own folder, read them (a measured BRDF, or
        a mesh by its suffix: :attr:`meshes`), return the name."""
        suffix = Path(name).suffix.lower()
        if suffix not in MEASURED_SUFFIXES + MESH_SUFFIXES:
            raise ProtocolError(
                f"uploaded file {name[:60]!r} must end in one of "
                f"{', '.join(MEASURED_SUFFIXES + MESH_SUFFIXES)}"
            )
        if len(data) > MAX_UPLOAD_BYTES:
            raise ProtocolError(
                f"uploaded file holds {len(data)} bytes; at most {MAX_UPLOAD_BYTES}"
            )
        safe = _safe_name(name)
        with self._lock:
            if self._uploads is None:
                self._uploads = Path(tempfile.mkdtemp(prefix="brdfkit-explore-"))
            path = self._uploads / f"{next(self._upload_numbers)}-{safe}"
        path.write_bytes(data)
        add = self.add_mesh if suffix in MESH_SUFFIXES else self.add_file
        try:
            return add(path, name=safe)
        except BrdfkitError as error:
            path.unlink()
            if isinstance(error, FormatError):  # named as the page knows it, not our path
                raise FormatError(
                    safe, error.reason, field=error.field, offset=error.offset
                ) from None
            raise

    def close(self) -> None:
        """Remove the uploads folder (only this session's own files are in it)."""
        if self._uploads is not None:
            shutil.rmtree(self._uploads, ignore_errors=True)
            self._uploads = None

    # -- BRDFs -------------------------------------------------------------------------------
    def brdf(self, entry: Entry) -> tuple[BRDF, dict[str, Any]]:
        """The BRDF of an entry and its description for the front end (canonical spec, tree
        and controls for an analytic model; the file's name for a measured one)."""
        if entry.kind == "file":
            if entry.value not in self._brdfs:
                raise ProtocolError(f"no file named {entry.value[:60]!r} in this session")
            brdf = self._brdfs[entry.value]
            return brdf, {"label": entry.value, "file": entry.value, "channels": brdf.channels}
        brdf = self._parsed(entry.kind, entry.value)
        info = {"label": brdf.to_spec(), "spec": brdf.to_spec(), "channels": brdf.channels}
        try:
            info |= {"tree": tree_of(brdf), "controls": controls_of(brdf)}
        except (BrdfkitError, ValueError):  # a model with no spec form has no sliders
            pass
        return brdf, info

    def _parsed(self, kind: str, value: Any) -> BRDF:
        brdf = brdf_of(value) if kind == "tree" else parse(value)
        key = brdf.to_spec()
        with self._lock:
            if key in self._cache:
                self._cache.move_to_end(key)
                return self._cache[key]
            self._cache[key] = brdf
            while len(self._cache) > 32:
                self._cache.popitem(last=False)
        return brdf

    # -- replies -----------------------------------------------------------------------------
    def render(self, message: Message, stale: Callable[[], bool] = lambda: False) -> Reply | None:
        """Every view of every visible entry; ``None`` as soon as ``stale()`` says a newer
        message is waiting.

        An entry's ``views`` name its arrays: ``sphere``, the lit sphere's visible pixels
        (:func:`~brdfkit.explore.views.sphere_values`) as float16
        (:func:`~brdfkit.explore.protocol.half_floats`: a third of a full float32 image's
        bytes), and ``disc``, which pixels those are (:func:`disc_bits`); ``theta_v``,
        ``theta_h``, ``theta_d``, ``slice`` and ``lobe``; the first entry's views also
        ``difference``, |first − second| of the first two spheres' pixels (from the float64
        values, as float32: it holds where the two nearly agree).
        """
        start = time.perf_counter()
        state = message.view
        arrays: list[np.ndarray] = []

        def put(a: np.ndarray) -> int:
            for index, held in enumerate(arrays):
                if held is a:  # an array shared by entries (the disc) is sent once
                    return index
            arrays.append(a)
            return len(arrays) - 1

        axes = {
            "theta_v": put(views.incidence_plane(state)[0]),
            "theta_h": put(np.radians(np.linspace(0, 90, views.CURVE_SAMPLES))),
            "theta_d": put(np.radians(np.linspace(0, 90, views.CURVE_SAMPLES))),
        }
        entries, per_entry, spheres = [], {}, []
        for entry in message.entries:
            if stale():
                return None
            try:
                brdf, info = self.brdf(entry)
            except (BrdfkitError, ValueError) as error:
                entries.append({"id": entry.id, "error": str(error)})
                continue
            entries.append({"id": entry.id, **info})
            if not entry.visible:
                continue
            try:
                affordable(brdf.channels, state.resolution)
                key = info.get("spec") or f"file:{info['file']}"
                incident = (key, state.theta_i, state.phi_i, state.sphere_resolution)
                values, sphere, theta_v, lobe = self._cached(
                    (*incident, state.irradiance), partial(self._incident_views, brdf, state)
                )
                theta_h, theta_d, slice_ = self._cached(
                    (key, state.theta_h, state.theta_d, state.phi_d),
                    partial(self._half_diff_views, brdf, state),
                )
                per_entry[entry.id] = {
                    "sphere": put(sphere),
                    "disc": put(disc_bits(state.sphere_resolution)),
                    "theta_v": put(theta_v),
                    "theta_h": put(theta_h),
                    "theta_d": put(theta_d),
                    "slice": put(slice_),
                    "lobe": put(lobe),
                }
                spheres.append((entry.id, (*incident, state.irradiance), values))
            except (BrdfkitError, ValueError, FloatingPointError, MemoryError) as error:
                entries[-1]["error"] = f"cannot evaluate: {error or 'out of memory'}"
        if len(spheres) >= 2:
            (first, key_a, a), (_, key_b, b) = spheres[:2]
            (difference,) = self._cached(
                ("difference", key_a, key_b), lambda: (np.abs(a - b).astype(np.float32),)
            )
            per_entry[first]["difference"] = put(difference)
        table, _ = array_table(arrays)
        light = state.light().direction
        header = {
            "type": "frame",
            "seq": message.seq,
            "entries": entries,
            "views": per_entry,
            "axes": axes,
            "light": [float(x) for x in light],
            "preview": state.preview,
            "arrays": table,
            "seconds": time.perf_counter() - start,
        }
        return header, arrays

    def _cached(
        self, key: tuple[Any, ...], compute: Callable[[], tuple[np.ndarray, ...]]
    ) -> tuple[np.ndarray, ...]:
        """``compute()``, remembered by ``key`` (the BRDF and the angles a view depends on):
        dragging the light recomputes only the views the light moves, and a θh/θd/φd slider
        only those it moves."""
        with self._lock:
            if key in self._views:
                self._views.move_to_end(key)
                return self._views[key]
        result = compute()
        with self._lock:
            self._views[key] = result
            self._cached_bytes += sum(a.nbytes for a in result)
            while len(self._views) > 32 or self._cached_bytes > MAX_CACHED_BYTES:
                _, dropped = self._views.popitem(last=False)
                self._cached_bytes -= sum(a.nbytes for a in dropped)
        return result

    @staticmethod
    def _incident_views(brdf: BRDF, state: views.ViewState) -> tuple[np.ndarray, ...]:
        """The views that depend on the incident direction: the sphere's visible pixels (in
        float64, and as sent), the θv curve and the lobe (f from
        :func:`~brdfkit.explore.views.fast_eval`)."""
        values = views.sphere_values(brdf, state)
        model = views.fast_eval(brdf)
        return (
            values,
            half_floats(values),
            views.theta_v_curve(model, state)[1],
            views.lobe(model, state).astype(np.float32),
        )

    @staticmethod
    def _half_diff_views(brdf: BRDF, state: views.ViewState) -> tuple[np.ndarray, ...]:
        """The θh and θd curves and the θh×θd slice, which do not depend on the light (f from
        :func:`~brdfkit.explore.views.fast_eval`)."""
        model = views.fast_eval(brdf)
        return (
            views.theta_h_curve(model, state)[1],
            views.theta_d_curve(model, state)[1],
            views.half_diff_slice(model, state).astype(np.float32),
        )

    def albedo(self, message: Message, stale: Callable[[], bool] = lambda: False) -> Reply | None:
        """The directional albedo (with its standard error) of each visible entry, from a cache
        keyed by the BRDF (it changes only when the BRDF does)."""
        arrays: list[np.ndarray] = []
        result: dict[str, Any] = {}
        theta = np.radians(np.linspace(0.0, 89.0, views.ALBEDO_ANGLES))
        for entry in message.entries:
            if not entry.visible or stale():
                continue
            try:
                brdf, info = self.brdf(entry)
                affordable(brdf.channels, message.view.resolution)
                key = info.get("spec") or f"file:{info['file']}"
                if key not in self._albedo:
                    self._albedo[key] = views.albedo(brdf)[1:]
                    while len(self._albedo) > 64:
                        self._albedo.popitem(last=False)
            except (BrdfkitError, ValueError):
                continue
            mean, stderr = self._albedo[key]
            arrays += [mean, stderr]
            result[entry.id] = {"albedo": len(arrays) - 2, "albedo_err": len(arrays) - 1}
        if stale():
            return None
        arrays.append(theta)
        table, _ = array_table(arrays)
        header = {
            "type": "albedo",
            "seq": message.seq,
            "views": result,
            "axes": {"albedo": len(arrays) - 1},
            "arrays": table,
        }
        return header, arrays

    def environment(
        self,
        message: Message,
        cancel: threading.Event,
        between_tiles: Callable[[], None] | None = None,
    ) -> Iterator[Reply]:
        """The environment-lit sphere of each visible entry: first the exact diffuse term
        (:func:`~brdfkit.explore.views.diffuse_term`, ``samples`` 0), then refined pass by pass
        (the entries' passes interleaved), until ``cancel`` is set or every sphere has its
        samples. ``noise`` is :func:`~brdfkit.explore.views.relative_noise` (``None`` for
        the diffuse term). ``between_tiles()`` is called after each tile of a pass (it may
        block: the server's passes wait there for its renders)."""
        if not message.view.envmap:
            return
        start = time.perf_counter()
        resolution = min(message.view.resolution, 256)
        mask = views.sphere_gbuffer(resolution).mask
        runs = []
        for entry in message.entries:
            if entry.visible:
                try:
                    brdf, _ = self.brdf(entry)
                    affordable(brdf.channels, resolution)
                except (BrdfkitError, ValueError):
                    continue
                if brdf.channels not in (1, self.envmap.channels):
                    continue  # a spectral BRDF under an RGB map: no environment-lit sphere
                passes = views.environment_passes(
                    brdf, self.envmap, resolution, cancel, between_tiles=between_tiles
                )
                runs.append((entry.id, passes))
                diffuse = views.diffuse_term(brdf, self.envmap, resolution)
                if diffuse is not None and not cancel.is_set():
                    yield self._pass_reply("env", message, entry.id, diffuse, 0, start, None)
        for entry_id, p in _interleaved(runs, cancel):
            noise = views.relative_noise(p, mask)
            yield self._pass_reply("env", message, entry_id, p.image, p.samples, start, noise)

    def _pass_reply(
        self,
        kind: str,
        message: Message,
        entry_id: str,
        image: np.ndarray,
        samples: int,
        start: float,
        noise: float | None,
    ) -> Reply:
        """A progressive view's image: ``kind`` ``"env"`` (the environment-lit sphere) or
        ``"lit"`` (the lit object, with its mesh and camera)."""
        image = image.astype(np.float32)
        header = {
            "type": kind,
            "seq": message.seq,
            "id": entry_id,
            "samples": samples,
            "seconds": time.perf_counter() - start,
            "noise": noise,
            "map": self.envmap_name,
            "arrays": array_table([image])[0],
        }
        if kind == "lit":
            view = message.view
            header |= {"mesh": view.mesh, "azimuth": view.azimuth, "elevation": view.elevation}
        return header, [image]

    def lit(
        self,
        message: Message,
        cancel: threading.Event,
        between_tiles: Callable[[], None] | None = None,
    ) -> Iterator[Reply]:
        """The lit object of each visible entry (:func:`~brdfkit.explore.views.lit_passes`:
        the view's mesh under the environment map, with shadows, seen by the orbiting camera),
        pass by pass (the entries' passes interleaved), until ``cancel`` is set or every image
        has its :data:`~brdfkit.explore.views.LIT_MAX_SAMPLES`. Nothing unless ``view.lit``.
        ``between_tiles`` as in :meth:`environment`.

        Raises
        ------
        ProtocolError
            For a mesh the session does not hold (at the first pass).
        """
        view = message.view
        if not view.lit:
            return
        start = time.perf_counter()
        scene, bounds = self.mesh(view.mesh)
        g = views.lit_gbuffer(scene, bounds, view.azimuth, view.elevation)
        runs = []
        for entry in message.entries:
            if not entry.visible:
                continue
            try:
                brdf, _ = self.brdf(entry)
            except (BrdfkitError, ValueError):
                continue
            if brdf.channels in (1, self.envmap.channels):
                passes = views.lit_passes(
                    brdf, scene, g, self.envmap, cancel, between_tiles=between_tiles
                )
                runs.append((entry.id, passes))
        for entry_id, p in _interleaved(runs, cancel):
            noise = views.relative_noise(p, g.mask)
            yield self._pass_reply("lit", message, entry_id, p.image, p.samples, start, noise)

    def warm_up(self, specs: Sequence[str], files: Sequence[str] = ()) -> None:
        """Build, before the page asks, what the views of ``specs`` and of the session's
        ``files`` need: the compiled float64 ``eval`` of the directional-light sphere
        (:func:`~brdfkit.explore.views.build_fast_eval`), and for the specs the
        environment-lit sphere's map tables and compiled kernels, of the very BRDF objects
        the page's messages resolve to (:meth:`brdf` keeps them by spec and by file; kernels
        are kept per object). In a fresh process the first renders otherwise run on NumPy
        while the kernels build."""
        from brdfkit.render.compiled_shading import compiled_shader

        for name in files:
            if name in self._brdfs:
                views.build_fast_eval(self._brdfs[name])
        for spec in specs or ([] if files else ["lambertian + ggx"]):
            try:
                brdf = self._parsed("spec", spec)
            except (BrdfkitError, ValueError):
                continue
            views.build_fast_eval(brdf)
            plan = compiled_shader(brdf, [self.envmap], method="auto")
            if plan is not None:
                plan[0].build()
            # then the map's tables, on the kernels just built (with none built, progressive
            # would start a background build that outlives the warm-up)
            for _ in views.environment_passes(brdf, self.envmap, 32, max_samples=1):
                pass
        self.warmed.set()

    def checks(self, message: Message) -> Reply:
        """The physics checks (:func:`brdfkit.checks.check`) of the message's entry."""
        from brdfkit.checks.properties import check

        entry = message.entries[0]
        brdf, _ = self.brdf(entry)
        report = check(brdf)
        return {
            "type": "checks",
            "seq": message.seq,
            "id": entry.id,
            "report": report.to_dict(),
            "arrays": [],
        }, []

    def handle(self, message: Message) -> list[Reply]:
        """Every reply to one message, in turn (the notebook widget's synchronous path): a
        render is followed by its albedo curves; a failure is an error reply (:func:`guarded`)."""
        if message.type == "checks":
            works = [partial(self.checks, message)]
        else:
            works = [partial(self.render, message), partial(self.albedo, message)]
        replies = [guarded(message.seq, work) for work in works]
        return [r for r in replies if r is not None]


def _interleaved(
    runs: list[tuple[str, Iterator[Pass]]], cancel: threading.Event
) -> Iterator[tuple[str, Pass]]:
    """``(id, pass)`` of each run in turn, one pass each, until all end or ``cancel`` is set."""
    runs = list(runs)
    while runs and not cancel.is_set():
        for run in list(runs):
            entry_id, passes = run
            p = next(passes, None)
            if p is None or cancel.is_set():
                runs.remove(run)
                continue
            yield entry_id, p


def error_reply(seq: int, error: Exception | str) -> Reply:
    """The reply to a message that could not be acted on."""
    return {"type": "error", "seq": seq, "message": str(error)[:500], "arrays": []}, []


def guarded(seq: int, work: Callable[[], Reply | None]) -> Reply | None:
    """``work()``, or the error reply to message ``seq`` for whatever it raised: the page is
    always answered and its connection keeps serving. Bad input is reported as itself; anything
    else (a bug, memory exhausted) is logged with its traceback and reported as such."""
    try:
        return work()
    except (BrdfkitError, ValueError) as error:
        return error_reply(seq, error)
    except MemoryError:
        _log.error("explorer message %d: out of memory", seq)
        return error_reply(seq, "not enough memory for this view: show fewer channels or pixels")
    except Exception as error:  # logged and answered, never dropped
        _log.error("explorer message %d failed", seq, exc_info=error)
        return error_reply(seq, f"internal error ({type(error).__name__}); see the server's log")


@lru_cache(maxsize=4)
def disc_bits(resolution: int) -> np.ndarray:
    """Which pixels of the lit sphere at ``resolution`` are visible
    (``views.sphere_disk(resolution).mask``), as bits packed along each row, most
    significant first (``np.packbits(mask, axis=1)``), ``(R, ⌈R/8⌉)`` uint8: the order of
    the frame's ``sphere`` values (cached: the same array while the resolution stays, so a
    frame leaves it out once the page holds it).

    Examples
    --------
    >>> bits = disc_bits(8)
    >>> bits.shape, np.unpackbits(bits, axis=1)[4].tolist()
    ((8, 1), [1, 1, 1, 1, 1, 1, 1, 1])
    """
    return np.packbits(views.sphere_disk(resolution).mask, axis=1)


def entry_values(channels: int, resolution: int) -> int:
    """The values (channels × points) of one entry's views at ``resolution``: its sphere, the
    θh×θd slice, the lobe, four curves and the albedo curves' samples."""
    points = (
        resolution**2
        + views.SLICE_RESOLUTION**2
        + math.prod(views.LOBE_GRID)
        + 3 * views.CURVE_SAMPLES
        + views.ALBEDO_ANGLES * views.ALBEDO_SAMPLES
    )
    return channels * points


def affordable(channels: int, resolution: int) -> None:
    """Refuse an entry whose views would exceed :data:`MAX_ENTRY_VALUES`, before computing.

    Raises
    ------
    brdfkit.errors.ResourceError
        Naming the channels, the resolution and the limit.
    """
    values = entry_values(channels, resolution)
    if values > MAX_ENTRY_VALUES:
        raise ResourceError(
            f"{channels} channels at {resolution} px need {values} values; an entry may take "
            f"at most {MAX_ENTRY_VALUES} (lower the resolution or the number of channels)"
        )


def _safe_name(name: str) -> str:
    """An uploaded file's name made safe for a path: its characters, cut to 64 with its suffix
    kept (a long name cut through its suffix was refused for the suffix it lost)."""
    base = Path(name).name
    safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in base)
    if len(safe) <= 64:
        return safe
    stem, suffix = Path(safe).stem, Path(safe).suffix
    return stem[: 64 - len(suffix)] + suffix


__all__ = [
    "MAX_CACHED_BYTES",
    "MAX_ENTRY_VALUES",
    "MAX_FIT_BYTES",
    "MAX_MESH_FACES",
    "MAX_UPLOAD_BYTES",
    "MEASURED_SUFFIXES",
    "Session",
    "affordable",
    "disc_bits",
    "entry_values",
    "error_reply",
    "fit_spec",
    "guarded",
]
