"""The output discipline every command follows (DESIGN.md §6).

A command names its outputs and its inputs *before* it starts working, and these checks run:

- an output is never an input, nor inside an input folder;
- an output folder is a folder (an existing file there is an error), an output file is not an
  existing folder;
- the place can be written (a probe file is created and removed in the nearest existing folder);
- in an output folder, an existing file of the same name as one the command writes is replaced
  only if this command wrote it before (the folder's :data:`MANIFEST` records each file it wrote
  with its SHA-256); anything else in the folder is never touched, and a file of the
  manifest's name that brdfkit did not write makes the folder an error, so that it is kept.

Each file is then written atomically (:func:`brdfkit.io.atomic_write`: a temporary beside it,
renamed when complete, with the umask's mode); any failure to write it (a full disk, a short
write) names the file and leaves no temporary. A file named directly with ``-o`` is what the
user asked for, so it is replaced, unless it is an input.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path

from brdfkit.cli._app import shown
from brdfkit.errors import OutputError

MANIFEST = ".brdfkit-outputs.json"
"""The record, in an output folder, of the files brdfkit wrote there (name → SHA-256)."""


def _resolved(path: Path) -> Path:
    return Path(os.path.abspath(path)).resolve()


def _inside(path: Path, folder: Path) -> bool:
    return path == folder or folder in path.parents


def _check_not_input(output: Path, inputs: Iterable[Path | None], option: str) -> None:
    """Refuse an output that is an input or lies inside an input folder."""
    target = _resolved(output)
    for source in inputs:
        if source is None or not Path(source).exists():
            continue
        origin = _resolved(Path(source))
        if target == origin:
            raise OutputError(
                f"{option} {shown(output)} is an input of this command; "
                "choose another path so that the input is kept"
            )
        if origin.is_dir() and _inside(target, origin):
            raise OutputError(
                f"{option} {shown(output)} lies inside the input folder {shown(source)}; "
                "choose a path outside it"
            )


def _check_writable(path: Path, option: str) -> None:
    """Probe that ``path`` (a file or folder to create) can be written, before any work."""
    ancestor = Path(os.path.abspath(path)).parent
    while not ancestor.exists():
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise OutputError(f"{option} {shown(path)} cannot be written: {shown(ancestor)} is a file")
    try:
        handle, probe = tempfile.mkstemp(prefix=".brdfkit-probe-", dir=ancestor)
    except OSError as error:
        reason = error.strerror or type(error).__name__
        raise OutputError(
            f"{option} {shown(path)} cannot be written: {shown(ancestor)}: {reason}"
        ) from None
    os.close(handle)
    os.unlink(probe)


def output_file(
    path: Path,
    *,
    inputs: Iterable[Path | None] = (),
    option: str = "--output",
    suffixes: tuple[str, ...] = (),
) -> Path:
    """Check, before any work, that ``path`` can take a command's output file.

    Raises
    ------
    OutputError
        ``path`` is an existing folder, an input, inside an input folder, or not writable.
    brdfkit.errors.ParameterError
        ``path`` does not end in one of ``suffixes`` (when given).
    """
    from brdfkit.errors import ParameterError

    path = Path(path)
    if path.is_dir():
        raise OutputError(f"{option} {shown(path)} is an existing folder; expected a file name")
    if suffixes and path.suffix.lower() not in suffixes:
        raise ParameterError(
            f"{option} must end in {', '.join(suffixes)}; got {shown(path.name)!r}"
        )
    _check_not_input(path, inputs, option)
    _check_writable(path, option)
    return path


class OutputFolder:
    """A command's output folder: checked before the work, then written file by file.

    Parameters
    ----------
    path : Path
        The folder (created when the first file is written).
    files : iterable of str
        The names of every file the command may write there.
    inputs : iterable of Path
        The command's inputs (files or folders).
    option : str
        The option's name, for messages.

    Raises
    ------
    OutputError
        The folder is an existing file, an input or inside one, cannot be written, or holds a
        file of one of ``files``' names that brdfkit did not write.
    """

    def __init__(
        self,
        path: Path,
        files: Iterable[str],
        *,
        inputs: Iterable[Path | None] = (),
        option: str = "--output",
    ) -> None:
        self.path = Path(path)
        self.files = tuple(files)
        self.option = option
        if self.path.exists() and not self.path.is_dir():
            raise OutputError(f"{option} {shown(self.path)} is an existing file; expected a folder")
        _check_not_input(self.path, inputs, option)
        _check_writable(self.path / MANIFEST, option)
        self._written = self._manifest()
        for name in self.files:
            self._check_ours(name)

    def _check_ours(self, name: str) -> None:
        """Refuse to replace ``name`` unless it is absent or brdfkit wrote it as it is."""
        target = self.path / name
        if target.exists() and self._written.get(name) != _digest(target):
            raise OutputError(
                f"{self.option} {shown(self.path)} already holds {shown(name)}, which brdfkit did "
                "not write there (or which was changed since); choose a new or empty folder so "
                "that it is kept"
            )

    def _manifest(self) -> dict[str, str]:
        """The files brdfkit wrote here, from the folder's :data:`MANIFEST` (none if absent).

        Raises
        ------
        OutputError
            The folder holds a file of that name that brdfkit did not write (not a manifest of
            brdfkit's form): it is never replaced.
        """
        path = self.path / MANIFEST
        if not path.exists():
            return {}
        try:
            record = json.loads(path.read_text(encoding="utf-8"))
            if record.get("written_by") != "brdfkit":
                raise ValueError("not brdfkit's")
            return {str(k): str(v) for k, v in record["files"].items()}
        except (OSError, ValueError, KeyError, TypeError, AttributeError):
            raise OutputError(
                f"{self.option} {shown(self.path)} already holds {MANIFEST}, which brdfkit did "
                "not write (brdfkit records its outputs in a file of that name); choose a new "
                "or empty folder so that it is kept"
            ) from None

    def _record(self, name: str, target: Path) -> None:
        """Add ``name`` to the folder's :data:`MANIFEST`, having checked that the manifest is
        still brdfkit's (a file put there meanwhile is kept)."""
        from brdfkit.io import atomic_write

        self._written = {**self._manifest(), **self._written, name: _digest(target)}
        record = {"written_by": "brdfkit", "files": dict(sorted(self._written.items()))}
        atomic_write(
            self.path / MANIFEST, lambda tmp: tmp.write_text(json.dumps(record, indent=1) + "\n")
        )

    def write(self, name: str, write_fn: Callable[[Path], object]) -> Path:
        """Write the file ``name`` atomically with ``write_fn(path)`` and record it."""
        from brdfkit.io import atomic_write

        if name not in self.files:
            raise AssertionError(f"{name!r} is not among the declared outputs {self.files}")
        self._check_ours(name)  # again: the file may have appeared while the command worked
        target = self.path / name
        # Each encoder writes to the path it is given: the temporary, renamed when complete.
        atomic_write(target, write_fn)
        self._record(name, target)
        return target

    def write_folder(self, name: str, write_fn: Callable[[Path], object]) -> Path:
        """Write the folder ``name`` (a Zarr store, say) with ``write_fn(path)`` into a
        temporary folder beside it, then put it in place and record it; an earlier version
        (which brdfkit wrote, see :meth:`write`) is moved aside first and removed after."""
        import shutil

        from brdfkit.io import output_failure

        if name not in self.files:
            raise AssertionError(f"{name!r} is not among the declared outputs {self.files}")
        self._check_ours(name)
        target = self.path / name
        self.path.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=".brdfkit-", dir=self.path))
        try:
            write_fn(tmp / "new")
            old = tmp / "old"
            if target.exists():
                os.replace(target, old)
            os.replace(tmp / "new", target)
        except OSError as error:
            raise output_failure(target, error, tmp) from error
        finally:
            shutil.rmtree(tmp, ignore_errors=True)  # our temporary, and the version we replaced
        self._record(name, target)
        return target


def _digest(path: Path) -> str:
    """``sha256:<hex>`` of a file's contents (of a folder's: names and contents, sorted)."""
    digest = hashlib.sha256()
    if path.is_dir():
        for item in sorted(p for p in path.rglob("*") if p.is_file()):
            digest.update(f"{item.relative_to(path).as_posix()}\0{_digest(item)}\0".encode())
        return f"sha256:{digest.hexdigest()}"
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return f"sha256:{digest.hexdigest()}"


def light_files(specs: Iterable[str]) -> list[Path]:
    """The files that light specs read (``envmap:PATH[:SCALE]``), as inputs to protect."""
    return [Path(spec.split(":")[1]) for spec in specs if spec.startswith("envmap:")]
