"""Walk the brdfkit package and write the API reference pages (run by ``conf.py``).

Every public module (no ``_`` in its dotted name; ``brdfkit.cli`` is the command line and is
documented by ``brdfkit --help``) gets a page with its docstring and a table of its public
names; each public name gets a page of its own (autosummary stubs), written once, at its
*canonical* place: the shallowest public module that exports the very same object under the
same name and is the object's own module or a package above it. ``brdfkit.brdf.GGX`` is
documented there; ``brdfkit.brdf.microfacet``'s page links to it. A module's public names are
its ``__all__``; a module without ``__all__`` offers the functions and classes it defines and
does not start with ``_``.

The test ``tests/test_docs.py`` imports this file to check that every page exists.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from pathlib import Path

PACKAGE = "brdfkit"
EXCLUDED = ("brdfkit.cli",)  # the command line: its reference is `brdfkit --help`


def public_modules() -> list[str]:
    """Dotted names of every public module of brdfkit, the package first, sorted."""
    pkg = importlib.import_module(PACKAGE)
    names = [PACKAGE]
    for info in pkgutil.walk_packages(pkg.__path__, PACKAGE + "."):
        name = info.name
        if any(part.startswith("_") for part in name.split(".")):
            continue
        if any(name == e or name.startswith(e + ".") for e in EXCLUDED):
            continue
        names.append(name)
    return sorted(names)


def public_names(modname: str) -> list[str]:
    """The names a module offers: ``__all__``, else what it defines itself."""
    mod = importlib.import_module(modname)
    if hasattr(mod, "__all__"):
        return list(mod.__all__)
    out = []
    for name, obj in vars(mod).items():
        if name.startswith("_") or inspect.ismodule(obj):
            continue
        if (inspect.isclass(obj) or inspect.isfunction(obj)) and obj.__module__ == modname:
            out.append(name)
    return sorted(out)


def _ancestors(modname: str) -> list[str]:
    parts = modname.split(".")
    return [".".join(parts[:i]) for i in range(1, len(parts) + 1)]


def canonical_map() -> dict[tuple[str, str], str]:
    """``(module, name)`` → the full name of the page that documents it."""
    modules = public_modules()
    exports = {m: public_names(m) for m in modules}
    result = {}
    for modname in modules:
        mod = importlib.import_module(modname)
        for name in exports[modname]:
            obj = getattr(mod, name)
            home = modname
            own = getattr(obj, "__module__", None) if callable(obj) else None
            # the shallowest ancestor of the module (or of the object's own module) that
            # exports the same object under the same name
            chain = _ancestors(own) if isinstance(own, str) else _ancestors(modname)
            if modname not in chain:
                chain = _ancestors(modname)
            for anc in chain:
                if anc in exports and name in exports[anc]:
                    if getattr(importlib.import_module(anc), name) is obj:
                        home = anc
                        break
            result[(modname, name)] = f"{home}.{name}"
    return result


def _title(text: str) -> str:
    return f"{text}\n{'=' * len(text)}\n"


def write_pages(outdir: Path) -> list[str]:
    """Write ``outdir/<module>.rst`` for every public module; return the module names."""
    outdir.mkdir(parents=True, exist_ok=True)
    cmap = canonical_map()
    modules = public_modules()
    wanted = set()
    for modname in modules:
        own = [n for n in public_names(modname) if cmap[(modname, n)] == f"{modname}.{n}"]
        elsewhere = [n for n in public_names(modname) if n not in own]
        lines = [_title(f"``{modname}``"), f".. automodule:: {modname}", "   :no-members:", ""]
        subs = [m for m in modules if m.rpartition(".")[0] == modname]
        if own:
            lines += [
                ".. currentmodule:: " + modname,
                "",
                ".. autosummary::",
                "   :toctree: generated",
                "   :nosignatures:",
                "",
            ]
            lines += [f"   {n}" for n in own]
            lines.append("")
        if elsewhere:
            lines += ["Also offered here (documented where they are exported first):", ""]
            lines += [f"- :py:obj:`{modname}.{n} <{cmap[(modname, n)]}>`" for n in elsewhere]
            lines.append("")
        if subs:
            lines += ["Modules", "-------", "", ".. toctree::", "   :maxdepth: 1", ""]
            lines += [f"   {m}" for m in subs]
            lines.append("")
        text = "\n".join(lines)
        path = outdir / f"{modname}.rst"
        wanted.add(path.name)
        if not path.exists() or path.read_text() != text:  # keep mtimes for incremental builds
            path.write_text(text)
    for stale in outdir.glob(PACKAGE + "*.rst"):
        if stale.name not in wanted:
            stale.unlink()
    return modules
