"""What building a model's compiled kernels costs: tracing its array code, compiling the result.

For a few models (GGX gold, Principled, a Lambertian + GGX sum, a BRDF Explorer file), the
``eval``, ``pdf`` and ``sample`` kernels of the model's structure in float32: the seconds
:func:`brdfkit.compiled.codegen.generate` takes to trace the model's own code on symbolic
arrays and write the kernel's source (best of ``--repeats``), the source's lines, and the
seconds numba then takes to compile it (once, no disk cache). Where JAX is installed, the
seconds :func:`jax.make_jaxpr` alone takes to trace the same function on a batch of one: what
the compiled path spent in JAX before it traced without it (a lower bound of that tracer's
time, which then also interpreted the jaxpr), timed interleaved with ours.

``python benchmarks/bench_tracer.py [--repeats 5]``; results go to
``benchmarks/results/tracer.json``. The machine is shared: read the ratios.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

os.environ["BRDFKIT_CACHE_DIR"] = ""  # no disk cache: every compile is timed

import brdfkit
from brdfkit.brdf import MODELS, Lambertian
from brdfkit.compiled import codegen, structure
from brdfkit.compiled.compiled_brdf import _method
from brdfkit.compiled.kernel import compile_traced

BRDF_EXPLORER = Path(os.environ.get("BRDFKIT_DATA", "../shared/data")) / "brdf_explorer"
METHODS = (("eval", (3, 3)), ("pdf", (3, 3)), ("sample", (3, 2)))


def models() -> dict[str, Any]:
    ggx = MODELS["ggx"](alpha=0.3, material="Au")
    found = {
        "ggx": ggx,
        "principled": MODELS["principled"](),
        "lambertian+ggx": Lambertian([0.5, 0.4, 0.3]) + ggx,
    }
    walter = BRDF_EXPLORER / "walter.brdf"
    if walter.exists():
        found["brdf_explorer walter"] = brdfkit.load(walter)
    return found


def traced_method(model: Any, method: str) -> tuple[Any, list[tuple[int, ...]]]:
    """The model's ``method`` as :class:`brdfkit.compiled.CompiledBRDF` traces it: a function
    of the parameters and the inputs, with the parameters' shapes, for the model's structure;
    the method itself (values baked in, no parameters) where the model's constructor needs
    values or the model has no structure key."""
    try:
        _, values = structure.split(model)
    except TypeError:
        return _method(model, method), []
    shapes = [tuple(np.shape(v)) for v in values]

    def traced(*args: Any) -> Any:
        rebuilt = structure.rebuild(model, iter(args[: len(shapes)]))
        return _method(rebuilt, method)(*args[len(shapes) :])

    widths = dict(METHODS)[method]
    try:
        codegen.generate(traced, widths, np.dtype(np.float32), shapes)
    except (ValueError, TypeError):
        return _method(model, method), []
    return traced, shapes


def jax_trace_seconds(fn: Any, widths: tuple[int, ...], shapes: list[tuple[int, ...]]) -> float:
    import jax

    args = [jax.ShapeDtypeStruct(s, np.float32) for s in shapes]
    args += [jax.ShapeDtypeStruct((1, w), np.float32) for w in widths]
    start = time.perf_counter()
    jax.make_jaxpr(lambda *a: fn(*a))(*args)  # a new function: no trace cached
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    with_jax = importlib.util.find_spec("jax") is not None
    rows = []
    for name, model in models().items():
        for method, widths in METHODS:
            fn, shapes = traced_method(model, method)
            ours, theirs = [], []
            for _ in range(args.repeats):  # interleaved
                start = time.perf_counter()
                generated = codegen.generate(fn, widths, np.dtype(np.float32), shapes)
                ours.append(time.perf_counter() - start)
                if with_jax:
                    theirs.append(jax_trace_seconds(fn, widths, shapes))
            kernel = compile_traced(fn, widths, np.float32, shapes)  # traced again, then compiled
            row = {
                "model": name,
                "method": method,
                "structural": bool(shapes),
                "trace_s": min(ours),
                "jax_make_jaxpr_s": min(theirs) if theirs else None,
                "source_lines": generated.source.count("\n"),
                "numba_compile_s": kernel.compile_seconds,
            }
            rows.append(row)
            print(row, flush=True)
    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    from _machine import write_results

    write_results(__file__, {"repeats": args.repeats, "rows": rows}, packages=("jax",))


if __name__ == "__main__":
    main()
