r"""Disney BRDF Explorer's analytic ``.brdf`` files, as ordinary brdfkit BRDFs.

A BRDF Explorer file [1]_ holds a model as GLSL. Its first line names its type (``analytic``);
``#`` starts a comment line (in every section: BRDF Explorer drops such lines before it reads
a section, so a shader cannot use ``#define``); a ``::begin parameters`` … ``::end parameters``
block declares the parameters, one a line::

    float NAME MIN MAX DEFAULT     a slider (a GLSL uniform float)
    bool NAME DEFAULT              a check box, 0 or 1 (a uniform bool)
    color NAME R G B               a colour (a uniform vec3)

and ``::begin shader`` … ``::end shader`` the GLSL source, which defines

.. math::

    \texttt{vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)} = f_r(L, V)

with L towards the light and V towards the viewer. The shader is translated by
:mod:`brdfkit.interop.glsl` (never executed as Python) and evaluated with L = ``wi``,
V = ``wo`` and the local frame N = (0, 0, 1), X = (1, 0, 0), Y = (0, 1, 0).

**Convention.** BRDF Explorer's templates (``src/shaderTemplates/`` of [1]_) take the shader's
value as f_r without the cosine (they multiply by N·L themselves where asked); its sphere and
image-based renderers clamp it to ``max(BRDF(…), vec3(0))``, its plots do not, and none masks
directions below the horizon. :class:`ExplorerBRDF` follows the renderers and this library's
contract (DESIGN §1): :meth:`~brdfkit.brdf.base.BRDF.eval` is the shader's value clamped
below at 0 above the surface and 0 where ``wi.z <= 0`` or ``wo.z <= 0``;
:meth:`ExplorerBRDF.shader_value` is the shader's value itself, everywhere. Where GLSL
leaves a result undefined the array library's stands: ``pow`` of a negative base is finite
for a whole exponent (``dAniso.brdf`` and ``edwards06.brdf`` take such powers; OpenGL on Mesa
gives NaN there) and NaN otherwise, and NaN stays NaN. Elsewhere the values are OpenGL's to
float32 accuracy (the tests run the shaders in Mesa's OpenGL). An ``isFunc`` section (BRDF
Explorer's own importance-sampling function) is ignored: brdfkit samples the cosine-weighted
hemisphere.
Files of type ``bparam`` and BRDF Explorer's measured formats are refused.

References
----------
.. [1] Walt Disney Animation Studios, *BRDF Explorer* (github.com/wdas/brdf), 2012:
       ``src/brdf/BRDFBase.cpp`` (the file format), ``src/shaderTemplates/`` (the conventions).
.. [2] B. Burley, "Physically-based shading at Disney", SIGGRAPH 2012 course notes.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from brdfkit._array import Array, asarray, constant, namespace
from brdfkit.brdf.base import result_shape
from brdfkit.errors import FormatError, ParameterError
from brdfkit.interop.glsl import Program, Value, run, translate
from brdfkit.measured import CosineSampled
from brdfkit.params import UNPHYSICAL_MAX, Domain, check_flag

__all__ = [
    "ExplorerBRDF",
    "ExplorerParameter",
    "ExplorerShader",
    "is_brdf_explorer_file",
    "read_brdf_explorer",
]

_SECTIONS = ("parameters", "shader")
_SIGNATURE = ("vec3", ("vec3",) * 5)
_COLOUR = Domain(0.0, UNPHYSICAL_MAX, hint="a colour component")


@dataclass(frozen=True)
class ExplorerParameter:
    """A parameter of a BRDF Explorer file: its ``kind`` (``"float"``, ``"bool"`` or
    ``"color"``), name, default and, for a float, the slider's range ``[lo, hi]``."""

    kind: str
    name: str
    default: Any
    lo: float | None = None
    hi: float | None = None

    def check(self, value: Any, path: str) -> Any:
        """``value`` if this parameter may take it, else :class:`ParameterError`."""
        if self.kind == "bool":
            return check_flag(self.name, value)
        if self.kind == "color":
            array = np.asarray(value, dtype=float) if not hasattr(value, "shape") else value
            if getattr(array, "ndim", 0) and array.shape[-1] not in (1, 3):
                raise ParameterError(
                    f"{self.name} must be a number or 3 values (r, g, b); got shape {array.shape}"
                )
            return _COLOUR.check(self.name, value)
        slider = Domain(
            float(self.lo), float(self.hi), hint=f"the slider range {Path(path).name} declares"
        )
        return slider.check(self.name, value)


