"""A real GLSL compiler as the oracle of the translator: a BRDF Explorer shader run by OpenGL.

The shader's lines (as BRDF Explorer keeps them: ``#`` lines dropped) go, after a ``uniform``
per parameter as BRDF Explorer declares them, into a GLSL 4.30 compute shader that evaluates
``BRDF(L, V, N, X, Y)`` for each pair of directions into a storage buffer, in float32. The
context is a headless OpenGL one (moderngl over EGL; Mesa's llvmpipe runs it on the CPU).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

GROUP = 64
"""Invocations per work group; batches are padded to a multiple."""

_KINDS = {"float": "float", "bool": "bool", "color": "vec3"}


def shader_source(path: str | Path) -> str:
    """The shader section of a ``.brdf`` file as BRDF Explorer passes it to OpenGL."""
    inside, body = False, []
    for line in Path(path).read_text(encoding="utf-8").splitlines()[1:]:
        words = line.split()
        if not words or words[0].startswith("#"):
            continue
        if words[0] in ("::begin", "::end"):
            inside = words[0] == "::begin" and words[1:2] == ["shader"]
        elif inside:
            body.append(line)
    return "\n".join(body)


def opengl_values(ctx: Any, brdf: Any, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """``BRDF(L=wi, V=wo, N, X, Y)`` of an :class:`~brdfkit.interop.brdf_explorer.ExplorerBRDF`
    as OpenGL computes it, float32, ``(n, 3)``."""
    uniforms = "\n".join(f"uniform {_KINDS[p.kind]} {p.name};" for p in brdf.shader.parameters)
    program = ctx.compute_shader(
        f"#version 430\nlayout(local_size_x = {GROUP}) in;\n"
        "layout(std430, binding = 0) readonly buffer Pairs { vec4 pairs[]; };\n"
        "layout(std430, binding = 1) writeonly buffer Values { vec4 values[]; };\n"
        f"{uniforms}\n{shader_source(brdf.shader.path)}\n"
        "void main() {\n    uint i = gl_GlobalInvocationID.x;\n"
        "    values[i] = vec4(BRDF(pairs[2u * i].xyz, pairs[2u * i + 1u].xyz,\n"
        "                          vec3(0, 0, 1), vec3(1, 0, 0), vec3(0, 1, 0)), 0.0);\n}\n"
    )
    for p in brdf.shader.parameters:
        if p.name in program:  # the compiler drops the uniforms the shader does not read
            value = brdf.values[p.name]
            if p.kind == "color":
                value = tuple(float(x) for x in np.broadcast_to(np.asarray(value, float), 3))
            program[p.name].value = bool(value) if p.kind == "bool" else value
    n = len(wi)
    padded = -(-n // GROUP) * GROUP
    pairs = np.zeros((padded, 2, 4), np.float32)
    pairs[:n, 0, :3], pairs[:n, 1, :3] = wi, wo
    source, out = ctx.buffer(pairs.tobytes()), ctx.buffer(reserve=padded * 16)
    try:
        source.bind_to_storage_buffer(0)
        out.bind_to_storage_buffer(1)
        program.run(group_x=padded // GROUP)
        return np.frombuffer(out.read(), np.float32).reshape(padded, 4)[:n, :3].copy()
    finally:
        source.release()
        out.release()
        program.release()
