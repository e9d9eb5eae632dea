"""Reader of the BRDF benchmark project's fit files (bsdfbenchmark/bbm, ``*.fit``).

Each line after the ``#`` header reads ``name = Aggregate(Lambertian(albedo = [r, g, b]),
Model(param = value, ...))``: a Lambertian plus one specular model of ``ngan.h``/``low.h``/
``bagher.h``, with numbers, lists and lists of lists as values. The right-hand side is a Python
expression, read with :func:`ast.parse` and only literals interpreted (never evaluated).

References
----------
.. [1] P. Peers et al., BRDF benchmark ``bbm`` (BSD-3), https://github.com/bsdfbenchmark/bbm
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from brdfkit.errors import FormatError


@dataclass(frozen=True)
class FitEntry:
    """One material of a fit file: its Lambertian albedo, the specular model's name and
    parameters (numbers and lists, as in the file)."""

    diffuse: list[float]
    model: str
    params: dict[str, Any]


def _call(node: ast.expr, where: str) -> tuple[str, list[ast.expr], dict[str, Any]]:
    if not isinstance(node, ast.Call) or not isinstance(node.func, ast.Name):
        raise FormatError(f"{where}: expected Model(name = value, ...)")
    try:
        params = {kw.arg: ast.literal_eval(kw.value) for kw in node.keywords}
    except ValueError:
        raise FormatError(f"{where}: parameters must be numbers or lists of numbers") from None
    return node.func.id, node.args, params


def read_fit_file(path: str | Path) -> tuple[list[str], dict[str, FitEntry]]:
    """The header comments and the materials of the fit file ``path``, in file order.

    Raises
    ------
    brdfkit.errors.FormatError
        Naming the file and line of a line that is no ``name = Aggregate(Lambertian(albedo =
        [...]), Model(...))``.
    """
    path = Path(path)
    header: list[str] = []
    entries: dict[str, FitEntry] = {}
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        line = line.strip()
        if not line:
            continue
        if line.startswith("#"):
            header.append(line.lstrip("# ").rstrip())
            continue
        where = f"{path}:{number}"
        name, sep, expression = line.partition("=")
        try:
            tree = ast.parse(expression.strip(), mode="eval")
        except SyntaxError:
            raise FormatError(f"{where}: not a fit line") from None
        outer, args, _ = _call(tree.body, where)
        if not sep or outer != "Aggregate" or len(args) != 2:
            raise FormatError(f"{where}: expected name = Aggregate(Lambertian(...), Model(...))")
        diffuse_name, _, diffuse = _call(args[0], where)
        model, _, params = _call(args[1], where)
        if diffuse_name != "Lambertian" or set(diffuse) != {"albedo"}:
            raise FormatError(f"{where}: the first term must be Lambertian(albedo = [...])")
        entries[name.strip()] = FitEntry(list(map(float, diffuse["albedo"])), model, params)
    return header, entries


def tables_from_fit_files(directory: str | Path) -> dict[str, Any]:
    """The preset tables brdfkit ships (``brdfkit/data/materials/bbm_fits.json``), built from
    the ``*.fit`` files in ``directory``: per source (the file's stem) its file name, model,
    header (the citation) and, per material, the Lambertian albedo and the model's parameters.
    """
    sources: dict[str, Any] = {}
    for path in sorted(Path(directory).glob("*.fit")):
        header, entries = read_fit_file(path)
        models = sorted({entry.model for entry in entries.values()})
        if len(models) != 1:
            raise FormatError(f"{path}: expected one model per file; got {models}")
        sources[path.stem] = {
            "file": path.name,
            "model": models[0],
            "header": header,
            "materials": {
                name: {"diffuse": entry.diffuse, "params": entry.params}
                for name, entry in entries.items()
            },
        }
    return {"licence": "LICENSE.bbm", "sources": sources}


__all__ = ["FitEntry", "read_fit_file", "tables_from_fit_files"]