@dataclass(frozen=True, eq=False)
class ExplorerShader:
    """A parsed BRDF Explorer file: its path, parameters and translated shader."""

    path: str
    parameters: tuple[ExplorerParameter, ...]
    program: Program

    @property
    def name(self) -> str:
        return Path(self.path).stem


@dataclass(frozen=True, eq=False)
class ExplorerBRDF(CosineSampled):
    """The BRDF of a BRDF Explorer shader with parameter ``values`` (every parameter of the
    file, by name): f_r = ``max(BRDF(L=wi, V=wo, N, X, Y), 0)`` above the surface, 0 below.

    RGB (3 channels). Claims nothing the shader may not keep: not reciprocal, not energy
    conserving and not isotropic unless measured so (``brdfkit check`` measures it).
    Sampling is the cosine-weighted hemisphere. Make one with :func:`read_brdf_explorer`
    (or :func:`brdfkit.load`); :meth:`with_values` overrides parameters.
    """

    shader: ExplorerShader
    values: Mapping[str, Any] = field(default_factory=dict)

    channels: ClassVar[int] = 3  # type: ignore[misc]
    isotropic: ClassVar[bool] = False

    def __post_init__(self) -> None:
        super().__post_init__()
        declared = {p.name: p for p in self.shader.parameters}
        unknown = sorted(set(self.values) - set(declared))
        if unknown:
            names = ", ".join(declared) or "none"
            raise ParameterError(
                f"{self.shader.name} has no parameter {unknown[0]!r}; its parameters: {names}"
            )
        checked = {
            name: p.check(self.values.get(name, p.default), self.shader.path)
            for name, p in declared.items()
        }
        object.__setattr__(self, "values", checked)

    def with_values(self, **values: Any) -> ExplorerBRDF:
        """This shader with some parameters set to new values (validated by their
        declarations)."""
        return ExplorerBRDF(self.shader, {**self.values, **values})

    def params(self) -> dict[str, Any]:
        """The shader's parameters by name."""
        return dict(self.values)

    def to_spec(self) -> str:
        raise ValueError(
            f"a BRDF Explorer shader ({self.shader.name}) has no spec string; "
            "read its file with brdfkit.load"
        )

    def __repr__(self) -> str:
        values = ", ".join(f"{k}={v!r}" for k, v in self.values.items())
        return f"ExplorerBRDF({self.shader.name}{', ' if values else ''}{values})"

    def _eval(self, wi: Array, wo: Array) -> Array:
        value = self.shader_value(wi, wo)
        return namespace(value).maximum(value, constant(0.0, value))

    def shader_value(self, wi: Array, wo: Array) -> Array:
        """The shader's ``BRDF(L=wi, V=wo, N, X, Y)`` itself, ``(..., 3)``: not clamped, not
        masked below the surface."""
        xp = namespace(wi, wo)
        wi, wo = asarray(wi, xp), asarray(wo, xp, like=wi)
        like = wi[..., 0]
        zero, one = constant(0.0, like), constant(1.0, like)
        frame = [(zero, zero, one), (one, zero, zero), (zero, one, zero)]
        arguments = [Value("vec3", tuple(w[..., k] for k in range(3))) for w in (wi, wo)] + [
            Value("vec3", axis) for axis in frame
        ]
        uniforms = {p.name: self._uniform(p, like) for p in self.shader.parameters}
        result = run(self.shader.program, "BRDF", arguments, uniforms, like)
        batch = np.broadcast_shapes(result_shape(wi, wo), *(tuple(p.shape) for p in result.parts))
        return xp.stack([xp.broadcast_to(p, batch) for p in result.parts], axis=-1)

    def _uniform(self, parameter: ExplorerParameter, like: Array) -> Value:
        value = self.values[parameter.name]
        if parameter.kind == "bool":
            return Value("bool", (bool(value),))
        array = asarray(value, namespace(like), like=like)
        if parameter.kind == "float":
            return Value("float", (array,))
        if array.ndim == 0 or array.shape[-1] == 1:
            scalar = array if array.ndim == 0 else array[..., 0]
            return Value("vec3", (scalar,) * 3)
        return Value("vec3", tuple(array[..., k] for k in range(3)))


