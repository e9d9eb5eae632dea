"""Batch fitting: every measured file × every model as one Dask task, with a results table
keyed by what determines a fit (so that a re-run skips what is done).

A fit is determined by the bytes of its file and its options (model spec, objective, loss,
loss scale, mode, starts, fixed parameters, seed): :attr:`FitTask.key` hashes exactly these, so
renaming or moving a file keeps its results, and changing a byte or an option makes a new fit.
Tasks return their record to the client, which alone writes files: a task that Dask runs again
(its worker died) cannot write twice, and workers need no access to the output folder.

A file is read, checked against its planned hash and made into the samples a fit uses
(:func:`prepare`) once per batch, by one task that all its fits depend on: a user fits each file
with several models, and for a MERL table this preparation passes over the 1.46 M-entry table
several times, which costs as much as a two-lobe fit and is bound by the memory bandwidth that
the workers share. Dask runs the fits where their file's samples are (it moves them, 80 MB for
MERL, only when that pays), keeps the samples while fits of them wait and prepares them again
if their worker dies.

References
----------
.. [1] A. Ngan, F. Durand, W. Matusik, "Experimental analysis of BRDF models", EGSR 2005 (the
   100 MERL materials × 7 models study this kind of batch serves).
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import traceback
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from brdfkit.errors import BrdfkitError, FormatError, ParameterError

READERS = {".binary": "read_merl", ".bsdf": "read_rgl", ".brdf": "read_cornell"}
"""The reader of each measured format, by file suffix."""

TABLE_COLUMNS = ("key", "file", "model", "status", "spec", "cost", "nfev", "samples",
                 "success", "seconds", "message")  # fmt: skip
"""The first columns of ``results.csv``; the errors and parameters follow, by name."""


def file_sha256(path: str | Path) -> str:
    """``sha256:<hex>`` of a file's bytes.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = Path(folder) / "paint.binary"
    ...     _ = path.write_bytes(b"abc")
    ...     file_sha256(path)
    'sha256:ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad'
    """
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return f"sha256:{digest.hexdigest()}"


@dataclass(frozen=True)
class FitTask:
    """One fit of a batch: a measured file, a model spec and the options of
    :func:`brdfkit.fit.fit` (``objective``, ``loss``, ``loss_scale``, ``mode``, ``starts``,
    ``fixed``, ``seed``)."""

    file: str
    file_sha256: str
    model: str
    options: dict[str, Any] = field(default_factory=dict)

    @property
    def key(self) -> str:
        """16 hex digits of SHA-256 over the file's hash, the spec and the options."""
        identity = {"file_sha256": self.file_sha256, "model": self.model, **self.options}
        text = json.dumps(identity, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    @property
    def folder(self) -> str:
        """The fit's sub-folder name: the file's stem (safe characters) and the key."""
        stem = "".join(c if c.isalnum() or c in "-_." else "_" for c in Path(self.file).stem)
        return f"{stem[:60]}-{self.key}"


def tasks(files: Iterable[str | Path], models: Iterable[str], **options: Any) -> list[FitTask]:
    """Every file × model as a :class:`FitTask` (files hashed here, once each).

    Raises
    ------
    brdfkit.errors.FormatError
        A file that does not exist or whose suffix no reader takes.

    Examples
    --------
    A task's key follows the file's bytes and the options, not the file's name:

    >>> import tempfile
    >>> from pathlib import Path
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = Path(folder) / "paint.binary"
    ...     _ = path.write_bytes(b"abc")
    ...     planned = tasks([path], ["lambertian", "lambertian + ggx"], starts=2)
    ...     path = path.rename(Path(folder) / "renamed.binary")
    ...     again = tasks([path], ["lambertian", "lambertian + ggx"], starts=2)
    >>> [task.model for task in planned], [t.key for t in planned] == [t.key for t in again]
    (['lambertian', 'lambertian + ggx'], True)
    >>> planned[0].folder == f"paint-{planned[0].key}"
    True
    """
    models = list(models)
    options = {k: (list(v) if isinstance(v, tuple | list) else v) for k, v in options.items()}
    result = []
    for file in files:
        path = Path(file)
        if not path.is_file():
            raise FormatError(path, "file does not exist")
        if path.suffix.lower() not in READERS:
            raise FormatError(path, f"must end in {', '.join(READERS)}")
        digest = file_sha256(path)
        result += [FitTask(str(path), digest, model, dict(options)) for model in models]
    return result


def prepare(task: FitTask) -> Any:
    """The measurements :func:`brdfkit.fit.fit` fits for ``task`` (a worker's task): its file
    read and checked against the planned hash, then :func:`brdfkit.fit.fit_data` at the task's
    seed (which draws the samples of a BRDF that is no table); or, when the file or the seed is
    refused, the error's message (a ``str``), which each fit of it reports."""
    import brdfkit.measured as measured_io
    from brdfkit.fit.analytic import fit_data

    try:
        seed = task.options.get("seed", 0)
        if not isinstance(seed, int) or isinstance(seed, bool) or not 0 <= seed < 2**63:
            raise ParameterError(f"seed must be an integer in [0, {2**63 - 1}]; got {seed!r:.40}")
        if file_sha256(task.file) != task.file_sha256:
            raise FormatError(task.file, "changed since the batch was planned")
        reader = getattr(measured_io, READERS[Path(task.file).suffix.lower()])
        return fit_data(reader(task.file), seed=seed)
    except Exception as error:
        return _message(error)


def fit_prepared(task: FitTask, measurements: Any) -> dict[str, Any]:
    """Run one fit on the ``measurements`` of :func:`prepare` (a worker's task); return its
    record: the task's identity and :meth:`brdfkit.fit.FitResult.to_dict`, ``status``
    ``"ok"``; or ``status`` ``"error"`` and the error's message when the file or the options
    are refused (or the fit fails)."""
    from brdfkit.fit.analytic import build_kernels, fit

    record: dict[str, Any] = {
        "key": task.key,
        "file": task.file,
        "file_sha256": task.file_sha256,
        "model": task.model,
        "options": task.options,
    }
    if isinstance(measurements, str):
        return {**record, "status": "error", "message": measurements}
    try:
        build_kernels(task.model)  # once per worker and structure (the disk cache after that)
        result = fit(measurements, task.model, **task.options)
    except Exception as error:
        return {**record, "status": "error", "message": _message(error)}
    return {**record, "status": "ok", **result.to_dict()}


def fit_one(task: FitTask) -> dict[str, Any]:
    """:func:`fit_prepared` on :func:`prepare` of ``task``: one fit in this process."""
    return fit_prepared(task, prepare(task))


def _message(error: Exception) -> str:
    """A refused input's message; for any other exception (a bug, which must not stop the
    batch) its type, message and where it was raised. Call it in the ``except`` block."""
    if isinstance(error, BrdfkitError | ValueError | OSError):
        return str(error) or type(error).__name__
    where = traceback.format_exc(limit=-1).strip().splitlines()[-2].strip()
    return f"{type(error).__name__}: {error} ({where})"


def run(
    dask_client: Any,
    batch: Iterable[FitTask],
    on_result: Callable[[FitTask, dict[str, Any]], None],
) -> None:
    """Fit every task of ``batch`` on ``dask_client``; call ``on_result(task, record)`` as each
    finishes (once per task, in the order they finish).

    Each file is prepared by one task per seed (:func:`prepare`), which its fits
    (:func:`fit_prepared`) depend on. Tasks are named by their keys (``prepare-<key of the
    first fit>``, ``fit-<key>``), so a fit that Dask runs again after its worker died still
    yields one result.
    """
    from distributed import as_completed

    by_key = {task.key: task for task in batch}
    prepared: dict[tuple[str, str], Any] = {}  # by (file hash, seed)
    futures = {}
    for key, task in by_key.items():
        content = (task.file_sha256, json.dumps(task.options.get("seed", 0), default=repr))
        if content not in prepared:
            prepared[content] = dask_client.submit(
                prepare, task, key=f"prepare-{key}", pure=False, retries=0
            )
        future = dask_client.submit(
            fit_prepared, task, prepared[content], key=f"fit-{key}", pure=False, retries=0
        )
        futures[future] = key
    del prepared  # the samples are kept only while fits of them wait
    for future, record in as_completed(futures, with_results=True):
        on_result(by_key[futures[future]], record)


def read_records(text: str) -> dict[str, dict[str, Any]]:
    """The records of a ``results.jsonl`` text by key (unreadable lines are skipped).

    Examples
    --------
    >>> text = jsonl([{"key": "k1", "model": "lambertian", "status": "ok"}]) + "{truncated\\n"
    >>> read_records(text)
    {'k1': {'key': 'k1', 'model': 'lambertian', 'status': 'ok'}}
    """
    records = {}
    for line in text.splitlines():
        try:
            record = json.loads(line)
        except ValueError:
            continue
        if isinstance(record, dict) and isinstance(record.get("key"), str):
            records[record["key"]] = record
    return records


def jsonl(records: Iterable[dict[str, Any]]) -> str:
    """Records as JSON lines, one per record.

    Examples
    --------
    >>> print(jsonl([{"key": "k1", "errors": {"rmse": 0.1}}, {"key": "k2"}]), end="")
    {"key": "k1", "errors": {"rmse": 0.1}}
    {"key": "k2"}
    """
    return "".join(json.dumps(r, ensure_ascii=False, allow_nan=False) + "\n" for r in records)


def table(records: Iterable[dict[str, Any]]) -> str:
    """Records as CSV: :data:`TABLE_COLUMNS`, then ``error.<name>`` and ``param.<name>``
    columns (the union over the records; a colour parameter's values joined by spaces).

    Examples
    --------
    >>> record = {"key": "k1", "model": "lambertian", "status": "ok", "errors": {"rmse": 0.1},
    ...           "params": {"0.lambertian.rho": [0.5, 0.4, 0.3]}}
    >>> print(table([record]), end="")
    key,file,model,status,spec,cost,nfev,samples,success,seconds,message,error.rmse,param.0.lambertian.rho
    k1,,lambertian,ok,,,,,,,,0.1,0.5 0.4 0.3
    """
    records = list(records)
    rows, extra = [], {}
    for record in records:
        row = {name: record.get(name, "") for name in TABLE_COLUMNS}
        for prefix, values in (
            ("error", record.get("errors", {})),
            ("param", record.get("params", {})),
        ):
            for name, value in values.items():
                column = f"{prefix}.{name}"
                extra[column] = None
                row[column] = " ".join(map(repr, value)) if isinstance(value, list) else repr(value)
        rows.append(row)
    stream = io.StringIO()
    writer = csv.DictWriter(stream, [*TABLE_COLUMNS, *extra], restval="", lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return stream.getvalue()