def is_brdf_explorer_file(path: str | os.PathLike) -> bool:
    """Whether the first line of the file at ``path`` names a BRDF Explorer type
    (``analytic`` or ``bparam``), as BRDF Explorer decides."""
    with open(path, "rb") as handle:
        first = handle.readline(256).decode("utf-8", "replace").split()
    return bool(first) and first[0] in ("analytic", "bparam")


def read_brdf_explorer(path: str | os.PathLike, **values: Any) -> ExplorerBRDF:
    """The BRDF of the analytic BRDF Explorer file at ``path``, its parameters at their
    defaults except those given as keywords.

    Raises
    ------
    brdfkit.errors.FormatError
        Naming the file and line: a file that is not an ``analytic`` BRDF Explorer file, a
        parameter line or section outside the format, a shader outside the GLSL subset
        (naming the construct) or without ``vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X,
        vec3 Y)``.
    brdfkit.errors.ParameterError
        For a keyword that is no parameter of the file or a value outside its declaration.

    Examples
    --------
    >>> import numpy as np, tempfile
    >>> from pathlib import Path
    >>> text = '''analytic
    ... ::begin parameters
    ... float reflectance 0 1 0.5
    ... ::end parameters
    ... ::begin shader
    ... vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y) { return vec3(reflectance / 3.14159265); }
    ... ::end shader
    ... '''
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = Path(folder) / "lambert.brdf"
    ...     _ = path.write_text(text)
    ...     brdf = read_brdf_explorer(path, reflectance=0.8)
    >>> w = np.array([0.0, 0.0, 1.0])
    >>> brdf.eval(w, w).round(4)
    array([0.2546, 0.2546, 0.2546])
    >>> brdf.with_values(reflectance=2.0)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    brdfkit.errors.ParameterError: reflectance must be in [0.0, 1.0]; got 2 (the slider range ...
    """
    path = os.fspath(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise FormatError(path, "is not text (a BRDF Explorer .brdf file is UTF-8)") from None
    shader = parse_brdf_explorer(text, path)
    brdf = ExplorerBRDF(shader, values)
    probe = np.array([0.36, 0.48, 0.8])
    brdf.shader_value(probe, probe[[1, 0, 2]])  # refuses now what the shader cannot evaluate
    return brdf


def parse_brdf_explorer(text: str, path: str) -> ExplorerShader:
    """The :class:`ExplorerShader` of the text of a BRDF Explorer file (as
    ``BRDFBase::loadBRDF`` reads it)."""
    lines = text.splitlines()
    kind = lines[0].split()[0] if lines and lines[0].split() else ""
    if kind != "analytic":
        what = "a 'bparam' file" if kind == "bparam" else f"first line {kind or '(empty)'!r}"
        raise FormatError(
            path,
            f"is not an analytic BRDF Explorer file ({what}; expected 'analytic'): only "
            "analytic BRDF Explorer files are read (measured data: MERL .binary, RGL .bsdf)",
            offset=1,
            line=True,
        )
    sections: dict[str, list[tuple[int, str]]] = {}
    current, opened = "", 0
    for number, line in enumerate(lines[1:], 2):
        words = line.split()
        if not words or words[0].startswith("#"):
            continue
        if words[0] in ("::begin", "::end"):
            name = words[1] if len(words) > 1 else ""
            if words[0] == "::begin":
                if current:
                    raise _line_error(path, number, f"'::begin {name}' inside '{current}'")
                if name in sections:
                    raise _line_error(path, number, f"a second '{name}' section")
                current, opened = name, number
                sections[name] = []
            elif name != current:
                raise _line_error(path, number, f"'::end {name}' closes no open section")
            else:
                current = ""
        elif current:
            sections[current].append((number, line))
    if current:
        raise _line_error(path, opened, f"section '{current}' has no '::end {current}'")
    parameters = _parameters(sections.get("parameters", []), path)
    if "shader" not in sections:
        raise FormatError(path, "has no '::begin shader' … '::end shader' section")
    return ExplorerShader(path, parameters, _program(sections["shader"], parameters, path))


def _line_error(path: str, line: int, reason: str) -> FormatError:
    return FormatError(path, reason, offset=line, line=True)


_NAME = re.compile(r"[A-Za-z_]\w*")
_FIELDS = {"float": 4, "bool": 2, "color": 4}


def _parameters(lines: list[tuple[int, str]], path: str) -> tuple[ExplorerParameter, ...]:
    parameters: dict[str, ExplorerParameter] = {}
    for number, line in lines:
        kind, *rest = line.split()
        if kind not in _FIELDS:
            raise _line_error(path, number, f"parameter type {kind!r} (float, bool or color)")
        if len(rest) < _FIELDS[kind] or not _NAME.fullmatch(rest[0]):
            shape = {"float": "NAME MIN MAX DEFAULT", "bool": "NAME 0|1", "color": "NAME R G B"}
            raise _line_error(
                path, number, f"expected '{kind} {shape[kind]}', got {line.strip()!r}"
            )
        name = rest[0]
        if name in parameters:
            raise _line_error(path, number, f"parameter {name!r} declared twice")
        numbers = [_number(word, path, number) for word in rest[1 : _FIELDS[kind]]]
        if kind == "bool":
            parameters[name] = ExplorerParameter("bool", name, numbers[0] != 0)
        elif kind == "color":
            parameters[name] = ExplorerParameter("color", name, tuple(numbers))
        else:
            lo, hi, default = numbers
            parameters[name] = ExplorerParameter("float", name, default, min(lo, hi), max(lo, hi))
    return tuple(parameters.values())


def _number(word: str, path: str, line: int) -> float:
    try:
        value = float(word)
    except ValueError:
        raise _line_error(path, line, f"{word!r} is not a number") from None
    if not math.isfinite(value):
        raise _line_error(path, line, f"{word!r} is not a finite number")
    return value


def _program(
    lines: list[tuple[int, str]], parameters: tuple[ExplorerParameter, ...], path: str
) -> Program:
    program = translate(lines, path)
    brdf = program.functions.get("BRDF")
    if brdf is None:
        raise FormatError(
            path, "its shader defines no 'vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)'"
        )
    signature = (brdf.type, tuple(p.type for p in brdf.parameters))
    if signature != _SIGNATURE:
        shown = f"{brdf.type} BRDF({', '.join(p.type for p in brdf.parameters)})"
        raise _line_error(
            path, brdf.line, f"BRDF is declared {shown}; expected vec3 BRDF(vec3 × 5)"
        )
    names = {p.name for p in parameters}
    for declaration in program.globals:
        for name, _ in declaration.variables:
            if name in names:
                raise _line_error(
                    path, declaration.line, f"global '{name}' redeclares the parameter '{name}'"
                )
    return program
